//! `ercube render --method pipeline` (and `pipeline-ftb`, the front-to-back
//! order with early ray termination): the bit-accurate PE array model, its
//! cycle counts, raw accumulator words and waveforms.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde_json::{json, Value};

use golden::methods::Method;
use golden::metrics::compare;
use golden::render::{render, Prepared, RenderOptions, Technique};
use golden::tf::Lut;
use golden::volume::Volume;
use golden::warp::warp;
use pipeline::config::{FormatId, Order, PipelineConfig};
use pipeline::fixed::QuantStats;
use pipeline::{FrameRun, Voxels};
use waves::{parse_cycle_window, PeFilter, TraceConfig, Tracer};

use super::method::MethodArg;
use super::stats::error_json;

/// The pipeline configuration on the command line, shared by every
/// command that runs the PE array.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Pipeline")]
pub struct ConfigArgs {
    /// Pipeline configuration (TOML; missing keys keep their defaults).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Number of PEs (overrides the configuration).
    #[arg(long)]
    pub pes: Option<u16>,
    /// The configuration as TOML text, given by a library caller instead
    /// of `--config` (not a flag).
    #[arg(skip)]
    pub toml: Option<String>,
}

impl ConfigArgs {
    /// Loads the configuration with the command line's overrides.
    pub fn load(&self) -> Result<PipelineConfig> {
        let mut cfg = match (&self.config, &self.toml) {
            (Some(_), Some(_)) => bail!("the configuration is given as text; drop --config"),
            (Some(p), None) => PipelineConfig::from_toml_file(p)?,
            (None, Some(text)) => PipelineConfig::from_toml_str(text)?,
            (None, None) => PipelineConfig::default(),
        };
        if let Some(p) = self.pes {
            cfg.pes = p;
        }
        cfg.validate()?;
        Ok(cfg)
    }
}

/// Sets the order a pipeline method names: `pipeline-ftb` runs front to
/// back with `--terminate`'s threshold (which replaces the configuration's
/// `terminate`); `pipeline` runs the configuration as it is.
pub fn apply_method(cfg: &mut PipelineConfig, method: MethodArg, terminate: f32) -> Result<()> {
    if method.pipeline_order() == Some(Order::FrontToBack) {
        cfg.order = Order::FrontToBack;
        cfg.terminate = f64::from(terminate);
        cfg.validate()?;
    }
    Ok(())
}

/// The configuration a pipeline method runs (`--config`, `--pes`, the
/// order `method` names) and the slice options that go with it: `--block`
/// sizes the occupancy memory's blocks, and golden's view of the volume
/// then uses the same blocks (the configuration's when `--block` is not
/// given).
pub fn configure(
    args: &ConfigArgs,
    method: MethodArg,
    slice: &super::args::SliceArgs,
) -> Result<(PipelineConfig, super::args::SliceArgs)> {
    let mut cfg = args.load()?;
    apply_method(&mut cfg, method, slice.terminate)?;
    let mut slice = slice.clone();
    match slice.block {
        Some(b) => {
            golden::occupancy::check_block(b)?;
            cfg.occupancy_block = b as u16;
        }
        None => slice.block = Some(usize::from(cfg.occupancy_block)),
    }
    cfg.validate()?;
    Ok((cfg, slice))
}

/// Refuses the slice options the pipeline does not model.
pub fn check_options(opts: &RenderOptions) -> Result<()> {
    if opts.slice.substeps != 1 {
        bail!("the pipeline models one sample per slice crossing; drop --substeps");
    }
    if opts.slice.preintegrate && opts.slice.shade.is_some() {
        bail!("the pipeline's pre-integrated frames are unshaded; drop --shade or --preintegrate");
    }
    if opts.slice.pre_colouring == golden::preint::Colouring::Attenuated {
        bail!("the pipeline's pre-integration unit models the fast and exact colourings, not attenuated");
    }
    if opts.slice.preintegrate && opts.slice.voi.is_some() {
        bail!("the pipeline's pre-integrated frames take no volume of interest; drop --voi or --preintegrate");
    }
    Ok(())
}

