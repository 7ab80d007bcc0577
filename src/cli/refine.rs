//! `ercube refine`: progressive refinement of a resting view (Levoy,
//! "Volume Rendering by Adaptive Refinement", cited by seeds 000 and 001;
//! [`golden::refine`]). The first step is the adaptive frame of
//! `--refine`; each next step casts an equal share of the rays still
//! uncast, the most complex cells first (with `--gaze`, the cells nearest
//! the gaze point first, so the sweet spot grows); the last step has cast
//! every pixel's ray once and is the one-ray-per-pixel frame bit for bit.
//! No ray is cast twice. The output folder gets each step's PNG, a CSV
//! and a plot of the error against the one-ray-per-pixel frame over
//! cumulative time, and the stats as JSON.
//!
//! Also here: `render --refine --compare-full`'s comparison, split into
//! the refined cells and the unsplit ones.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use golden::metrics::{compare, compare_where, ImageError};
use golden::refine::frame::{self, Step};
use golden::refine::{Refine, RefineStats};
use golden::render::{lut_for, Prepared, RenderOptions, Technique};
use serde_json::json;

use super::args::{with_threads, SliceArgs, ViewArgs};
use super::memory::FrameSpec;
use super::method::MethodArg;
use super::plot::{write_chart, Chart, Kind, Series};
use super::progress::Stage;
use super::render::{refine_of, timed};
use super::stats::{error_json, median, write_json};

/// Arguments of `ercube refine`.
#[derive(Debug, Args)]
pub struct RefineArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Method: reference (its one-ray-per-pixel rays) or mipmap.
    #[arg(long, value_enum, default_value = "reference")]
    pub method: MethodArg,
    /// The first step's adaptive refinement: `complexity` or
    /// `complexity:THRESHOLD` (default 0.02).
    #[arg(
        long,
        default_value = "complexity",
        value_name = "complexity[:THRESHOLD]"
    )]
    pub refine: String,
    /// The coarsest level L (one ray per 2^L x 2^L pixels), 1 to 6.
    #[arg(long, default_value_t = Refine::DEFAULT_LEVELS)]
    pub refine_levels: u32,
    /// Steps, the first the adaptive frame and the last the full one
    /// (2 to 1000).
    #[arg(long, default_value_t = 8)]
    pub steps: usize,
    /// Gaze point x,y in pixels: the first step refines only where the
    /// paper's profile allows, and later steps grow the sweet spot.
    #[arg(long, value_parser = super::args::parse_point2, allow_hyphen_values = true)]
    pub gaze: Option<[f64; 2]>,
    /// With --gaze: the profile's radii in pixels, inner and outer.
    #[arg(long, value_parser = super::args::parse_point2)]
    pub gaze_radii: Option<[f64; 2]>,
    /// With --gaze: the profile's coarsest level.
    #[arg(long, default_value_t = 2)]
    pub gaze_levels: u32,
    #[command(flatten)]
    pub slice: SliceArgs,
    /// Worker threads (default: all cores); results are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Folder for step_NN.png, progress.csv, progress.png and stats.json.
    #[arg(long, default_value = "refine")]
    pub out_dir: PathBuf,
}

/// One written step.
struct Row {
    index: usize,
    rays_new: u64,
    rays: u64,
    time_s: f64,
    err: ImageError,
    stats: RefineStats,
}

/// Runs `ercube refine`.
pub fn run(a: &RefineArgs) -> Result<()> {
    let tech = match a.method.technique() {
        Some(t @ (Technique::Reference | Technique::MipMap)) => t,
        _ => anyhow::bail!(
            "ercube refine takes --method reference or mipmap, not {}",
            a.method.name()
        ),
    };
    super::outputs::check_dirs(&[Some(&a.out_dir)])?;
    super::outputs::all_or_nothing(&[&a.out_dir], || {
        with_threads(a.threads, || refine(a, tech))
    })
}

