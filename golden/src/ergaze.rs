//! Gaze-directed variable resolution for ER (`er`, `er-ftb`): Levoy and
//! Whitaker's sweet spot ([`crate::gaze::Gaze`]) by one ER frame per
//! level, blended by the profile. ER's rays live in object space, so the
//! image-order casters' trick (fewer rays through the periphery's pixels)
//! does not apply; instead each level is a whole, correct ER frame:
//!
//! - **Level 0** is the full-resolution frame, culled to the window (the
//!   bounding box) of the pixels that read it: the culling ER already does
//!   for the image's frustum ([`crate::skip::SampleMask::within`]), so
//!   those pixels have the full frame's bits.
//! - **Level `l`** is ER on the volume at `2^l` times the voxel spacing
//!   ([`coarse_volume`]: the base filtered by a tent `2^l` voxels wide at
//!   every `2^l`-th voxel, so its voxels sit on the base's grid points and
//!   it is seen by the same camera), culled to its own window. Its slices
//!   are `2^l` apart and its rays `2^l` apart on every plane, so per unit
//!   of image area it casts `4^-l` of the rays and per unit length `2^-l`
//!   of the samples, as the profile asks: `8^-l` of the samples in all.
//! - **Pixels** of level `lev` blend the frames of the two bracketing
//!   levels at their own position, linearly by `lev - floor(lev)`, as
//!   [`crate::gaze::render_with`] blends its ray pyramid. In the sweet spot
//!   (`lev = 0`) a pixel is the full ER frame's pixel bit for bit.
//!
//! The coarse levels are prepared once per volume and camera
//! ([`prepare_levels`], kept by [`crate::render::Prepared::with_gaze_levels`]).
//! A box filter (the mip-map's) would centre level `l`'s voxel `i` at base
//! position `2^l i + (2^l - 1) / 2`, half a level voxel behind the base's
//! slice 0; with the eye a few voxels from the face that moves the whole
//! near rim (at D = 2 a level-1 frame drew the volume 20% smaller), hence
//! the centred tent. An axis whose `n - 1` is not a multiple of `2^l`
//! ends up to `2^l - 1` base voxels deeper, replicating the edge voxel.
//! docs/golden.md#gaze-directed-variable-resolution.

use rayon::prelude::*;

use glam::DVec3;

use crate::camera::Camera;
use crate::error::{input, Result};
use crate::gaze::Gaze;
use crate::geometry::View;
use crate::image::Image;
use crate::methods::{self, Method, Options};
use crate::render::{PrepareOptions, Prepared};
use crate::volume::Volume;
use crate::warp::{warp_window, PixelWindow};

/// What one level's frame did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ErLevel {
    /// The level (0: full resolution).
    pub level: u32,
    /// The level's volume dimensions in view space.
    pub volume: [usize; 3],
    /// Pixels whose colour reads this level.
    pub pixels: u64,
    /// The window the level was culled to (`None`: no pixel reads it, not
    /// rendered).
    pub window: Option<PixelWindow>,
    /// Samples taken.
    pub samples: u64,
    /// Rays kept, summed over the regions (ray segments).
    pub rays: u64,
}

/// What a gaze-directed ER frame did, per level, finest first.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ErGazeStats {
    /// Per level.
    pub levels: Vec<ErLevel>,
    /// Samples over all levels.
    pub samples_total: u64,
    /// Rays over all levels.
    pub rays_total: u64,
}

