//! `ercube cost`: what the PE array costs on an FPGA and how fast it runs.
//!
//! The resources come from `pipeline::cost` (per-unit models calibrated
//! against yosys); the cycles per frame from an actual pipeline run of the
//! scene and view, at the configured `P` and at each `P` of a sweep.
//! Like `render`, it needs `--scene` or `--volume`; the figures in
//! docs/cost.md are of the reference view `--scene checker:128 --eye
//! 64,64,-64`, about a second of simulation per `P` on two cores. The field of view does not change the cycles (the rays are laid
//! out by the eye and the volume; the fov only shapes the warped image).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;

use golden::render::Prepared;
use golden::skip::Skips;
use pipeline::config::{Mapping, PipelineConfig, RayBuffer, MAX_PES};
use pipeline::cost::inventory::Geometry;
use pipeline::cost::report::build;
use pipeline::cost::throughput::RunSummary;
use pipeline::cost::{clock, Target};
use pipeline::{FrameRun, Voxels};

use super::args::ViewArgs;
use super::chip::{self, ConfigArgs};
use super::progress::Stage;
use super::stats::write_json;

/// The reference view's scene, which the refusal without a source names.
const REFERENCE_SCENE: &str = "checker:128";
/// Its eye: 64 voxels in front of the middle of the front face, so the
/// view has two regions and a merge.
const REFERENCE_EYE: [f64; 3] = [64.0, 64.0, -64.0];

fn parse_target(s: &str) -> std::result::Result<Target, String> {
    s.parse()
}

/// Arguments of `ercube cost`.
#[derive(Debug, Args)]
pub struct CostArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    #[command(flatten)]
    pub cfg: ConfigArgs,
    /// FPGA family: xc7 (Artix-7), ecp5 or ice40 (UltraPlus).
    #[arg(long, value_parser = parse_target, default_value = "xc7")]
    pub target: Target,
    /// Clock in MHz (an assumption, not a timing result; as explore and
    /// render, whose default is xc7's 200).
    #[arg(long, allow_hyphen_values = true)]
    pub clock_mhz: Option<f64>,
    /// Where the clock comes from: "measured" (the PE sample stage of this
    /// volume's edge, PEs and widths placed and routed by `ercube synth`),
    /// "predicted" (the slowest of the datapath's stages and the sample
    /// stage's paths, delay models fitted to `ercube synth` runs; ecp5 and
    /// ice40 only), "assumed" (the family default: 200 MHz on xc7, 150 on
    /// ecp5, 48 on ice40) or "auto": --clock-mhz when given, else the
    /// first of measured, predicted and assumed there is.
    #[arg(long, default_value = "auto")]
    pub clock: String,
    /// Pipeline the sample datapath for this clock on --target (MHz,
    /// 1..=1000): sets the configuration's `target_mhz` and
    /// `target_family`, so the stages the delay model of
    /// `pipeline::cost::fmax` places set the datapath's latency and the
    /// run's cycles; reports the stages and register bits, or refuses
    /// when no schedule reaches the clock.
    #[arg(long, allow_hyphen_values = true)]
    pub target_mhz: Option<u16>,
    /// Sample empty space too (as render's --no-skip-empty).
    #[arg(long)]
    pub no_skip_empty: bool,
    /// Sample rays that cannot reach the image too (as render's --no-cull).
    #[arg(long)]
    pub no_cull: bool,
    /// PE counts to run and cost as a sweep, e.g. 8,16,32,64; "none" skips it.
    #[arg(long, default_value = "8,16,32,64")]
    pub sweep_pes: String,
    /// Write the report as JSON here (as every command's --stats; --json
    /// is accepted as an older spelling).
    #[arg(long, alias = "json")]
    pub stats: Option<PathBuf>,
    /// Write the calibration Verilog modules (one .v per unit) into this directory.
    #[arg(long)]
    pub verilog_dir: Option<PathBuf>,
    /// Cost and clock PEs with the gradient and shading unit (headlight,
    /// the default material; docs/pipeline.md#shading).
    #[arg(long)]
    pub shade: bool,
    /// Cost and clock PEs with the volume-of-interest stage, scaling by
    /// --voi-scale inside this region (box:x0,y0,z0,x1,y1,z1 or
    /// sphere:cx,cy,cz,r, world units; docs/pipeline.md#volume-of-interest).
    #[arg(long, value_parser = super::args::parse_voi, allow_hyphen_values = true)]
    pub voi: Option<golden::voi::Shape>,
    /// The VOI's opacity factor (0..=100).
    #[arg(long, default_value_t = 2.0)]
    pub voi_scale: f64,
    /// Scale outside the VOI instead of inside.
    #[arg(long)]
    pub voi_outside: bool,
    /// The VOI's transition width in world units.
    #[arg(long, default_value_t = 0.0)]
    pub voi_ramp: f64,
    /// Cost and clock PEs with the pre-integration unit in place of the
    /// classification (its table, lerps, dividers and the previous sample
    /// each ray carries; docs/cost.md#pre-integration). Not with --shade
    /// or --voi.
    #[arg(long)]
    pub preintegrate: bool,
    /// Architectures to run and cost beside the configuration, at its P:
    /// "all" (blocks, interleave and cyclic at the configuration's
    /// cyclic_width, each with the ray buffer on chip and external) or
    /// "none".
    #[arg(long, default_value = "all")]
    pub archs: String,
}

