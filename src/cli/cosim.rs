//! `ercube cosim`: the frame in the model and, replayed from it, in the
//! emitted Verilog of every PE's datapath, compared on every cycle
//! (`pipeline::cosim`). By default the datapath stage of the
//! co-simulation: each PE's datapath is fed the issue stream the model's
//! PE gave its own, bubbles included, and its outputs are checked against
//! the model's write-backs (`--stage pe` runs the PE's sample stage
//! instead, [`super::cosim_pe`]). Then the readout stage (`pipeline::cosim::readout`): the
//! emitted readout array loaded with the PEs' buffers as the model held
//! them at `BeginReadout`, every PE's host port compared on every readout
//! cycle, and the host's baseplane from the RTL's stream compared with the
//! model's final raw words. Exit status 1 on any mismatch.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{anyhow, bail, Result};
use clap::Args;
use serde_json::json;

use pipeline::config::Order;
use pipeline::cosim::build::{build, run as run_sim, Simulator};
use pipeline::cosim::fold::Fold;
use pipeline::cosim::merge::Merge;
use pipeline::cosim::outcome::{parse, Outcome};
use pipeline::cosim::readout::{simulate, ReadoutRecord, StageRun, Tee};
use pipeline::cosim::replay::{Replay, StreamFiles, TOP};
use pipeline::cosim::split::Split;
use pipeline::hw::readout_rtl::{emit as emit_readout, ReadoutShape};

use super::rtl::MODULE;

/// Arguments of `ercube cosim`.
#[derive(Debug, Args)]
pub struct CosimArgs {
    #[command(flatten)]
    pub frame: FrameArgs,
    /// The simulator: verilator or iverilog.
    #[arg(long, value_parser = ["verilator", "iverilog"], default_value = "verilator")]
    pub simulator: String,
    /// Write the figures as JSON here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Write the RTL's waveform (every PE's datapath) as VCD here.
    #[arg(long)]
    pub vcd: Option<PathBuf>,
    /// Check the RTL up to this cycle only (the samples issued by then,
    /// each to its write-back); the model still runs the whole frame.
    #[arg(long)]
    pub max_cycles: Option<u64>,
    /// The datapath's Verilog from this file instead of the emitted one:
    /// a module named `ercube_sample` with the emitted module's ports
    /// (`ercube rtl` lists them), say a team's own or a modified copy.
    #[arg(long)]
    pub verilog: Option<PathBuf>,
    /// Where builds are kept, by a hash of their Verilog (default:
    /// $XDG_CACHE_HOME/ercube/cosim or ~/.cache/ercube/cosim).
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
    /// What is emitted and compared: the datapath stage with the readout
    /// (`datapath`), or each PE's sample stage with its control, voxel
    /// memory and compositing buffer, then the readout from its buffers
    /// (`pe`; either order, column blocks), or every dense split of a
    /// front-to-back frame in the PE's split module (`split`), or every
    /// dense merge of a back-to-front frame in the PE's merge module
    /// (`merge`), or every dense fold of a front-to-back frame in the PE's
    /// fold module (`fold`).
    #[arg(long, value_parser = ["datapath", "pe", "split", "merge", "fold"], default_value = "datapath")]
    pub stage: String,
}

impl CosimArgs {
    /// Refuses, in one line naming `cmd`, the flags only the datapath
    /// stage takes (`--vcd`, `--max-cycles`, `--verilog`).
    pub fn refuse_datapath_flags(&self, cmd: &str) -> Result<()> {
        for (given, what) in [
            (self.vcd.is_some(), "--vcd"),
            (self.max_cycles.is_some(), "--max-cycles"),
            (self.verilog.is_some(), "--verilog"),
        ] {
            if given {
                bail!("{cmd}: {what} is for the datapath stage only");
            }
        }
        Ok(())
    }
}

pub use super::cosim_frame::{setup, FrameArgs, Setup};

/// A failed comparison: the report is printed, the exit status is 1.
#[derive(Debug)]
pub struct Mismatched(pub String);

impl std::fmt::Display for Mismatched {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Mismatched {}

/// The simulator named on the command line, refused in one line when it
/// is not installed.
pub(super) fn simulator(name: &str) -> Result<Simulator> {
    let sim = match name {
        "iverilog" => Simulator::Icarus,
        _ => Simulator::Verilator,
    };
    let found = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(sim.tool()).is_file()));
    if !found {
        bail!(
            "cosim: {} is not on PATH (Debian: apt-get install {})",
            sim.tool(),
            sim.tool()
        );
    }
    Ok(sim)
}

