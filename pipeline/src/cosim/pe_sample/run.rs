//! Running the sample stage's co-simulation on a frame: the model with
//! the capture, the emitted PE and testbench built and run, the streams
//! and the buffers compared, and the readout fed from the RTL's buffers.

use std::path::Path;
use std::sync::{Arc, Mutex};

use super::bench::{testbench, TOP};
use super::compare::{buffers, streams, Buffers, StageOutcome};
use super::slots::Slots;
use super::{PeCapture, Widths};
use crate::cosim::build::{build, run, Built, Simulator};
use crate::cosim::readout::StageRun;
use crate::cosim::replay::table_rows;
use crate::hw::pe_sample_rtl::{emit, PeSampleShape, MODULE};
use crate::hw::pe_units_rtl::UnitWiring;
use crate::hw::pipeline_rtl::PipelinedModule;
use crate::hw::readout_rtl::{emit as emit_readout, ReadoutShape};
use crate::FrameRun;

/// What a run of the sample stage's co-simulation found.
pub struct PeStageRun {
    /// The streams compared.
    pub outcome: StageOutcome,
    /// The buffers at the readout's start (a frame reaching it).
    pub buffers: Option<Buffers>,
    /// The readout fed from the RTL's buffers.
    pub readout: Option<StageRun>,
    /// The clocks simulated (to the readout's start, or past it to the
    /// last write-back).
    pub cycles: u64,
    /// The readout's start and the clock the buffers were dumped in.
    pub dump: Option<(u64, u64)>,
    /// The frame's cycles in the model.
    pub frame_cycles: u64,
    /// Samples the model issued.
    pub samples: u64,
    /// Buffer words the model changed outside the sample stage (replayed).
    pub outside_words: u64,
    /// Runs the controller drove on the PEs' plan port (from each sampled
    /// slice's first clock, one a clock).
    pub plan_runs: u64,
    /// Held columns inside a slice's x range that sampled rows left out
    /// (the runs' gaps; [`super::PeCapture::skipped_in_rows`]).
    pub skipped_in_rows: u64,
    /// Front to back: in-run columns of sampled rows the termination bits
    /// left out ([`super::PeCapture::terminated_in_rows`]).
    pub terminated_in_rows: u64,
    /// Termination bits written outside the stage (replayed).
    pub outside_flags: u64,
    /// The build.
    pub built: Built,
    /// Seconds: the model capturing, the simulation.
    pub seconds: [f64; 2],
    /// Lines of Verilog: the PE module, the testbench.
    pub lines: [usize; 2],
    /// The PE module's memory and control register bits.
    pub bits: [u64; 2],
    /// Why the frame was not checked, if it was not.
    pub unfit: Option<String>,
    /// A readout read the model made before the ray's write-back landed
    /// ([`super::PeCapture::early_read`]).
    pub early_read: Option<String>,
    /// The most columns a PE held at a slice's start, and the column
    /// map's declared slots (the emitted module has the larger).
    pub slots: (u64, u64),
    /// The most voxel columns a PE's memory held, and the slice buffer's
    /// declared columns (the emitted module has the larger).
    pub stored: (u64, u64),
}

/// A capture noting the most columns any PE holds at a slice's start,
/// under a round-robin mapping the most slots migration gives out
/// ([`super::slots`], as many as it needs), and the most voxel columns a
/// PE's memory holds.
struct Peak(u64, Option<Slots>, u64);

impl crate::cosim::capture::IssueSink for Peak {
    fn issue(&mut self, i: &crate::cosim::capture::Issue) {
        if let Some(t) = &mut self.1 {
            t.landed(i.pe, i.input.m, i.input.land);
        }
    }
    fn slice_begin(&mut self, cycle: u64, _: usize, pes: &[crate::pe::Pe]) {
        for (k, p) in pes.iter().enumerate() {
            self.0 = self.0.max(p.rays.len() as u64);
            self.2 = self.2.max(p.held_columns() as u64);
            if let Some(t) = &mut self.1 {
                let mxs: Vec<i64> = p.rays.iter().map(|c| c.mx).collect();
                let _ = t.hold(k, &mxs, cycle);
            }
        }
    }
    fn readout_begin(&mut self, start: &crate::cosim::capture::ReadoutStart) {
        if let Some(t) = &mut self.1 {
            for (k, p) in start.pes.iter().enumerate() {
                let _ = t.hold(k, &p.mx, start.cycle);
            }
        }
    }
}