/// The golden method a configuration mirrors: `er` back to front, `er-ftb`
/// front to back.
pub fn golden_method(cfg: &PipelineConfig) -> Method {
    match cfg.order {
        Order::BackToFront => Method::Er,
        Order::FrontToBack => Method::ErFtb,
    }
}

/// Pipeline options of `ercube render`.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Pipeline")]
#[command(group(clap::ArgGroup::new("trace_out").args(["vcd", "fst"]).multiple(true)))]
pub struct PipelineArgs {
    #[command(flatten)]
    pub cfg: ConfigArgs,
    /// Write a VCD waveform here (and a GTKWave save file, X.gtkw, beside
    /// it). Time: one cycle of the 200 MHz clock `cost` assumes for
    /// Artix-7 is 5 ns.
    #[arg(long, help_heading = "Waveforms")]
    pub vcd: Option<PathBuf>,
    /// Write an FST waveform here (GTKWave's compressed format, an order
    /// of magnitude smaller than VCD; and its own save file beside it,
    /// X.gtkw, or X.fst.gtkw when --vcd X.vcd takes that name).
    #[arg(long, help_heading = "Waveforms")]
    pub fst: Option<PathBuf>,
    /// PEs to trace: "all", or a list such as 0-3,8 (each below --pes).
    /// Default: every PE of an array of up to 4, else the 4 busiest of
    /// the frame (found by a first, untraced run of it).
    #[arg(long, requires = "trace_out", help_heading = "Waveforms")]
    pub trace_pes: Option<String>,
    /// Cycle window to trace: A-B (inclusive), A.., or ..=B.
    #[arg(long, requires = "trace_out", help_heading = "Waveforms")]
    pub trace_cycles: Option<String>,
    /// Signal groups to trace, comma-separated: ctrl (the controller's
    /// stage, slice, row), ports (each PE's left and right link ports:
    /// rays, edge voxels, merge parents; and its host port), datapath, acc,
    /// regs (registers and FIFO levels); or all. Default:
    /// ctrl,ports,datapath,acc.
    #[arg(long, requires = "trace_out", help_heading = "Waveforms")]
    pub trace_signals: Option<String>,
    /// Nodes of the datapath's description to trace by name,
    /// comma-separated, `*` a glob (comp.*,class.addr1, or * for every
    /// node): each PE's node words in scope top.pe_K.hw, a node of
    /// pipeline stage s showing the sample issued s cycles earlier.
    #[arg(long, requires = "trace_out", help_heading = "Waveforms")]
    pub trace_nodes: Option<String>,
    /// Write the raw accumulator words of the baseplane (int64 H x W x 4 .npy).
    #[arg(long)]
    pub raw_npy: Option<PathBuf>,
    /// Clock of the printed frame rate, MHz (an assumption). Default:
    /// xc7's assumed 200 MHz, as cost and explore.
    #[arg(long, allow_hyphen_values = true)]
    pub clock_mhz: Option<f64>,
    /// Skip the golden twin: no render of golden `er` (or `er-ftb`) with
    /// the same table, so the stats carry no `error_vs_golden` and no
    /// derived bound. The twin costs about a fifth of a pipeline frame on
    /// brainsmall, outside the frame's `time_s`; skip it when only the
    /// image, the raw words or the cycles are wanted.
    #[arg(long)]
    pub no_golden_twin: bool,
}

impl PipelineArgs {
    /// The clock of the frame rate: `--clock-mhz`, else xc7's assumed one.
    pub fn clock(&self) -> Result<f64> {
        let c = self
            .clock_mhz
            .unwrap_or_else(|| pipeline::cost::clock::assumed_mhz(pipeline::cost::Target::Xc7));
        pipeline::cost::clock::check_mhz(c).map_err(anyhow::Error::msg)
    }
}

/// The classification table the pipeline and its golden comparison share.
pub fn pipeline_lut(cfg: &PipelineConfig, vol: &Volume, tf: &golden::tf::TransferFunction) -> Lut {
    Lut::for_bits(tf, cfg.table_entries as usize, vol.kind().bits())
}

/// PEs a default trace shows: all of an array this small, else this many
/// of the busiest.
pub const DEFAULT_TRACED_PES: usize = 4;

