//! The co-simulation's merge stage: every dense merge of a back-to-front
//! frame as the model ran it, each PE's pass broadcast, held parents and
//! neighbours' edge rays replayed into one emitted `ercube_pe_merge` per
//! PE ([`crate::hw::merge_rtl`]) and every clock's line-buffer write and
//! child word compared with the model's. The run, its vector file and
//! testbench are [`crate::cosim::pass`]'s; here are the merge's capture
//! and its ports.
//!
//! The held parents come from the model (`h0_*` .. `h2_*`: its held
//! columns' words, zero for a column it does not hold) and so do the edge
//! rays (`el_*`, `er_*`: what the links carried that clock, as
//! [`crate::stages::merge`] read them): the compositing buffer's read and
//! the links are not in the module; which of them a parent is, the module
//! picks.

use golden::geometry::View;

use crate::array::StageCycles;
use crate::config::PipelineConfig;
use crate::cosim::capture::Capture;
use crate::cosim::pass::testbench::{acc_words, broadcast, hex, line_words, Bench};
use crate::cosim::pass::{PassDims, PassKind, PassOutcome, PassRecord, PassRun};
use crate::cost::inventory::Geometry;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::hw::merge_rtl::{self, MergeShape, MODULE};
use crate::rtl::RtlError;

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

/// Hands a finished pass to the frame's capture.
pub(crate) fn captured(capture: &Capture, pass: &MergeCapture) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .merge_pass(pass);
}

/// The merge as a boundary pass.
#[derive(Debug, Clone, Copy, Default)]
pub struct Merge;

/// A sink keeping a frame's merge passes.
pub type MergeRecord = PassRecord<Merge>;
/// What the merge's simulation printed, read back.
pub type MergeOutcome = PassOutcome;
/// The merge stage simulated and compared.
pub type MergeRun = PassRun<Merge>;

impl PassKind for Merge {
    const STAGE: &'static str = "merge";
    const PREFIX: &'static str = "M";
    const MODULE: &'static str = MODULE;
    const TOP: &'static str = TOP;
    type Shape = MergeShape;
    type Capture = MergeCapture;
    type Tick = MergeTick;

    fn shape(cfg: &PipelineConfig, geo: &Geometry) -> Result<MergeShape, String> {
        MergeShape::new(cfg, geo)
    }

    fn shape_for_view(cfg: &PipelineConfig, view: &View) -> Result<MergeShape, String> {
        MergeShape::for_view(cfg, view)
    }

    fn emit(cfg: &PipelineConfig, shape: &MergeShape) -> Result<String, RtlError> {
        merge_rtl::emit(cfg, shape)
    }

    fn cycles(stages: &StageCycles) -> u64 {
        stages.merge
    }

    fn dims(s: &MergeShape) -> PassDims {
        PassDims {
            pes: s.pes,
            acc: s.acc,
            merge: s.merge,
            width: s.width,
            col_bits: s.col_bits(),
            row_bits: s.row_bits(),
            rows: s.rows,
            memory_bits: s.memory_bits(),
            register_bits: s.register_bits(),
        }
    }

    fn header(p: &MergeCapture) -> (u64, (i64, usize, i64), Vec<usize>) {
        (p.first, p.grids, p.children.iter().map(|c| c.0).collect())
    }

    fn child_line(p: &MergeCapture, k: usize) -> String {
        let (n, m0, lo, hi) = p.children[k];
        let ib = RAY_INDEX_BITS;
        format!("{n:x} {} {} {}", hex(m0, ib), hex(lo, ib), hex(hi, ib))
    }

    fn ticks(p: &MergeCapture) -> &[Vec<MergeTick>] {
        &p.ticks
    }

    fn tick_fields(d: &PassDims, e: &MergeTick) -> Vec<String> {
        let mut f = broadcast(e.x, e.y, e.col);
        for w in e.held.iter().chain(&e.edges) {
            acc_words(&mut f, d, w);
        }
        line_words(&mut f, d, e.line);
        f.push(hex(i64::from(e.child.is_some()), 1));
        acc_words(&mut f, d, &e.child.unwrap_or_default());
        f
    }

    fn writes(t: &MergeTick) -> (bool, bool) {
        (t.line.is_some(), t.child.is_some())
    }

    fn bench() -> Bench {
        Bench {
            parents: &["h0", "h1", "h2", "el", "er"],
            done: false,
            begin: "begin_merge",
            broadcast: "BeginMerge",
            per_pe: &["m0", "lo", "hi"],
            grids: ["bg_lo", "bg_rows", "fg_lo"],
            ports_a_line: 2,
            merge_parents: &[],
            merge_child: false,
        }
    }
}