impl PeStageRun {
    /// Every way the run failed, most telling first.
    pub fn problems(&self) -> Vec<String> {
        let mut v = Vec::new();
        let o = &self.outcome;
        if let Some(e) = &self.early_read {
            v.push(format!(
                "the model's readout reads a ray before it lands: {e}"
            ));
        }
        if let Some(m) = &o.first {
            v.push(format!("{} mismatches; the first: {m}", o.mismatches));
        }
        if let Some(b) = &self.buffers {
            if let Some((k, mx, row, m, r)) = &b.first {
                v.push(format!(
                    "buffer at the readout: {} of {} ray words differ; the first: PE {k}, ray ({mx}, {row}): model {m:?}, RTL {r:?}",
                    b.differ, b.compared
                ));
            }
        }
        if let Some(r) = &self.readout {
            v.extend(
                r.problems()
                    .into_iter()
                    .map(|p| format!("readout from the RTL's buffers: {p}")),
            );
        }
        if o.compared[0] != self.samples && self.unfit.is_none() {
            v.push(format!(
                "{} issues compared of the model's {}",
                o.compared[0], self.samples
            ));
        }
        v
    }
}

/// The declared shape of `cfg`'s sample stage for `view`, and what a run
/// of the frame `frame` makes needs: the most column map slots (columns
/// a PE holds, or slots migration gives out) and the most voxel columns
/// a PE's memory holds. The emitted module is sized to the larger of each.
pub(crate) fn peaks<'a>(
    frame: &dyn Fn() -> FrameRun<'a>,
    cfg: &crate::config::PipelineConfig,
    view: &golden::geometry::View,
) -> Result<(PeSampleShape, u64, u64), String> {
    let declared = PeSampleShape::for_view(cfg, view)?;
    let pes = usize::from(cfg.pes);
    let slots = declared.round_robin.then(|| Slots::new(pes, None));
    let peak = Arc::new(Mutex::new(Peak(0, slots, 0)));
    frame()
        .capture(peak.clone())
        .run()
        .map_err(|e| e.to_string())?;
    let p = peak.lock().map_err(|_| "capture poisoned".to_owned())?;
    let given = p.1.as_ref().map_or(0, |t| t.peak);
    Ok((declared, p.0.max(given), p.2))
}

/// The host's writes of the PE's frame registers (`frame.hex`, a line
/// each: `{frm_sel, frm_data}` in hex), in `frm_sel` order, from the
/// model's per-frame words `words`; a register the model has no word for
/// is an error.
fn frame_rows(u: &UnitWiring, words: &[(String, i64)]) -> Result<String, String> {
    let db = u.data_bits();
    let mut rows = String::new();
    for (i, (n, w)) in u.frame.iter().enumerate() {
        let v = words
            .iter()
            .find(|(m, _)| m == n)
            .ok_or_else(|| format!("the model has no word for the frame register {n}"))?
            .1;
        let data = crate::cosim::replay::masked(v, w.bits);
        rows.push_str(&format!("{:x}\n", ((i as u128) << db) | data));
    }
    Ok(rows)
}