/// The build cache's folder.
pub(super) fn cache_dir(given: Option<&Path>) -> PathBuf {
    if let Some(d) = given {
        return d.to_owned();
    }
    let base = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .unwrap_or_else(std::env::temp_dir);
    base.join("ercube").join("cosim")
}

/// `n / s` per second, `0` for no time.
fn rate(n: u64, s: f64) -> f64 {
    if s > 0.0 {
        n as f64 / s
    } else {
        0.0
    }
}

/// Runs `ercube cosim`.
pub fn run(a: &CosimArgs) -> Result<()> {
    if a.stage == "pe" {
        return super::cosim_pe::run(a);
    }
    if a.stage == "merge" {
        return super::cosim_pass::run::<Merge>(a);
    }
    if a.stage == "fold" {
        return super::cosim_pass::run::<Fold>(a);
    }
    if a.stage == "split" {
        return super::cosim_pass::run::<Split>(a);
    }
    super::outputs::check_files(&[a.stats.as_deref(), a.vcd.as_deref()])?;
    if a.max_cycles == Some(0) {
        bail!("--max-cycles 0: give at least one cycle");
    }
    let sim = simulator(&a.simulator)?;
    let given = match &a.verilog {
        Some(p) => Some(
            std::fs::read_to_string(p).map_err(|e| anyhow!("--verilog {}: {e}", p.display()))?,
        ),
        None => None,
    };
    let s = setup(&a.frame, "cosim")?;
    let datapath = given.as_deref().unwrap_or(&s.module.verilog);
    let p = usize::from(s.cfg.pes);
    let depth = u64::from(s.module.depth);
    let latency = s.latency();
    // The model untraced: the frame as `render` runs it.
    let t = Instant::now();
    let plain = s.frame().run()?;
    let untraced_s = t.elapsed().as_secs_f64();
    // The model again, each PE's issue stream written as it runs.
    let replay = Replay::new(s.module.clone(), latency)?;
    // Back to front slice 0's rays composite two steps in one sample.
    let replay = if s.units.preint && s.cfg.order == Order::BackToFront {
        replay.with_second_steps()
    } else {
        replay
    };
    let lanes = p * replay.lanes;
    let run_dir = tempfile::Builder::new().prefix("ercube-cosim-").tempdir()?;
    let last_issue = a.max_cycles.unwrap_or(u64::MAX);
    let realign = (latency != depth).then_some(depth);
    let streams = StreamFiles::create(replay.clone(), run_dir.path(), p, last_issue, realign)?;
    let streams = Arc::new(Mutex::new(streams));
    let readout = Arc::new(Mutex::new(ReadoutRecord::default()));
    let t = Instant::now();
    let captured = s
        .frame()
        .capture(Tee::capture(streams.clone(), readout.clone()))
        .run()?;
    let capture_s = t.elapsed().as_secs_f64();
    if captured.cycles != plain.cycles || captured.raw != plain.raw {
        bail!("cosim: the captured frame differs from the untraced one (a model bug)");
    }
    let (issued, last_land) = {
        let mut st = streams
            .lock()
            .map_err(|_| anyhow!("cosim: capture poisoned"))?;
        st.finish()?;
        (st.issued.clone(), st.last_land)
    };
    let samples: u64 = issued[..p].iter().sum();
    let frame_end = a.max_cycles.map_or(plain.cycles, |m| m.min(plain.cycles));
    let cycles = frame_end.max(last_land);
    // The RTL: built once per text, run on the streams.
    let tb = replay.testbench(lanes);
    let sources = [
        (format!("{MODULE}.v"), datapath),
        (format!("{TOP}.v"), tb.as_str()),
    ];
    let sources: Vec<(&str, &str)> = sources.iter().map(|(n, t)| (n.as_str(), *t)).collect();
    let cache = cache_dir(a.cache_dir.as_deref());
    let built =
        build(sim, &cache, &sources, TOP, a.vcd.is_some()).map_err(|e| anyhow!("cosim: {e}"))?;
    let mut args = vec![format!("+cycles={cycles}")];
    if a.vcd.is_some() {
        args.push("+vcd".into());
    }
    let (text, sim_s) =
        run_sim(&built, run_dir.path(), &args).map_err(|e| anyhow!("cosim: {e}"))?;
    let mut o = parse(&replay, lanes, &text);
    if let Some(m) = o.first.as_mut().filter(|m| m.pe >= p && m.pe < lanes) {
        m.pe -= p;
        m.signal = format!("{} (the second step)", m.signal);
    }
    let readout = readout
        .lock()
        .map_err(|_| anyhow!("cosim: capture poisoned"))?;
    let stage = readout_stage(a, &s, sim, &readout, &plain.raw, &cache, run_dir.path())?;
    let report = Report {
        a,
        s: &s,
        sim,
        o: &o,
        samples,
        cycles,
        frame_cycles: plain.cycles,
        times: [untraced_s, capture_s, built.seconds, sim_s],
        cached: built.cached,
        tb_lines: tb.lines().count(),
        load_clocks: replay.table_words() as u64 + 2,
        datapath_lines: datapath.lines().count(),
    };
    let mut problems = report.problems(&issued);
    match &stage {
        Stage::Ran(r, _) => problems.extend(r.problems()),
        Stage::Unfit(_) | Stage::Skipped(_) => {}
    }
    if latency != depth {
        problems.insert(
            0,
            format!(
                "mismatch class latency: the model writes back {latency} clocks after issue, the RTL {depth} (results compared at the RTL's)"
            ),
        );
    }
    let mut lines = report.lines();
    lines.push(stage.line(&s, plain.stages.readout));
    super::outputs::all_or_nothing(&[], || {
        if let Some(path) = &a.stats {
            let mut j = report.json(&problems);
            j["readout"] = stage.json(plain.stages.readout);
            super::stats::write_json(path, &j)?;
        }
        if let Some(path) = &a.vcd {
            place_vcd(&run_dir.path().join("rtl.vcd"), path)?;
        }
        Ok(())
    })?;
    report_out(&lines, &problems)
}

