//! What `ercube render` compares a frame with: the same method at full
//! resolution for a gaze-directed frame, the reference with
//! `--compare-reference`, and the refinement and gaze profiles the flags
//! ask for.

use anyhow::Result;

use golden::metrics::compare;
use golden::render::{render, Prepared, RenderOptions, Technique};

use super::{timed_frames, RenderArgs, SliceArgs};
use crate::cli::progress::Stage;
use crate::cli::stats::median;

/// A gaze-directed frame against the same method at full resolution.
pub(super) struct VersusFull {
    time_s: f64,
    samples: Option<u64>,
    /// Rays of the full frame: one per pixel for the casters, ER's kept
    /// rays summed over its regions.
    rays: Option<u64>,
    inside: (golden::metrics::ImageError, u64),
    outside: (golden::metrics::ImageError, u64),
}

impl VersusFull {
    pub(super) fn json(&self) -> serde_json::Value {
        let part = |(e, n): &(golden::metrics::ImageError, u64)| {
            let mut v = crate::cli::stats::error_json(e);
            v["pixels"] = serde_json::json!(n);
            v
        };
        serde_json::json!({
            "full_time_s": self.time_s,
            "full_samples": self.samples,
            "full_rays": self.rays,
            "inside": part(&self.inside),
            "outside": part(&self.outside),
        })
    }

    pub(super) fn summary(&self, time_s: f64, samples: Option<u64>) -> String {
        let mut s = format!(
            "; full resolution {:.3} s ({:.2}x)",
            self.time_s,
            self.time_s / time_s
        );
        if let (Some(f), Some(g)) = (self.samples, samples) {
            s += &format!(", samples {g} of {f} ({:.3})", g as f64 / f.max(1) as f64);
        }
        let (i, o) = (&self.inside.0, &self.outside.0);
        s + &format!(
            ", vs full: sweet spot rmse {:.5} max {} /255, outside rmse {:.5} max {} /255",
            i.rmse, i.max_abs_255, o.rmse, o.max_abs_255
        )
    }
}

/// Renders `tech` at full resolution (the reference: one ray per pixel,
/// what its gaze frames save against) and compares `frame` with it inside
/// and outside the sweet spot.
pub(super) fn versus_full(
    a: &RenderArgs,
    prep: &Prepared,
    lut: &golden::tf::Lut,
    tech: Technique,
    opts: &RenderOptions,
    g: &golden::gaze::Gaze,
    frame: &golden::render::Frame,
) -> Result<VersusFull> {
    let mut full = *opts;
    full.reference.gaze = match tech {
        Technique::Reference => Some(golden::gaze::Gaze::full(
            prep.view.size[0],
            prep.view.size[1],
        )),
        _ => None,
    };
    let (f, times) = {
        let _s = Stage::start("rendering at full resolution");
        timed_frames(a.repeat, || Ok(render(prep, lut, tech, &full)?))?
    };
    let inside = |x: usize, y: usize| {
        let (dx, dy) = (x as f64 + 0.5 - g.at[0], y as f64 + 0.5 - g.at[1]);
        (dx * dx + dy * dy).sqrt() <= g.inner
    };
    let rays = match (&f.slice, &f.gaze) {
        (Some(o), _) => Some(o.stats.rays_per_region.iter().sum::<u64>() - o.stats.rays_culled),
        (None, Some(g)) => Some(g.rays),
        (None, None) => f
            .mip
            .as_ref()
            .map(|_| u64::from(prep.view.size[0]) * u64::from(prep.view.size[1])),
    };
    Ok(VersusFull {
        time_s: median(&times),
        samples: f.samples(),
        rays,
        inside: golden::metrics::compare_where(&frame.image, &f.image, inside)?,
        outside: golden::metrics::compare_where(&frame.image, &f.image, |x, y| !inside(x, y))?,
    })
}

