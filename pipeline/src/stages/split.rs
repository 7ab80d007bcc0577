//! Front to back: the bilinear split at a region boundary, the bit-exact
//! twin of [`golden::merge::split`] and the merge's adjoint. Back ray `n`
//! continues front ray `n / 2` when `n` is even and takes the mean of
//! front rays `floor(n / 2)` and `floor(n / 2) + 1` when odd, per axis.
//! After a migration to the rays' positions on the boundary plane (one
//! voxel apart there), a child is computed by the PE holding its parent
//! `clamp(floor(n / 2))`; the other parent is held there or is the right
//! neighbour's first column, which crosses the link. Each PE keeps its
//! parents' final states for the fold, and each child carries what it
//! inherited. The cycles come from [`super::passes`].

use golden::geometry::RayGrid;

use super::passes::{inside, PassBus};
use crate::array::{clamp, Array, Links, RunError};
use crate::datapath::{Acc, Datapath};
use crate::pe::{FtbState, Pe, Ports, RayColumn, StepError};
use crate::probes::Stage;

impl Pe {
    /// Starts a split of the front grid `fg`'s rays into the back grid
    /// `bg`'s: the children whose first parent this PE holds. Returns how
    /// many (the PE's report).
    pub fn begin_split(&mut self, fg: &RayGrid, bg: &RayGrid) -> usize {
        let span = self.span();
        let children: Vec<i64> = (bg.lo[0]..=bg.hi[0])
            .filter(|&n| {
                let parent = clamp(n.div_euclid(2), fg.lo[0], fg.hi[0]);
                span.is_some_and(|(lo, hi)| (lo..=hi).contains(&parent))
            })
            .collect();
        let rows = bg.counts()[1];
        let next = children
            .iter()
            .map(|&n| RayColumn::empty(n, rows, true))
            .collect();
        self.pass.begin(children, next);
        self.pass.children.len()
    }

    /// Drives this PE's first held column of parent row `row`, with its
    /// index, to the left neighbour (whose last odd child averages it with
    /// its own last column).
    pub fn split_drive(&self, row: usize) -> Ports {
        let mut out = Ports::default();
        if let Some(f) = self.rays.front() {
            out.left.edge_acc = f.acc[row];
            out.left.edge_mx = Some(f.mx);
        }
        out
    }

    /// A parent of the split, front ray `mx` at `row`: held here, or the
    /// right neighbour's first column on its port, or empty outside the
    /// parent rectangle `grid` (inclusive).
    fn split_parent(
        &self,
        mx: i64,
        row: usize,
        grid: (i64, i64),
        links: &Links<'_>,
    ) -> Result<Acc, StepError> {
        if mx < grid.0 || mx > grid.1 {
            return Ok(Acc::default());
        }
        if let Some((lo, hi)) = self.span() {
            if (lo..=hi).contains(&mx) {
                return Ok(self.rays[(mx - lo) as usize].acc[row]);
            }
        }
        if links.from_right.edge_mx == Some(mx) {
            return Ok(links.from_right.edge_acc);
        }
        Err(StepError::Unreachable { pe: self.k, mx })
    }

    /// One split clock: the y pass writes child `col` of child row `bus.y`
    /// (the mean of parent rows `floor(my / 2)` and the next when `my` is
    /// odd) with its inherited state and termination flag, then the x pass
    /// forms child `col` of parent row `bus.x` into the line buffer.
    pub fn split_step(
        &mut self,
        dp: &Datapath,
        bus: &PassBus,
        links: Links<'_>,
        (fg, bg): (&RayGrid, &RayGrid),
    ) -> Result<Ports, StepError> {
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        let c = bus.col;
        let prows = fg.counts()[1] as i64;
        if let Some(i) = bus.y.filter(|_| c < self.pass.children.len()) {
            let my = bg.lo[1] + i as i64;
            let py = my.div_euclid(2);
            let mut taps = [[0i64; 4]; 2];
            for (t, p) in taps.iter_mut().zip([py, py + my.rem_euclid(2)]) {
                let row = p - fg.lo[1];
                if (0..prows).contains(&row) {
                    *t = self.pass.line.read(self.k, row as usize, c)?;
                }
            }
            let col = &mut self.pass.next[c];
            for (ch, o) in col.acc[i].raw.iter_mut().enumerate() {
                let to = if ch < 3 { fc } else { fa };
                *o = dp
                    .halve([taps[0][ch], taps[1][ch]], fm, to, &mut self.stats)
                    .raw();
            }
            col.ftb[i] = FtbState {
                inh: col.acc[i],
                // A child of terminated parents is terminated: the
                // comparator checks every child as it is written.
                done: dp.terminated(&col.acc[i]),
            };
            self.counters.split_outputs += 1;
        }
        if let Some(q) = bus.x.filter(|_| c < self.pass.children.len()) {
            let n = self.pass.children[c];
            let grid = (fg.lo[0], fg.hi[0]);
            let m = n.div_euclid(2);
            let a = self.split_parent(m, q, grid, &links)?;
            let b = if n.rem_euclid(2) == 0 {
                a
            } else {
                self.split_parent(m + 1, q, grid, &links)?
            };
            let mut out = [0i64; 4];
            for (ch, o) in out.iter_mut().enumerate() {
                let f = if ch < 3 { fc } else { fa };
                *o = dp
                    .halve([a.raw[ch], b.raw[ch]], f, fm, &mut self.stats)
                    .raw();
            }
            self.pass.line.write(q, c, out);
        }
        Ok(bus
            .drive
            .map_or_else(Ports::default, |r| self.split_drive(r)))
    }

    /// Ends a split: the parents' final states are kept for the fold and
    /// the children become the held columns.
    pub fn end_split(&mut self) {
        let next = std::mem::take(&mut self.pass.next);
        let parents = std::mem::take(&mut self.rays);
        self.finals.push(parents.into());
        self.set_rays(next);
    }
}

impl Array {
    /// Front to back: the split of `fg`'s rays (on their rear plane) into
    /// `bg`'s.
    pub(crate) fn split(&mut self, fg: &RayGrid, bg: &RayGrid) -> Result<(), RunError> {
        let prows = fg.counts()[1];
        // Child row my reads parent rows floor(my / 2) and, when odd, the next.
        let needs: Vec<_> = (bg.lo[1]..=bg.hi[1])
            .map(|my| {
                let py = my.div_euclid(2) - fg.lo[1];
                inside([py, py + my.rem_euclid(2)].into_iter(), prows)
            })
            .collect();
        let dp = std::sync::Arc::clone(&self.dp);
        self.run_pass(
            Stage::Split,
            (prows, &needs),
            |pe| pe.begin_split(fg, bg),
            |pe, bus, links| pe.split_step(&dp, bus, links, (fg, bg)),
            Pe::end_split,
        )
    }
}
