//! The co-simulation's merge stage: every dense merge of a back-to-front
//! frame as the model ran it, each PE's pass broadcast, held parents and
//! neighbours' edge rays replayed into one emitted `ercube_pe_merge` per
//! PE ([`crate::hw::merge_rtl`]) and every clock's line-buffer write and
//! child word compared with the model's.
//!
//! The held parents come from the model (`h0_*` .. `h2_*`: its held
//! columns' words, zero for a column it does not hold) and so do the edge
//! rays (`el_*`, `er_*`: what the links carried that clock, as
//! [`crate::stages::merge`] read them): the compositing buffer's read and
//! the links are not in the module; which of them a parent is, the module
//! picks.

use std::path::Path;

use crate::cosim::capture::{Capture, IssueSink};
use crate::cosim::outcome::Mismatch;
use crate::cosim::replay::parse_hex;
use crate::hw::merge_rtl::{MergeShape, MODULE};

mod testbench;

pub use testbench::{testbench, write_files};

/// The generated testbench's module name.
pub const TOP: &str = "ercube_merge_cosim";

/// One PE in one clock of a merge: the broadcast, the parents it read and
/// what it wrote.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MergeTick {
    /// The parent row the x pass filters.
    pub x: Option<usize>,
    /// The child row the y pass writes.
    pub y: Option<usize>,
    /// The child column.
    pub col: usize,
    /// The x pass's three parents as the held columns give them (zero for
    /// a column not held, and when it filters nothing here).
    pub held: [[i64; 4]; 3],
    /// The left and right neighbours' edge rays on the links.
    pub edges: [[i64; 4]; 2],
    /// The x pass's merge words written to the line buffer.
    pub line: Option<[i64; 4]>,
    /// The y pass's child word.
    pub child: Option<[i64; 4]>,
}

/// One merge pass as the model ran it.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MergeCapture {
    /// The frame's cycle of the pass's first clock.
    pub first: u64,
    /// The back grid's first row and rows, the front grid's first row.
    pub grids: (i64, usize, i64),
    /// Each PE's child count (its `BeginMerge` report), first child and
    /// held span (first and last column; zeros when it holds none).
    pub children: Vec<(usize, i64, i64, i64)>,
    /// The clocks, each PE's in index order.
    pub ticks: Vec<Vec<MergeTick>>,
}

/// A sink keeping a frame's merge passes.
#[derive(Debug, Clone, Default)]
pub struct MergeRecord {
    /// The passes, in the frame's order.
    pub passes: Vec<MergeCapture>,
}

impl IssueSink for MergeRecord {
    fn issue(&mut self, _issue: &crate::cosim::capture::Issue) {}

    fn merge_pass(&mut self, pass: &MergeCapture) {
        self.passes.push(pass.clone());
    }
}

/// Hands a finished pass to the frame's capture.
pub(crate) fn captured(capture: &Capture, pass: &MergeCapture) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .merge_pass(pass);
}

/// What the merge's simulation printed, read back.
#[derive(Debug, Clone, Default)]
pub struct MergeOutcome {
    /// Clocks simulated (over every pass).
    pub ticks: u64,
    /// Per PE: line-buffer writes and child words compared, mismatches.
    pub pes: Vec<(u64, u64, u64)>,
    /// The earliest mismatch (by cycle, then PE).
    pub first: Option<Mismatch>,
    /// Lines that say something went wrong.
    pub errors: Vec<String>,
}

impl MergeOutcome {
    /// Mismatches over every PE.
    pub fn mismatches(&self) -> u64 {
        self.pes.iter().map(|p| p.2).sum()
    }
    /// Line-buffer writes and child words compared, over every PE.
    pub fn compared(&self) -> (u64, u64) {
        self.pes.iter().fold((0, 0), |(a, b), p| (a + p.0, b + p.1))
    }
}

/// Reads what the merge testbench printed.
pub fn parse(shape: &MergeShape, text: &str) -> MergeOutcome {
    let mut o = MergeOutcome {
        pes: vec![(0, 0, 0); shape.pes],
        ..MergeOutcome::default()
    };
    let mb = u32::from(shape.merge.bits());
    let mut seen = vec![false; shape.pes];
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            ["MTICKS", n] => o.ticks = n.parse().unwrap_or(0),
            ["MPE", k, lines, words, mism] => {
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
            ["MMISMATCH", cycle, pe, signal, model, rtl] => {
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
        o.errors.push(format!("merge PE {k} reported nothing"));
    }
    o
}

/// The merge stage simulated and compared.
#[derive(Debug, Clone)]
pub struct MergeRun {
    /// What the simulation reported.
    pub outcome: MergeOutcome,
    /// The model's merge clocks (over every pass).
    pub model_ticks: u64,
    /// Merge passes replayed.
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

impl MergeRun {
    /// Every way the run failed: mismatches, clocks or words missing.
    pub fn problems(&self) -> Vec<String> {
        let o = &self.outcome;
        let mut v = Vec::new();
        match &o.first {
            Some(m) => v.push(format!(
                "merge: {} mismatches; the first: {m}",
                o.mismatches()
            )),
            None if o.mismatches() > 0 => v.push(format!("merge: {} mismatches", o.mismatches())),
            None => {}
        }
        if o.ticks != self.model_ticks {
            v.push(format!(
                "merge: the RTL ran {} clocks of the model's {}",
                o.ticks, self.model_ticks
            ));
        }
        if o.compared() != self.model_writes {
            v.push(format!(
                "merge: the RTL compared {:?} line-buffer writes and child words of the model's {:?}",
                o.compared(),
                self.model_writes
            ));
        }
        v.extend(o.errors.iter().map(|e| format!("merge: {e}")));
        v
    }
}

/// Builds the merge module (`module`, its text, possibly a modified copy
/// of the emitted one) with `sim` under `cache`, and runs it in `dir` on
/// the model's passes.
pub fn simulate(
    shape: &MergeShape,
    module: &str,
    passes: &[MergeCapture],
    sim: super::build::Simulator,
    cache: &Path,
    dir: &Path,
) -> Result<MergeRun, String> {
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
    Ok(MergeRun {
        outcome,
        model_ticks: ticks,
        passes: passes.len(),
        model_writes,
        built,
        run_s,
        lines: [module.lines().count(), tb.lines().count()],
    })
}
