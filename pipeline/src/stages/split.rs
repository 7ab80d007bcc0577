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

use super::passes::{inside, plan_slots_where, PassBus};
use crate::array::{clamp, Array, Links, RunError};
use crate::datapath::{Acc, Datapath};
use crate::pe::{Broadcast, FtbState, Pe, Ports, RayColumn, StepError};
use crate::probes::Stage;
use crate::schedule::btf::rays;

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
    pub fn split_drive(&self, row: usize, out: &mut Ports) {
        if let Some(f) = self.rays.front() {
            out.left.edge_acc = f.acc[row];
            out.left.edge_mx = Some(f.mx);
        }
    }

    /// A parent of the split, front ray `mx` at `row`: held here, or the
    /// right neighbour's first column on its port, or empty outside the
    /// parent rectangle `grid` (inclusive).
    fn split_parent(
        &self,
        mx: i64,
        row: usize,
        grid: (i64, i64),
        (right, right_mx): (Acc, Option<i64>),
    ) -> Result<Acc, StepError> {
        if mx < grid.0 || mx > grid.1 {
            return Ok(Acc::default());
        }
        if let Some((lo, hi)) = self.span() {
            if (lo..=hi).contains(&mx) {
                return Ok(self.rays[(mx - lo) as usize].acc[row]);
            }
        }
        if right_mx == Some(mx) {
            return Ok(right);
        }
        Err(StepError::Unreachable { pe: self.k, mx })
    }

    /// Child `c`'s two parents in parent row `q` (the same one twice for
    /// an even child), the right neighbour's edge ray `right` beyond the
    /// held span.
    fn split_parents(
        &self,
        c: usize,
        q: usize,
        grid: (i64, i64),
        right: (Acc, Option<i64>),
    ) -> Result<(Acc, Acc), StepError> {
        let n = self.pass.children[c];
        let m = n.div_euclid(2);
        let a = self.split_parent(m, q, grid, right)?;
        let b = if n.rem_euclid(2) == 0 {
            a
        } else {
            self.split_parent(m + 1, q, grid, right)?
        };
        Ok((a, b))
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
        out: &mut Ports,
    ) -> Result<(), StepError> {
        let c = bus.col;
        let right = (links.from_right.edge_acc, links.from_right.edge_mx);
        if let Some(i) = bus.y.filter(|_| c < self.pass.children.len()) {
            self.split_y(dp, c, i, (fg, bg), false)?;
        }
        if let Some(q) = bus.x.filter(|_| c < self.pass.children.len()) {
            self.split_x(dp, c, q, fg, right)?;
        }
        self.split_ports(bus, out);
        Ok(())
    }

    /// One clock of the sparse split (`pass_skip_empty`), as
    /// [`Pe::merge_step_sparse`]: the slot's first cycle latches the right
    /// neighbour's edge ray and forms the work list (children with a
    /// non-zero parent in the x row, or a valid line-buffer entry for the
    /// y row); children left out stay transparent, live and inheriting
    /// nothing, which is what the dense split writes for them.
    pub fn split_step_sparse(
        &mut self,
        dp: &Datapath,
        bus: &PassBus,
        links: Links<'_>,
        (fg, bg): (&RayGrid, &RayGrid),
        out: &mut Ports,
    ) -> Result<(), StepError> {
        if bus.col == 0 {
            self.pass.edge_in.1 = links.from_right.edge_acc;
            self.pass.edge_mx.1 = links.from_right.edge_mx;
            self.plan_split_slot(bus, (fg, bg))?;
        }
        let right = (self.pass.edge_in.1, self.pass.edge_mx.1);
        if let Some(&(c, x, y)) = self.pass.slot.get(bus.col) {
            if let Some(i) = bus.y.filter(|_| y) {
                self.split_y(dp, c, i, (fg, bg), true)?;
            }
            if let Some(q) = bus.x.filter(|_| x) {
                self.split_x(dp, c, q, fg, right)?;
            }
        }
        self.split_ports(bus, out);
        Ok(())
    }

    /// What the PE drives in a split cycle.
    fn split_ports(&self, bus: &PassBus, out: &mut Ports) {
        if let Some(r) = bus.drive {
            self.split_drive(r, out);
        }
    }

    /// The sparse split's work list for the slot on `bus`.
    fn plan_split_slot(
        &mut self,
        bus: &PassBus,
        (fg, bg): (&RayGrid, &RayGrid),
    ) -> Result<(), StepError> {
        let prows = fg.counts()[1] as i64;
        let grid = (fg.lo[0], fg.hi[0]);
        let right = (self.pass.edge_in.1, self.pass.edge_mx.1);
        self.set_work_list(|pe, c| {
            let x = match bus.x {
                Some(q) => {
                    let (a, b) = pe.split_parents(c, q, grid, right)?;
                    a.raw != [0; 4] || b.raw != [0; 4]
                }
                None => false,
            };
            let y = bus.y.is_some_and(|i| {
                let my = bg.lo[1] + i as i64;
                let py = my.div_euclid(2) - fg.lo[1];
                pe.pass
                    .line
                    .holds_any([py, py + my.rem_euclid(2)], prows, c)
            });
            Ok((x, y))
        })
    }

    /// The y pass for child `c` of child row `i`: the mean of its parent
    /// rows from the line buffer, with the inherited state and the flag.
    fn split_y(
        &mut self,
        dp: &Datapath,
        c: usize,
        i: usize,
        (fg, bg): (&RayGrid, &RayGrid),
        sparse: bool,
    ) -> Result<(), StepError> {
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        let prows = fg.counts()[1] as i64;
        let my = bg.lo[1] + i as i64;
        let py = my.div_euclid(2);
        let mut taps = [[0i64; 4]; 2];
        for (t, p) in taps.iter_mut().zip([py, py + my.rem_euclid(2)]) {
            let row = p - fg.lo[1];
            if (0..prows).contains(&row) {
                *t = if sparse {
                    self.pass.line.read_sparse(self.k, row as usize, c)?
                } else {
                    self.pass.line.read(self.k, row as usize, c)?
                };
            }
        }
        let col = &mut self.pass.next[c];
        for (ch, o) in col.acc[i].raw.iter_mut().enumerate() {
            let to = if ch < 3 { fc } else { fa };
            *o = dp
                .halve([taps[0][ch], taps[1][ch]], fm, to, &mut self.model.stats)
                .raw();
        }
        col.ftb[i] = FtbState {
            inh: col.acc[i],
            // A child of terminated parents is terminated: the
            // comparator checks every child as it is written.
            done: dp.terminated(&col.acc[i]),
        };
        self.counters.split_outputs += 1;
        Ok(())
    }

    /// The x pass for child `c` of parent row `q`: the mean of its two
    /// parents into the line buffer.
    fn split_x(
        &mut self,
        dp: &Datapath,
        c: usize,
        q: usize,
        fg: &RayGrid,
        right: (Acc, Option<i64>),
    ) -> Result<(), StepError> {
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        let (a, b) = self.split_parents(c, q, (fg.lo[0], fg.hi[0]), right)?;
        let mut out = [0i64; 4];
        for (ch, o) in out.iter_mut().enumerate() {
            let f = if ch < 3 { fc } else { fa };
            *o = dp
                .halve([a.raw[ch], b.raw[ch]], f, fm, &mut self.model.stats)
                .raw();
        }
        self.pass.line.write(q, c, out);
        Ok(())
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
    /// `bg`'s. Returns the rays it read and wrote (an external ray
    /// buffer's traffic): every parent and child, or with
    /// `pass_skip_empty` the non-zero parents and the children written.
    pub(crate) fn split(&mut self, fg: &RayGrid, bg: &RayGrid) -> Result<(u64, u64), RunError> {
        let prows = fg.counts()[1];
        let dp = std::sync::Arc::clone(&self.dp);
        // A datapath that would flag a transparent child as terminated (a
        // threshold rounded to zero) splits densely: skipped children are
        // live.
        if dp.cfg.pass_skip_empty && !dp.terminated(&Acc::default()) {
            return self.split_sparse(&dp, fg, bg);
        }
        // Child row my reads parent rows floor(my / 2) and, when odd, the next.
        let needs: Vec<_> = (bg.lo[1]..=bg.hi[1])
            .map(|my| {
                let py = my.div_euclid(2) - fg.lo[1];
                inside([py, py + my.rem_euclid(2)].into_iter(), prows)
            })
            .collect();
        self.run_pass(
            Stage::Split,
            (prows, &needs),
            Broadcast::BeginSplit {
                front: fg,
                back: bg,
            },
            |pe, bus, links, out| pe.split_step(&dp, bus, links, (fg, bg), out),
            Broadcast::EndSplit,
        )?;
        Ok((rays(fg), rays(bg)))
    }

    /// The sparse split (`pass_skip_empty`), planned as the sparse merge
    /// ([`Array::merge`]): only the parent rows some PE holds a non-zero
    /// ray in are filtered, only the child rows reading one are written.
    fn split_sparse(
        &mut self,
        dp: &Datapath,
        fg: &RayGrid,
        bg: &RayGrid,
    ) -> Result<(u64, u64), RunError> {
        let prows = fg.counts()[1];
        let (live, reads) = self.live_rows(prows);
        let needs: Vec<_> = (bg.lo[1]..=bg.hi[1])
            .map(|my| {
                let py = my.div_euclid(2) - fg.lo[1];
                let rows = [py, py + my.rem_euclid(2)]
                    .into_iter()
                    .filter(|&r| r >= 0 && (r as usize) < prows && live[r as usize]);
                inside(rows, prows)
            })
            .collect();
        let written = |a: &Array| -> u64 { a.clock.reports().map(|r| r.split_outputs).sum() };
        let before = written(self);
        // The lowest parent row each child row reads, live or not.
        let lows: Vec<_> = (bg.lo[1]..=bg.hi[1])
            .map(|my| {
                let py = my.div_euclid(2) - fg.lo[1];
                inside([py, py + my.rem_euclid(2)].into_iter(), prows).map(|n| n.0)
            })
            .collect();
        let slots = plan_slots_where(prows, &needs, &lows, |q| live[q], false)?;
        self.run_sparse_pass(
            Stage::Split,
            &slots,
            Broadcast::BeginSplit {
                front: fg,
                back: bg,
            },
            |pe, bus, links, out| pe.split_step_sparse(dp, bus, links, (fg, bg), out),
            Broadcast::EndSplit,
        )?;
        Ok((reads, written(self) - before))
    }
}
