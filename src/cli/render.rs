//! `ercube render`: one image of a volume with one method.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};

use super::args::{with_threads, SliceArgs, ViewArgs};
use super::chip::{self, PipelineArgs};
use super::memory::FrameSpec;
use super::method::MethodArg;
use super::progress::Stage;
use super::stats::{frame_json, median, write_json};
use pipeline::cost::clock::ClockSource;

/// Arguments of `ercube render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Method.
    #[arg(long, value_enum, default_value = "er")]
    pub method: MethodArg,
    /// Output PNG (RGB over black).
    #[arg(long, default_value = "render.png")]
    pub out: PathBuf,
    /// Write statistics as JSON here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Write the final RGBA image as float32 H x W x 4 .npy here.
    #[arg(long)]
    pub npy: Option<PathBuf>,
    /// Write the baseplane image (before the warp) as float32 .npy here.
    #[arg(long)]
    pub baseplane_npy: Option<PathBuf>,
    /// Also render the reference and report the error against it.
    #[arg(long)]
    pub compare_reference: bool,
    #[command(flatten)]
    pub slice: SliceArgs,
    /// Worker threads (default: all cores); results are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Render this many frames and report the median time (the image is
    /// the last frame's; every frame is identical).
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    #[command(flatten)]
    pub pipeline: PipelineArgs,
    /// Reference, mipmap, er and er-ftb: gaze-directed variable resolution
    /// around pixel x,y (full resolution near it, one ray per 16 pixels and
    /// a quarter of the samples at the periphery; ER renders one frame per
    /// level; docs/golden.md#gaze-directed-variable-resolution).
    #[arg(long, value_parser = super::args::parse_point2, allow_hyphen_values = true)]
    pub gaze: Option<[f64; 2]>,
    /// With --gaze: the profile's radii in pixels, inner (full
    /// resolution) and outer (coarsest level); default a tenth and four
    /// tenths of the image's larger side.
    #[arg(long, value_parser = super::args::parse_point2)]
    pub gaze_radii: Option<[f64; 2]>,
    /// With --gaze: the coarsest level (one ray per 2^L x 2^L pixels).
    #[arg(long, default_value_t = 2)]
    pub gaze_levels: u32,
    /// With --gaze: also render the same method at full resolution (the
    /// reference: one ray per pixel) and report its time and samples and
    /// the error inside the sweet spot (within the inner radius) and
    /// outside it, separately.
    #[arg(long)]
    pub compare_full: bool,
}

/// Runs `f` `n` times (at least once), returning the last result and each
/// run's wall-clock seconds.
pub fn timed<T>(n: usize, f: impl FnMut() -> Result<T>) -> Result<(T, Vec<f64>)> {
    timed_with(n, f, drop)
}

/// [`timed`] for golden frames: each frame but the last gives its buffers
/// back before the next starts (untimed), as a renderer drawing frame
/// after frame does.
pub fn timed_frames(
    n: usize,
    f: impl FnMut() -> Result<golden::render::Frame>,
) -> Result<(golden::render::Frame, Vec<f64>)> {
    timed_with(n, f, golden::render::Frame::recycle)
}

/// [`timed`], handing each result but the last to `done` before the next
/// run starts.
fn timed_with<T>(
    n: usize,
    mut f: impl FnMut() -> Result<T>,
    mut done: impl FnMut(T),
) -> Result<(T, Vec<f64>)> {
    if n == 0 || n > 100_000 {
        anyhow::bail!("--repeat {n} must be 1 to 100000");
    }
    let mut times = Vec::with_capacity(n);
    let mut last = None;
    for _ in 0..n {
        if let Some(prev) = last.take() {
            done(prev);
        }
        let t = Instant::now();
        last = Some(f()?);
        times.push(t.elapsed().as_secs_f64());
    }
    Ok((last.expect("at least one run"), times))
}

