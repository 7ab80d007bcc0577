//! The co-simulation's fold stage: every dense fold of a front-to-back
//! frame as the model ran it, each PE's pass broadcast, held results and
//! inherited states, left edge differences and kept final states
//! replayed into one emitted `ercube_pe_fold` per PE
//! ([`crate::hw::fold_rtl`]) and every clock's line-buffer write and
//! child word compared with the model's. The run, its vector file and
//! testbench are [`crate::cosim::pass`]'s; here are the fold's capture
//! and its ports.
//!
//! From the model come the held results (`h0_*` .. `h2_*`: its held
//! columns' result words as `merge` words, the deepest boundary's
//! accumulator words shifted left by `merge.frac - acc.frac`; zero for a
//! column it does not hold) and inherited states (`i0_*` .. `i2_*`), the
//! left edge difference (`el_*`: what the link carried that clock, as
//! [`crate::stages::fold`] read it) and the kept final state (`f_*`):
//! the compositing buffer's and ray buffer's reads and the link are not
//! in the module; which of them a tap is, the module picks, and it forms
//! the differences, tents and adds itself.

use golden::geometry::View;

use crate::array::StageCycles;
use crate::config::PipelineConfig;
use crate::cosim::capture::Capture;
use crate::cosim::pass::testbench::{acc_words, broadcast, hex, line_words, merge_words, Bench};
use crate::cosim::pass::{PassDims, PassKind, PassOutcome, PassRecord, PassRun};
use crate::cost::inventory::Geometry;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::hw::fold_rtl::{self, FoldShape, MODULE};
use crate::rtl::RtlError;

/// The generated testbench's module name.
pub const TOP: &str = "ercube_fold_cosim";

/// One PE in one clock of a fold: the broadcast, the words it read and
/// what it wrote.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FoldTick {
    /// The back row the x pass filters.
    pub x: Option<usize>,
    /// The child row the y pass writes.
    pub y: Option<usize>,
    /// The child column.
    pub col: usize,
    /// The x pass's three back columns' results as `merge` words (zero for
    /// a column not held, and when it filters nothing here).
    pub result: [[i64; 4]; 3],
    /// Their inherited states (accumulator words).
    pub inherited: [[i64; 4]; 3],
    /// The left neighbour's edge difference on the link.
    pub edge: [i64; 4],
    /// The child's kept final state in the y pass's row (zero when it
    /// writes nothing here).
    pub kept: [i64; 4],
    /// The x pass's merge words written to the line buffer.
    pub line: Option<[i64; 4]>,
    /// The y pass's child word (`merge` words).
    pub child: Option<[i64; 4]>,
}

/// One fold pass as the model ran it.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FoldCapture {
    /// The frame's cycle of the pass's first clock.
    pub first: u64,
    /// The back grid's first row and rows, the front grid's first row.
    pub grids: (i64, usize, i64),
    /// Each PE's child count (its `BeginFold` report), first child and
    /// held span (first and last back column; zeros when it holds none).
    pub children: Vec<(usize, i64, i64, i64)>,
    /// The clocks, each PE's in index order.
    pub ticks: Vec<Vec<FoldTick>>,
}

/// Hands a finished pass to the frame's capture.
pub(crate) fn captured(capture: &Capture, pass: &FoldCapture) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .fold_pass(pass);
}

/// The fold as a boundary pass.
#[derive(Debug, Clone, Copy, Default)]
pub struct Fold;

/// A sink keeping a frame's fold passes.
pub type FoldRecord = PassRecord<Fold>;
/// What the fold's simulation printed, read back.
pub type FoldOutcome = PassOutcome;
/// The fold stage simulated and compared.
pub type FoldRun = PassRun<Fold>;

impl PassKind for Fold {
    const STAGE: &'static str = "fold";
    const PREFIX: &'static str = "F";
    const MODULE: &'static str = MODULE;
    const TOP: &'static str = TOP;
    type Shape = FoldShape;
    type Capture = FoldCapture;
    type Tick = FoldTick;

    fn shape(cfg: &PipelineConfig, geo: &Geometry) -> Result<FoldShape, String> {
        FoldShape::new(cfg, geo)
    }

    fn shape_for_view(cfg: &PipelineConfig, view: &View) -> Result<FoldShape, String> {
        FoldShape::for_view(cfg, view)
    }

    fn emit(cfg: &PipelineConfig, shape: &FoldShape) -> Result<String, RtlError> {
        fold_rtl::emit(cfg, shape)
    }

    fn cycles(stages: &StageCycles) -> u64 {
        stages.fold
    }

    fn dims(s: &FoldShape) -> PassDims {
        PassDims {
            register_bits: s.register_bits(),
            ..crate::cosim::merge::Merge::dims(&s.pass)
        }
    }

    fn header(p: &FoldCapture) -> (u64, (i64, usize, i64), Vec<usize>) {
        (p.first, p.grids, p.children.iter().map(|c| c.0).collect())
    }

    fn child_line(p: &FoldCapture, k: usize) -> String {
        let (n, m0, lo, hi) = p.children[k];
        let ib = RAY_INDEX_BITS;
        format!("{n:x} {} {} {}", hex(m0, ib), hex(lo, ib), hex(hi, ib))
    }

    fn ticks(p: &FoldCapture) -> &[Vec<FoldTick>] {
        &p.ticks
    }

    fn tick_fields(d: &PassDims, e: &FoldTick) -> Vec<String> {
        let mut f = broadcast(e.x, e.y, e.col);
        for w in &e.result {
            merge_words(&mut f, d, w);
        }
        for w in &e.inherited {
            acc_words(&mut f, d, w);
        }
        merge_words(&mut f, d, &e.edge);
        acc_words(&mut f, d, &e.kept);
        line_words(&mut f, d, e.line);
        f.push(hex(i64::from(e.child.is_some()), 1));
        merge_words(&mut f, d, &e.child.unwrap_or_default());
        f
    }

    fn writes(t: &FoldTick) -> (bool, bool) {
        (t.line.is_some(), t.child.is_some())
    }

    fn bench() -> Bench {
        Bench {
            parents: &["h0", "h1", "h2", "i0", "i1", "i2", "el", "f"],
            done: false,
            begin: "begin_fold",
            broadcast: "BeginFold",
            per_pe: &["m0", "lo", "hi"],
            grids: ["bg_lo", "bg_rows", "fg_lo"],
            ports_a_line: 2,
            merge_parents: &["h0", "h1", "h2", "el"],
            merge_child: true,
        }
    }
}
