//! `ercube bench`: every chosen method (golden techniques and the pipeline
//! at chosen widths) over a sweep of eye distances `D`, several timed
//! frames per point, against one reference render per distance; writes a
//! CSV of every run, PNG plots (time against `D` as the paper's Figure 9,
//! error against time, samples per slice and per frame beside the paper's
//! formulas) and a markdown summary. `ercube bench --report DIR` runs the
//! fixed plan of `docs/benchmarks.md`; `ercube sweep-widths` (in
//! [`widths`]) sweeps the pipeline's datapath widths.
//!
//! **Views.** The eye sits on the line through the volume's centre
//! parallel to z, `D` voxels in front of slice 0 (`z = 0`), looking at the
//! centre; the principal axis is therefore +z and `D` is the paper's eye
//! distance. `--fov fit` (the default) opens the field of view so that the
//! front face exactly fills the image, `2 atan(N / 2D)`: the paper's two
//! views of the 256^3 checkerboard (D = 64 at 127 degrees, D = 128 at 90)
//! are exactly such views.
//!
//! **Determinism.** Rendering involves no randomness and every renderer is
//! bit-identical for any thread count, so images, sample and cycle counts
//! and errors depend only on the arguments. The seed orders the methods
//! within each frame (a seeded shuffle, so that slow drifts of the machine
//! do not always favour the same method); rows are written in a fixed
//! order, so the CSV is the same for the same arguments except its
//! `time_s` column.

mod model;
mod report;
mod widths;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::Args;
use glam::DVec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use golden::camera::{Camera, ImagePlane};
use golden::metrics::{compare, ImageError};
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::tf::{Lut, TransferFunction};
use golden::volume::Volume;
use pipeline::config::PipelineConfig;

use super::args::{parse_size, with_threads, PlaneArg, SourceArgs, TfArgs};
use super::plot::{write_chart, write_charts, Chart, Kind, Series};
pub use model::Model;
pub use widths::{sweep as sweep_widths, SweepArgs};

/// Arguments of `ercube bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub source: SourceArgs,
    #[command(flatten)]
    pub tf: TfArgs,
    /// Comma-separated methods: reference, under, over, box, er, er-ftb,
    /// pipeline (default widths), pipeline-ftb (front to back, default
    /// widths) or pipeline:FILE.toml (widths from FILE).
    #[arg(long, default_value = "reference,under,over,box,er,er-ftb,pipeline")]
    pub methods: String,
    /// Comma-separated eye distances D in voxels (eye to slice 0).
    #[arg(long, default_value = "2,4,8,16,32,64,125,250,500")]
    pub distances: String,
    /// Vertical field of view in degrees: "fit" (the front face fills the
    /// image), one angle for every distance, or one angle per distance.
    #[arg(long, default_value = "fit")]
    pub fov: String,
    /// Image size WxH.
    #[arg(long, value_parser = parse_size, default_value = "256x256")]
    pub size: [u32; 2],
    /// Image plane: the volume's front face (the paper's figures) or an
    /// ordinary camera.
    #[arg(long, value_enum, default_value_t = PlaneArg::Front)]
    pub image_plane: PlaneArg,
    /// Timed frames per method and distance (the reference: one).
    #[arg(long, default_value_t = 3)]
    pub frames: usize,
    /// Distance of the samples-per-slice plot (default: the smallest).
    #[arg(long)]
    pub slices_at: Option<f64>,
    /// Seed of the order in which methods run within a frame.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// PEs of every pipeline method (overrides their configurations).
    #[arg(long)]
    pub pes: Option<u16>,
    /// Worker threads (default: all cores); results are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Directory for bench.csv, the plots and summary.md.
    #[arg(long, default_value = "bench")]
    pub out_dir: PathBuf,
    /// Run the fixed plan of the benchmark report instead and write
    /// DIR/benchmarks.md with its data and plots under DIR/bench/.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// The brainsmall volume for --report.
    #[arg(long, default_value = "../shared/data/brainsmall.den")]
    pub brainsmall: PathBuf,
}

/// A method the bench runs.
#[derive(Debug, Clone)]
pub enum BenchMethod {
    /// A golden technique (or the reference, timed once per distance).
    Golden(Technique),
    /// The pipeline model with a configuration, under a label.
    Pipeline {
        /// `pipeline` or `pipeline:STEM`.
        label: String,
        /// Widths and PEs.
        cfg: PipelineConfig,
    },
}

impl BenchMethod {
    /// Name in tables, plots and the CSV.
    pub fn label(&self) -> String {
        match self {
            BenchMethod::Golden(t) => t.name().to_string(),
            BenchMethod::Pipeline { label, .. } => label.clone(),
        }
    }
}