/// The configurations of `--archs`: every mapping with every placement,
/// the rest of `cfg` unchanged.
fn arch_configs(cfg: &PipelineConfig, spec: &str) -> Result<Vec<PipelineConfig>> {
    match spec.trim().to_ascii_lowercase().as_str() {
        "none" => Ok(Vec::new()),
        "all" => {
            let mut out = Vec::new();
            for mapping in Mapping::ALL {
                for ray_buffer in [RayBuffer::OnChip, RayBuffer::External] {
                    let c = PipelineConfig {
                        mapping,
                        ray_buffer,
                        ..*cfg
                    };
                    c.validate()?;
                    out.push(c);
                }
            }
            Ok(out)
        }
        other => bail!("--archs '{other}': expected all or none"),
    }
}

fn parse_sweep(s: &str) -> Result<Vec<u16>> {
    let s = s.trim();
    if s.eq_ignore_ascii_case("none") || s.is_empty() {
        return Ok(Vec::new());
    }
    let mut out = Vec::new();
    for part in s.split(',') {
        let p: u16 = part
            .trim()
            .parse()
            .ok()
            .filter(|p| (1..=MAX_PES).contains(p))
            .with_context(|| {
                format!(
                    "--sweep-pes: '{}' is not a PE count 1..={MAX_PES}",
                    part.trim()
                )
            })?;
        if !out.contains(&p) {
            out.push(p);
        }
    }
    Ok(out)
}

/// The units a run's PEs carry: the label of the run, the shading unit,
/// the volume-of-interest stage, the pre-integration unit, and what the
/// controller skips.
type Units<'a> = (&'a str, bool, Option<&'a golden::voi::Voi>, bool, Skips);

/// Runs one frame at `pes` PEs and summarises it: the frame `ercube render
/// --method pipeline` runs for the same view and skipping (the PEs loading
/// from `prep`'s slice stack, the occupancy memory from its blocks).
fn run_at(
    cfg: &PipelineConfig,
    pes: u16,
    vol: &golden::volume::Volume,
    lut: &golden::tf::Lut,
    prep: &Prepared,
    (label, shade, voi, preint, skips): Units,
) -> Result<RunSummary> {
    let cfg = PipelineConfig { pes, ..*cfg };
    cfg.validate()?;
    let _s = Stage::start(format!("clocking {pes} PEs"));
    let bits = vol.kind().bits();
    let frame = FrameRun::prepared(&cfg, lut, prep, Voxels::Stack { data_bits: bits }).skips(skips);
    let frame = if preint {
        // The unit's table is golden's, from the same classification
        // table; the frame's cycles include the prime and finish passes.
        let pt = golden::preint::PreTable::new(lut);
        frame.unit(Some(&pt)).run()?
    } else {
        let sh = shade.then(golden::shading::Shade::default);
        frame.unit(sh.as_ref()).unit(voi).run()?
    };
    let plan = pipeline::host::plan(&cfg, &prep.view)?;
    Ok(RunSummary::new(
        &cfg,
        label,
        Geometry::for_view(&cfg, &prep.view)?.with_units(frame.units),
        (&frame, &plan),
    ))
}

