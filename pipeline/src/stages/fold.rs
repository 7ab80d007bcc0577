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

use super::passes::{tent_needs, PassBus};
use crate::array::{Array, Links, RunError};
use crate::datapath::{Acc, Datapath};
use crate::fixed::Format;
use crate::pe::{Pe, Ports, RayColumn, StepError};
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
                *o = dp.fold_diff(r[ch], f, h[ch], hf, &mut self.stats).raw();
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
    fn fold_drive(&mut self, dp: &Datapath, row: usize, rf: [Format; 2]) -> Ports {
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
        let mut out = Ports::default();
        if let (Some(c), Some(d)) = (self.rays.back(), line.and_then(|l| l.last())) {
            out.right.edge_acc = Acc { raw: *d };
            out.right.edge_mx = Some(c.mx);
        }
        out
    }

    /// A tap of the x pass, back ray `n`'s difference in the current row:
    /// held here, or the left neighbour's last column on its port, or
    /// empty outside the back rectangle `grid`.
    fn fold_tap(&self, n: i64, grid: (i64, i64), links: &Links<'_>) -> Result<[i64; 4], StepError> {
        if n < grid.0 || n > grid.1 {
            return Ok([0; 4]);
        }
        if let (Some((lo, hi)), Some((_, line))) = (self.span(), &self.pass.dline) {
            if (lo..=hi).contains(&n) {
                return Ok(line[(n - lo) as usize]);
            }
        }
        if links.from_left.edge_mx == Some(n) {
            return Ok(links.from_left.edge_acc.raw);
        }
        Err(StepError::Unreachable { pe: self.k, mx: n })
    }

    /// One fold clock: the y pass writes child `col` of front row `bus.y`
    /// (the tent of back rows `2 my - 1 ..= 2 my + 1` from the line buffer
    /// plus the kept final state), then the x pass filters child `col` of
    /// back row `bus.x` (the tent of back rays `2m - 1 ..= 2m + 1`'s
    /// differences) into the line buffer.
    pub fn fold_step(
        &mut self,
        dp: &Datapath,
        bus: &PassBus,
        links: Links<'_>,
        g: FoldGrids,
    ) -> Result<Ports, StepError> {
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        let c = bus.col;
        let n = self.pass.children.len();
        let prows = g.back.counts()[1] as i64;
        if let Some(i) = bus.y.filter(|_| c < n) {
            let my = g.front.lo[1] + i as i64;
            let mut taps = [[0i64; 4]; 3];
            for (t, py) in taps.iter_mut().zip(2 * my - 1..=2 * my + 1) {
                let row = py - g.back.lo[1];
                if (0..prows).contains(&row) {
                    *t = self.pass.line.read(self.k, row as usize, c)?;
                }
            }
            let fin = self.finals.last().map(|f| f[c].acc[i]).unwrap_or_default();
            let out = &mut self.pass.next[c].acc[i].raw;
            for (ch, o) in out.iter_mut().enumerate() {
                let merged = dp.tent(
                    [taps[0][ch], taps[1][ch], taps[2][ch]],
                    fm,
                    fm,
                    &mut self.stats,
                );
                let ff = if ch < 3 { fc } else { fa };
                *o = dp
                    .fold_add(fin.raw[ch], ff, merged.raw(), &mut self.stats)
                    .raw();
            }
            self.counters.merge_outputs += 1;
        }
        if let Some(q) = bus.x {
            self.fold_line(dp, q, g.rf);
            if c < n {
                let m = self.pass.children[c];
                let grid = (g.back.lo[0], g.back.hi[0]);
                let p = [
                    self.fold_tap(2 * m - 1, grid, &links)?,
                    self.fold_tap(2 * m, grid, &links)?,
                    self.fold_tap(2 * m + 1, grid, &links)?,
                ];
                let mut out = [0i64; 4];
                for (ch, o) in out.iter_mut().enumerate() {
                    *o = dp
                        .tent([p[0][ch], p[1][ch], p[2][ch]], fm, fm, &mut self.stats)
                        .raw();
                }
                self.pass.line.write(q, c, out);
            }
        }
        Ok(match bus.drive {
            Some(r) => self.fold_drive(dp, r, g.rf),
            None => Ports::default(),
        })
    }

    /// Ends a fold step: the kept final states are spent and the results
    /// become the held columns.
    pub fn end_fold(&mut self) {
        self.finals.pop();
        let next = std::mem::take(&mut self.pass.next);
        self.set_rays(next);
    }
}

impl Array {
    /// Front to back: one step of the fold, `g.back`'s rays into
    /// `g.front`'s.
    pub(crate) fn fold(&mut self, g: FoldGrids) -> Result<(), RunError> {
        let dp = std::sync::Arc::clone(&self.dp);
        self.run_pass(
            Stage::Fold,
            (g.back.counts()[1], &tent_needs(g.front, g.back)),
            |pe| pe.begin_fold(g.front),
            |pe, bus, links| pe.fold_step(&dp, bus, links, g),
            Pe::end_fold,
        )
    }
}
