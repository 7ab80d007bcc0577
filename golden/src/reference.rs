//! The ground truth: image-order ray casting of every final pixel in `f64`,
//! supersampled with a tent pixel filter, trilinear interpolation, steps of
//! at most 1/4 voxel, the same classification and opacity correction as the
//! slice-order methods, front-to-back compositing.

use glam::DVec3;
use rayon::prelude::*;

use crate::clip::ViewClip;
use crate::error::{Error, Result};
use crate::gaze::Gaze;
use crate::geometry::{box_interval, View};
use crate::image::Image;
use crate::shading::{Shade, Shader};
use crate::slices::SliceStack;
use crate::tf::Lut;
use crate::voi::{ViewVoi, Voi};

/// Reference renderer settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefOptions {
    /// Rays per pixel along each image axis (at least 4).
    pub rays_per_axis: usize,
    /// Longest step along the ray in voxels; each ray's path through the
    /// volume is cut into equal steps no longer than this.
    pub step: f64,
    /// A ray stops once its remaining transmittance is below this; the
    /// error this makes is below it too (1e-6 is far under one 8-bit level).
    pub cutoff: f64,
    /// Gradient shading with the slice-order methods' model, from the
    /// reference's own trilinear gradients in `f64`.
    pub shade: Option<Shade>,
    /// A volume of interest scaling opacity, as the slice-order methods.
    pub voi: Option<Voi>,
    /// Gaze-directed variable resolution instead of the supersampled grid
    /// (see [`crate::gaze`]).
    pub gaze: Option<Gaze>,
    /// Adaptive refinement by image complexity, one full-resolution ray
    /// per cast (see [`crate::refine`]); with `gaze`, both criteria.
    pub refine: Option<crate::refine::Refine>,
}

impl Default for RefOptions {
    fn default() -> RefOptions {
        RefOptions {
            rays_per_axis: 4,
            step: 0.25,
            cutoff: 1e-6,
            shade: None,
            voi: None,
            gaze: None,
            refine: None,
        }
    }
}

/// Largest ray buffer the reference allocates (bytes).
const MAX_RAY_BUFFER: u128 = 4 << 30;

/// Renders `view` by ray casting. Rays are cast on a grid `q` times finer
/// than the pixels (`q = rays_per_axis`), extended one pixel beyond the
/// image so that every pixel's tent filter of one pixel radius sees all of
/// its `2q x 2q` rays.
pub fn render(
    view: &View,
    stack: &SliceStack,
    clip: &ViewClip,
    lut: &Lut,
    opts: &RefOptions,
) -> Result<Image> {
    let q = opts.rays_per_axis.max(1);
    let (w, h) = (view.size[0] as usize, view.size[1] as usize);
    let (rw, rh) = ((w + 2) * q, (h + 2) * q);
    let bytes = rw as u128 * rh as u128 * 32;
    if bytes > MAX_RAY_BUFFER {
        return Err(Error::TooLarge {
            what: "the reference renderer's ray buffer".into(),
            bytes,
            limit: MAX_RAY_BUFFER as u64,
        });
    }
    // Ray k sits at pixel position (k + 1/2) / q - 1/2, so pixel i's rays
    // i q .. i q + 2q - 1 lie symmetrically about its centre i + 1/2.
    let ray_pos = |k: usize| (k as f64 + 0.5) / q as f64 - 0.5;
    let pass = RefPass::new(view, stack, opts)?;
    let mut rays = vec![[0f64; 4]; rw * rh];
    rays.par_chunks_mut(rw).enumerate().for_each(|(r, row)| {
        let py = ray_pos(r);
        for (c, out) in row.iter_mut().enumerate() {
            let dir = view.rays.dir(ray_pos(c), py);
            *out = cast_ray(&pass, clip, lut, opts, dir);
        }
    });
    // Tent weights of the 2q rays under one pixel, per axis.
    let weights: Vec<f64> = (0..2 * q)
        .map(|k| 1.0 - ((k as f64 + 0.5) / q as f64 - 1.0).abs())
        .collect();
    let norm: f64 = weights.iter().sum::<f64>().powi(2);
    let mut img = Image::new(w, h);
    img.data.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, out) in row.iter_mut().enumerate() {
            let mut acc = [0f64; 4];
            for (dy, wy) in weights.iter().enumerate() {
                let line = &rays[(j * q + dy) * rw..];
                for (dx, wx) in weights.iter().enumerate() {
                    let v = line[i * q + dx];
                    for c in 0..4 {
                        acc[c] += wx * wy * v[c];
                    }
                }
            }
            *out = std::array::from_fn(|c| (acc[c] / norm) as f32);
        }
    });
    Ok(img)
}

/// What every ray of a frame shares: the view, the volume, the shader
/// and the volume of interest in view space.
pub(crate) struct RefPass<'a> {
    view: &'a View,
    stack: &'a SliceStack,
    shader: Option<Shader>,
    voi: Option<ViewVoi>,
}

impl<'a> RefPass<'a> {
    /// The pass of `view` over `stack` with `opts`' shading and VOI.
    pub(crate) fn new(view: &'a View, stack: &'a SliceStack, opts: &RefOptions) -> Result<Self> {
        Ok(RefPass {
            view,
            stack,
            shader: match &opts.shade {
                Some(sh) => Some(Shader::new(view, stack, sh)?),
                None => None,
            },
            voi: match &opts.voi {
                Some(v) => Some(ViewVoi::new(view, v)?),
                None => None,
            },
        })
    }
}

/// Casts one ray from the eye along view-space direction `dir`, in steps
/// of at most `opts.step` voxels.
pub(crate) fn cast_ray(
    pass: &RefPass,
    clip: &ViewClip,
    lut: &Lut,
    opts: &RefOptions,
    dir: DVec3,
) -> [f64; 4] {
    let (view, stack) = (pass.view, pass.stack);
    let (shader, voi) = (pass.shader.as_ref(), pass.voi.as_ref());
    let e = view.eye;
    let Some((t0, t1)) = box_interval(e, dir, view.dims) else {
        return [0.0; 4];
    };
    // Equal steps of at most `opts.step` voxels that tile the ray's path
    // through the volume exactly, so a uniform slab integrates exactly.
    let steps = ((t1 - t0) * dir.length() / opts.step).ceil().max(1.0);
    let dt = (t1 - t0) / steps;
    let steps = steps as usize;
    let ds = view.world_length(dir.x * dt, dir.y * dt, dir.z * dt);
    let mut acc = [0f64; 4];
    for n in 0..steps {
        let p = e + dir * (t0 + (n as f64 + 0.5) * dt);
        // Clipping drops steps, never moves them: the same steps as unclipped.
        if !clip.keeps(p.x, p.y, p.z) {
            continue;
        }
        let mut c = lut.lookup_f64(stack.trilinear(p.x, p.y, p.z));
        if let Some(v) = voi {
            c[3] *= v.factor(p);
        }
        if c[3] <= 0.0 {
            continue;
        }
        if let Some(sh) = shader {
            c = sh.shade(c, sh.gradient_trilinear(stack, p.x, p.y, p.z));
        }
        let a = -(ds * (-c[3]).ln_1p()).exp_m1();
        let k = (1.0 - acc[3]) * a;
        acc[0] += k * c[0];
        acc[1] += k * c[1];
        acc[2] += k * c[2];
        acc[3] += k;
        if 1.0 - acc[3] < opts.cutoff {
            break;
        }
    }
    acc
}