/// Parses `--methods`.
pub fn parse_methods(s: &str, pes: Option<u16>) -> Result<Vec<BenchMethod>> {
    let mut out: Vec<BenchMethod> = Vec::new();
    for tok in s.split(',').map(str::trim) {
        let m = if tok == "pipeline" || tok == "pipeline-ftb" || tok.starts_with("pipeline:") {
            let (label, mut cfg) = match tok.strip_prefix("pipeline:") {
                // Front to back at golden er-ftb's default threshold, so the
                // two run the same samples.
                None if tok == "pipeline-ftb" => (
                    tok.to_string(),
                    PipelineConfig {
                        order: pipeline::config::Order::FrontToBack,
                        terminate: f64::from(golden::methods::Options::default().terminate),
                        ..PipelineConfig::default()
                    },
                ),
                None => ("pipeline".to_string(), PipelineConfig::default()),
                Some(path) => {
                    let p = Path::new(path);
                    let stem = p
                        .file_stem()
                        .map(|f| f.to_string_lossy().into_owned())
                        .unwrap_or_else(|| path.to_string());
                    let cfg = PipelineConfig::from_toml_file(p)
                        .with_context(|| format!("method '{tok}'"))?;
                    (format!("pipeline:{stem}"), cfg)
                }
            };
            if let Some(p) = pes {
                cfg.pes = p;
            }
            cfg.validate().with_context(|| format!("method '{tok}'"))?;
            BenchMethod::Pipeline { label, cfg }
        } else {
            let t: Technique = tok.parse().map_err(|_| {
                anyhow::anyhow!(
                    "unknown method '{tok}' in --methods: use reference, under, over, box, er, er-ftb, pipeline, pipeline-ftb or pipeline:FILE.toml"
                )
            })?;
            BenchMethod::Golden(t)
        };
        if out.iter().any(|o| o.label() == m.label()) {
            bail!("method '{}' is listed twice in --methods", m.label());
        }
        out.push(m);
    }
    Ok(out)
}

/// Largest eye distance accepted (voxels): far beyond any useful view.
const MAX_DISTANCE: f64 = 1e6;

/// Parses a comma-separated list of positive eye distances.
pub fn parse_distances(s: &str) -> Result<Vec<f64>> {
    let mut v = Vec::new();
    for p in s.split(',').map(str::trim) {
        let d: f64 = p
            .parse()
            .map_err(|_| anyhow::anyhow!("--distances: '{p}' is not a number"))?;
        if !(d.is_finite() && d > 0.0 && d <= MAX_DISTANCE) {
            bail!(
                "--distances: {p} must be a distance above 0 and at most {MAX_DISTANCE:e} voxels"
            );
        }
        v.push(d);
    }
    Ok(v)
}

/// The field of view per distance: `None` means fit the front face.
pub fn parse_fovs(s: &str, n: usize) -> Result<Vec<Option<f64>>> {
    if s.trim() == "fit" {
        return Ok(vec![None; n]);
    }
    let mut v = Vec::new();
    for p in s.split(',').map(str::trim) {
        let f: f64 = p.parse().map_err(|_| {
            anyhow::anyhow!("--fov: '{p}' is not an angle in degrees (or use 'fit')")
        })?;
        if !(f.is_finite() && f > 0.0 && f < 180.0) {
            bail!("--fov: {p} degrees must lie strictly between 0 and 180");
        }
        v.push(Some(f));
    }
    match v.len() {
        1 => Ok(vec![v[0]; n]),
        k if k == n => Ok(v),
        k => bail!(
            "--fov has {k} angles for {n} distances: give 'fit', one angle, or one per distance"
        ),
    }
}

/// Everything one bench case needs.
pub struct Case {
    /// Name of the scene or file.
    pub label: String,
    /// The volume.
    pub vol: Volume,
    /// Its transfer function.
    pub tf: TransferFunction,
    /// Methods, in table order.
    pub methods: Vec<BenchMethod>,
    /// Eye distances.
    pub distances: Vec<f64>,
    /// Field of view per distance (`None`: fit).
    pub fovs: Vec<Option<f64>>,
    /// Image size.
    pub size: [u32; 2],
    /// Image plane.
    pub plane: ImagePlane,
    /// Timed frames per point.
    pub frames: usize,
    /// Method order seed.
    pub seed: u64,
    /// Distance of the per-slice plot.
    pub slices_at: f64,
}

/// One CSV row: one method, distance and run.
#[derive(Debug, Clone)]
pub struct Row {
    /// Eye distance (the view's `D`).
    pub d: f64,
    /// Field of view used.
    pub fov: f64,
    /// Method label.
    pub method: String,
    /// Frame index.
    pub run: usize,
    /// Why the run did not happen (`None`: it ran).
    pub skipped: Option<String>,
    /// Wall-clock seconds of the frame.
    pub time_s: Option<f64>,
    /// Samples taken.
    pub samples: Option<u64>,
    /// Regions `K` (1 for under and over).
    pub regions: Option<usize>,
    /// Pipeline cycles.
    pub cycles: Option<u64>,
    /// Pipeline utilization.
    pub utilization: Option<f64>,
    /// Error against the reference.
    pub err: Option<ImageError>,
    /// The pipeline's error against golden `er` with the same table.
    pub vs_er: Option<ImageError>,
}

/// Samples per slice measured at one distance, for the per-slice plot.
#[derive(Debug, Clone)]
pub struct PerSlice {
    /// The view's `D`.
    pub d: f64,
    /// Slice area `nx ny`.
    pub area: f64,
    /// Slices.
    pub nz: usize,
    /// Method label and its counts, front to back.
    pub measured: Vec<(String, Vec<u64>)>,
}

/// What a case produced.
pub struct CaseResult {
    /// Every run.
    pub rows: Vec<Row>,
    /// Per-slice counts at `slices_at`.
    pub per_slice: Option<PerSlice>,
    /// Slice area and count of the rendered stack (for the models).
    pub area: f64,
    /// Slices in the stack.
    pub nz: usize,
    /// Whether the pipeline's samples per slice equal golden er's at every
    /// distance (`None` without both).
    pub pipeline_matches_er: Option<bool>,
}

