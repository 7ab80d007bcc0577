//! The co-simulation's split stage: every dense split of a front-to-back
//! frame as the model ran it, each PE's pass broadcast and parents
//! replayed into one emitted `ercube_pe_split` per PE
//! ([`crate::hw::split_rtl`]) and every clock's line-buffer write and
//! child word (with its termination flag) compared with the model's.
//!
//! The parents come from the model (`a_*`, `b_*`: its held columns and
//! the right neighbour's edge ray, as [`crate::stages::split`] fetched
//! them): the compositing buffer's read and the links are not in the
//! module.

use std::path::Path;

use crate::cosim::capture::{Capture, IssueSink};
use crate::cosim::outcome::Mismatch;
use crate::cosim::replay::parse_hex;
use crate::hw::split_rtl::{SplitShape, MODULE};

mod testbench;

pub use testbench::{testbench, write_files};

/// The generated testbench's module name.
pub const TOP: &str = "ercube_split_cosim";

/// One PE in one clock of a split: the broadcast, the parents it read and
/// what it wrote.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SplitTick {
    /// The parent row the x pass filters.
    pub x: Option<usize>,
    /// The child row the y pass writes.
    pub y: Option<usize>,
    /// The child column.
    pub col: usize,
    /// The x pass's two parents (zero when it filters nothing here).
    pub parents: [[i64; 4]; 2],
    /// The x pass's merge words written to the line buffer.
    pub line: Option<[i64; 4]>,
    /// The y pass's child word and termination flag.
    pub child: Option<([i64; 4], bool)>,
}

/// One split pass as the model ran it.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SplitCapture {
    /// The frame's cycle of the pass's first clock.
    pub first: u64,
    /// The front grid's first row and rows, the back grid's first row.
    pub grids: (i64, usize, i64),
    /// Each PE's child count (its `BeginSplit` report).
    pub children: Vec<usize>,
    /// The clocks, each PE's in index order.
    pub ticks: Vec<Vec<SplitTick>>,
}

/// A sink keeping a frame's split passes.
#[derive(Debug, Clone, Default)]
pub struct SplitRecord {
    /// The passes, in the frame's order.
    pub passes: Vec<SplitCapture>,
}

impl IssueSink for SplitRecord {
    fn issue(&mut self, _issue: &crate::cosim::capture::Issue) {}

    fn split_pass(&mut self, pass: &SplitCapture) {
        self.passes.push(pass.clone());
    }
}

/// Hands a finished pass to the frame's capture.
pub(crate) fn captured(capture: &Capture, pass: &SplitCapture) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .split_pass(pass);
}

/// What the split's simulation printed, read back.
#[derive(Debug, Clone, Default)]
pub struct SplitOutcome {
    /// Clocks simulated (over every pass).
    pub ticks: u64,
    /// Per PE: line-buffer writes and child words compared, mismatches.
    pub pes: Vec<(u64, u64, u64)>,
    /// The earliest mismatch (by cycle, then PE).
    pub first: Option<Mismatch>,
    /// Lines that say something went wrong.
    pub errors: Vec<String>,
}

impl SplitOutcome {
    /// Mismatches over every PE.
    pub fn mismatches(&self) -> u64 {
        self.pes.iter().map(|p| p.2).sum()
    }
    /// Line-buffer writes and child words compared, over every PE.
    pub fn compared(&self) -> (u64, u64) {
        self.pes.iter().fold((0, 0), |(a, b), p| (a + p.0, b + p.1))
    }
}