/// Runs the frame `frame` makes with the capture (twice: first for the
/// most columns a PE holds), then the sample stage of `cfg`'s PEs
/// around datapath `dp` in `sim` (built under `cache`, run in `dir`);
/// `mutate` edits the PE module's text first (a test's broken control).
#[allow(clippy::too_many_arguments)]
pub fn simulate<'a>(
    frame: &dyn Fn() -> FrameRun<'a>,
    cfg: &crate::config::PipelineConfig,
    view: &golden::geometry::View,
    dp: &PipelinedModule,
    sim: Simulator,
    cache: &Path,
    dir: &Path,
    mutate: Option<&dyn Fn(&str) -> String>,
) -> Result<PeStageRun, String> {
    let (declared, held, cols) = peaks(frame, cfg, view)?;
    let pes = usize::from(cfg.pes);
    let shape = declared.with_slots(held).with_stored(cols);
    let pe = emit(&shape, dp)?;
    let verilog = mutate.map_or_else(|| pe.verilog.clone(), |f| f(&pe.verilog));
    let widths = Widths::of(&shape, dp);
    let tap_stage = widths.tap_stage;
    let capture = PeCapture::create(shape, widths, dir, pes).map_err(|e| e.to_string())?;
    let capture = Arc::new(Mutex::new(capture));
    let t = std::time::Instant::now();
    let f = frame()
        .capture(capture.clone())
        .run()
        .map_err(|e| e.to_string())?;
    let capture_s = t.elapsed().as_secs_f64();
    let mut c = capture.lock().map_err(|_| "capture poisoned".to_owned())?;
    c.finish().map_err(|e| e.to_string())?;
    if let Some(e) = &c.error {
        return Err(format!("capture: {e}"));
    }
    let (rows, n) = table_rows(dp, &c.tables);
    std::fs::write(dir.join("tables.hex"), rows).map_err(|e| e.to_string())?;
    let frame_rows = frame_rows(&UnitWiring::of(dp), &c.frame)?;
    std::fs::write(dir.join("frame.hex"), &frame_rows).map_err(|e| e.to_string())?;
    let start = c.readout.clone();
    let dump = start.as_ref().map(|s| c.dump_cycle(s));
    let cycles = dump
        .unwrap_or(f.cycles)
        .max(c.last_cycle + u64::from(dp.depth) + 1);
    let tb = testbench(&shape, dp, pes, view.dims[2] as u64, tap_stage);
    let sources = [
        (format!("{}.v", dp.name), dp.verilog.as_str()),
        (format!("{MODULE}.v"), verilog.as_str()),
        (format!("{TOP}.v"), tb.as_str()),
    ];
    let sources: Vec<(&str, &str)> = sources.iter().map(|(n, t)| (n.as_str(), *t)).collect();
    let mut out = PeStageRun {
        outcome: StageOutcome::default(),
        buffers: None,
        readout: None,
        cycles,
        dump: start.as_ref().zip(dump).map(|(s, d)| (s.cycle, d)),
        frame_cycles: f.cycles,
        samples: c.issued.iter().sum(),
        outside_words: c.outside_words,
        plan_runs: c.plan_runs,
        skipped_in_rows: c.skipped_in_rows,
        terminated_in_rows: c.terminated_in_rows,
        outside_flags: c.outside_flags,
        built: Built {
            exe: dir.to_owned(),
            sim,
            seconds: 0.0,
            cached: false,
        },
        seconds: [capture_s, 0.0],
        lines: [verilog.lines().count(), tb.lines().count()],
        bits: [shape.memory_bits(), pe.register_bits],
        unfit: c.unfit.clone(),
        early_read: c.early_read.clone(),
        slots: (held, declared.slots()),
        stored: (cols, declared.stored),
    };
    if out.unfit.is_some() {
        return Ok(out);
    }
    out.built = build(sim, cache, &sources, TOP, false).map_err(|e| e.to_string())?;
    let mut args = vec![
        format!("+cycles={cycles}"),
        format!("+tables={n}"),
        format!("+frames={}", frame_rows.lines().count()),
    ];
    if let Some(d) = dump {
        args.push(format!("+dump={d}"));
    }
    let (_, run_s) = run(&out.built, dir, &args).map_err(|e| e.to_string())?;
    out.seconds[1] = run_s;
    out.outcome = streams(dir, pes)?;
    if let Some(s) = &start {
        let b = buffers(dir, &shape, &widths, s, &|k, mx, row| c.addr(k, mx, row))?;
        if let Ok(rs) = ReadoutShape::for_view(cfg, view) {
            if crate::cosim::readout::counts(&rs, &b.start).is_ok() {
                let rtl = emit_readout(&rs);
                let rdir = dir.join("readout");
                std::fs::create_dir_all(&rdir).map_err(|e| e.to_string())?;
                let r = crate::cosim::readout::simulate(
                    &rtl, &rtl.pe, &b.start, &c.ticks, &f.raw, sim, cache, &rdir, false,
                )?;
                out.readout = Some(r);
            }
        }
        out.buffers = Some(b);
    }
    Ok(out)
}