/// A small, fast, seedable generator (SplitMix64) for the run order.
pub struct SplitMix(u64);

impl SplitMix {
    /// Seeds the generator.
    pub fn new(seed: u64) -> SplitMix {
        SplitMix(seed)
    }
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Shuffles `v` (Fisher-Yates).
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = (self.next_u64() % (i as u64 + 1)) as usize;
            v.swap(i, j);
        }
    }
}

/// A progress bar on stderr, drawn only when stdout is a terminal.
pub fn progress(len: u64) -> ProgressBar {
    let bar = if std::io::stdout().is_terminal() {
        ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden())
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:32} {pos}/{len} {msg} [{elapsed} < {eta}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// The median of a non-empty list.
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        s[n / 2]
    } else {
        (s[n / 2 - 1] + s[n / 2]) / 2.0
    }
}

/// The bench camera: the eye on the centre line, `d` voxels in front of
/// slice 0, looking at the centre.
pub fn bench_camera(
    vol: &Volume,
    d: f64,
    fov: Option<f64>,
    size: [u32; 2],
    plane: ImagePlane,
) -> Result<(Camera, f64)> {
    let c = DVec3::from_array(vol.center_world());
    let s = vol.spacing();
    let eye = DVec3::new(c.x, c.y, -d * s[2]);
    // Fit: the front face (the larger of its two extents) fills the
    // vertical field of view.
    let extent = (vol.dims()[0] as f64 * s[0]).max(vol.dims()[1] as f64 * s[1]);
    let fov = fov.unwrap_or_else(|| 2.0 * (extent / (2.0 * d * s[2])).atan().to_degrees());
    let mut cam = Camera::new(eye, c, DVec3::Y, fov, size[0], size[1])?;
    cam.image_plane = plane;
    Ok((cam, fov))
}

/// Runs `ercube bench`.
pub fn run(a: &BenchArgs) -> Result<()> {
    if let Some(dir) = &a.report {
        if a.source.scene.is_some() || a.source.volume.is_some() {
            bail!("--report runs the report's own scenes; drop --scene and --volume");
        }
        return with_threads(a.threads, || report::run(a, dir));
    }
    if a.frames == 0 || a.frames > 1000 {
        bail!("--frames {} must be 1 to 1000", a.frames);
    }
    let methods = parse_methods(&a.methods, a.pes)?;
    let distances = parse_distances(&a.distances)?;
    let fovs = parse_fovs(&a.fov, distances.len())?;
    let slices_at = match a.slices_at {
        Some(d) if distances.contains(&d) => d,
        Some(d) => bail!("--slices-at {d} is not one of --distances"),
        None => distances.iter().copied().fold(f64::INFINITY, f64::min),
    };
    with_threads(a.threads, || {
        let (vol, default_tf) = a.source.load()?;
        let tf = a.tf.resolve(default_tf)?;
        let case = Case {
            label: a.source.label(),
            vol,
            tf,
            methods,
            distances,
            fovs,
            size: a.size,
            plane: match a.image_plane {
                PlaneArg::Camera => ImagePlane::Camera,
                PlaneArg::Front => ImagePlane::Front,
            },
            frames: a.frames,
            seed: a.seed,
            slices_at,
        };
        std::fs::create_dir_all(&a.out_dir)
            .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
        let res = run_case(&case)?;
        write_case(&a.out_dir, &case, &res, "")?;
        let md = summary(&case, &res, "", &command_line())?;
        golden::image::write_atomic(&a.out_dir.join("summary.md"), |w| {
            w.write_all(md.as_bytes())
        })?;
        super::say(&console_table(&case, &res));
        super::say(&format!("wrote {}", a.out_dir.display()));
        Ok(())
    })
}

/// The command line as typed (for the summaries).
pub fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    format!("ercube {}", args.join(" "))
}

/// Is this golden error "too large to render" (recorded as skipped)?
fn too_large(e: &golden::Error) -> bool {
    matches!(e, golden::Error::TooLarge { .. })
}