fn refine(a: &RefineArgs, tech: Technique) -> Result<()> {
    let refine =
        refine_of(Some(&a.refine), a.refine_levels, tech)?.expect("a refinement was given");
    if !(2..=frame::MAX_STEPS).contains(&a.steps) {
        anyhow::bail!("--steps {} must be 2 to {}", a.steps, frame::MAX_STEPS);
    }
    if a.gaze.is_none() && a.gaze_radii.is_some() {
        anyhow::bail!("--gaze-radii needs --gaze");
    }
    let mut opts = a.slice.options()?;
    let spec = FrameSpec {
        technique: Some(tech),
        shade: opts.slice.shade.is_some(),
        size: a.view.camera.size,
    };
    let (vol, tf, cam) = a.view.load_for(tech.name(), &spec)?;
    a.slice.apply_tf(&mut opts, &tf)?;
    if let Some(at) = a.gaze {
        let mut g = golden::gaze::Gaze::around(at, cam.width, cam.height);
        if let Some([inner, outer]) = a.gaze_radii {
            g.inner = inner;
            g.outer = outer;
        }
        g.levels = a.gaze_levels;
        g.validate()?;
        opts.reference.gaze = Some(g);
    }
    let lut = lut_for(vol.kind(), &tf);
    let prep = a.slice.prepared_owning(vol, &cam)?;
    if tech == Technique::MipMap {
        // The pyramid is built once per volume and table, before any
        // step (its time is not a step's).
        prep.mipmap_of(&lut, &opts.mip())?;
    }
    let (full, full_times) = {
        let _s = Stage::start("rendering one ray per pixel");
        timed(1, || Ok(frame::full(&prep, &lut, tech, &opts)?))?
    };
    std::fs::create_dir_all(&a.out_dir)?;
    let mut rows: Vec<Row> = Vec::new();
    {
        let _s = Stage::start(format!("refining {} in {} steps", tech.name(), a.steps));
        frame::progressive(&prep, &lut, tech, &opts, &refine, a.steps, |s: &Step| {
            s.image
                .write_png(&a.out_dir.join(format!("step_{:02}.png", s.index)))?;
            rows.push(Row {
                index: s.index,
                rays_new: s.rays_new,
                rays: s.rays,
                time_s: s.time_s,
                err: compare(&s.image, &full)?,
                stats: s.stats.clone(),
            });
            Ok(())
        })?;
    }
    let last = rows.last().expect("at least two steps");
    let exact = last.err.max_abs_255 == 0.0 && last.err.rmse == 0.0;
    write_outputs(a, tech, &refine, &rows, median(&full_times))?;
    let first = &rows[0];
    super::say(&format!(
        "{} refined in {} steps: first step {} rays ({:.3} of {}) in {:.3} s, rmse {:.5}; full image after {:.3} s, {} rays in all{} (one ray per pixel: {:.3} s) -> {}",
        tech.name(),
        rows.len(),
        first.rays,
        first.rays as f64 / first.stats.pixels as f64,
        first.stats.pixels,
        first.time_s,
        first.err.rmse,
        last.time_s,
        last.rays,
        if exact { ", equal to one ray per pixel" } else { ", DIFFERS from one ray per pixel" },
        median(&full_times),
        a.out_dir.display()
    ));
    if !exact {
        anyhow::bail!("the last step differs from the one-ray-per-pixel frame");
    }
    Ok(())
}