/// Prints a run's report `lines`, then the problems after the first, and
/// fails with the first one (exit 1): what every cosim stage ends with.
pub(super) fn report_out(lines: &[String], problems: &[String]) -> Result<()> {
    for l in lines {
        super::say(l);
    }
    if let Some((first, rest)) = problems.split_first() {
        for l in rest {
            super::say(&format!("  {l}"));
        }
        return Err(Mismatched(first.clone()).into());
    }
    Ok(())
}

/// Moves the simulation's VCD to `dest`, staged with the run's files.
fn place_vcd(vcd: &Path, dest: &Path) -> Result<()> {
    let dir = match dest.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let tmp = tempfile::NamedTempFile::new_in(dir)?;
    if std::fs::rename(vcd, tmp.path()).is_err() {
        std::fs::copy(vcd, tmp.path())
            .map_err(|e| anyhow!("cosim: the simulation wrote no waveform: {e}"))?;
    }
    golden::image::place(tmp, dest)?;
    Ok(())
}

/// What a cosim run measured, for the lines it prints and `--stats`.
struct Report<'a> {
    a: &'a CosimArgs,
    s: &'a Setup,
    sim: Simulator,
    o: &'a Outcome,
    samples: u64,
    cycles: u64,
    frame_cycles: u64,
    /// Seconds: the model untraced, the model capturing, the build, the
    /// simulation.
    times: [f64; 4],
    cached: bool,
    tb_lines: usize,
    /// Clocks before the frame's first: the reset and the table writes.
    load_clocks: u64,
    datapath_lines: usize,
}