/// The volume at level `l`: voxel `i` of it is the base volume filtered at
/// base voxel `2^l i` by the separable tent (Bartlett) filter of
/// half-width `2^l` (weights `2^l - |k|`, beyond an edge the edge voxel),
/// rounded to the nearest scalar unit; `ceil((n - 1) / 2^l) + 1` voxels
/// per axis at `2^l` times the spacing. Its voxels sit on the base's grid
/// points, so the level has the base's world: slice 0 on slice 0, the same
/// camera, clip planes and volume of interest. Refuses a level whose
/// voxels span an axis (`2^l >= n`).
pub fn coarse_volume(volume: &Volume, l: u32) -> Result<Volume> {
    let k = 1i64 << l;
    let d = volume.dims();
    let dims = d.map(|n| (n - 1).div_ceil(k as usize) + 1);
    if d.iter().any(|&n| (n as i64) <= k) {
        return Err(input(format!(
            "gaze level {l}'s voxels, {k} base voxels wide, span the whole {}x{}x{} volume on an axis; use fewer --gaze-levels",
            d[0], d[1], d[2]
        )));
    }
    // One axis's taps: (base index, integer weight), the weights summing
    // to 4^l.
    let taps = |i: usize, n: usize| -> Vec<(usize, u64)> {
        (1 - k..k)
            .map(|t| {
                let at = (i as i64 * k + t).clamp(0, n as i64 - 1) as usize;
                (at, (k - t.abs()) as u64)
            })
            .collect()
    };
    let tx: Vec<_> = (0..dims[0]).map(|i| taps(i, d[0])).collect();
    let ty: Vec<_> = (0..dims[1]).map(|i| taps(i, d[1])).collect();
    let tz: Vec<_> = (0..dims[2]).map(|i| taps(i, d[2])).collect();
    let norm = 1u64 << (6 * l);
    let out = Volume::from_fn(dims, volume.kind(), u64::MAX, |x, y, z| {
        let mut sum = 0u64;
        for &(zz, wz) in &tz[z] {
            for &(yy, wy) in &ty[y] {
                let wzy = wz * wy;
                for &(xx, wx) in &tx[x] {
                    sum += wzy * wx * u64::from(volume.get(xx, yy, zz));
                }
            }
        }
        ((sum + norm / 2) / norm) as u16
    })?;
    let s = volume.spacing().map(|v| v * k as f64);
    Ok(out.with_spacing(s)?.with_units(volume.units()))
}

/// `opts` for level `l`: the near distance in the level's voxels.
fn coarse_prepare(opts: &PrepareOptions, l: u32) -> PrepareOptions {
    PrepareOptions {
        near: opts.near / f64::from(1u32 << l),
        ..opts.clone()
    }
}

/// `view`'s pixel ray directions given in `to`'s view space (both views
/// of the same world).
fn rays_into(view: &View, to: &View) -> [DVec3; 3] {
    let r = &view.rays;
    let (from, into) = (spacing_of(view), spacing_of(to));
    [r.a, r.b, r.c].map(|d| {
        // View to index to world to `to`'s index to `to`'s view.
        let mut idx = [0.0; 3];
        let v = d.to_array();
        let p = view.axes.perm;
        idx[p[0]] = v[0];
        idx[p[1]] = v[1];
        idx[p[2]] = if view.axes.flip_z { -v[2] } else { v[2] };
        to.axes
            .dir_to_view(DVec3::from_array(std::array::from_fn(|k| {
                idx[k] * from[k] / into[k]
            })))
    })
}

/// The coarse levels `1..=levels` of `volume` seen by `camera`, each
/// prepared like the base with `opts`.
pub fn prepare_levels(
    volume: &Volume,
    camera: &Camera,
    opts: &PrepareOptions,
    levels: u32,
) -> Result<Vec<Prepared>> {
    if levels > crate::gaze::MAX_LEVEL {
        return Err(input(format!(
            "gaze levels {levels} must be at most {}",
            crate::gaze::MAX_LEVEL
        )));
    }
    let base = View::new(volume.dims(), volume.spacing(), camera, opts.near)?;
    (1..=levels)
        .map(|l| level_prepared(volume, camera, opts, &base, l))
        .collect()
}

