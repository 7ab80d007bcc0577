//! Perspective shear-warp (Lacroute's factorisation; Schulze, Niemeier
//! and Lang's perspective implementation): object order, slice by slice.
//!
//! A frame: [`EyeCase::of`] the view (behind the eye: nothing drawn, no
//! compositing); the factorisation ([`factor`]) shears and scales each
//! slice onto the intermediate image on the plane of slice 0; the
//! compositing ([`composite`]) resamples every slice there (bilinear
//! where a voxel covers more than a pixel, a one-pixel tent footprint
//! where it covers less), front to back with early termination, skipping
//! transparent voxels through the run-length encoded classified volume
//! ([`rle`]) and opaque pixels through per-scanline skip links; then the
//! 2D projective warp ([`warp`]) resamples the intermediate image into
//! the final one. With shading ([`render_shaded`]) each sample is shaded
//! before it is composited, as in the slice-order methods. Scanlines are independent tasks, so the image is the
//! same for any thread count. docs/golden.md#perspective-shear-warp.

pub mod composite;
pub mod factor;
pub mod rle;
pub mod warp;

use rayon::prelude::*;

use crate::clip::ViewClip;
use crate::error::{input, Result};
use crate::geometry::View;
use crate::image::Image;
use crate::shading::Shader;
use crate::slices::SliceStack;

pub use factor::{check_scale, EyeCase, Factor};
pub use rle::Classified;

/// Default intermediate scale: Lacroute's one pixel per voxel of the
/// front slice.
pub const DEFAULT_SCALE: f64 = 1.0;

/// Settings of the shear-warp renderer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwOptions {
    /// Intermediate pixels per voxel of slice 0 (`--intermediate-scale`).
    pub scale: f64,
    /// Early termination opacity (1 disables it).
    pub terminate: f32,
    /// Skip transparent voxels through the runs (exact).
    pub skip_empty: bool,
    /// Cut the intermediate image to what the final image reads (exact).
    pub cull: bool,
    /// Volume of interest: each resampled sample's opacity-weighted colour
    /// and opacity scaled by the region's factor at the sample
    /// ([`crate::voi`]) before the opacity correction, as the slice-order
    /// methods scale theirs. A transparent run stays transparent, so
    /// skipping stays exact.
    pub voi: Option<crate::voi::Voi>,
}

impl Default for SwOptions {
    fn default() -> SwOptions {
        SwOptions {
            scale: DEFAULT_SCALE,
            terminate: 0.99,
            skip_empty: true,
            cull: true,
            voi: None,
        }
    }
}

impl SwOptions {
    /// Refuses options the renderer cannot run with.
    pub fn validate(&self) -> Result<()> {
        check_scale(self.scale)?;
        if !(self.terminate.is_finite() && self.terminate > 0.0 && self.terminate <= 1.0) {
            return Err(input(format!(
                "termination threshold {} must lie in (0, 1]",
                self.terminate
            )));
        }
        Ok(())
    }
}

/// What one frame counted.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct SwStats {
    /// Where the volume lies relative to the eye.
    pub eye_case: Option<EyeCase>,
    /// Intermediate pixels per voxel of slice 0.
    pub scale: f64,
    /// Intermediate image width and height.
    pub intermediate: [usize; 2],
    /// Pixel-slice pairs inside a slice's footprint (the work without skipping).
    pub samples_candidate: u64,
    /// Samples resampled (pixel-slice pairs the skipping left).
    pub samples_total: u64,
    /// Of those, samples with non-zero opacity.
    pub samples_composited: u64,
    /// Samples beyond a clip plane.
    pub samples_clipped: u64,
    /// Intermediate pixels that reached the termination opacity.
    pub rays_terminated: u64,
    /// Runs in the classified volume (0 with skipping off).
    pub runs: u64,
    /// Fraction of voxels with non-zero opacity.
    pub occupied_fraction: f64,
}

impl SwStats {
    fn add(&mut self, o: &SwStats) {
        self.samples_candidate += o.samples_candidate;
        self.samples_total += o.samples_total;
        self.samples_composited += o.samples_composited;
        self.samples_clipped += o.samples_clipped;
        self.rays_terminated += o.rays_terminated;
    }
}

/// Renders `view` from its classified stack `cls` (built with the frame's
/// table) with clip planes `clip`.
pub fn render(
    view: &View,
    cls: &Classified,
    clip: &ViewClip,
    opts: &SwOptions,
) -> Result<(Image, SwStats)> {
    render_shaded(view, cls, clip, opts, None)
}

/// [`render`] with every sample shaded by `shade`'s shader before it is
/// composited (the slice-order methods' Blinn-Phong, [`crate::shading`]):
/// the sample's colour is its filtered premultiplied colour over its
/// filtered opacity, its gradient the voxel gradients filtered with the
/// same taps (voxels mode) or the shader's differences of bilinear
/// samples of the scalar stack at its position (samples mode).
pub fn render_shaded(
    view: &View,
    cls: &Classified,
    clip: &ViewClip,
    opts: &SwOptions,
    shade: Option<(&Shader, &SliceStack)>,
) -> Result<(Image, SwStats)> {
    opts.validate()?;
    if cls.dims != view.dims {
        return Err(input(format!(
            "a classified volume of {:?} cannot render a view of {:?}",
            cls.dims, view.dims
        )));
    }
    let case = EyeCase::of(view);
    let mut stats = SwStats {
        eye_case: Some(case),
        scale: opts.scale,
        runs: if opts.skip_empty {
            cls.run_count() as u64
        } else {
            0
        },
        occupied_fraction: cls.occupied_fraction(),
        ..SwStats::default()
    };
    let (w, h) = (view.size[0] as usize, view.size[1] as usize);
    if case == EyeCase::Behind {
        return Ok((Image::new(w, h), stats));
    }
    let voi = opts
        .voi
        .map(|v| crate::voi::ViewVoi::new(view, &v))
        .transpose()?;
    let factor = Factor::new(view, opts.scale, opts.cull)?;
    let [iw, ih] = factor.grid.counts;
    stats.intermediate = [iw, ih];
    let [nx, ny, nz] = view.dims;
    let x = (0..nz)
        .into_par_iter()
        .map(|z| composite::Taps::new(&factor, z, 0, nx, iw))
        .collect();
    let y = (0..nz)
        .into_par_iter()
        .map(|z| composite::Taps::new(&factor, z, 1, ny, ih))
        .collect();
    let pass = composite::Pass {
        view,
        factor: &factor,
        cls,
        clip,
        x,
        y,
        terminate: opts.terminate,
        rle: opts.skip_empty,
        shade,
        voi: voi.as_ref(),
    };
    let mut inter = vec![[0f32; 4]; iw * ih];
    let rows: Vec<SwStats> = if iw == 0 {
        Vec::new()
    } else {
        inter
            .par_chunks_mut(iw)
            .enumerate()
            .map_init(composite::Scratch::default, |sc, (v, row)| {
                composite::scanline(&pass, v, row, sc)
            })
            .collect()
    };
    // Integer counts summed in scanline order: the same for any thread count.
    for r in &rows {
        stats.add(r);
    }
    let m = factor.pixel_to_intermediate(view);
    Ok((warp::warp(view, &m, [iw, ih], &inter), stats))
}
