//! The Bartlett merge at a region boundary (back to front), the bit-exact
//! twin of [`golden::merge::merge`]: child ray `m` of the front region is
//! the tent `(1/4, 1/2, 1/4)` of parents `2m - 1 ..= 2m + 1`, per axis.
//! After a migration to the rays' positions on the boundary plane, a child
//! is computed by the PE holding its centre parent `clamp(2m)`; the
//! parents beyond the PE's held span are its neighbours' edge rays, which
//! cross the links (see [`super::passes`] for the x pass, line buffer and
//! y pass the cycles come from).

use golden::geometry::RayGrid;

use super::passes::{tent_needs, PassBus};
use crate::array::{Array, Links, RunError};
use crate::datapath::{Acc, Datapath};
use crate::pe::{Pe, Ports, RayColumn, StepError};
use crate::probes::Stage;

impl Pe {
    /// Starts a merge of the back grid `bg`'s rays into the front grid
    /// `fg`'s: the children whose centre parent this PE holds. Returns how
    /// many (the PE's report).
    pub fn begin_merge(&mut self, bg: &RayGrid, fg: &RayGrid) -> usize {
        let span = self.span();
        let children: Vec<i64> = (fg.lo[0]..=fg.hi[0])
            .filter(|&m| {
                let centre = (2 * m).clamp(bg.lo[0], bg.hi[0]);
                span.is_some_and(|(lo, hi)| (lo..=hi).contains(&centre))
            })
            .collect();
        let rows = fg.counts()[1];
        let next = children
            .iter()
            .map(|&m| RayColumn::empty(m, rows, false))
            .collect();
        self.pass.begin(children, next);
        self.pass.children.len()
    }

    /// Accumulators of held column `mx` at `row`, or the neighbours' edge
    /// rays when `mx` is just beyond the held span; empty rays otherwise.
    fn parent(&self, mx: i64, row: usize, links: &Links<'_>) -> Acc {
        let Some((lo, hi)) = self.span() else {
            return Acc::default();
        };
        if mx < lo {
            return if mx == lo - 1 {
                links.from_left.edge_acc
            } else {
                Acc::default()
            };
        }
        if mx > hi {
            return if mx == hi + 1 {
                links.from_right.edge_acc
            } else {
                Acc::default()
            };
        }
        self.rays[(mx - lo) as usize].acc[row]
    }

    /// Drives this PE's edge rays of parent row `row`: its first held
    /// column to the left, its last to the right.
    pub fn merge_drive(&self, row: usize) -> Ports {
        let mut out = Ports::default();
        if let (Some(f), Some(l)) = (self.rays.front(), self.rays.back()) {
            out.left.edge_acc = f.acc[row];
            out.left.edge_mx = Some(f.mx);
            out.right.edge_acc = l.acc[row];
            out.right.edge_mx = Some(l.mx);
        }
        out
    }

    /// One merge clock: the y pass writes child `col` of child row `bus.y`
    /// from the line buffer (parent rows `2 my - 1 ..= 2 my + 1` of the
    /// back grid `bg`), then the x pass filters child `col` of parent row
    /// `bus.x` (parents `2m - 1 ..= 2m + 1`) into it.
    pub fn merge_step(
        &mut self,
        dp: &Datapath,
        bus: &PassBus,
        links: Links<'_>,
        (bg, fg): (&RayGrid, &RayGrid),
    ) -> Result<Ports, StepError> {
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        let c = bus.col;
        let prows = bg.counts()[1] as i64;
        if let Some(i) = bus.y.filter(|_| c < self.pass.children.len()) {
            let my = fg.lo[1] + i as i64;
            let mut taps = [[0i64; 4]; 3];
            for (t, py) in taps.iter_mut().zip(2 * my - 1..=2 * my + 1) {
                let row = py - bg.lo[1];
                if (0..prows).contains(&row) {
                    *t = self.pass.line.read(self.k, row as usize, c)?;
                }
            }
            let out = &mut self.pass.next[c].acc[i].raw;
            for (ch, o) in out.iter_mut().enumerate() {
                let to = if ch < 3 { fc } else { fa };
                let v = dp.tent(
                    [taps[0][ch], taps[1][ch], taps[2][ch]],
                    fm,
                    to,
                    &mut self.stats,
                );
                *o = v.raw();
            }
            self.counters.merge_outputs += 1;
        }
        if let Some(q) = bus.x.filter(|_| c < self.pass.children.len()) {
            let m = self.pass.children[c];
            let p = [
                self.parent(2 * m - 1, q, &links),
                self.parent(2 * m, q, &links),
                self.parent(2 * m + 1, q, &links),
            ];
            let mut out = [0i64; 4];
            for (ch, o) in out.iter_mut().enumerate() {
                let f = if ch < 3 { fc } else { fa };
                *o = dp
                    .tent(
                        [p[0].raw[ch], p[1].raw[ch], p[2].raw[ch]],
                        f,
                        fm,
                        &mut self.stats,
                    )
                    .raw();
            }
            self.pass.line.write(q, c, out);
        }
        Ok(bus
            .drive
            .map_or_else(Ports::default, |r| self.merge_drive(r)))
    }

    /// Ends a merge: the children become the held columns (the bank
    /// select flips).
    pub fn end_merge(&mut self) {
        let next = std::mem::take(&mut self.pass.next);
        self.set_rays(next);
    }
}

impl Array {
    /// Bartlett merge of `back`'s rays into `front`'s.
    pub(crate) fn merge(&mut self, bg: &RayGrid, fg: &RayGrid) -> Result<(), RunError> {
        let dp = std::sync::Arc::clone(&self.dp);
        self.run_pass(
            Stage::Merge,
            (bg.counts()[1], &tent_needs(fg, bg)),
            |pe| pe.begin_merge(bg, fg),
            |pe, bus, links| pe.merge_step(&dp, bus, links, (bg, fg)),
            Pe::end_merge,
        )
    }
}