/// Renders every method of `case` at every distance.
pub fn run_case(case: &Case) -> Result<CaseResult> {
    let opts = RenderOptions::default();
    let lut = lut_for(case.vol.kind(), &case.tf);
    let timed_methods = case
        .methods
        .iter()
        .filter(|m| !matches!(m, BenchMethod::Golden(Technique::Reference)))
        .count();
    let pipes = case
        .methods
        .iter()
        .filter(|m| matches!(m, BenchMethod::Pipeline { .. }))
        .count();
    let per_d = 1 + pipes + case.frames * timed_methods;
    let bar = progress((per_d * case.distances.len()) as u64);
    let mut rows = Vec::new();
    let mut per_slice = None;
    let mut rng = SplitMix::new(case.seed);
    let (mut area, mut nz) = (0.0, 0);
    let mut pipeline_matches_er: Option<bool> = None;
    let mut table_luts: BTreeMap<u32, Lut> = BTreeMap::new();
    for (&d, &fov) in case.distances.iter().zip(&case.fovs) {
        let (cam, fov) = bench_camera(&case.vol, d, fov, case.size, case.plane)?;
        let prep = Prepared::new(&case.vol, &cam)?;
        let vd = prep.view.d;
        area = (prep.view.dims[0] * prep.view.dims[1]) as f64;
        nz = prep.view.dims[2];
        bar.set_message(format!("{} D={d}: reference", case.label));
        let t = Instant::now();
        let reference = render(&prep, &lut, Technique::Reference, &opts)?.image;
        let ref_time = t.elapsed().as_secs_f64();
        bar.inc(1);
        let row = |method: &str, run: usize| Row {
            d: vd,
            fov,
            method: method.to_string(),
            run,
            skipped: None,
            time_s: None,
            samples: None,
            regions: None,
            cycles: None,
            utilization: None,
            err: None,
            vs_er: None,
        };
        // Golden er with each pipeline's table, untimed, for the
        // pipeline's bit-level comparison.
        let mut er_for: BTreeMap<String, golden::image::Image> = BTreeMap::new();
        for m in &case.methods {
            if let BenchMethod::Pipeline { label, cfg } = m {
                let plut = table_luts.entry(cfg.table_entries).or_insert_with(|| {
                    Lut::for_bits(&case.tf, cfg.table_entries as usize, case.vol.kind().bits())
                });
                bar.set_message(format!("{} D={d}: golden er for {label}", case.label));
                // The golden method the pipeline mirrors (er-ftb at its
                // threshold, front to back).
                let mut o = opts;
                o.slice.terminate = cfg.terminate as f32;
                let er = render(
                    &prep,
                    plut,
                    Technique::Slice(crate::cli::pipeline::golden_method(cfg)),
                    &o,
                )?;
                er_for.insert(label.clone(), er.image);
                bar.inc(1);
            }
        }
        let mut got: BTreeMap<String, Vec<Row>> = BTreeMap::new();
        let mut spans: BTreeMap<String, Vec<u64>> = BTreeMap::new();
        if case
            .methods
            .iter()
            .any(|m| matches!(m, BenchMethod::Golden(Technique::Reference)))
        {
            let mut r = row("reference", 0);
            r.time_s = Some(ref_time);
            got.entry("reference".into()).or_default().push(r);
        }
        let mut skipped: BTreeMap<String, String> = BTreeMap::new();
        for run in 0..case.frames {
            let mut order: Vec<usize> = (0..case.methods.len()).collect();
            rng.shuffle(&mut order);
            for &i in &order {
                let m = &case.methods[i];
                let label = m.label();
                if matches!(m, BenchMethod::Golden(Technique::Reference)) {
                    continue;
                }
                bar.set_message(format!("{} D={d}: {label} frame {}", case.label, run + 1));
                if skipped.contains_key(&label) {
                    bar.inc(1);
                    continue;
                }
                let mut r = row(&label, run);
                match m {
                    BenchMethod::Golden(t) => {
                        let t0 = Instant::now();
                        match render(&prep, &lut, *t, &opts) {
                            Ok(f) => {
                                r.time_s = Some(t0.elapsed().as_secs_f64());
                                r.err = Some(compare(&f.image, &reference)?);
                                if let Some(o) = &f.slice {
                                    r.samples = Some(o.stats.samples_total);
                                    r.regions = Some(o.stats.regions.len().saturating_sub(1));
                                    if run == 0 {
                                        spans.insert(
                                            label.clone(),
                                            o.stats.samples_per_slice.clone(),
                                        );
                                    }
                                }
                            }
                            Err(e) if too_large(&e) => {
                                skipped.insert(label.clone(), e.to_string());
                                r.skipped = Some(e.to_string());
                            }
                            Err(e) => return Err(e).context(format!("{label} at D = {d}")),
                        }
                    }
                    BenchMethod::Pipeline { cfg, .. } => {
                        let plut = &table_luts[&cfg.table_entries];
                        let t0 = Instant::now();
                        let res = pipeline::run_frame(
                            cfg,
                            &case.vol,
                            plut,
                            &prep.view,
                            waves::Tracer::disabled(),
                        );
                        match res {
                            Ok(f) => {
                                let image = golden::warp::warp(&prep.view, &f.baseplane);
                                r.time_s = Some(t0.elapsed().as_secs_f64());
                                r.err = Some(compare(&image, &reference)?);
                                r.vs_er = Some(compare(&image, &er_for[&label])?);
                                r.samples = Some(f.samples);
                                r.cycles = Some(f.cycles);
                                r.utilization = Some(f.utilization());
                                r.regions = Some(prep.view.regions().count());
                                if run == 0 {
                                    spans.insert(label.clone(), f.samples_per_slice.clone());
                                }
                            }
                            Err(pipeline::RunError::Plan(e)) => {
                                skipped.insert(label.clone(), e.to_string());
                                r.skipped = Some(e.to_string());
                            }
                            Err(e) => return Err(e).context(format!("{label} at D = {d}")),
                        }
                    }
                }
                got.entry(label).or_default().push(r);
                bar.inc(1);
            }
        }
        // Rows in method order, then run order: independent of the shuffle.
        for m in &case.methods {
            rows.extend(got.remove(&m.label()).unwrap_or_default());
        }
        if let Some(er) = spans.get("er") {
            for m in &case.methods {
                if let BenchMethod::Pipeline { label, cfg } = m {
                    if cfg.order != pipeline::config::Order::BackToFront {
                        continue;
                    }
                    if let Some(p) = spans.get(label) {
                        let same = p == er;
                        pipeline_matches_er = Some(pipeline_matches_er.unwrap_or(true) && same);
                    }
                }
            }
        }
        if d == case.slices_at {
            let measured = case
                .methods
                .iter()
                .filter_map(|m| {
                    let l = m.label();
                    spans.get(&l).map(|v| (l, v.clone()))
                })
                .collect();
            per_slice = Some(PerSlice {
                d: vd,
                area,
                nz,
                measured,
            });
        }
    }
    bar.finish_and_clear();
    Ok(CaseResult {
        rows,
        per_slice,
        area,
        nz,
        pipeline_matches_er,
    })
}

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