/// The clock `--clock` and `--clock-mhz` ask for, decided before the
/// frame runs: a measured or predicted clock is found for the view's
/// geometry once it has run.
#[derive(Debug, Clone, Copy)]
enum Wanted {
    /// An assumed clock, MHz (the family's or `--clock-mhz`).
    Assumed(f64),
    /// The placed stage's clock; without one, the predicted clock when
    /// `or_predicted` (`auto`), else a refusal.
    Measured { or_predicted: bool },
    /// The predicted clock.
    Predicted,
}

/// What `a`'s clock options ask for on `cfg`: `auto` is `--clock-mhz`
/// when given, else measured-or-predicted where the family has a delay
/// model, else the family's assumed clock.
fn wanted_clock(a: &CostArgs, cfg: &PipelineConfig) -> Result<Wanted> {
    let source = a.clock.trim();
    if let Some(mhz) = a.clock_mhz {
        if !matches!(source, "auto" | "assumed") {
            bail!("--clock-mhz {mhz}: an assumed clock; drop --clock {source}");
        }
    }
    let assumed = || -> Result<Wanted> {
        Ok(Wanted::Assumed(
            clock::check_mhz(a.clock_mhz.unwrap_or_else(|| clock::assumed_mhz(a.target)))
                .map_err(anyhow::Error::msg)?,
        ))
    };
    let has_model = pipeline::cost::fmax::pe_prediction(cfg, a.target).is_some();
    match source {
        "assumed" => assumed(),
        "auto" if a.clock_mhz.is_some() || !has_model => assumed(),
        "auto" => Ok(Wanted::Measured { or_predicted: true }),
        "measured" => Ok(Wanted::Measured {
            or_predicted: false,
        }),
        "predicted" if has_model => Ok(Wanted::Predicted),
        "predicted" => bail!(
            "--clock predicted: no predicted clock for {} (no open timing flow to fit the model to); give --clock-mhz",
            a.target.name()
        ),
        other => bail!("--clock {other}: expected auto, measured, predicted or assumed"),
    }
}

/// Runs `ercube cost`.
pub fn run(a: &CostArgs) -> Result<()> {
    super::outputs::check_files(&[a.stats.as_deref()])?;
    super::outputs::check_dirs(&[a.verilog_dir.as_deref()])?;
    let made: Vec<&std::path::Path> = a.verilog_dir.as_deref().into_iter().collect();
    super::outputs::all_or_nothing(&made, || cost(a))
}