/// The CSV, the plot and the stats.
fn write_outputs(
    a: &RefineArgs,
    tech: Technique,
    refine: &Refine,
    rows: &[Row],
    full_time_s: f64,
) -> Result<()> {
    let mut csv = String::from("step,rays_new,rays,rays_fraction,time_s,rmse,max_abs_255,psnr\n");
    for r in rows {
        csv += &format!(
            "{},{},{},{:.6},{:.6},{:.6},{},{:.3}\n",
            r.index,
            r.rays_new,
            r.rays,
            r.rays as f64 / r.stats.pixels as f64,
            r.time_s,
            r.err.rmse,
            r.err.max_abs_255,
            r.err.psnr
        );
    }
    golden::image::write_atomic(&a.out_dir.join("progress.csv"), |w| {
        w.write_all(csv.as_bytes())
    })?;
    let label = format!("{}+refine", tech.name());
    let chart = Chart {
        title: format!(
            "progressive refinement, {} (threshold {}, L = {})",
            tech.name(),
            refine.threshold,
            refine.levels
        ),
        x_label: "cumulative time (s)".into(),
        y_label: "RMSE vs one ray per pixel".into(),
        x_log: false,
        y_log: false,
        series: vec![
            Series::new(
                label.clone(),
                rows.iter().map(|r| (r.time_s, r.err.rmse)).collect(),
                Kind::LinePoints,
            ),
            Series::new(
                format!("{} one ray per pixel", tech.name()),
                vec![(full_time_s, 0.0)],
                Kind::Points,
            ),
        ],
    };
    write_chart(&a.out_dir.join("progress.png"), &chart, (800, 500))?;
    let steps: Vec<_> = rows
        .iter()
        .map(|r| {
            json!({
                "step": r.index,
                "rays_new": r.rays_new,
                "rays": r.rays,
                "time_s": r.time_s,
                "vs_full": error_json(&r.err),
                "refine": r.stats,
            })
        })
        .collect();
    write_json(
        &a.out_dir.join("stats.json"),
        &json!({
            "method": label,
            "threshold": refine.threshold,
            "levels": refine.levels,
            "gaze": a.gaze,
            "full_time_s": full_time_s,
            "steps": steps,
        }),
    )
}

/// A refined frame against one ray per pixel, over the whole image, inside
/// the refined cells (leaf level below `L`) and inside the unsplit ones.
pub struct VersusFull {
    time_s: f64,
    rays: u64,
    pixels: u64,
    all: ImageError,
    complex: (ImageError, u64),
    flat: (ImageError, u64),
}

impl VersusFull {
    /// As JSON.
    pub fn json(&self) -> serde_json::Value {
        let part = |(e, n): &(ImageError, u64)| {
            let mut v = error_json(e);
            v["pixels"] = json!(n);
            v
        };
        json!({
            "full_time_s": self.time_s,
            "rays": self.rays,
            "full_rays": self.pixels,
            "all": error_json(&self.all),
            "refined_cells": part(&self.complex),
            "unsplit_cells": part(&self.flat),
        })
    }

    /// The render line's tail.
    pub fn summary(&self, time_s: f64) -> String {
        format!(
            "; one ray per pixel {:.3} s ({:.2}x), rays {} of {} ({:.3}), vs full: rmse {:.5} max {} /255, refined cells ({} px) rmse {:.5}, unsplit cells ({} px) rmse {:.5}",
            self.time_s,
            self.time_s / time_s,
            self.rays,
            self.pixels,
            self.rays as f64 / self.pixels.max(1) as f64,
            self.all.rmse,
            self.all.max_abs_255,
            self.complex.1,
            self.complex.0.rmse,
            self.flat.1,
            self.flat.0.rmse
        )
    }
}

/// Renders `tech` with one ray per pixel and compares `image` (refined by
/// `r`, leaves `leaf`) with it.
#[allow(clippy::too_many_arguments)]
pub fn versus_full(
    repeat: usize,
    prep: &Prepared,
    lut: &golden::tf::Lut,
    tech: Technique,
    opts: &RenderOptions,
    r: &Refine,
    leaf: &[u8],
    stats: &RefineStats,
    image: &golden::image::Image,
) -> Result<VersusFull> {
    let (full, times) = {
        let _s = Stage::start("rendering one ray per pixel");
        timed(repeat, || Ok(frame::full(prep, lut, tech, opts)?))?
    };
    let w = image.width;
    let top = r.levels as u8;
    Ok(VersusFull {
        time_s: median(&times),
        rays: stats.rays,
        pixels: stats.pixels,
        all: compare(image, &full)?,
        complex: compare_where(image, &full, |x, y| leaf[y * w + x] < top)?,
        flat: compare_where(image, &full, |x, y| leaf[y * w + x] == top)?,
    })
}
