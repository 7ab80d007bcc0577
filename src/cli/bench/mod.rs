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
mod run;
mod scales;
mod shard;
mod summary;
mod widths;
mod write;

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use golden::camera::ImagePlane;
use golden::metrics::ImageError;
use golden::render::Technique;
use golden::tf::TransferFunction;
use golden::volume::Volume;
use pipeline::config::{Order, PipelineConfig};

use super::args::{parse_size, with_threads, PlaneArg, SourceArgs, TfArgs};
use super::method::MethodArg;
pub use model::Model;
pub use run::{progress, run_case};
pub use shard::{merge as merge_results, MergeArgs};
use summary::console_table;
pub use summary::summary;
pub use widths::{sweep as sweep_widths, SweepArgs};
pub use write::{pareto, points, write_case};

/// Arguments of `ercube bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub source: SourceArgs,
    #[command(flatten)]
    pub tf: TfArgs,
    /// Comma-separated methods: reference, under, over, box, er, er-ftb,
    /// mipmap, shear-warp, reference+gaze, mipmap+gaze, er+gaze and
    /// er-ftb+gaze (the paper's gaze profile around the image centre),
    /// reference+refine, mipmap+refine (adaptive refinement at the default
    /// threshold and levels), reference+gaze+refine,
    /// mipmap+gaze+refine (both criteria), pipeline (default widths), pipeline-ftb (front to back, default
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
    /// Image plane: an ordinary camera (every command's default) or the
    /// volume's front face (the paper's figures, which --report uses).
    #[arg(long, value_enum, default_value_t = PlaneArg::Camera)]
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
    /// Directory for bench.csv, the plots and summary.md (the default
    /// stays clear of the repository's own bench/ folder).
    #[arg(long, default_value = "bench-results")]
    pub out_dir: PathBuf,
    /// Run the fixed plan of the benchmark report instead and write
    /// DIR/benchmarks.md with its data and plots under DIR/bench/.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// The brainsmall volume for --report.
    #[arg(long, default_value = "data/brainsmall.den")]
    pub brainsmall: PathBuf,
    /// Run only shard K of N (every N-th distance from the K-th) and write
    /// its rows as DIR/shard-K-of-N.json; `ercube merge-results` joins
    /// the N shards into what the unsharded run writes.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<shard::Shard>,
    /// Shade every method and the reference (a headlight and the default
    /// material, or the transfer function's): errors are against the
    /// shaded reference, and each method's shaded frame is followed by its
    /// unshaded frame, timed too (`unshaded_time_s`), for the cost of
    /// shading.
    #[arg(long)]
    pub shade: bool,
}

/// A method the bench runs.
#[derive(Debug, Clone)]
pub enum BenchMethod {
    /// A golden technique (or the reference, timed once per distance).
    Golden(Technique),
    /// A method with the paper's gaze profile around the image centre
    /// (`reference+gaze`, `mipmap+gaze`, `er+gaze`, `er-ftb+gaze`).
    Gaze(Technique),
    /// The reference or the mip-map adaptively refined at the default
    /// threshold and levels ([`golden::refine`]), with the gaze profile
    /// too when `gaze` (`reference+refine`, `mipmap+gaze+refine`).
    Refine {
        /// Reference or mip-map.
        tech: Technique,
        /// Also the paper's gaze profile around the image centre.
        gaze: bool,
    },
    /// The pipeline model with a configuration, under a label.
    Pipeline {
        /// `pipeline` or `pipeline:STEM`.
        label: String,
        /// Widths and PEs (boxed: a configuration is large beside a
        /// technique).
        cfg: Box<PipelineConfig>,
    },
}

impl BenchMethod {
    /// Whether it takes the gaze profile.
    pub fn gazes(&self) -> bool {
        matches!(
            self,
            BenchMethod::Gaze(_) | BenchMethod::Refine { gaze: true, .. }
        )
    }

    /// Name in tables, plots and the CSV.
    pub fn label(&self) -> String {
        match self {
            BenchMethod::Golden(t) => t.name().to_string(),
            BenchMethod::Gaze(t) => format!("{}+gaze", t.name()),
            BenchMethod::Refine { tech, gaze } => {
                format!("{}{}+refine", tech.name(), if *gaze { "+gaze" } else { "" })
            }
            BenchMethod::Pipeline { label, .. } => label.clone(),
        }
    }
}

/// Whether a label names the PE array.
pub(crate) fn is_pipeline(label: &str) -> bool {
    MethodArg::of_label(label).is_some_and(MethodArg::is_pipeline)
}

