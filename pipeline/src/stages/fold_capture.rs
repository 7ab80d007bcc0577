//! The dense fold of [`super::fold`] with each PE's clocks recorded for
//! the co-simulation ([`crate::cosim::fold`]), run only when the frame
//! carries a capture: the broadcast, the held results and inherited
//! states and the left edge difference the x pass reads, the kept final
//! state the y pass adds, and what both passes write. The same clocks
//! (through [`Array::run_pass`]) and the same words as the uncaptured
//! fold.

use super::boundary::{Edges, OnPassBus, PassStep};
use super::fold::FoldGrids;
use super::passes::{tent_needs, PassBus};
use super::Step;
use crate::array::{Array, Links, RunError};
use crate::cosim::capture::Capture;
use crate::cosim::fold::{FoldCapture, FoldTick};
use crate::datapath::Datapath;
use crate::pe::{Broadcast, Pe, Ports, StepError};
use crate::probes::{Ctrl, Stage};

impl Pe {
    /// Held back column `mx`'s result at `row` shifted left by `shift`
    /// (the compositing buffer's read into `merge` words) and its
    /// inherited state, zeros for a column this PE does not hold.
    fn fold_word(&self, mx: i64, row: usize, shift: [u32; 4]) -> ([i64; 4], [i64; 4]) {
        match self.span() {
            Some((lo, hi)) if (lo..=hi).contains(&mx) => {
                let c = &self.rays[(mx - lo) as usize];
                let r = c.acc[row].raw;
                let res = [0, 1, 2, 3].map(|ch| r[ch] << shift[ch]);
                (res, c.ftb[row].inh.raw)
            }
            _ => ([0; 4], [0; 4]),
        }
    }
}

/// The dense fold's step ([`PassStep`] of [`FoldGrids`]) recording, per
/// PE, one [`FoldTick`] a cycle.
struct CapturedFold<'a> {
    step: PassStep<'a, FoldGrids<'a>>,
    /// The shift of each channel's result into a `merge` word.
    shift: [u32; 4],
    /// Each PE's children, first child and held span.
    children: &'a mut [(usize, i64, i64, i64)],
    per_pe: Vec<Vec<FoldTick>>,
}

impl Step for CapturedFold<'_> {
    fn ctrl(&self) -> Ctrl {
        self.step.ctrl()
    }

    fn step(&mut self, pe: &mut Pe, links: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        let bus = *self.step.bus();
        let (c, n) = (bus.col, pe.pass.children.len());
        let e = Edges::on(&links);
        let mut t = FoldTick {
            x: bus.x,
            y: bus.y,
            col: c,
            edge: e.left.0.raw,
            ..FoldTick::default()
        };
        if let Some(q) = bus.x.filter(|_| c < n) {
            let m = pe.pass.children[c];
            for (k, mx) in [2 * m - 1, 2 * m, 2 * m + 1].into_iter().enumerate() {
                (t.result[k], t.inherited[k]) = pe.fold_word(mx, q, self.shift);
            }
        }
        if let Some(i) = bus.y.filter(|_| c < n) {
            t.kept = pe.finals.last().map_or([0; 4], |f| f[c].acc[i].raw);
        }
        self.step.step(pe, links, out)?;
        (t.line, t.child) = pe.pass_writes(&bus);
        self.children[pe.k] = pe.pass_children();
        self.per_pe[pe.k].push(t);
        Ok(())
    }
}

impl OnPassBus for CapturedFold<'_> {
    fn show(&mut self, bus: PassBus, row: usize) {
        self.step.show(bus, row);
    }
}

impl Array {
    /// [`Array::fold`]'s dense pass with every PE's clocks recorded and
    /// handed to `capture` after the pass.
    pub(super) fn fold_captured(
        &mut self,
        capture: &Capture,
        dp: &Datapath,
        g: FoldGrids,
    ) -> Result<(), RunError> {
        let p = self.clock.pes().len();
        let prows = g.back.counts()[1];
        let needs = tent_needs(g.front, g.back);
        let mf = dp.cfg.merge.frac();
        let shift = [0, 1, 2, 3].map(|ch| u32::from(mf - g.rf[usize::from(ch == 3)].frac()));
        let mut rec = FoldCapture {
            first: self.clock.now(),
            grids: (g.back.lo[1], prows, g.front.lo[1]),
            children: vec![(0, 0, 0, 0); p],
            ticks: Vec::new(),
        };
        let mut step = CapturedFold {
            step: PassStep::new(Stage::Fold, g, dp, false),
            shift,
            children: &mut rec.children,
            per_pe: vec![Vec::new(); p],
        };
        self.run_pass(
            (prows, &needs),
            Broadcast::BeginFold { front: g.front },
            &mut step,
            Broadcast::EndFold,
        )?;
        rec.ticks = crate::cosim::pass::by_clock(&step.per_pe);
        crate::cosim::fold::captured(capture, &rec);
        Ok(())
    }
}