impl Report<'_> {
    /// Every way the run failed, most telling first (the first mismatch).
    fn problems(&self, issued: &[u64]) -> Vec<String> {
        let o = self.o;
        let mut v = Vec::new();
        if let Some(m) = &o.first {
            v.push(format!("{} mismatches; the first: {m}", o.mismatches()));
        } else if o.mismatches() > 0 {
            v.push(format!("{} mismatches", o.mismatches()));
        }
        let p = usize::from(self.s.cfg.pes);
        for (k, (pe, &n)) in o.pes.iter().zip(issued).enumerate() {
            if pe.issued != n || pe.left {
                let what = if k < p { "samples" } else { "second steps" };
                v.push(format!(
                    "PE {}: the RTL issued {} of the model's {n} {what}",
                    k % p.max(1),
                    pe.issued
                ));
            }
        }
        if o.checked() != o.issued() {
            v.push(format!(
                "{} write-backs compared of {} samples issued",
                o.checked(),
                o.issued()
            ));
        }
        v.extend(o.errors.iter().cloned());
        v
    }

    /// Write-backs compared: the samples' (each PE's first datapath) and
    /// the second steps' ([`Replay::lanes`]).
    fn checked(&self) -> [u64; 2] {
        let p = usize::from(self.s.cfg.pes).min(self.o.pes.len());
        let (a, b) = self.o.pes.split_at(p);
        [a, b].map(|l| l.iter().map(|x| x.checked).sum())
    }

    fn lines(&self) -> Vec<String> {
        let (s, o) = (self.s, self.o);
        let [untraced, capture, build_s, sim_s] = self.times;
        let order = match s.cfg.order {
            Order::BackToFront => "back to front",
            Order::FrontToBack => "front to back",
        };
        let [checked, second] = self.checked();
        let mut v = vec![format!(
            "cosim: {}, {} PEs, {order}, {}: {} cycles{}, {} samples, {checked} write-backs compared{}, {} mismatches",
            s.label,
            s.cfg.pes,
            self.sim.tool(),
            self.cycles,
            if self.cycles == self.frame_cycles {
                String::new()
            } else {
                format!(" (of the frame's {})", self.frame_cycles)
            },
            self.samples,
            if o.pes.len() > usize::from(s.cfg.pes) {
                format!(", {second} second steps compared (slice 0's half step, in each PE's second datapath)")
            } else {
                String::new()
            },
            o.mismatches()
        )];
        v.push(format!(
            "  model: {} cycles in {untraced:.2} s untraced ({:.0} cycles/s), {capture:.2} s capturing ({:.0} cycles/s)",
            self.frame_cycles,
            rate(self.frame_cycles, untraced),
            rate(self.frame_cycles, capture)
        ));
        v.push(format!(
            "  rtl: {MODULE} {} lines ({} clocks deep) x {} + {TOP} {} lines; {}; ran {} cycles after {} clocks of reset and table writes in {sim_s:.2} s ({:.0} clocks/s)",
            self.datapath_lines,
            s.module.depth,
            o.pes.len(),
            self.tb_lines,
            if self.cached {
                "build cached".to_owned()
            } else {
                format!("built in {build_s:.1} s")
            },
            self.cycles,
            self.load_clocks,
            rate(self.cycles + self.load_clocks, sim_s)
        ));
        v
    }

    fn json(&self, problems: &[String]) -> serde_json::Value {
        let (s, o) = (self.s, self.o);
        let [untraced, capture, build_s, sim_s] = self.times;
        json!({
            "volume": s.label,
            "pes": s.cfg.pes,
            "order": s.cfg.order.name(),
            "simulator": self.sim.tool(),
            "frame_cycles": self.frame_cycles,
            "cycles": self.cycles,
            "max_cycles": self.a.max_cycles,
            "samples": self.samples,
            "write_backs_compared": self.checked()[0],
            "second_steps_compared": self.checked()[1],
            "mismatches": o.mismatches(),
            "first_mismatch": o.first.as_ref().map(|m| json!({
                "cycle": m.cycle, "pe": m.pe, "signal": m.signal, "model": m.model, "rtl": m.rtl,
            })),
            "problems": problems,
            "per_pe": o.pes,
            "model_latency": s.latency(),
            "rtl_depth": s.module.depth,
            "model_untraced_s": untraced,
            "model_untraced_cycles_per_s": rate(self.frame_cycles, untraced),
            "model_capture_s": capture,
            "model_capture_cycles_per_s": rate(self.frame_cycles, capture),
            "rtl_build_s": build_s,
            "rtl_build_cached": self.cached,
            "rtl_run_s": sim_s,
            "rtl_load_clocks": self.load_clocks,
            "rtl_clocks_per_s": rate(self.cycles + self.load_clocks, sim_s),
            "rtl_lines": { "datapath": self.datapath_lines, "top": self.tb_lines },
            "verilog": self.a.verilog.as_ref().map(|p| p.display().to_string()),
            "config": serde_json::to_value(s.cfg).unwrap_or(serde_json::Value::Null),
        })
    }
}

/// The readout stage of a cosim run: simulated, or why not.
enum Stage {
    /// Simulated and compared, with the emitted shape.
    Ran(Box<StageRun>, ReadoutShape),
    /// Not simulated, and why.
    Skipped(String),
    /// Not simulated: a PE holds more rays than the emitted memories
    /// declare (said in one line; the datapath's result stands).
    Unfit(String),
}