fn psnr_text(p: f64) -> String {
    if p.is_finite() {
        format!("{p:.3}")
    } else {
        "inf".into()
    }
}

/// The CSV of every run.
pub fn csv(case: &Case, res: &CaseResult) -> String {
    let dims = case.vol.dims();
    let mut s = String::from(
        "scene,volume,image,D,fov_deg,method,run,status,note,time_s,samples,regions,cycles,utilization,max_abs_255,rmse,psnr,vs_er_max_abs_255,vs_er_rmse\n",
    );
    for r in &res.rows {
        let note = r.skipped.as_deref().unwrap_or("").replace(['"', ','], ";");
        let _ = writeln!(
            s,
            "{},{}x{}x{},{}x{},{},{:.4},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            case.label.replace(',', ";"),
            dims[0],
            dims[1],
            dims[2],
            case.size[0],
            case.size[1],
            r.d,
            r.fov,
            r.method,
            r.run,
            if r.skipped.is_some() { "skipped" } else { "ok" },
            note,
            r.time_s.map(|t| format!("{t:.6}")).unwrap_or_default(),
            opt(r.samples),
            opt(r.regions),
            opt(r.cycles),
            r.utilization.map(|u| format!("{u:.4}")).unwrap_or_default(),
            opt(r.err.map(|e| e.max_abs_255)),
            r.err.map(|e| format!("{:.6}", e.rmse)).unwrap_or_default(),
            r.err.map(|e| psnr_text(e.psnr)).unwrap_or_default(),
            opt(r.vs_er.map(|e| e.max_abs_255)),
            r.vs_er
                .map(|e| format!("{:.6}", e.rmse))
                .unwrap_or_default(),
        );
    }
    s
}

/// Per method and distance: median time and the run's counts and errors.
#[derive(Debug, Clone)]
pub struct Point {
    /// Method label.
    pub method: String,
    /// Eye distance.
    pub d: f64,
    /// Median seconds over the frames (`None`: skipped).
    pub time: Option<f64>,
    /// First run's row (counts and errors are identical in every run).
    pub first: Row,
}

/// Groups rows into points, in method then distance order.
pub fn points(case: &Case, res: &CaseResult) -> Vec<Point> {
    let mut out = Vec::new();
    for m in &case.methods {
        let label = m.label();
        let mut ds: Vec<f64> = Vec::new();
        for r in res.rows.iter().filter(|r| r.method == label) {
            if !ds.contains(&r.d) {
                ds.push(r.d);
            }
        }
        for d in ds {
            let rs: Vec<&Row> = res
                .rows
                .iter()
                .filter(|r| r.method == label && r.d == d)
                .collect();
            let times: Vec<f64> = rs.iter().filter_map(|r| r.time_s).collect();
            out.push(Point {
                method: label.clone(),
                d,
                time: (!times.is_empty()).then(|| median(&times)),
                first: rs[0].clone(),
            });
        }
    }
    out
}

/// Distances of the case's rows, in sweep order.
fn distances_of(res: &CaseResult) -> Vec<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = Vec::new();
    for r in &res.rows {
        if !v.iter().any(|x| x.0 == r.d) {
            v.push((r.d, r.fov));
        }
    }
    v
}