/// The PEs `--trace-pes` names, refused in one line when one lies outside
/// an array of `pes`; `None` when it is not given.
fn traced_pes(a: &PipelineArgs, pes: u16) -> Result<Option<PeFilter>> {
    let Some(text) = &a.trace_pes else {
        return Ok(None);
    };
    let filter = PeFilter::parse(text)?;
    if let PeFilter::Only(set) = &filter {
        let outside: Vec<String> = set
            .iter()
            .filter(|&&k| k >= u32::from(pes))
            .map(u32::to_string)
            .collect();
        if !outside.is_empty() {
            bail!(
                "--trace-pes {text}: PE {} outside the array of {pes} PEs (0-{})",
                outside.join(","),
                pes - 1
            );
        }
    }
    Ok(Some(filter))
}

/// The [`DEFAULT_TRACED_PES`] PEs with the most busy sampling cycles
/// (the lower index first among equals).
fn busiest(counters: &[pipeline::pe::PeCounters]) -> PeFilter {
    let mut order: Vec<usize> = (0..counters.len()).collect();
    order.sort_by_key(|&k| (std::cmp::Reverse(counters[k].busy), k));
    PeFilter::Only(
        order
            .into_iter()
            .take(DEFAULT_TRACED_PES)
            .map(|k| k as u32)
            .collect(),
    )
}

fn tracer(a: &PipelineArgs, pes: PeFilter) -> Result<Tracer> {
    let groups = match &a.trace_signals {
        Some(text) => Some(pipeline::probes::parse_groups(text).map_err(anyhow::Error::msg)?),
        None => None,
    };
    let tc = match (&a.vcd, &a.fst) {
        (None, None) => return Ok(Tracer::disabled()),
        (Some(v), None) => TraceConfig::new(v),
        (None, Some(f)) => TraceConfig::new_fst(f),
        (Some(v), Some(f)) => TraceConfig::new(v).with_fst(f),
    };
    let mut tc = tc.with_pes(pes).with_markers(
        pipeline::probes::STAGE_SIGNAL,
        pipeline::probes::MARKED_STAGES.map(|s| s.code()),
    );
    if let Some(g) = groups {
        tc = tc.with_groups(g);
    }
    if let Some(w) = &a.trace_cycles {
        // Accept the README's A-B as well as Rust-style ranges.
        let spec = match w.split_once('-') {
            Some((x, y)) if !x.is_empty() && !y.is_empty() => format!("{x}..={y}"),
            _ => w.clone(),
        };
        tc = tc.with_cycles(parse_cycle_window(&spec)?);
    }
    Ok(Tracer::new(tc)?)
}

/// What a pipeline render produced.
pub struct PipelineRun {
    /// The final image (warped in float by the driver).
    pub image: golden::image::Image,
    /// The frame: baseplane, raw words, counters.
    pub frame: pipeline::Frame,
    /// Wall-clock seconds of the frame.
    pub time_s: f64,
}