/// Runs the readout stage on the frame's captured readout, when the frame
/// reached it (`--max-cycles`) and the configuration's readout is emitted.
fn readout_stage(
    a: &CosimArgs,
    s: &Setup,
    sim: Simulator,
    rec: &ReadoutRecord,
    raw: &[[i64; 4]],
    cache: &Path,
    run_dir: &Path,
) -> Result<Stage> {
    let Some(start) = &rec.start else {
        return Ok(Stage::Skipped("the frame has no readout".into()));
    };
    if a.max_cycles
        .is_some_and(|m| m < start.cycle + rec.ticks.len() as u64)
    {
        return Ok(Stage::Skipped(format!(
            "not checked: --max-cycles ends before the readout's last cycle {}",
            start.cycle + rec.ticks.len() as u64
        )));
    }
    let shape = match ReadoutShape::for_view(&s.cfg, &s.prep.view) {
        Ok(shape) => shape,
        Err(e) => return Ok(Stage::Skipped(format!("not checked: {e}"))),
    };
    if let Err(e) = pipeline::cosim::readout::counts(&shape, start) {
        return Ok(Stage::Unfit(format!(
            "readout: not checked: the frame does not fit the declared memories: {e}"
        )));
    }
    let rtl = emit_readout(&shape);
    let dir = run_dir.join("readout");
    std::fs::create_dir_all(&dir)?;
    let run = simulate(
        &rtl, &rtl.pe, start, &rec.ticks, raw, sim, cache, &dir, false,
    )
    .map_err(|e| anyhow!("cosim: readout: {e}"))?;
    Ok(Stage::Ran(Box::new(run), shape))
}

impl Stage {
    fn line(&self, s: &Setup, frame_readout: u64) -> String {
        match self {
            Stage::Skipped(why) => format!("  readout: {why}"),
            Stage::Unfit(why) => format!("  {why}"),
            Stage::Ran(r, shape) => {
                let o = &r.outcome;
                format!(
                    "  readout: {} memory bits and {} register bits a PE (compositing buffer 2 x {} x {}, column map {} x {}{}); {} clocks (the frame's readout cycles: {frame_readout}) x {} PEs, {} host words, {} mismatches; {} raw words compared with the model's, {} differ; {} {} lines x {} + {} {} + {} {}; {}; ran in {:.2} s",
                    shape.memory_bits(),
                    shape.register_bits(),
                    shape.bank_depth,
                    shape.buffer_width,
                    shape.map_depth,
                    shape.map_width,
                    if shape.sparse {
                        format!(", valid bits {} x {}", shape.max_rows, shape.map_depth)
                    } else {
                        String::new()
                    },
                    o.ticks,
                    s.cfg.pes,
                    o.words(),
                    o.mismatches(),
                    r.raw.0,
                    r.raw.1,
                    pipeline::hw::readout_rtl::PE_MODULE,
                    r.lines[0],
                    s.cfg.pes,
                    pipeline::hw::readout_rtl::ARRAY_MODULE,
                    r.lines[1],
                    pipeline::cosim::readout::TOP,
                    r.lines[2],
                    if r.built.cached {
                        "build cached".to_owned()
                    } else {
                        format!("built in {:.1} s", r.built.seconds)
                    },
                    r.run_s
                )
            }
        }
    }

    fn json(&self, frame_readout: u64) -> serde_json::Value {
        match self {
            Stage::Skipped(why) => json!({ "skipped": why }),
            Stage::Unfit(why) => json!({ "unfit": why }),
            Stage::Ran(r, shape) => {
                let o = &r.outcome;
                json!({
                    "shape": shape,
                    "memory_bits_per_pe": shape.memory_bits(),
                    "register_bits_per_pe": shape.register_bits(),
                    "clocks": o.ticks,
                    "frame_readout_cycles": frame_readout,
                    "host_words": o.words(),
                    "loads": o.loads,
                    "mismatches": o.mismatches(),
                    "first_mismatch": o.first.as_ref().map(|m| json!({
                        "cycle": m.cycle, "pe": m.pe, "signal": m.signal, "model": m.model, "rtl": m.rtl,
                    })),
                    "raw_words_compared": r.raw.0,
                    "raw_words_differing": r.raw.1,
                    "per_pe": o.pes.iter().map(|p| json!({"host_words": p.0, "mismatches": p.1})).collect::<Vec<_>>(),
                    "rtl_build_s": r.built.seconds,
                    "rtl_build_cached": r.built.cached,
                    "rtl_run_s": r.run_s,
                    "rtl_lines": { "pe": r.lines[0], "array": r.lines[1], "top": r.lines[2] },
                    "problems": r.problems(),
                })
            }
        }
    }
}