/// Runs `ercube render`.
pub fn run(a: &RenderArgs) -> Result<()> {
    let Some(tech) = a.method.technique() else {
        return with_threads(a.threads, || run_pipeline(a));
    };
    chip::check_unused(&a.pipeline)?;
    with_threads(a.threads, || {
        if !matches!(tech, Technique::Slice(_)) && a.slice.preintegrate {
            anyhow::bail!(
                "--preintegrate applies to the slice-order methods; {} does not take it",
                tech.name()
            );
        }
        if !matches!(tech, Technique::Slice(_)) && a.baseplane_npy.is_some() {
            anyhow::bail!(
                "--baseplane-npy needs a slice-order method; {} has no baseplane",
                tech.name()
            );
        }
        let mut opts = a.slice.options()?;
        let spec = FrameSpec {
            technique: Some(tech),
            shade: opts.slice.shade.is_some(),
            size: a.view.camera.size,
        };
        let (vol, tf, cam) = a.view.load_for(tech.name(), &spec)?;
        a.slice.apply_tf(&mut opts, &tf)?;
        // The comparison's reference is always the full one.
        let full = opts;
        opts.reference.gaze = gaze_of(a, &cam, tech)?;
        let lut = lut_for(vol.kind(), &tf);
        if a.baseplane_npy.is_some() && opts.reference.gaze.is_some() {
            anyhow::bail!("--baseplane-npy: a gaze-directed frame has one baseplane per level; drop one of them");
        }
        let shape = (vol.dims(), vol.spacing());
        let prep = match (&opts.reference.gaze, tech) {
            // The gaze levels filter the volume itself, so a gaze-directed
            // slice-order frame keeps it beside the stack.
            (Some(g), Technique::Slice(_)) => {
                let prep = a.slice.prepared(&vol, &cam)?;
                let _s = Stage::start("preparing the gaze levels");
                prep.with_gaze_levels(&vol, &cam, &a.slice.prepare()?, g.levels)?
            }
            _ => a.slice.prepared_owning(vol, &cam)?,
        };
        let (frame, times) = {
            let _s = Stage::start(format!("rendering with {}", tech.name()));
            timed_frames(a.repeat, || Ok(render(&prep, &lut, tech, &opts)?))?
        };
        let time_s = median(&times);
        let vs_full = match &opts.reference.gaze {
            Some(g) if a.compare_full => Some(versus_full(a, &prep, &lut, tech, &opts, g, &frame)?),
            _ if a.compare_full => anyhow::bail!("--compare-full needs --gaze"),
            _ => None,
        };
        let base = frame.slice.as_ref().map(|o| &o.baseplane);
        let err = write_outputs(a, &prep, &lut, &full, &frame.image, base)?;
        if let Some(p) = &a.stats {
            let mut v = frame_json(
                tech.name(),
                shape,
                &prep.view,
                cam.eye,
                time_s,
                &frame,
                err.as_ref(),
            );
            v["times_s"] = serde_json::json!(times);
            if let Some(f) = &vs_full {
                v["gaze_vs_full"] = f.json();
            }
            write_json(p, &v)?;
        }
        let mut line = format!(
            "{}: {}x{} in {:.3} s, principal axis {}, D = {:.3}",
            tech.name(),
            cam.width,
            cam.height,
            time_s,
            prep.view.axes.label(),
            prep.view.d
        );
        if let Some(e) = err {
            line += &format!(
                ", vs reference: max {} /255, rmse {:.5}, psnr {:.2} dB",
                e.max_abs_255, e.rmse, e.psnr
            );
        }
        if let Some(f) = &vs_full {
            line += &f.summary(time_s, frame.samples());
        }
        super::say(&format!("{line} -> {}", a.out.display()));
        Ok(())
    })
}

/// A gaze-directed frame against the same method at full resolution.
struct VersusFull {
    time_s: f64,
    samples: Option<u64>,
    /// Rays of the full frame: one per pixel for the casters, ER's kept
    /// rays summed over its regions.
    rays: Option<u64>,
    inside: (golden::metrics::ImageError, u64),
    outside: (golden::metrics::ImageError, u64),
}