/// Renders `prep` (of `data_bits`-bit data) through the pipeline, the PEs
/// loading from its slice stack, the controller skipping what `skips`
/// allows and clipping to `prep`'s planes, shaded with `shade` and
/// scaled by the volume of interest `voi` when given; or pre-integrated
/// with golden's table `preint` (no shading, volume of interest or
/// clipping).
pub fn run(
    a: &PipelineArgs,
    cfg: &PipelineConfig,
    data_bits: u32,
    lut: &Lut,
    prep: &Prepared,
    (skips, shade, voi, preint): (
        golden::skip::Skips,
        Option<&golden::shading::Shade>,
        Option<&golden::voi::Voi>,
        Option<&golden::preint::PreTable>,
    ),
    (spare, tap): (
        &mut Option<pipeline::Resident>,
        Option<pipeline::stepper::Tap>,
    ),
) -> Result<PipelineRun> {
    let tracing = a.vcd.is_some() || a.fst.is_some();
    let pes = match traced_pes(a, cfg.pes)? {
        Some(f) => f,
        None if !tracing || usize::from(cfg.pes) <= DEFAULT_TRACED_PES => PeFilter::All,
        None => {
            // The busiest PEs are known once the frame has run.
            let mut scratch = None;
            let untraced = ((Tracer::disabled(), Vec::new()), &mut scratch, None);
            let opts = (skips, shade, voi, preint);
            let f = frame_with(cfg, data_bits, lut, prep, opts, untraced)?;
            busiest(&f.pes)
        }
    };
    let tr = tracer(a, pes)?;
    let nodes = match &a.trace_nodes {
        Some(text) => {
            pipeline::probes::nodes::parse_node_patterns(text).map_err(anyhow::Error::msg)?
        }
        None => Vec::new(),
    };
    let t = Instant::now();
    // The previous frame's memories only lend their buffers: this frame
    // loads the volume again, as a fresh one does.
    let mut resident = spare.take().map(pipeline::Resident::stale);
    let frame = frame_with(
        cfg,
        data_bits,
        lut,
        prep,
        (skips, shade, voi, preint),
        ((tr, nodes), &mut resident, tap),
    )?;
    *spare = resident;
    let time_s = t.elapsed().as_secs_f64();
    let image = warp(&prep.view, &frame.baseplane);
    Ok(PipelineRun {
        image,
        frame,
        time_s,
    })
}

/// The options of one frame: skips, shading, volume of interest and the
/// pre-integration table.
type FrameOptions<'a> = (
    golden::skip::Skips,
    Option<&'a golden::shading::Shade>,
    Option<&'a golden::voi::Voi>,
    Option<&'a golden::preint::PreTable>,
);

/// One frame through the array with tracer `tr` (and the description's
/// nodes `nodes` names), reusing `resident`'s
/// memories, stepped through `tap` when given.
fn frame_with(
    cfg: &PipelineConfig,
    data_bits: u32,
    lut: &Lut,
    prep: &Prepared,
    (skips, shade, voi, preint): FrameOptions<'_>,
    ((tr, nodes), resident, tap): (
        (Tracer, Vec<String>),
        &mut Option<pipeline::Resident>,
        Option<pipeline::stepper::Tap>,
    ),
) -> Result<pipeline::Frame> {
    let mut frame = FrameRun::prepared(cfg, lut, prep, Voxels::Stack { data_bits })
        .skips(skips)
        .trace(tr)
        .trace_nodes(nodes)
        .resident(resident);
    if let Some(t) = tap {
        frame = frame.tap(t);
    }
    Ok(match preint {
        Some(pt) => frame.unit(Some(pt)),
        None => frame.unit(shade).unit(voi),
    }
    .run()?)
}

