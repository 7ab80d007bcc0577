//! `ercube skip-bench`: what each kind of skipping saves, on scenes that
//! need it to different degrees (brainsmall with transparent air, also
//! seen narrowly, the mostly empty checkerboard, a sphere shell, the dense
//! Marschner-Lobb):
//! golden time and samples, and pipeline cycles, with and without each
//! skip, and how far each skipped image is from the unskipped one (0 where
//! the skip cannot change the image). Writes `DIR/bench/skip/skip.csv`
//! and the "Skipping" section of `DIR/benchmarks.md` (between its markers,
//! or appended).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use glam::DVec3;

use golden::camera::Camera;
use golden::image::Image;
use golden::load::load_auto;
use golden::methods::{Method, Options};
use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::scenes::{tf_preset, Scene};
use golden::skip::Skips;
use golden::tf::TransferFunction;
use golden::volume::{Volume, DEFAULT_MEMORY_LIMIT};
use pipeline::config::{Order, PipelineConfig};
use pipeline::Voxels;

use super::args::with_threads;
use super::render::timed_frames;
use super::stats::median;

/// Arguments of `ercube skip-bench`.
#[derive(Debug, Args)]
pub struct SkipBenchArgs {
    /// Golden frames per configuration (the median time is reported).
    #[arg(long, default_value_t = 7)]
    pub frames: usize,
    /// Report folder: writes DIR/bench/skip/skip.csv and the "Skipping"
    /// section of DIR/benchmarks.md (created if missing). The default,
    /// ./skip-bench, keeps a run apart from the repository's own report;
    /// `--report docs` updates that.
    #[arg(long, default_value = "skip-bench")]
    pub report: PathBuf,
    /// Edge of the synthetic scenes' volumes.
    #[arg(long, default_value_t = 256)]
    pub n: usize,
    /// The brainsmall volume (skipped with a note when missing).
    #[arg(long, default_value = "data/brainsmall.den")]
    pub brainsmall: PathBuf,
    /// Leave out the pipeline's cycle counts (the slowest part).
    #[arg(long)]
    pub no_pipeline: bool,
    /// Pipeline configuration (TOML) of the pipeline rows, e.g. an
    /// architecture to compare (default: the default configuration); each
    /// row sets its order and termination.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

const OFF: Skips = Skips::NONE;

/// One scene of the plan.
struct Case {
    key: String,
    about: String,
    vol: Volume,
    tf: TransferFunction,
    cam: Camera,
}

/// One measured configuration.
struct Row {
    case: String,
    what: String,
    time_ms: Option<f64>,
    cycles: Option<u64>,
    /// Pipeline rows: `ideal_cycles / cycles`.
    utilization: Option<f64>,
    samples: u64,
    speedup: f64,
    max_diff_255: f64,
    slices_skipped: u64,
    beams_skipped: u64,
    rays_culled: u64,
}

fn cases(a: &SkipBenchArgs, notes: &mut Vec<String>) -> Result<Vec<Case>> {
    let mut out = Vec::new();
    match load_auto(&a.brainsmall, None, DEFAULT_MEMORY_LIMIT) {
        Ok(vol) => {
            let c = DVec3::from_array(vol.center_world());
            let eye = DVec3::new(c.x, c.y, -64.0);
            // A narrow view of one side: culling's case.
            let side = DVec3::new(c.x * 0.4, c.y, c.z);
            out.push(Case {
                key: "brainsmall-narrow".into(),
                about: "brainsmall, the same eye looking at (0.4 x, y, z) of the centre with a 30-degree field of view, 256x256: most rays miss the image".into(),
                cam: Camera::new(eye, side, DVec3::Y, 30.0, 256, 256)?,
                vol: vol.clone(),
                tf: tf_preset("grey-ramp")?,
            });
            out.insert(
                0,
                Case {
                    key: "brainsmall".into(),
                    about: "brainsmall (128x128x84, `grey-ramp`: air transparent), eye 64 voxels in front of the centre, 90 degrees, 256x256".into(),
                    cam: Camera::new(eye, c, DVec3::Y, 90.0, 256, 256)?,
                    vol,
                    tf: tf_preset("grey-ramp")?,
                },
            );
        }
        Err(e) => notes.push(format!("brainsmall left out: {e}")),
    }
    let n = a.n;
    for (scene, about) in [
        (
            Scene::Checker {
                n,
                cube: (n / 8).max(1),
            },
            "the checkerboard room (mostly empty)",
        ),
        (Scene::Sphere { n }, "a sphere shell (empty inside and out)"),
        (
            Scene::MarschnerLobb { n: n / 2 },
            "Marschner-Lobb (dense: no empty blocks)",
        ),
    ] {
        let vol = scene.build(DEFAULT_MEMORY_LIMIT)?;
        let c = DVec3::from_array(vol.center_world());
        let m = scene.size() as f64;
        out.push(Case {
            key: scene.to_string(),
            about: format!(
                "{about}: `{scene}`, `{}` preset, eye {m:.0}/2 voxels in front of the centre, 90 degrees, 256x256",
                scene.name()
            ),
            cam: Camera::new(DVec3::new(c.x, c.y, -m / 2.0), c, DVec3::Y, 90.0, 256, 256)?,
            vol,
            tf: scene.preset(),
        });
    }
    Ok(out)
}

/// The golden configurations: each method with nothing skipped first.
fn golden_plan() -> Vec<(&'static str, Method, f32, Skips)> {
    let (empty, cull) = (Skips::EMPTY, Skips::CULL);
    vec![
        ("er, nothing skipped", Method::Er, 1.0, OFF),
        ("er, empty space", Method::Er, 1.0, empty),
        ("er, culling", Method::Er, 1.0, cull),
        (
            "er, empty space + culling (default)",
            Method::Er,
            1.0,
            Skips::default(),
        ),
        ("er-ftb, nothing skipped", Method::ErFtb, 1.0, OFF),
        ("er-ftb, termination 0.99", Method::ErFtb, 0.99, OFF),
        ("er-ftb, empty space", Method::ErFtb, 1.0, empty),
        ("er-ftb, culling", Method::ErFtb, 1.0, cull),
        (
            "er-ftb, all (default)",
            Method::ErFtb,
            0.99,
            Skips::default(),
        ),
    ]
}

/// The pipeline configurations: order, termination, skips.
fn pipeline_plan() -> Vec<(&'static str, Order, f64, Skips)> {
    let empty = Skips::EMPTY;
    vec![
        ("pipeline, nothing skipped", Order::BackToFront, 1.0, OFF),
        ("pipeline, empty space", Order::BackToFront, 1.0, empty),
        (
            "pipeline, empty space + culling",
            Order::BackToFront,
            1.0,
            Skips::default(),
        ),
        (
            "pipeline-ftb, nothing skipped",
            Order::FrontToBack,
            1.0,
            OFF,
        ),
        (
            "pipeline-ftb, termination 0.99",
            Order::FrontToBack,
            0.99,
            OFF,
        ),
        (
            "pipeline-ftb, all",
            Order::FrontToBack,
            0.99,
            Skips::default(),
        ),
    ]
}

/// What one configuration measured: its image, its cost (golden
/// milliseconds or pipeline cycles) and its counts.
struct Run {
    image: Image,
    cost: f64,
    utilization: Option<f64>,
    samples: u64,
    slices: u64,
    beams: u64,
    culled: u64,
}

/// The unskipped run of a method (its plan's first): image and cost.
type Base = Option<(Image, f64)>;

/// `run`'s table row, against `base`; an unskipped run becomes the base.
fn row(
    case: &Case,
    what: &str,
    run: Run,
    unskipped: bool,
    base: &mut Base,
    golden: bool,
) -> Result<Row> {
    if unskipped {
        *base = Some((run.image.clone(), run.cost));
    }
    let (img0, cost0) = base.as_ref().context("the unskipped run comes first")?;
    let max_diff_255 = compare(&run.image, img0).map_or(f64::INFINITY, |e| e.max_abs_255);
    let unit = if golden { "ms" } else { "cycles" };
    super::say(&format!(
        "{}: {what}: {:.2} {unit}, {} samples",
        case.key, run.cost, run.samples
    ));
    Ok(Row {
        case: case.key.clone(),
        what: what.into(),
        time_ms: golden.then_some(run.cost),
        cycles: (!golden).then_some(run.cost as u64),
        utilization: run.utilization,
        samples: run.samples,
        speedup: cost0 / run.cost.max(1e-12),
        max_diff_255,
        slices_skipped: run.slices,
        beams_skipped: run.beams,
        rays_culled: run.culled,
    })
}

fn measure(
    a: &SkipBenchArgs,
    base_cfg: &PipelineConfig,
    case: &Case,
    rows: &mut Vec<Row>,
) -> Result<()> {
    let prep = Prepared::new(&case.vol, &case.cam)?;
    let lut = lut_for(case.vol.kind(), &case.tf);
    let mut base = None;
    for (what, m, terminate, skips) in golden_plan() {
        let opts = RenderOptions {
            slice: Options {
                terminate,
                skips,
                ..Options::default()
            },
            ..RenderOptions::default()
        };
        let (frame, times) = timed_frames(a.frames, || {
            Ok(render(&prep, &lut, Technique::Slice(m), &opts)?)
        })?;
        let s = &frame.slice.as_ref().context("a slice-order frame")?.stats;
        let run = Run {
            cost: median(&times) * 1e3,
            utilization: None,
            samples: s.samples_total,
            slices: s.slices_skipped,
            beams: s.beams_skipped,
            culled: s.rays_culled,
            image: frame.image,
        };
        let unskipped = skips == OFF && terminate >= 1.0;
        rows.push(row(case, what, run, unskipped, &mut base, true)?);
    }
    if a.no_pipeline {
        return Ok(());
    }
    let mut base = None;
    for (what, order, terminate, skips) in pipeline_plan() {
        let cfg = PipelineConfig {
            order,
            terminate,
            ..*base_cfg
        };
        cfg.validate()?;
        let lut = super::chip::pipeline_lut(&cfg, &case.vol, &case.tf);
        let f = pipeline::FrameRun::prepared(&cfg, &lut, &prep, Voxels::Volume(&case.vol))
            .skips(skips)
            .run()?;
        let run = Run {
            image: golden::warp::warp(&prep.view, &f.baseplane),
            cost: f.cycles as f64,
            utilization: Some(f.utilization()),
            samples: f.samples,
            slices: f.skipped.slices,
            beams: f.skipped.beams,
            culled: f.skipped.rays_culled,
        };
        let unskipped = skips == OFF && terminate >= 1.0;
        rows.push(row(case, what, run, unskipped, &mut base, false)?);
    }
    Ok(())
}

/// Runs `ercube skip-bench`.
pub fn run(a: &SkipBenchArgs) -> Result<()> {
    if a.frames == 0 || a.frames > 1000 {
        bail!("--frames {} must be 1 to 1000", a.frames);
    }
    if !(16..=1024).contains(&a.n) {
        bail!("--n {} must be 16 to 1024", a.n);
    }
    super::outputs::check_dirs(&[Some(&a.report)])?;
    super::outputs::all_or_nothing(&[&a.report], || {
        with_threads(a.threads, || {
            let section = section(a)?;
            let md = a.report.join("benchmarks.md");
            splice(&md, &section)?;
            super::say(&format!(
                "wrote {} and {}",
                md.display(),
                a.report.join("bench/skip/skip.csv").display()
            ));
            Ok(())
        })
    })
}

const BEGIN: &str = "<!-- skip-bench: begin -->";
const END: &str = "<!-- skip-bench: end -->";

/// Measures the plan and returns the markdown section (writing the CSV).
pub fn section(a: &SkipBenchArgs) -> Result<String> {
    let base_cfg = match &a.config {
        Some(p) => PipelineConfig::from_toml_file(p)?,
        None => PipelineConfig::default(),
    };
    base_cfg.validate()?;
    let mut notes = Vec::new();
    let cases = cases(a, &mut notes)?;
    let mut rows = Vec::new();
    for case in &cases {
        measure(a, &base_cfg, case, &mut rows)?;
    }
    let dir = a.report.join("bench").join("skip");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut csv = String::from(
        "case,configuration,time_ms,cycles,utilization,samples,speedup,max_diff_255,slices_skipped,beams_skipped,rays_culled\n",
    );
    for r in &rows {
        writeln!(
            csv,
            "{},{},{},{},{},{},{:.3},{},{},{},{}",
            r.case,
            r.what.replace(',', ";"),
            r.time_ms.map_or(String::new(), |t| format!("{t:.3}")),
            r.cycles.map_or(String::new(), |c| c.to_string()),
            r.utilization.map_or(String::new(), |u| format!("{u:.4}")),
            r.samples,
            r.speedup,
            r.max_diff_255,
            r.slices_skipped,
            r.beams_skipped,
            r.rays_culled
        )?;
    }
    golden::image::write_atomic(&dir.join("skip.csv"), |w| w.write_all(csv.as_bytes()))?;
    let mut md = format!(
        "{BEGIN}\n## Skipping what the scene does not need\n\n\
         Generated by `ercube skip-bench --frames {}{}` (also part of `ercube bench --report`); CSV in \
         `bench/skip/skip.csv`. Golden times are medians of {} frames (view prepared, warp included); \
         pipeline rows give clock cycles of {}, bookkeeping included, and the sampling utilisation \
         (`ideal_cycles / cycles`). \
         *Speed-up* is against the same method with nothing skipped; *max diff* is the largest \
         8-bit channel difference from that unskipped image (0: bit-identical images are 0 by \
         construction, and every skip but termination is 0 here).\n",
        a.frames,
        a.config
            .as_ref()
            .map_or(String::new(), |p| format!(" --config {}", p.display())),
        a.frames,
        match &a.config {
            Some(p) => format!(
                "`{}` ({}, {} PEs)",
                p.display(),
                pipeline::cost::arch::label(&base_cfg),
                base_cfg.pes
            ),
            None => "the default configuration (16 PEs)".to_owned(),
        }
    );
    for n in &notes {
        writeln!(md, "\n_{n}_")?;
    }
    for case in &cases {
        writeln!(md, "\n### {}\n", case.about)?;
        md.push_str("| configuration | time (ms) | cycles | utilisation | samples | speed-up | max diff /255 | slices skipped | beams skipped | rays culled |\n");
        md.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        for r in rows.iter().filter(|r| r.case == case.key) {
            writeln!(
                md,
                "| {} | {} | {} | {} | {} | {:.2}x | {} | {} | {} | {} |",
                r.what,
                r.time_ms.map_or("".into(), |t| format!("{t:.2}")),
                r.cycles.map_or("".into(), |c| c.to_string()),
                r.utilization.map_or("".into(), |u| format!("{u:.3}")),
                r.samples,
                r.speedup,
                r.max_diff_255,
                r.slices_skipped,
                r.beams_skipped,
                r.rays_culled
            )?;
        }
    }
    md.push_str(END);
    md.push('\n');
    Ok(md)
}

/// Replaces the section between the markers of `path`, or appends it.
fn splice(path: &Path, section: &str) -> Result<()> {
    let old = std::fs::read_to_string(path).unwrap_or_default();
    let new = match (old.find(BEGIN), old.find(END)) {
        (Some(b), Some(e)) if e > b => format!(
            "{}{section}{}",
            &old[..b],
            &old[e + END.len()..].trim_start_matches('\n')
        ),
        _ => format!(
            "{}{}{section}",
            old,
            if old.is_empty() || old.ends_with("\n\n") {
                ""
            } else {
                "\n"
            }
        ),
    };
    golden::image::write_atomic(path, |w| w.write_all(new.as_bytes()))?;
    Ok(())
}