impl VersusFull {
    fn json(&self) -> serde_json::Value {
        let part = |(e, n): &(golden::metrics::ImageError, u64)| {
            let mut v = super::stats::error_json(e);
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

    fn summary(&self, time_s: f64, samples: Option<u64>) -> String {
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
fn versus_full(
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

/// The gaze profile `--gaze` asks for; the reference and the mip-map take one.
fn gaze_of(
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

/// The outputs every render writes: the PNG, `--npy`, `--baseplane-npy`,
/// and (with `--compare-reference`) the error against the reference,
/// which it returns.
fn write_outputs(
    a: &RenderArgs,
    prep: &Prepared,
    lut: &golden::tf::Lut,
    opts: &RenderOptions,
    image: &golden::image::Image,
    baseplane: Option<&golden::warp::Baseplane>,
) -> Result<Option<golden::metrics::ImageError>> {
    let err = if a.compare_reference {
        let _s = Stage::start("rendering the reference");
        let r = render(prep, lut, Technique::Reference, opts)?;
        Some(compare(image, &r.image)?)
    } else {
        None
    };
    image.write_png(&a.out)?;
    if let Some(p) = &a.npy {
        image.write_npy(p)?;
    }
    if let (Some(p), Some(b)) = (&a.baseplane_npy, baseplane) {
        b.to_image().write_npy(p)?;
    }
    Ok(err)
}

/// `ercube render --method pipeline` or `pipeline-ftb`.
fn run_pipeline(a: &RenderArgs) -> Result<()> {
    let clock = a.pipeline.clock()?;
    let (cfg, slice) = chip::configure(&a.pipeline.cfg, a.method, &a.slice)?;
    let opts = slice.options()?;
    chip::check_options(&opts)?;
    let spec = FrameSpec {
        technique: None,
        shade: opts.slice.shade.is_some(),
        size: a.view.camera.size,
    };
    let (vol, tf, cam) = a.view.load_for(a.method.name(), &spec)?;
    let mut opts = opts;
    slice.apply_tf(&mut opts, &tf)?;
    let (shade, voi) = (opts.slice.shade, opts.slice.voi);
    let lut = chip::pipeline_lut(&cfg, &vol, &tf);
    let shape = (vol.dims(), vol.spacing());
    let bits = vol.kind().bits();
    // The PEs load from golden's stack, which takes the volume's voxels:
    // the frame holds them once.
    let prep = slice.prepared_owning(vol, &cam)?;
    // Golden's own table from the same classification table: the unit
    // quantises it, and the comparison below renders golden with it.
    let preint = opts
        .slice
        .preintegrate
        .then(|| golden::preint::PreTable::new(&lut));
    let (run, times) = {
        let _s = Stage::start(format!("clocking {} PEs", cfg.pes));
        let mut spare = None;
        timed(a.repeat, || {
            chip::run(
                &a.pipeline,
                &cfg,
                bits,
                &lut,
                &prep,
                (
                    opts.slice.skips,
                    shade.as_ref(),
                    voi.as_ref(),
                    preint.as_ref(),
                ),
                &mut spare,
            )
        })?
    };
    let run = chip::PipelineRun {
        time_s: median(&times),
        ..run
    };
    let vs_golden = chip::versus_golden(
        &prep,
        &lut,
        &run.image,
        &cfg,
        (shade, voi, opts.slice.preintegrate),
    )?;
    let err = write_outputs(
        a,
        &prep,
        &lut,
        &opts,
        &run.image,
        Some(&run.frame.baseplane),
    )?;
    if let Some(p) = &a.stats {
        let frame = golden::render::Frame {
            image: run.image.clone(),
            slice: None,
            mip: None,
            gaze: None,
            sw: None,
            er_gaze: None,
        };
        let mut v = frame_json(
            a.method.name(),
            shape,
            &prep.view,
            cam.eye,
            run.time_s,
            &frame,
            err.as_ref(),
        );
        let extra = chip::stats_json(&cfg, &run, Some(vs_golden.clone()));
        if let (Some(o), Some(e)) = (v.as_object_mut(), extra.as_object()) {
            for (k, val) in e {
                o.insert(k.clone(), val.clone());
            }
        }
        v["regions"] = serde_json::json!(prep.view.regions().bounds);
        v["clock_mhz"] = serde_json::json!(clock);
        v["clock_source"] = serde_json::json!(ClockSource::Assumed);
        v["frames_per_s"] = serde_json::json!(pipeline::cost::clock::fps(run.frame.cycles, clock));
        v["times_s"] = serde_json::json!(times);
        write_json(p, &v)?;
    }
    let f = &run.frame;
    super::say(&format!(
        "{}: {} PEs, {} cycles (ideal {:.0}, utilization {:.3}), {} samples, {:.3} s; vs golden {}: max {} /255 -> {}",
        a.method.name(),
        cfg.pes,
        f.cycles,
        f.ideal_cycles,
        f.utilization(),
        f.samples,
        run.time_s,
        chip::golden_method(&cfg).name(),
        vs_golden["max_abs_255"],
        a.out.display()
    ));
    super::say(&format!(
        "  frame: {}",
        pipeline::cost::clock::rate_line(f.cycles, clock, ClockSource::Assumed)
    ));
    Ok(())
}