/// Raw accumulator words as int64 `H x W x 4`.
pub fn write_raw_npy(path: &Path, f: &pipeline::Frame) -> Result<()> {
    let [w, h] = f.baseplane.grid.counts;
    golden::image::write_atomic(path, |out| {
        out.write_all(&golden::image::npy_header("<i8", &[h, w, 4]))?;
        for p in &f.raw {
            for v in p {
                out.write_all(&v.to_le_bytes())?;
            }
        }
        Ok(())
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// The stats' `quantization` object: the totals, the overflows that are
/// range violations (`harmful_overflows`), and per register format its
/// counts and whether its overflow is a designed clamp (`clamp`).
pub fn quant_json(q: &QuantStats) -> Value {
    let by_format: serde_json::Map<String, Value> = q
        .by_format
        .iter()
        .filter(|(id, c)| *id != FormatId::OTHER || c.assignments > 0)
        .map(|(id, c)| {
            let v = json!({
                "assignments": c.assignments,
                "inexact": c.inexact,
                "overflows": c.overflows,
                "clamp": id.clamps(),
            });
            (id.name().to_string(), v)
        })
        .collect();
    json!({
        "assignments": q.assignments,
        "inexact": q.inexact,
        "overflows": q.overflows,
        "harmful_overflows": q.harmful_overflows(),
        "by_format": by_format,
    })
}

/// The render summary's quantisation note when anything overflowed: the
/// total and each overflowing format's count, marked `clamp` or `range`
/// (a range violation), most overflows first.
pub fn overflow_line(q: &QuantStats) -> Option<String> {
    if q.overflows == 0 {
        return None;
    }
    let mut formats: Vec<_> = q
        .by_format
        .iter()
        .filter(|(_, c)| c.overflows > 0)
        .collect();
    formats.sort_by_key(|(id, c)| (std::cmp::Reverse(c.overflows), *id));
    let parts: Vec<String> = formats
        .iter()
        .map(|(id, c)| {
            let kind = if id.clamps() { "clamp" } else { "range" };
            format!("{} {} ({kind})", id.name(), c.overflows)
        })
        .collect();
    Some(format!(
        "quantization: {} overflows, {} of them range violations: {}",
        q.overflows,
        q.harmful_overflows(),
        parts.join(", ")
    ))
}

/// The pipeline's part of the stats JSON, and its error against the golden
/// method it mirrors (`error_vs_golden`, naming the method; back to front
/// also as `error_vs_golden_er`).
pub fn stats_json(cfg: &PipelineConfig, run: &PipelineRun, vs_golden: Option<Value>) -> Value {
    let f = &run.frame;
    let btf = cfg.order == Order::BackToFront;
    let named = vs_golden.clone().map(|mut v| {
        v["method"] = json!(golden_method(cfg).name());
        v
    });
    json!({
        "order": cfg.order.name(),
        "terminate": cfg.terminate,
        "terminated_samples": f.terminated_samples,
        "cycles_saved": f.cycles_saved,
        "skipped": f.skipped,
        "raw_format": [f.raw_format[0].to_string(), f.raw_format[1].to_string()],
        "error_vs_golden": named,
        "cycles": f.cycles,
        "ideal_cycles": f.ideal_cycles,
        "utilization": f.utilization(),
        "stages": f.stages,
        "samples_total": f.samples,
        "samples_per_slice": f.samples_per_slice,
        "merges": f.merges,
        "pes": f.pes,
        "mapping": cfg.mapping.name(),
        "ray_buffer": f.ray_buffer,
        "voxel_load": f.voxel_load,
        "quantization": quant_json(&f.quant),
        "pe_cycles_per_second": f.cycles as f64 * f64::from(cfg.pes) / run.time_s.max(1e-12),
        "config": serde_json::to_value(cfg).unwrap_or(Value::Null),
        "error_vs_golden_er": if btf { vs_golden } else { None },
    })
}

/// Compares the pipeline's image with the golden method it mirrors
/// ([`golden_method`]: `er`, or `er-ftb` at the same threshold) using the
/// same table: the error's JSON and the largest per-channel difference of
/// the two float images (RGBA, before rounding to 8 bits), which the
/// derived bound ([`super::bound`]) is on.
pub fn versus_golden(
    prep: &Prepared,
    lut: &Lut,
    image: &golden::image::Image,
    cfg: &PipelineConfig,
    (shade, voi, preint): (
        Option<golden::shading::Shade>,
        Option<golden::voi::Voi>,
        bool,
    ),
) -> Result<(Value, f64)> {
    let mut opts = RenderOptions::default();
    opts.slice.shade = shade;
    opts.slice.voi = voi;
    opts.slice.preintegrate = preint;
    // The configuration's threshold was validated in (0, 1]; f32 is what
    // golden compares in.
    opts.slice.terminate = cfg.terminate as f32;
    let g = render(prep, lut, Technique::Slice(golden_method(cfg)), &opts)?;
    let max_abs = image
        .data
        .iter()
        .zip(&g.image.data)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(a, b)| f64::from((a - b).abs())))
        .fold(0.0, f64::max);
    Ok((error_json(&compare(image, &g.image)?), max_abs))
}

/// Refuses pipeline options on other methods.
pub fn check_unused(a: &PipelineArgs) -> Result<()> {
    if a.cfg.config.is_some()
        || a.cfg.toml.is_some()
        || a.cfg.pes.is_some()
        || a.vcd.is_some()
        || a.fst.is_some()
        || a.raw_npy.is_some()
    {
        bail!(
            "--config, --pes, --vcd, --fst and --raw-npy apply only to --method pipeline or pipeline-ftb"
        );
    }
    Ok(())
}
