//! The dense merge of [`super::merge`] with each PE's clocks recorded for
//! the co-simulation ([`crate::cosim::merge`]), run only when the frame
//! carries a capture: the broadcast, the held parents and edge rays the
//! x pass reads, and what both passes write. The same clocks (through
//! [`Array::run_pass`]) and the same words as the uncaptured merge.

use golden::geometry::RayGrid;

use super::boundary::{Edges, OnPassBus, PassStep};
use super::merge::MergePass;
use super::passes::PassBus;
use super::Step;
use crate::array::{Array, Links, RunError};
use crate::cosim::capture::Capture;
use crate::cosim::merge::{MergeCapture, MergeTick};
use crate::datapath::Datapath;
use crate::pe::{Broadcast, Pe, Ports, StepError};
use crate::probes::{Ctrl, Stage};

impl Pe {
    /// Held column `mx`'s accumulator words at `row`, zero for a column
    /// this PE does not hold (what the compositing buffer's read gives the
    /// emitted merge; the module picks the edge rays itself).
    fn held_word(&self, mx: i64, row: usize) -> [i64; 4] {
        match self.span() {
            Some((lo, hi)) if (lo..=hi).contains(&mx) => self.rays[(mx - lo) as usize].acc[row].raw,
            _ => [0; 4],
        }
    }

    /// What this PE's pass wrote in a clock of `bus`: the x pass's
    /// line-buffer word and the y pass's child word (the merge's and the
    /// fold's captures).
    pub(super) fn pass_writes(&self, bus: &PassBus) -> (Option<[i64; 4]>, Option<[i64; 4]>) {
        let c = bus.col;
        let here = c < self.pass.children.len();
        let line = bus
            .x
            .filter(|_| here)
            .and_then(|q| self.pass.line.read(self.k, q, c).ok());
        let child = bus.y.filter(|_| here).map(|i| self.pass.next[c].acc[i].raw);
        (line, child)
    }

    /// This PE's child count, first child and held span (zeros when it
    /// holds none), as its pass latches them.
    pub(super) fn pass_children(&self) -> (usize, i64, i64, i64) {
        let (lo, hi) = self.span().unwrap_or((0, 0));
        let m0 = self.pass.children.first().copied().unwrap_or(0);
        (self.pass.children.len(), m0, lo, hi)
    }
}

/// The dense merge's step ([`PassStep`] of [`MergePass`], twin of
/// [`golden::merge::merge`]) recording, per PE, one [`MergeTick`] a
/// cycle: the bus, the held parents and edge rays the x pass reads and
/// what both passes write.
struct CapturedMerge<'a> {
    step: PassStep<'a, MergePass<'a>>,
    /// Each PE's children, first child and held span.
    children: &'a mut [(usize, i64, i64, i64)],
    per_pe: Vec<Vec<MergeTick>>,
}

impl Step for CapturedMerge<'_> {
    fn ctrl(&self) -> Ctrl {
        self.step.ctrl()
    }

    fn step(&mut self, pe: &mut Pe, links: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        let bus = *self.step.bus();
        let (c, n) = (bus.col, pe.pass.children.len());
        let e = Edges::on(&links);
        let mut t = MergeTick {
            x: bus.x,
            y: bus.y,
            col: c,
            edges: [e.left.0.raw, e.right.0.raw],
            ..MergeTick::default()
        };
        if let Some(q) = bus.x.filter(|_| c < n) {
            let m = pe.pass.children[c];
            t.held = [2 * m - 1, 2 * m, 2 * m + 1].map(|mx| pe.held_word(mx, q));
        }
        self.step.step(pe, links, out)?;
        (t.line, t.child) = pe.pass_writes(&bus);
        self.children[pe.k] = pe.pass_children();
        self.per_pe[pe.k].push(t);
        Ok(())
    }
}

impl OnPassBus for CapturedMerge<'_> {
    fn show(&mut self, bus: PassBus, row: usize) {
        self.step.show(bus, row);
    }
}

impl Array {
    /// [`Array::merge`]'s dense pass with every PE's clocks recorded and
    /// handed to `capture` after the pass.
    pub(super) fn merge_captured(
        &mut self,
        capture: &Capture,
        dp: &Datapath,
        (bg, fg): (&RayGrid, &RayGrid),
        (prows, needs): (usize, &[Option<(usize, usize)>]),
    ) -> Result<(), RunError> {
        let p = self.clock.pes().len();
        let mut rec = MergeCapture {
            first: self.clock.now(),
            grids: (bg.lo[1], prows, fg.lo[1]),
            children: vec![(0, 0, 0, 0); p],
            ticks: Vec::new(),
        };
        let mut step = CapturedMerge {
            step: PassStep::new(Stage::Merge, MergePass { bg, fg }, dp, false),
            children: &mut rec.children,
            per_pe: vec![Vec::new(); p],
        };
        self.run_pass(
            (prows, needs),
            Broadcast::BeginMerge {
                back: bg,
                front: fg,
            },
            &mut step,
            Broadcast::EndMerge,
        )?;
        rec.ticks = crate::cosim::pass::by_clock(&step.per_pe);
        crate::cosim::merge::captured(capture, &rec);
        Ok(())
    }
}