/// The refinement `--refine` asks for; the reference and the mip-map
/// take one.
pub fn refine_of(
    spec: Option<&str>,
    levels: u32,
    tech: Technique,
) -> Result<Option<golden::refine::Refine>> {
    let Some(spec) = spec else {
        if levels != golden::refine::Refine::DEFAULT_LEVELS {
            anyhow::bail!("--refine-levels needs --refine");
        }
        return Ok(None);
    };
    if !matches!(tech, Technique::Reference | Technique::MipMap) {
        anyhow::bail!(
            "--refine applies to --method reference or mipmap only (ER's rays live in object space)"
        );
    }
    Ok(Some(golden::refine::Refine::parse(spec, levels)?))
}

/// The gaze profile `--gaze` asks for; the reference and the mip-map take one.
pub(super) fn gaze_of(
    a: &RenderArgs,
    cam: &golden::camera::Camera,
    tech: Technique,
) -> Result<Option<golden::gaze::Gaze>> {
    let Some(at) = a.gaze else {
        if a.gaze_radii.is_some() {
            anyhow::bail!("--gaze-radii needs --gaze");
        }
        return Ok(None);
    };
    if !matches!(
        tech,
        Technique::Reference
            | Technique::MipMap
            | Technique::Slice(golden::methods::Method::Er | golden::methods::Method::ErFtb)
    ) {
        anyhow::bail!("--gaze applies to --method reference, mipmap, er or er-ftb only");
    }
    let mut g = golden::gaze::Gaze::around(at, cam.width, cam.height);
    if let Some([inner, outer]) = a.gaze_radii {
        g.inner = inner;
        g.outer = outer;
    }
    g.levels = a.gaze_levels;
    g.validate()?;
    Ok(Some(g))
}

/// How many rays an ER frame casts (`--rays`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Rays {
    /// One to two rays per voxel (the paper's density).
    Voxels,
    /// The coarsest prefiltered level that still gives every pixel two rays across.
    Footprint,
}

/// The uniform gaze profile `--rays footprint` asks for: every pixel at
/// [`golden::ergaze::footprint_level`] of the view, `None` at level 0 (the
/// plain frame).
pub(super) fn footprint_of(
    a: &RenderArgs,
    vol: &golden::volume::Volume,
    cam: &golden::camera::Camera,
    tech: Technique,
) -> Result<Option<golden::gaze::Gaze>> {
    if !matches!(
        tech,
        Technique::Slice(golden::methods::Method::Er | golden::methods::Method::ErFtb)
    ) {
        anyhow::bail!("--rays footprint applies to --method er, er-ftb, pipeline or pipeline-ftb");
    }
    if a.gaze.is_some() {
        anyhow::bail!("--rays footprint and --gaze both choose the rays: drop one of them");
    }
    let level = footprint_level_of(&a.slice, vol, cam)?;
    Ok((level > 0).then(|| golden::gaze::Gaze::uniform(level)))
}

/// The level `--rays footprint` renders `vol` at for `cam`
/// ([`golden::ergaze::footprint_level`]; 0: the voxels' own rays).
pub(super) fn footprint_level_of(
    slice: &SliceArgs,
    vol: &golden::volume::Volume,
    cam: &golden::camera::Camera,
) -> Result<u32> {
    let near = slice.prepare()?.near;
    let view = golden::geometry::View::new(vol.dims(), vol.spacing(), cam, near)?;
    Ok(golden::ergaze::footprint_level(&view))
}

/// With `--compare-reference`, `image`'s error against the reference.
pub(super) fn versus_reference(
    a: &RenderArgs,
    prep: &Prepared,
    lut: &golden::tf::Lut,
    opts: &RenderOptions,
    image: &golden::image::Image,
) -> Result<Option<golden::metrics::ImageError>> {
    if !a.compare_reference {
        return Ok(None);
    }
    let _s = Stage::start("rendering the reference");
    let r = render(prep, lut, Technique::Reference, opts)?;
    Ok(Some(compare(image, &r.image)?))
}