/// Level `l` alone of [`prepare_levels`] (`1 <= l <=`
/// [`crate::gaze::MAX_LEVEL`]): what a frame of one level reads, such as
/// `--rays footprint` ([`footprint_level`]) in golden and in the
/// pipeline's host, which loads the PEs with this level's voxels.
pub fn prepare_level(
    volume: &Volume,
    camera: &Camera,
    opts: &PrepareOptions,
    l: u32,
) -> Result<Prepared> {
    if !(1..=crate::gaze::MAX_LEVEL).contains(&l) {
        return Err(input(format!(
            "level {l} must be from 1 to {}",
            crate::gaze::MAX_LEVEL
        )));
    }
    let base = View::new(volume.dims(), volume.spacing(), camera, opts.near)?;
    level_prepared(volume, camera, opts, &base, l)
}

/// Level `l` of `volume` prepared, its rays the `base` view's.
fn level_prepared(
    volume: &Volume,
    camera: &Camera,
    opts: &PrepareOptions,
    base: &View,
    l: u32,
) -> Result<Prepared> {
    let v = coarse_volume(volume, l)?;
    let mut p = Prepared::with(&v, camera, &coarse_prepare(opts, l))?;
    // The base view's rays, whatever the image plane (a front one
    // would lie on the level's face, which may end up to 2^l - 1
    // base voxels beyond the base's); nothing prepared depends on
    // them.
    [p.view.rays.a, p.view.rays.b, p.view.rays.c] = rays_into(base, &p.view);
    Ok(p)
}

/// Rays per pixel, across, that [`footprint_level`] keeps: two, so the
/// warp's bilinear reconstruction still has a sample on each side of every
/// pixel centre. Measured on brainsmall's far views against the reference,
/// one ray per pixel doubled the error of the full frame; two cost it
/// 0-25% (docs/golden.md#rays-matched-to-the-image).
pub const RAYS_PER_PIXEL: f64 = 2.0;

/// The coarsest level whose rays still give every pixel
/// [`RAYS_PER_PIXEL`] rays across (`--rays footprint`): ER's final rays (region 0's, one voxel apart on
/// its back plane `z = D`, [`crate::geometry::Layout::exponential`]) set
/// the base density; a pixel covers `f` of them across, measured on that
/// plane along both pixel axes at nine points spread over the image (the
/// smallest counts), and level `l` casts `f / 2^l`. So the level is
/// `floor(log2(f / RAYS_PER_PIXEL))`, 0 when the image needs the voxels' rays
/// (then the frame is ER's own, bit for bit), at most [`MAX_LEVEL`]. The
/// coarse volume is the prefiltered one of [`coarse_volume`], so fewer
/// rays do not alias.
///
/// [`MAX_LEVEL`]: crate::gaze::MAX_LEVEL
pub fn footprint_level(view: &View) -> u32 {
    let r = &view.rays;
    let depth = 2.0 * view.d;
    let [w, h] = view.size.map(f64::from);
    let mut f = f64::INFINITY;
    for (u, v) in [0.0, 0.5, 1.0]
        .iter()
        .flat_map(|&u| [0.0, 0.5, 1.0].map(move |v| (u, v)))
    {
        let dir = r.dir(u * w, v * h);
        if dir.z <= 1e-12 {
            // A pixel looking away from the volume's slices says nothing.
            continue;
        }
        for step in [r.b, r.c] {
            // d/dpx of the hit point (x, y) = eye + depth * dir / dir.z.
            let dx = depth * (step.x * dir.z - dir.x * step.z) / (dir.z * dir.z);
            let dy = depth * (step.y * dir.z - dir.y * step.z) / (dir.z * dir.z);
            f = f.min(dx.hypot(dy));
        }
    }
    let f = f / RAYS_PER_PIXEL;
    if !f.is_finite() || f < 2.0 {
        return 0;
    }
    (f.log2().floor() as u32).min(crate::gaze::MAX_LEVEL)
}

/// Which levels each pixel reads: `(l0, t)` with the colour
/// `(1 - t) level[l0] + t level[l0 + 1]` (`t = 0`: level `l0` alone).
fn pixel_levels(gaze: &Gaze, w: usize, h: usize) -> Vec<(usize, f64)> {
    (0..w * h)
        .map(|p| {
            let (x, y) = ((p % w) as f64 + 0.5, (p / w) as f64 + 0.5);
            let lev = gaze.level(x, y);
            let l0 = lev.floor();
            (l0 as usize, lev - l0)
        })
        .collect()
}