fn cost(a: &CostArgs) -> Result<()> {
    let mut cfg = a.cfg.load()?;
    if let Some(mhz) = a.target_mhz {
        if mhz == 0 {
            bail!("--target-mhz 0: give a clock of 1..=1000 MHz (leave the option out for one operator a stage)");
        }
        cfg.target_mhz = mhz;
        cfg.target_family = a.target;
        cfg.validate()?;
    }
    let wanted = wanted_clock(a, &cfg)?;
    // The configuration's clock schedule (validated above: it reaches the
    // clock), beside the one-operator one.
    let pipelined = if cfg.target_mhz > 0 {
        Some(
            pipeline::cost::fmax::schedule_for(&cfg, cfg.target_family, f64::from(cfg.target_mhz))
                .map_err(anyhow::Error::msg)?,
        )
    } else {
        None
    };
    let skips = Skips {
        empty: !a.no_skip_empty,
        cull: !a.no_cull,
    };
    let sweep = parse_sweep(&a.sweep_pes)?;
    let archs = arch_configs(&cfg, &a.archs)?;
    let view = &a.view;
    if view.source.scene.is_none() && view.source.volume.is_none() {
        bail!(
            "no volume: give --scene SPEC or --volume FILE (the cost model's reference view is \
             --scene {REFERENCE_SCENE} --eye {},{},{})",
            REFERENCE_EYE[0],
            REFERENCE_EYE[1],
            REFERENCE_EYE[2]
        );
    }
    if let Some(dir) = &a.verilog_dir {
        write_verilog(dir, &cfg)?;
    }
    let (vol, tf, cam) = view.load()?;
    let lut = chip::pipeline_lut(&cfg, &vol, &tf);
    // Prepared as render prepares it: min-max blocks of the
    // configuration's occupancy block, no clip planes.
    let opts = golden::render::PrepareOptions {
        block: usize::from(cfg.occupancy_block),
        ..Default::default()
    };
    let prep = Prepared::with(&vol, &cam, &opts)?;
    // The field of view only shapes the warp's output image: the slice
    // order rays, and so the cycles, depend on the eye and the volume.
    let label = format!(
        "{}, eye ({}, {}, {})",
        view.source.label(),
        cam.eye.x,
        cam.eye.y,
        cam.eye.z
    );
    let voi = a.voi.map(|shape| golden::voi::Voi {
        shape,
        scale: a.voi_scale,
        outside: a.voi_outside,
        ramp: a.voi_ramp,
    });
    if let Some(v) = &voi {
        v.validate()?;
    }
    if a.preintegrate && (a.shade || voi.is_some()) {
        // Golden does not shade pre-integrated steps, and the unit has no
        // VOI factor for their extinction.
        bail!("--preintegrate is costed without the shading unit and the VOI stage; drop --shade and --voi");
    }
    let units = (label.as_str(), a.shade, voi.as_ref(), a.preintegrate, skips);
    let main = run_at(&cfg, cfg.pes, &vol, &lut, &prep, units)?;
    let mut runs = Vec::new();
    for &p in &sweep {
        if p == cfg.pes {
            runs.push(main.clone());
        } else {
            runs.push(run_at(&cfg, p, &vol, &lut, &prep, units)?);
        }
    }
    let mut arch_runs = Vec::new();
    for c in archs {
        let r = if c == cfg {
            main.clone()
        } else {
            run_at(&c, c.pes, &vol, &lut, &prep, units)?
        };
        arch_runs.push((c, r));
    }
    let measured = pipeline::cost::fmax::stages::measured_stage(&cfg, &main.geometry, a.target);
    let clock = match (wanted, measured) {
        (Wanted::Assumed(mhz), _) => (mhz, clock::ClockSource::Assumed),
        (Wanted::Measured { .. }, Some(m)) => (m.mhz, clock::ClockSource::Measured),
        (Wanted::Measured { or_predicted: false }, None) => bail!(
            "--clock measured: no PE sample stage of this design was placed on {} ({}^3 on {} PEs at these widths; pipeline/data/measured/stages.csv lists those placed); give --clock predicted",
            a.target.name(),
            main.geometry.dims[0],
            cfg.pes
        ),
        (Wanted::Measured { or_predicted: true } | Wanted::Predicted, _) => {
            // The sample stage's clock for this view's memories, as the
            // report's predicted line gives it (one decimal, as printed).
            let p = pipeline::cost::fmax::predicted_clock(&cfg, &main.geometry, a.target)
                .context("--clock predicted: no prediction for this design")?;
            ((p.mhz * 10.0).round() / 10.0, clock::ClockSource::Predicted)
        }
    };
    let report = build(&cfg, a.target, clock, main, &runs, &arch_runs);
    super::say(report.text().trim_end());
    if let Some(c) = &pipelined {
        super::say(&format!(
            "pipelined for {} MHz on {}: {} stages (latency {} clocks), {} pipeline-register bits, slowest stage predicted at {:.1} MHz (one operator a stage: {} stages, {} bits)",
            c.target_mhz,
            c.target.name(),
            c.depth,
            c.depth,
            c.register_bits,
            c.predicted_mhz,
            c.one_op_depth,
            c.one_op_register_bits
        ));
    }
    if let Some(p) = &a.stats {
        let mut v = serde_json::to_value(&report).context("serialising the report")?;
        if let (Some(c), Some(obj)) = (&pipelined, v.as_object_mut()) {
            obj.insert(
                "clock_schedule".to_owned(),
                serde_json::to_value(c).context("serialising the schedule")?,
            );
        }
        write_json(p, &v)?;
    }
    Ok(())
}

/// Writes each calibration module as `<name>.v` into `dir`.
fn write_verilog(dir: &std::path::Path, cfg: &PipelineConfig) -> Result<()> {
    let mut mods = pipeline::rtl::calibration_modules(cfg)?;
    mods.extend(pipeline::rtl::shading_modules(cfg));
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for m in &mods {
        let path = dir.join(format!("{}.v", m.name));
        golden::image::write_atomic(&path, |w| w.write_all(m.verilog.as_bytes()))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