/// Reads what the split testbench printed.
pub fn parse(shape: &SplitShape, text: &str) -> SplitOutcome {
    let mut o = SplitOutcome {
        pes: vec![(0, 0, 0); shape.pes],
        ..SplitOutcome::default()
    };
    let mb = u32::from(shape.merge.bits());
    let mut seen = vec![false; shape.pes];
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            ["STICKS", n] => o.ticks = n.parse().unwrap_or(0),
            ["SPE", k, lines, words, mism] => {
                match k.parse::<usize>().ok().filter(|&k| k < shape.pes) {
                    Some(k) => {
                        seen[k] = true;
                        o.pes[k] = (
                            lines.parse().unwrap_or(0),
                            words.parse().unwrap_or(0),
                            mism.parse().unwrap_or(u64::MAX),
                        );
                    }
                    None => o.errors.push(line.to_owned()),
                }
            }
            ["SMISMATCH", cycle, pe, signal, model, rtl] => {
                let dec = |sig: &str, hex: &str| {
                    let (bits, signed) = match sig.split_once('_') {
                        Some(("lx", _)) => (mb, shape.merge.is_signed()),
                        Some(("w", "a")) => {
                            (u32::from(shape.acc[1].bits()), shape.acc[1].is_signed())
                        }
                        Some(("w", "r" | "g" | "b")) => {
                            (u32::from(shape.acc[0].bits()), shape.acc[0].is_signed())
                        }
                        _ => (1, false),
                    };
                    parse_hex(hex, bits, signed).map_or(hex.to_owned(), |v| v.to_string())
                };
                Mismatch::from_fields([cycle, pe, signal, model, rtl], dec)
                    .keep_earliest(&mut o.first);
            }
            ["ERROR", ..] => o.errors.push(line.to_owned()),
            _ => {}
        }
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        o.errors.push(format!("split PE {k} reported nothing"));
    }
    o
}

/// The split stage simulated and compared.
#[derive(Debug, Clone)]
pub struct SplitRun {
    /// What the simulation reported.
    pub outcome: SplitOutcome,
    /// The model's split clocks (over every pass) and passes.
    pub model_ticks: u64,
    /// Split passes replayed.
    pub passes: usize,
    /// The model's line-buffer writes and child words.
    pub model_writes: (u64, u64),
    /// The build.
    pub built: super::build::Built,
    /// Seconds the simulation ran.
    pub run_s: f64,
    /// Lines of Verilog: the module, the testbench.
    pub lines: [usize; 2],
}

impl SplitRun {
    /// Every way the run failed: mismatches, clocks or words missing.
    pub fn problems(&self) -> Vec<String> {
        let o = &self.outcome;
        let mut v = Vec::new();
        match &o.first {
            Some(m) => v.push(format!(
                "split: {} mismatches; the first: {m}",
                o.mismatches()
            )),
            None if o.mismatches() > 0 => v.push(format!("split: {} mismatches", o.mismatches())),
            None => {}
        }
        if o.ticks != self.model_ticks {
            v.push(format!(
                "split: the RTL ran {} clocks of the model's {}",
                o.ticks, self.model_ticks
            ));
        }
        if o.compared() != self.model_writes {
            v.push(format!(
                "split: the RTL compared {:?} line-buffer writes and child words of the model's {:?}",
                o.compared(),
                self.model_writes
            ));
        }
        v.extend(o.errors.iter().map(|e| format!("split: {e}")));
        v
    }
}

/// Builds the split module (`module`, its text, possibly a modified copy
/// of the emitted one) with `sim` under `cache`, and runs it in `dir` on
/// the model's passes.
pub fn simulate(
    shape: &SplitShape,
    module: &str,
    passes: &[SplitCapture],
    sim: super::build::Simulator,
    cache: &Path,
    dir: &Path,
) -> Result<SplitRun, String> {
    let ticks = write_files(shape, passes, dir)?;
    let tb = testbench(shape);
    let sources = [
        (format!("{MODULE}.v"), module),
        (format!("{TOP}.v"), tb.as_str()),
    ];
    let sources: Vec<(&str, &str)> = sources.iter().map(|(n, t)| (n.as_str(), *t)).collect();
    let built = super::build::build(sim, cache, &sources, TOP, false).map_err(|e| e.to_string())?;
    let args = vec![format!("+passes={}", passes.len())];
    let (text, run_s) = super::build::run(&built, dir, &args).map_err(|e| e.to_string())?;
    let outcome = parse(shape, &text);
    let each = passes.iter().flat_map(|p| p.ticks.iter().flatten());
    let model_writes = each.fold((0, 0), |(a, b), t| {
        (
            a + u64::from(t.line.is_some()),
            b + u64::from(t.child.is_some()),
        )
    });
    Ok(SplitRun {
        outcome,
        model_ticks: ticks,
        passes: passes.len(),
        model_writes,
        built,
        run_s,
        lines: [module.lines().count(), tb.lines().count()],
    })
}
