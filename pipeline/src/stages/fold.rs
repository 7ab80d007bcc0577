//! Front to back: one step of the fold (after the last region, boundary by
//! boundary from the back), the fixed-point twin of the fold in
//! [`golden::methods::render`]: `result_(i-1) = final_(i-1) +
//! merge(result_i - inherited_i)`, with [`golden::merge::merge`]'s tent.
//! The back region's rays were brought to the PE that kept their split
//! parent's final state; each PE forms a row's differences as the row
//! enters the x pass (its last column's crosses the link to the right
//! neighbour, whose first child's left tap it is), filters them, and adds
//! its kept final states as the y pass writes each child. Differences,
//! merge passes and results are `merge` words. The cycles come from
//! [`super::passes`].

use golden::geometry::RayGrid;

use super::boundary::{BoundaryPass, Edges, PassStep};
use super::passes::{plan_slots, tent_needs, PassBus};
use crate::array::{Array, RunError};
use crate::datapath::{Acc, Datapath};
use crate::fixed::Format;
use crate::pe::{Broadcast, Pe, Ports, RayColumn, StepError};
use crate::probes::Stage;

/// The grids of a fold step and the formats of the back rays' results
/// (colour, opacity).
#[derive(Debug, Clone, Copy)]
pub struct FoldGrids<'a> {
    /// The back region's grid (the x pass's rows).
    pub back: &'a RayGrid,
    /// The front region's grid (the children).
    pub front: &'a RayGrid,
    /// Formats of the back results.
    pub rf: [Format; 2],
}

impl Pe {
    /// Starts a fold step: the children are the front rays whose final
    /// states this PE kept at the split. Returns how many.
    pub fn begin_fold(&mut self, front: &RayGrid) -> usize {
        let rows = front.counts()[1];
        let kept = self.finals.last().map_or(&[][..], Vec::as_slice);
        let children: Vec<i64> = kept.iter().map(|f| f.mx).collect();
        let next = kept
            .iter()
            .map(|f| RayColumn {
                ftb: f.ftb.clone(),
                ..RayColumn::empty(f.mx, rows, false)
            })
            .collect();
        self.pass.begin(children, next);
        self.pass.children.len()
    }

    /// The differences of back row `row`, result minus inherited state
    /// (results in `rf`; inherited states in the accumulators), for every
    /// held column, into `merge` words.
    fn fold_differences(&mut self, dp: &Datapath, row: usize, rf: [Format; 2]) -> Vec<[i64; 4]> {
        let (fc, fa) = (dp.cfg.accum_color, dp.cfg.accum_alpha);
        let mut line = Vec::with_capacity(self.rays.len());
        for c in &self.rays {
            let (r, h) = (c.acc[row].raw, c.ftb[row].inh.raw);
            let mut d = [0i64; 4];
            for (ch, o) in d.iter_mut().enumerate() {
                let (f, hf) = if ch < 3 { (rf[0], fc) } else { (rf[1], fa) };
                *o = dp
                    .fold_diff(r[ch], f, h[ch], hf, &mut self.model.stats)
                    .raw();
            }
            line.push(d);
        }
        line
    }

    /// The differences of back row `row` for the x pass: formed when the
    /// row's edge was driven, or now.
    fn fold_line(&mut self, dp: &Datapath, row: usize, rf: [Format; 2]) {
        if self.pass.dline.as_ref().is_some_and(|d| d.0 == row) {
            return;
        }
        if self.pass.dnext.as_ref().is_some_and(|d| d.0 == row) {
            self.pass.dline = self.pass.dnext.take();
            return;
        }
        let line = self.fold_differences(dp, row, rf);
        self.pass.dline = Some((row, line));
    }