/// Writes bench.csv, samples_per_slice.csv and the plots into `dir`.
pub fn write_case(dir: &Path, case: &Case, res: &CaseResult, title: &str) -> Result<()> {
    let text = csv(case, res);
    golden::image::write_atomic(&dir.join("bench.csv"), |w| w.write_all(text.as_bytes()))?;
    let pts = points(case, res);
    let name = if title.is_empty() {
        case.label.clone()
    } else {
        title.to_string()
    };
    const SIZE: (u32, u32) = (900, 600);

    // Figure 9: time against D.
    let mut series = Vec::new();
    for m in &case.methods {
        let label = m.label();
        let p: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| p.method == label)
            .filter_map(|p| p.time.map(|t| (p.d, t)))
            .collect();
        if !p.is_empty() {
            series.push(Series::new(label, p, Kind::LinePoints));
        }
    }
    write_chart(
        &dir.join("time_vs_distance.png"),
        &Chart {
            title: format!("{name}: time per frame against eye distance"),
            x_label: "eye distance D to the front slice (voxels)".into(),
            y_label: format!("median seconds per frame ({} frames)", case.frames),
            x_log: true,
            y_log: true,
            series,
        },
        SIZE,
    )?;

    // Error against time at up to three distances (the nearest, a middle
    // one and the farthest), each with its Pareto front: a front only
    // means something among renderings of the same view.
    let all_d: Vec<f64> = distances_of(res).iter().map(|x| x.0).collect();
    let picked: Vec<f64> = if all_d.len() <= 3 {
        all_d.clone()
    } else {
        let mut v = all_d.clone();
        v.sort_by(f64::total_cmp);
        vec![v[0], v[v.len() / 2], v[v.len() - 1]]
    };
    let mut charts = Vec::new();
    for &d in &picked {
        let mut series = Vec::new();
        let mut all: Vec<(f64, f64)> = Vec::new();
        for m in &case.methods {
            let label = m.label();
            let p: Vec<(f64, f64)> = pts
                .iter()
                .filter(|p| p.method == label && p.d == d)
                .filter_map(|p| Some((p.time?, p.first.err?.rmse)))
                .filter(|&(_, e)| e > 0.0)
                .collect();
            all.extend(&p);
            if !p.is_empty() {
                series.push(Series::new(label, p, Kind::Points));
            }
        }
        let front = pareto(&all);
        if front.len() > 1 {
            series.push(
                Series::new("Pareto front", front, Kind::Line)
                    .with_color(plotters::style::RGBColor(90, 90, 90)),
            );
        }
        charts.push(Chart {
            title: format!("{name}, D = {d}: error against time"),
            x_label: "median seconds per frame".into(),
            y_label: "RMSE against the reference".into(),
            x_log: true,
            y_log: true,
            series,
        });
    }
    write_charts(&dir.join("error_vs_time.png"), &charts, (640, 560))?;

    // Samples per slice at one distance, with the bounds and the models.
    if let Some(ps) = &res.per_slice {
        let mut series = Vec::new();
        let mut csv = String::from("slice");
        let mut cols: Vec<Vec<f64>> = Vec::new();
        for (label, v) in &ps.measured {
            if !label.starts_with("pipeline") {
                series.push(Series::new(
                    format!("{label} measured"),
                    v.iter()
                        .enumerate()
                        .map(|(z, &s)| (z as f64, s as f64))
                        .collect(),
                    Kind::Line,
                ));
            }
            let _ = write!(csv, ",{label}");
            cols.push(v.iter().map(|&s| s as f64).collect());
        }
        for model in Model::ALL {
            let shown = match model {
                Model::Upper | Model::Lower => true,
                m => ps
                    .measured
                    .iter()
                    .any(|(l, _)| Model::for_method(l) == Some(m)),
            };
            if !shown {
                continue;
            }
            let v = model.slices(ps.area, ps.nz, ps.d);
            let label = match model {
                Model::Over => "over model (eq. 9)",
                Model::Under => "under model",
                Model::Er => "er model",
                Model::Upper => "4 N^2 (eq. 13)",
                Model::Lower => "N^2 (eq. 14)",
            };
            let mut s = Series::new(
                label,
                v.iter().enumerate().map(|(z, &s)| (z as f64, s)).collect(),
                Kind::Dashed,
            );
            if matches!(model, Model::Upper | Model::Lower) {
                s = s.with_color(plotters::style::RGBColor(110, 110, 110));
            }
            series.push(s);
            let _ = write!(csv, ",model_{}", model_key(model));
            cols.push(v);
        }
        csv.push('\n');
        for z in 0..ps.nz {
            let _ = write!(csv, "{z}");
            for c in &cols {
                let _ = write!(
                    csv,
                    ",{}",
                    trim_float(c.get(z).copied().unwrap_or(f64::NAN))
                );
            }
            csv.push('\n');
        }
        golden::image::write_atomic(&dir.join("samples_per_slice.csv"), |w| {
            w.write_all(csv.as_bytes())
        })?;
        write_chart(
            &dir.join("samples_per_slice.png"),
            &Chart {
                title: format!("{name}: samples per slice at D = {}", ps.d),
                x_label: "slice z (0 = front)".into(),
                y_label: "samples on the slice".into(),
                x_log: false,
                y_log: true,
                series,
            },
            SIZE,
        )?;
    }

    // Samples per frame against D, beside equations 10 to 14.
    let mut series = Vec::new();
    let ds: Vec<f64> = distances_of(res).iter().map(|x| x.0).collect();
    for m in &case.methods {
        let label = m.label();
        let p: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| p.method == label)
            .filter_map(|p| Some((p.d, p.first.samples? as f64)))
            .collect();
        if !p.is_empty() && !label.starts_with("pipeline") {
            series.push(Series::new(format!("{label} measured"), p, Kind::Points));
        }
    }
    if !ds.is_empty() && res.nz > 0 {
        let lo = ds.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ds.iter().copied().fold(0.0, f64::max);
        let grid: Vec<f64> = (0..=48)
            .map(|k| lo * (hi / lo).powf(k as f64 / 48.0))
            .collect();
        for model in Model::ALL {
            let shown = match model {
                Model::Upper | Model::Lower => true,
                m => case
                    .methods
                    .iter()
                    .any(|x| Model::for_method(&x.label()) == Some(m)),
            };
            if !shown {
                continue;
            }
            let p = grid
                .iter()
                .map(|&d| (d, model.total(res.area, res.nz, d)))
                .collect();
            let mut s = Series::new(model.label(), p, Kind::Dashed);
            if matches!(model, Model::Upper | Model::Lower) {
                s = s.with_color(plotters::style::RGBColor(110, 110, 110));
            }
            series.push(s);
        }
    }
    write_chart(
        &dir.join("samples_vs_distance.png"),
        &Chart {
            title: format!("{name}: samples per frame, measured and the paper's formulas"),
            x_label: "eye distance D to the front slice (voxels)".into(),
            y_label: "samples per frame".into(),
            x_log: true,
            y_log: true,
            series,
        },
        SIZE,
    )?;
    Ok(())
}