/// Parses `--methods`.
pub fn parse_methods(s: &str, pes: Option<u16>) -> Result<Vec<BenchMethod>> {
    let mut out: Vec<BenchMethod> = Vec::new();
    for tok in s.split(',').map(str::trim) {
        // `pipeline:FILE.toml` names a configuration; every other token is
        // a method's name.
        let (name, file) = match tok.split_once(':') {
            Some((name, file)) => (name, Some(file)),
            None => (tok, None),
        };
        if let Some(base) = name.strip_suffix("+refine") {
            let (base, gaze) = match base.strip_suffix("+gaze") {
                Some(b) => (b, true),
                None => (base, false),
            };
            let m = match MethodArg::parse(base).and_then(MethodArg::technique) {
                Some(tech @ (Technique::Reference | Technique::MipMap)) if file.is_none() => {
                    BenchMethod::Refine { tech, gaze }
                }
                _ => bail!(
                    "'{tok}' in --methods: only reference and mipmap take +refine (or +gaze+refine)"
                ),
            };
            if out.iter().any(|o| o.label() == m.label()) {
                bail!("method '{}' is listed twice in --methods", m.label());
            }
            out.push(m);
            continue;
        }
        if let Some(base) = name.strip_suffix("+gaze") {
            let m = match MethodArg::parse(base).and_then(MethodArg::technique) {
                Some(
                    t @ (Technique::Reference
                    | Technique::MipMap
                    | Technique::Slice(golden::methods::Method::Er | golden::methods::Method::ErFtb)),
                ) if file.is_none() => BenchMethod::Gaze(t),
                _ => bail!(
                    "'{tok}' in --methods: only reference+gaze, mipmap+gaze, er+gaze and er-ftb+gaze take a gaze"
                ),
            };
            if out.iter().any(|o| o.label() == m.label()) {
                bail!("method '{}' is listed twice in --methods", m.label());
            }
            out.push(m);
            continue;
        }
        let method = MethodArg::parse(name).filter(|m| file.is_none() || *m == MethodArg::Pipeline);
        let Some(method) = method else {
            bail!(
                "unknown method '{tok}' in --methods: use reference, under, over, box, er, er-ftb, mipmap, shear-warp, reference+gaze, mipmap+gaze, er+gaze, er-ftb+gaze, reference+refine, mipmap+refine, reference+gaze+refine, mipmap+gaze+refine, pipeline, pipeline-ftb or pipeline:FILE.toml"
            );
        };
        let m = match (method.technique(), method.pipeline_order()) {
            (Some(t), _) => BenchMethod::Golden(t),
            (None, order) => {
                let (label, mut cfg) = match file {
                    Some(path) => {
                        let p = Path::new(path);
                        let stem = p
                            .file_stem()
                            .map(|f| f.to_string_lossy().into_owned())
                            .unwrap_or_else(|| path.to_string());
                        let cfg = PipelineConfig::from_toml_file(p)
                            .with_context(|| format!("method '{tok}'"))?;
                        (format!("{}:{stem}", method.name()), cfg)
                    }
                    // Front to back at golden er-ftb's default threshold, so
                    // the two run the same samples.
                    None if order == Some(Order::FrontToBack) => (
                        method.name().to_string(),
                        PipelineConfig {
                            order: Order::FrontToBack,
                            terminate: f64::from(golden::methods::Options::default().terminate),
                            ..PipelineConfig::default()
                        },
                    ),
                    None => (method.name().to_string(), PipelineConfig::default()),
                };
                if let Some(p) = pes {
                    cfg.pes = p;
                }
                cfg.validate().with_context(|| format!("method '{tok}'"))?;
                BenchMethod::Pipeline {
                    label,
                    cfg: Box::new(cfg),
                }
            }
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
    /// Shading of every method and the reference (`None`: unshaded).
    pub shade: Option<golden::shading::Shade>,
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
    /// Wall-clock seconds of the same method's unshaded frame, taken right
    /// after the shaded one (`--shade` only).
    pub unshaded_time_s: Option<f64>,
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

/// Runs `ercube bench`.
pub fn run(a: &BenchArgs) -> Result<()> {
    super::outputs::check_dirs(&[Some(a.report.as_ref().unwrap_or(&a.out_dir))])?;
    if let Some(dir) = &a.report {
        if a.shard.is_some() {
            bail!("--shard splits a sweep's distances; the report's plan is not sharded");
        }
        if a.shade {
            bail!("--report runs the report's own plan; --shade is for a single sweep");
        }
        if a.source.scene.is_some() || a.source.volume.is_some() {
            bail!("--report runs the report's own scenes; drop --scene and --volume");
        }
        return with_threads(a.threads, || report::run(a, dir));
    }
    with_threads(a.threads, || {
        let case = case_of(a)?;
        std::fs::create_dir_all(&a.out_dir)
            .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
        if let Some(s) = a.shard {
            let res = run::run_case_in(&case, Some(s))?;
            return shard::write_shard(&a.out_dir, s, &res, case.distances.len());
        }
        let res = run_case(&case)?;
        finish(a, &case, &res, &command_line())
    })
}

/// The case `a` describes: its volume loaded, its methods and sweep parsed.
fn case_of(a: &BenchArgs) -> Result<Case> {
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
    let (vol, default_tf) = a.source.load()?;
    let tf = a.tf.resolve(default_tf, &vol, a.source.window.is_some())?;
    let shade = a.shade.then(|| {
        let mut sh = golden::shading::Shade::default();
        sh.material = tf.material.unwrap_or_default();
        sh
    });
    Ok(Case {
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
        shade,
    })
}

/// Writes a case's CSV, plots and summary into `a.out_dir` and prints its
/// table (`command` is the command line the summary names).
fn finish(a: &BenchArgs, case: &Case, res: &CaseResult, command: &str) -> Result<()> {
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
    write_case(&a.out_dir, case, res, "")?;
    let md = summary(case, res, "", command)?;
    golden::image::write_atomic(&a.out_dir.join("summary.md"), |w| {
        w.write_all(md.as_bytes())
    })?;
    super::say(&console_table(case, res));
    super::say(&format!("wrote {}", a.out_dir.display()));
    Ok(())
}

/// The command line as typed (for the summaries).
pub fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    format!("ercube {}", args.join(" "))
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
