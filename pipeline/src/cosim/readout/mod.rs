//! The co-simulation's readout stage: the emitted array of PE readout
//! stages ([`crate::hw::readout_rtl`]) loaded with each PE's compositing
//! buffer and column map as the model held them when the controller
//! broadcast `BeginReadout`, then clocked through the readout and compared
//! with the model on every clock (every PE's host port and `done` line);
//! the host's baseplane is assembled from the RTL's host stream and
//! compared word for word with the model's final raw words.
//!
//! The buffers' contents come from the model at the readout's start: the
//! sampling, the merges and the migrations that fill them are not in RTL
//! yet.

use std::path::Path;
use std::sync::Arc;

use super::capture::{Capture, Issue, IssueSink, ReadoutStart, ReadoutTick};
use crate::datapath::Datapath;
use crate::hw::readout_rtl::ARRAY_MODULE;

mod compare;
mod files;
mod testbench;

pub use compare::{compare_raw, parse, RawCompare, ReadoutOutcome};
pub use files::{counts, write_files};
pub use testbench::testbench;

/// The generated testbench's module name.
pub const TOP: &str = "ercube_readout_cosim";

/// A sink keeping what the readout starts from and its clocks.
#[derive(Debug, Clone, Default)]
pub struct ReadoutRecord {
    /// The buffers at the readout's start.
    pub start: Option<ReadoutStart>,
    /// The readout's clocks as the model ran them.
    pub ticks: Vec<ReadoutTick>,
}

impl IssueSink for ReadoutRecord {
    fn issue(&mut self, _issue: &Issue) {}

    fn readout_begin(&mut self, start: &ReadoutStart) {
        self.start = Some(start.clone());
    }

    fn readout_tick(&mut self, tick: &ReadoutTick) {
        self.ticks.push(tick.clone());
    }
}

/// Two captures fed the same frame.
pub struct Tee(pub Capture, pub Capture);

impl Tee {
    /// `a` and `b` as one capture.
    pub fn capture(a: Capture, b: Capture) -> Capture {
        Arc::new(std::sync::Mutex::new(Tee(a, b)))
    }

    fn each(&self, mut f: impl FnMut(&mut dyn IssueSink)) {
        for c in [&self.0, &self.1] {
            f(&mut *c.lock().unwrap_or_else(|e| e.into_inner()));
        }
    }
}

impl IssueSink for Tee {
    fn begin(&mut self, dp: &Datapath) {
        self.each(|s| s.begin(dp));
    }
    fn issue(&mut self, issue: &Issue) {
        self.each(|s| s.issue(issue));
    }
    fn readout_begin(&mut self, start: &ReadoutStart) {
        self.each(|s| s.readout_begin(start));
    }
    fn readout_tick(&mut self, tick: &ReadoutTick) {
        self.each(|s| s.readout_tick(tick));
    }
    fn split_pass(&mut self, pass: &crate::cosim::split::SplitCapture) {
        self.each(|s| s.split_pass(pass));
    }
    fn merge_pass(&mut self, pass: &crate::cosim::merge::MergeCapture) {
        self.each(|s| s.merge_pass(pass));
    }
    fn fold_pass(&mut self, pass: &crate::cosim::fold::FoldCapture) {
        self.each(|s| s.fold_pass(pass));
    }
}

/// A readout stage simulated and compared.
#[derive(Debug, Clone)]
pub struct StageRun {
    /// What the simulation reported, the host's baseplane assembled.
    pub outcome: ReadoutOutcome,
    /// Raw words compared with the model's final ones, how many differ,
    /// and the first that does (`x`, `y`, model, RTL).
    pub raw: RawCompare,
    /// The model's readout clocks.
    pub model_ticks: u64,
    /// The build.
    pub built: super::build::Built,
    /// Seconds the simulation ran.
    pub run_s: f64,
    /// Lines of Verilog: the PE module, the array, the testbench.
    pub lines: [usize; 3],
}

impl StageRun {
    /// Every way the run failed, most telling first: mismatches on the
    /// ports, raw words that differ, clocks or words missing.
    pub fn problems(&self) -> Vec<String> {
        let o = &self.outcome;
        let mut v = Vec::new();
        match &o.first {
            Some(m) => v.push(format!(
                "readout: {} mismatches; the first: {m}",
                o.mismatches()
            )),
            None if o.mismatches() > 0 => v.push(format!("readout: {} mismatches", o.mismatches())),
            None => {}
        }
        if let (_, n, Some((x, y, m, r))) = self.raw {
            v.push(format!(
                "readout: {n} raw words differ; the first at x {x}, y {y}: model {m:?}, RTL {r:?}"
            ));
        }
        if o.ticks != self.model_ticks {
            v.push(format!(
                "readout: the RTL ran {} clocks of the model's {}",
                o.ticks, self.model_ticks
            ));
        }
        v.extend(o.errors.iter().map(|e| format!("readout: {e}")));
        v
    }
}

/// Builds the readout stage (`pe`, the PE module's text, possibly a
/// modified copy of `rtl.pe`) with `sim` under `cache`, runs it in `dir`
/// on the model's readout (`start`, `ticks`) and compares the host's
/// baseplane with `model_raw`.
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    rtl: &crate::hw::readout_rtl::ReadoutRtl,
    pe: &str,
    start: &ReadoutStart,
    ticks: &[ReadoutTick],
    model_raw: &[[i64; 4]],
    sim: super::build::Simulator,
    cache: &Path,
    dir: &Path,
    vcd: bool,
) -> Result<StageRun, String> {
    use crate::hw::readout_rtl::PE_MODULE;
    let shape = &rtl.shape;
    write_files(shape, start, ticks, dir)?;
    let tb = testbench(shape);
    let sources = [
        (format!("{PE_MODULE}.v"), pe),
        (format!("{ARRAY_MODULE}.v"), rtl.array.as_str()),
        (format!("{TOP}.v"), tb.as_str()),
    ];
    let sources: Vec<(&str, &str)> = sources.iter().map(|(n, t)| (n.as_str(), *t)).collect();
    let built = super::build::build(sim, cache, &sources, TOP, vcd).map_err(|e| e.to_string())?;
    let mut args = vec![
        format!("+ticks={}", ticks.len()),
        format!("+first={}", start.cycle),
    ];
    if vcd {
        args.push("+vcd".into());
    }
    let (text, run_s) = super::build::run(&built, dir, &args).map_err(|e| e.to_string())?;
    let outcome = parse(shape, start, &text);
    let raw = compare_raw(model_raw, &outcome.raw, start.size[0]);
    Ok(StageRun {
        outcome,
        raw,
        model_ticks: ticks.len() as u64,
        built,
        run_s,
        lines: [
            pe.lines().count(),
            rtl.array.lines().count(),
            tb.lines().count(),
        ],
    })
}