fn model_key(m: Model) -> &'static str {
    match m {
        Model::Over => "over",
        Model::Under => "under",
        Model::Er => "er",
        Model::Upper => "upper_4n2",
        Model::Lower => "lower_n2",
    }
}

/// A number without float noise: integers as integers, others to 6
/// significant digits.
fn trim_float(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        format!("{v:.6e}")
    }
}

/// The points no other point beats in both time and error, by time.
pub fn pareto(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if front.last().is_none_or(|l| q.1 < l.1) {
            front.push(q);
        }
    }
    front
}

fn fmt_time(t: Option<f64>) -> String {
    match t {
        None => "skipped".into(),
        Some(t) if t >= 10.0 => format!("{t:.1}"),
        Some(t) if t >= 0.1 => format!("{t:.3}"),
        Some(t) => format!("{t:.4}"),
    }
}

fn fmt_count(n: f64) -> String {
    if n >= 1e6 {
        format!("{:.2} M", n / 1e6)
    } else if n >= 1e3 {
        format!("{:.1} k", n / 1e3)
    } else {
        format!("{n:.0}")
    }
}

/// The markdown summary of one case; plot links are prefixed by `img`.
pub fn summary(case: &Case, res: &CaseResult, img: &str, command: &str) -> Result<String> {
    let pts = points(case, res);
    let ds = distances_of(res);
    let dims = case.vol.dims();
    let labels: Vec<String> = case.methods.iter().map(BenchMethod::label).collect();
    let get = |m: &str, d: f64| pts.iter().find(|p| p.method == m && p.d == d);
    let mut s = String::new();
    writeln!(
        s,
        "Volume `{}` ({}x{}x{}), {}x{} images, image plane {}, eye on the centre line in front of slice 0; `{command}`; \
         times are medians of {} frames (the reference: one frame).\n",
        case.label,
        dims[0],
        dims[1],
        dims[2],
        case.size[0],
        case.size[1],
        match case.plane {
            ImagePlane::Front => "on the front face",
            ImagePlane::Camera => "the camera's",
        },
        case.frames
    )?;
    // Times.
    write!(s, "Median seconds per frame:\n\n| D | fov |")?;
    for l in &labels {
        write!(s, " {l} |")?;
    }
    write!(s, "\n| --- | --- |")?;
    for _ in &labels {
        write!(s, " --- |")?;
    }
    writeln!(s)?;
    for &(d, fov) in &ds {
        write!(s, "| {d} | {fov:.1} |")?;
        for l in &labels {
            write!(s, " {} |", fmt_time(get(l, d).and_then(|p| p.time)))?;
        }
        writeln!(s)?;
    }
    // Errors.
    write!(
        s,
        "\nError against the reference, RMSE (largest difference of 255):\n\n| D |"
    )?;
    let errs: Vec<&String> = labels.iter().filter(|l| *l != "reference").collect();
    for l in &errs {
        write!(s, " {l} |")?;
    }
    write!(s, "\n| --- |")?;
    for _ in &errs {
        write!(s, " --- |")?;
    }
    writeln!(s)?;
    for &(d, _) in &ds {
        write!(s, "| {d} |")?;
        for l in &errs {
            let cell = match get(l, d).and_then(|p| p.first.err) {
                Some(e) => format!("{:.4} ({})", e.rmse, e.max_abs_255),
                None => "skipped".into(),
            };
            write!(s, " {cell} |")?;
        }
        writeln!(s)?;
    }
    // Samples beside the formulas.
    let (area, nz) = (res.area, res.nz);
    write!(
        s,
        "\nSamples per frame, measured beside the paper's formulas (N^2 = {area:.0} voxels per slice, {nz} slices):\n\n| D |"
    )?;
    let counted: Vec<&String> = labels
        .iter()
        .filter(|l| Model::for_method(l).is_some() && !l.starts_with("pipeline"))
        .collect();
    for l in &counted {
        write!(s, " {l} |")?;
    }
    write!(
        s,
        " eq. 10 (over) | eq. 11 (under) | eq. 12 (er) | eq. 14, N^2 nz | eq. 13, 4 N^2 nz |\n| --- |"
    )?;
    for _ in 0..counted.len() + 5 {
        write!(s, " --- |")?;
    }
    writeln!(s)?;
    for &(d, _) in &ds {
        write!(s, "| {d} |")?;
        for l in &counted {
            let cell = get(l, d)
                .and_then(|p| p.first.samples)
                .map(|n| fmt_count(n as f64))
                .unwrap_or_else(|| "skipped".into());
            write!(s, " {cell} |")?;
        }
        for m in [
            Model::Over,
            Model::Under,
            Model::Er,
            Model::Lower,
            Model::Upper,
        ] {
            write!(s, " {} |", fmt_count(m.total(area, nz, d)))?;
        }
        writeln!(s)?;
    }
    // over / er.
    if labels.iter().any(|l| l == "over") && labels.iter().any(|l| l == "er") {
        write!(s, "\nOversampling against ER:\n\n| D | time over/er | samples over/er |\n| --- | --- | --- |\n")?;
        for &(d, _) in &ds {
            let (o, e) = (get("over", d), get("er", d));
            let t = match (o.and_then(|p| p.time), e.and_then(|p| p.time)) {
                (Some(a), Some(b)) => format!("{:.2}", a / b),
                _ => "-".into(),
            };
            let n = match (
                o.and_then(|p| p.first.samples),
                e.and_then(|p| p.first.samples),
            ) {
                (Some(a), Some(b)) => format!("{:.2}", a as f64 / b as f64),
                _ => "-".into(),
            };
            writeln!(s, "| {d} | {t} | {n} |")?;
        }
    }
    // Pipeline.
    let pipes: Vec<&String> = labels
        .iter()
        .filter(|l| l.starts_with("pipeline"))
        .collect();
    if !pipes.is_empty() {
        write!(
            s,
            "\nPipeline (PE-array model; its time is the simulator's wall clock, its cycles the chip's):\n\n\
             | method | D | cycles | utilization | samples | max of 255 vs golden er | RMSE vs reference |\n| --- | --- | --- | --- | --- | --- | --- |\n"
        )?;
        for l in &pipes {
            for &(d, _) in &ds {
                if let Some(p) = get(l, d) {
                    let r = &p.first;
                    writeln!(
                        s,
                        "| {l} | {d} | {} | {} | {} | {} | {} |",
                        r.cycles.map(|c| fmt_count(c as f64)).unwrap_or("-".into()),
                        r.utilization
                            .map(|u| format!("{u:.3}"))
                            .unwrap_or("-".into()),
                        r.samples.map(|c| fmt_count(c as f64)).unwrap_or("-".into()),
                        r.vs_er
                            .map(|e| e.max_abs_255.to_string())
                            .unwrap_or("-".into()),
                        r.err
                            .map(|e| format!("{:.4}", e.rmse))
                            .unwrap_or("-".into()),
                    )?;
                }
            }
        }
        if let Some(same) = res.pipeline_matches_er {
            writeln!(
                s,
                "\nThe pipeline's samples per slice {} golden er's at every distance.",
                if same { "equal" } else { "differ from" }
            )?;
        }
    }
    // Skips.
    let skips: Vec<&Row> = res.rows.iter().filter(|r| r.skipped.is_some()).collect();
    if !skips.is_empty() {
        writeln!(s, "\nSkipped:\n")?;
        for r in skips {
            writeln!(
                s,
                "- {} at D = {}: {}",
                r.method,
                r.d,
                r.skipped.as_deref().unwrap_or("")
            )?;
        }
    }
    writeln!(
        s,
        "\n![time against D]({img}time_vs_distance.png)\n![error against time]({img}error_vs_time.png)"
    )?;
    if res.per_slice.is_some() {
        writeln!(s, "![samples per slice]({img}samples_per_slice.png)")?;
    }
    writeln!(s, "![samples against D]({img}samples_vs_distance.png)")?;
    Ok(s)
}

