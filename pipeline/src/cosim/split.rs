//! The co-simulation's split stage: every dense split of a front-to-back
//! frame as the model ran it, each PE's pass broadcast and parents
//! replayed into one emitted `ercube_pe_split` per PE
//! ([`crate::hw::split_rtl`]) and every clock's line-buffer write and
//! child word (with its termination flag) compared with the model's.
//! The run, its vector file and testbench are [`crate::cosim::pass`]'s;
//! here are the split's capture and its ports.
//!
//! The parents come from the model (`a_*`, `b_*`: its held columns and
//! the right neighbour's edge ray, as [`crate::stages::split`] fetched
//! them): the compositing buffer's read and the links are not in the
//! module.

use golden::geometry::View;

use crate::array::StageCycles;
use crate::config::PipelineConfig;
use crate::cosim::capture::Capture;
use crate::cosim::pass::testbench::{acc_words, broadcast, hex, line_words, Bench};
use crate::cosim::pass::{PassDims, PassKind, PassOutcome, PassRecord, PassRun};
use crate::cost::inventory::Geometry;
use crate::hw::split_rtl::{self, SplitShape, MODULE};
use crate::rtl::RtlError;

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

/// Hands a finished pass to the frame's capture.
pub(crate) fn captured(capture: &Capture, pass: &SplitCapture) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .split_pass(pass);
}

/// The split as a boundary pass.
#[derive(Debug, Clone, Copy, Default)]
pub struct Split;

/// A sink keeping a frame's split passes.
pub type SplitRecord = PassRecord<Split>;
/// What the split's simulation printed, read back.
pub type SplitOutcome = PassOutcome;
/// The split stage simulated and compared.
pub type SplitRun = PassRun<Split>;

impl PassKind for Split {
    const STAGE: &'static str = "split";
    const PREFIX: &'static str = "S";
    const MODULE: &'static str = MODULE;
    const TOP: &'static str = TOP;
    type Shape = SplitShape;
    type Capture = SplitCapture;
    type Tick = SplitTick;

    fn shape(cfg: &PipelineConfig, geo: &Geometry) -> Result<SplitShape, String> {
        SplitShape::new(cfg, geo)
    }

    fn shape_for_view(cfg: &PipelineConfig, view: &View) -> Result<SplitShape, String> {
        SplitShape::for_view(cfg, view)
    }

    fn emit(cfg: &PipelineConfig, shape: &SplitShape) -> Result<String, RtlError> {
        split_rtl::emit(cfg, shape)
    }

    fn cycles(stages: &StageCycles) -> u64 {
        stages.split
    }

    fn dims(s: &SplitShape) -> PassDims {
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

    fn header(p: &SplitCapture) -> (u64, (i64, usize, i64), Vec<usize>) {
        (p.first, p.grids, p.children.clone())
    }

    fn child_line(p: &SplitCapture, k: usize) -> String {
        format!("{:x}", p.children[k])
    }

    fn ticks(p: &SplitCapture) -> &[Vec<SplitTick>] {
        &p.ticks
    }

    fn tick_fields(d: &PassDims, e: &SplitTick) -> Vec<String> {
        let mut f = broadcast(e.x, e.y, e.col);
        for w in &e.parents {
            acc_words(&mut f, d, w);
        }
        line_words(&mut f, d, e.line);
        let (child, done) = e.child.unwrap_or_default();
        f.push(hex(i64::from(e.child.is_some()), 1));
        acc_words(&mut f, d, &child);
        f.push(hex(i64::from(done), 1));
        f
    }

    fn writes(t: &SplitTick) -> (bool, bool) {
        (t.line.is_some(), t.child.is_some())
    }

    fn bench() -> Bench {
        Bench {
            parents: &["a", "b"],
            done: true,
            begin: "begin_split",
            broadcast: "BeginSplit",
            per_pe: &[],
            grids: ["fg_lo", "fg_rows", "bg_lo"],
            ports_a_line: 3,
            merge_parents: &[],
            merge_child: false,
        }
    }
}