    /// Drives this PE's last held column's difference of back row `row`,
    /// with its index, to the right neighbour, forming the row's
    /// differences if they are not formed yet.
    fn fold_drive(&mut self, dp: &Datapath, row: usize, rf: [Format; 2], out: &mut Ports) {
        let formed = |d: &Option<(usize, Vec<[i64; 4]>)>| d.as_ref().is_some_and(|d| d.0 == row);
        if !formed(&self.pass.dline) && !formed(&self.pass.dnext) {
            let line = self.fold_differences(dp, row, rf);
            self.pass.dnext = Some((row, line));
        }
        let line = [&self.pass.dline, &self.pass.dnext]
            .into_iter()
            .flatten()
            .find(|d| d.0 == row)
            .map(|d| &d.1);
        if let (Some(c), Some(d)) = (self.rays.back(), line.and_then(|l| l.last())) {
            out.right.edge_acc = Acc { raw: *d };
            out.right.edge_mx = Some(c.mx);
        }
    }

    /// A tap of the x pass, back ray `n`'s difference in the current row:
    /// held here, or the left neighbour's last column on its port, or
    /// empty outside the back rectangle `grid`.
    fn fold_tap(
        &self,
        n: i64,
        grid: (i64, i64),
        (left, left_mx): (Acc, Option<i64>),
    ) -> Result<[i64; 4], StepError> {
        if n < grid.0 || n > grid.1 {
            return Ok([0; 4]);
        }
        if let (Some((lo, hi)), Some((_, line))) = (self.span(), &self.pass.dline) {
            if (lo..=hi).contains(&n) {
                return Ok(line[(n - lo) as usize]);
            }
        }
        if left_mx == Some(n) {
            return Ok(left.raw);
        }
        Err(StepError::Unreachable { pe: self.k, mx: n })
    }

    /// Child `c`'s three taps in the current x row's differences.
    fn fold_taps(
        &self,
        c: usize,
        grid: (i64, i64),
        left: (Acc, Option<i64>),
    ) -> Result<[[i64; 4]; 3], StepError> {
        let m = self.pass.children[c];
        Ok([
            self.fold_tap(2 * m - 1, grid, left)?,
            self.fold_tap(2 * m, grid, left)?,
            self.fold_tap(2 * m + 1, grid, left)?,
        ])
    }

    /// Ends a fold step: the kept final states are spent and the results
    /// become the held columns.
    pub fn end_fold(&mut self) {
        self.finals.pop();
        let next = std::mem::take(&mut self.pass.next);
        self.set_rays(next);
    }
}