/// Renders `prep` with ER `method` under `gaze`'s profile; `coarse` holds
/// levels `1..` ([`prepare_levels`]), at least `gaze.levels` of them.
pub fn render(
    method: Method,
    prep: &Prepared,
    coarse: &[Prepared],
    lut: &crate::tf::Lut,
    opts: &Options,
    gaze: &Gaze,
) -> Result<(Image, ErGazeStats)> {
    gaze.validate()?;
    if !matches!(method, Method::Er | Method::ErFtb) {
        return Err(input(format!(
            "--gaze applies to er and er-ftb among the slice-order methods, not {}",
            method.name()
        )));
    }
    let levels = gaze.levels as usize;
    if coarse.len() < levels {
        return Err(input(format!(
            "a gaze profile of {levels} levels needs its coarse volumes prepared (Prepared::with_gaze_levels)"
        )));
    }
    let [w, h] = prep.view.size.map(|v| v as usize);
    let px = pixel_levels(gaze, w, h);
    // Per level: the pixels that read it and their bounding window.
    let mut count = vec![0u64; levels + 1];
    let mut boxes: Vec<Option<[u32; 4]>> = vec![None; levels + 1];
    for (p, &(l0, t)) in px.iter().enumerate() {
        let (x, y) = ((p % w) as u32, (p / w) as u32);
        for l in [Some(l0), (t > 0.0).then_some(l0 + 1)]
            .into_iter()
            .flatten()
        {
            count[l] += 1;
            let b = boxes[l].get_or_insert([x, x, y, y]);
            *b = [b[0].min(x), b[1].max(x), b[2].min(y), b[3].max(y)];
        }
    }
    let mut images: Vec<Option<Image>> = Vec::with_capacity(levels + 1);
    let mut stats = ErGazeStats {
        levels: Vec::with_capacity(levels + 1),
        samples_total: 0,
        rays_total: 0,
    };
    for l in 0..=levels {
        let p = if l == 0 { prep } else { &coarse[l - 1] };
        let window = boxes[l].map(|b| PixelWindow {
            x: [b[0], b[1]],
            y: [b[2], b[3]],
        });
        let mut lv = ErLevel {
            level: l as u32,
            volume: p.stack.dims,
            pixels: count[l],
            window,
            samples: 0,
            rays: 0,
        };
        let img = match &window {
            None => None,
            Some(win) => {
                let out = methods::render_within(method, p, lut, opts, Some(win))?;
                let st = &out.stats;
                lv.samples = st.samples_total;
                lv.rays = st.rays_per_region.iter().sum::<u64>() - st.rays_culled;
                let img = warp_window(&p.view, &out.baseplane, win);
                crate::merge::recycle(out.baseplane.data);
                Some(img)
            }
        };
        stats.samples_total += lv.samples;
        stats.rays_total += lv.rays;
        stats.levels.push(lv);
        images.push(img);
    }
    let mut out = Image::new(w, h);
    out.data.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, o) in row.iter_mut().enumerate() {
            let p = j * w + i;
            let (l0, t) = px[p];
            let a = images[l0].as_ref().expect("a read level is rendered").data[p];
            *o = if t > 0.0 {
                let b = images[l0 + 1]
                    .as_ref()
                    .expect("a read level is rendered")
                    .data[p];
                std::array::from_fn(|c| {
                    let (a, b) = (f64::from(a[c]), f64::from(b[c]));
                    (a + t * (b - a)) as f32
                })
            } else {
                a
            };
        }
    });
    for img in images.into_iter().flatten() {
        crate::merge::recycle(img.data);
    }
    Ok((out, stats))
}

/// The volume's spacing on its index axes (a view holds it on its own).
fn spacing_of(view: &View) -> [f64; 3] {
    let s = view.spacing;
    let mut out = [0.0; 3];
    for (k, &axis) in view.axes.perm.iter().enumerate() {
        out[axis] = s[k];
    }
    out
}