/// A compact table of median times for the terminal.
fn console_table(case: &Case, res: &CaseResult) -> String {
    let pts = points(case, res);
    let labels: Vec<String> = case.methods.iter().map(BenchMethod::label).collect();
    let mut s = format!("{:>8}", "D");
    for l in &labels {
        let _ = write!(s, " {l:>12}");
    }
    s.push('\n');
    for (d, _) in distances_of(res) {
        let _ = write!(s, "{d:>8}");
        for l in &labels {
            let t = pts
                .iter()
                .find(|p| &p.method == l && p.d == d)
                .and_then(|p| p.time);
            let _ = write!(s, " {:>12}", fmt_time(t));
        }
        s.push('\n');
    }
    s.trim_end().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_keeps_the_undominated() {
        let f = pareto(&[(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (0.5, 9.0)]);
        assert_eq!(f, vec![(0.5, 9.0), (1.0, 5.0), (2.0, 3.0), (4.0, 1.0)]);
    }

    #[test]
    fn shuffle_is_seeded() {
        let mut a: Vec<u32> = (0..10).collect();
        let mut b = a.clone();
        SplitMix::new(7).shuffle(&mut a);
        SplitMix::new(7).shuffle(&mut b);
        assert_eq!(a, b);
        let mut s = a.clone();
        s.sort();
        assert_eq!(s, (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn argument_lists() {
        assert_eq!(parse_distances("2, 4.5").unwrap(), vec![2.0, 4.5]);
        assert!(parse_distances("0").is_err());
        assert!(parse_distances("x").is_err());
        assert_eq!(parse_fovs("fit", 2).unwrap(), vec![None, None]);
        assert_eq!(parse_fovs("90", 2).unwrap(), vec![Some(90.0); 2]);
        assert!(parse_fovs("90,80,70", 2).is_err());
        assert!(parse_fovs("180", 1).is_err());
        assert!(parse_methods("er,er", None).is_err());
        assert!(parse_methods("er,warp", None).is_err());
        let m = parse_methods("reference,er,pipeline", Some(4)).unwrap();
        assert!(matches!(&m[2], BenchMethod::Pipeline { cfg, .. } if cfg.pes == 4));
    }

    #[test]
    fn fit_opens_the_paper_views() {
        let vol = golden::scenes::Scene::Sphere { n: 256 }
            .build(golden::volume::DEFAULT_MEMORY_LIMIT)
            .unwrap();
        let (_, fov) = bench_camera(&vol, 64.0, None, [8, 8], ImagePlane::Front).unwrap();
        assert!((fov - 126.87).abs() < 0.01, "{fov}");
        let (_, fov) = bench_camera(&vol, 128.0, None, [8, 8], ImagePlane::Front).unwrap();
        assert!((fov - 90.0).abs() < 1e-9, "{fov}");
    }
}