/// The fold as a [`BoundaryPass`]: the back rays' differences (result
/// minus inherited state) filtered onto the front rays and added to their
/// kept final states. A tap beyond the held span is the left neighbour's
/// edge difference, found by its index.
impl BoundaryPass for FoldGrids<'_> {
    /// Forms back row `q`'s differences (unless its drive formed them).
    fn x_row(&self, pe: &mut Pe, dp: &Datapath, q: usize) {
        pe.fold_line(dp, q, self.rf);
    }

    /// The tent of child `c`'s three taps' differences in back row `q`
    /// into the line buffer.
    fn x(
        &self,
        pe: &mut Pe,
        dp: &Datapath,
        c: usize,
        q: usize,
        edges: Edges,
    ) -> Result<(), StepError> {
        let fm = crate::reg!(dp.cfg, merge);
        let p = pe.fold_taps(c, (self.back.lo[0], self.back.hi[0]), edges.left)?;
        let mut out = [0i64; 4];
        for (ch, o) in out.iter_mut().enumerate() {
            *o = dp
                .tent([p[0][ch], p[1][ch], p[2][ch]], *fm, fm, &mut pe.model.stats)
                .raw();
        }
        pe.pass.line.write(q, c, out);
        Ok(())
    }

    /// Child `c` of front row `i`: the tent of the line buffer's back rows
    /// `2 my - 1 ..= 2 my + 1` plus the kept final state.
    fn y(
        &self,
        pe: &mut Pe,
        dp: &Datapath,
        c: usize,
        i: usize,
        sparse: bool,
    ) -> Result<(), StepError> {
        let (fc, fa) = (dp.cfg.accum_color, dp.cfg.accum_alpha);
        let fm = crate::reg!(dp.cfg, merge);
        let prows = self.back.counts()[1] as i64;
        let my = self.front.lo[1] + i as i64;
        let rows = [2 * my - 1, 2 * my, 2 * my + 1].map(|py| py - self.back.lo[1]);
        let taps = pe.pass.line.taps(pe.k, rows, prows, c, sparse)?;
        let fin = pe.finals.last().map(|f| f[c].acc[i]).unwrap_or_default();
        let out = &mut pe.pass.next[c].acc[i].raw;
        for (ch, o) in out.iter_mut().enumerate() {
            let merged = dp.tent(
                [taps[0][ch], taps[1][ch], taps[2][ch]],
                *fm,
                fm,
                &mut pe.model.stats,
            );
            let ff = if ch < 3 { fc } else { fa };
            *o = dp
                .fold_add(fin.raw[ch], ff, merged.raw(), &mut pe.model.stats)
                .raw();
        }
        pe.counters.merge_outputs += 1;
        Ok(())
    }

    /// Children with a non-zero tap difference in the x row; children of
    /// the y row with a non-zero kept final state or a valid line-buffer
    /// entry. A child left out is `final + merged` with both zero: zero,
    /// as the bank reads.
    fn work_list(&self, pe: &mut Pe, bus: &PassBus) -> Result<(), StepError> {
        let prows = self.back.counts()[1] as i64;
        let grid = (self.back.lo[0], self.back.hi[0]);
        let left = pe.pass.edges.left;
        pe.set_work_list(|pe, c| {
            let x = match bus.x {
                Some(_) => pe.fold_taps(c, grid, left)?.iter().any(|t| *t != [0; 4]),
                None => false,
            };
            let y = bus.y.is_some_and(|i| {
                let kept = pe.finals.last().is_some_and(|f| f[c].acc[i].raw != [0; 4]);
                let my = self.front.lo[1] + i as i64;
                kept || pe.pass.line.holds_any(
                    (2 * my - 1..=2 * my + 1).map(|py| py - self.back.lo[1]),
                    prows,
                    c,
                )
            });
            Ok((x, y))
        })
    }

    /// [`Pe::fold_drive`](Pe): the last held column's difference of back
    /// row `row` to the right neighbour.
    fn drive(&self, pe: &mut Pe, dp: &Datapath, row: usize, out: &mut Ports) {
        pe.fold_drive(dp, row, self.rf, out);
    }
}

impl Array {
    /// Front to back: one step of the fold, `g.back`'s rays into
    /// `g.front`'s. With `pass_skip_empty` every slot lasts as long as the
    /// busiest PE's work list ([`Pe::pass_step_sparse`]); every row keeps
    /// its slot, since which back rows hold a difference is known only
    /// once each PE forms them. With a capture attached, the dense pass
    /// records every clock for the co-simulation (`stages::fold_capture`).
    pub(crate) fn fold(&mut self, g: FoldGrids) -> Result<(), RunError> {
        let dp = std::sync::Arc::clone(&self.dp);
        let needs = tent_needs(g.front, g.back);
        if !dp.cfg.pass_skip_empty {
            if let Some(c) = self.clock.capture().cloned() {
                return self.fold_captured(&c, &dp, g);
            }
            return self.run_pass(
                (g.back.counts()[1], &needs),
                Broadcast::BeginFold { front: g.front },
                &mut PassStep::new(Stage::Fold, g, &dp, false),
                Broadcast::EndFold,
            );
        }
        let slots = plan_slots(g.back.counts()[1], &needs)?;
        self.run_sparse_pass(
            &slots,
            Broadcast::BeginFold { front: g.front },
            &mut PassStep::new(Stage::Fold, g, &dp, true),
            Broadcast::EndFold,
        )
    }
}
