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

use super::boundary::{BoundaryPass, Edges, OnPassBus, PassStep};
use super::passes::{inside, plan_slots_where, PassBus};
use super::Step;
use crate::array::{clamp, Array, Links, RunError};
use crate::cosim::split::SplitTick;
use crate::datapath::{Acc, Datapath};
use crate::pe::{Broadcast, FtbState, Pe, Ports, RayColumn, StepError};
use crate::probes::{Ctrl, Stage};
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

    /// Ends a split: the parents' final states are kept for the fold and
    /// the children become the held columns.
    pub fn end_split(&mut self) {
        let next = std::mem::take(&mut self.pass.next);
        let parents = std::mem::take(&mut self.rays);
        self.finals.push(parents.into());
        self.set_rays(next);
    }
}

/// The split as a [`BoundaryPass`]: the front grid `fg`'s rays (the
/// parents) into the back grid `bg`'s. A child's second parent beyond the
/// held span is the right neighbour's edge ray, found by its index.
#[derive(Debug, Clone, Copy)]
pub struct SplitPass<'a> {
    /// The front grid (the parents, the x pass's rows).
    pub fg: &'a RayGrid,
    /// The back grid (the children).
    pub bg: &'a RayGrid,
}

impl BoundaryPass for SplitPass<'_> {
    /// The mean of child `c`'s two parents in parent row `q` into the line
    /// buffer.
    fn x(
        &self,
        pe: &mut Pe,
        dp: &Datapath,
        c: usize,
        q: usize,
        edges: Edges,
    ) -> Result<(), StepError> {
        let (fc, fa) = (dp.cfg.accum_color, dp.cfg.accum_alpha);
        let fm = crate::reg!(dp.cfg, merge);
        let fg = self.fg;
        let (a, b) = pe.split_parents(c, q, (fg.lo[0], fg.hi[0]), edges.right)?;
        let mut out = [0i64; 4];
        for (ch, o) in out.iter_mut().enumerate() {
            let f = if ch < 3 { fc } else { fa };
            *o = dp
                .halve([a.raw[ch], b.raw[ch]], f, fm, &mut pe.model.stats)
                .raw();
        }
        pe.pass.line.write(q, c, out);
        Ok(())
    }

    /// Child `c` of child row `i`: the mean of its parent rows
    /// `floor(my / 2)` and, when `my` is odd, the next, from the line
    /// buffer, with its inherited state and termination flag.
    fn y(
        &self,
        pe: &mut Pe,
        dp: &Datapath,
        c: usize,
        i: usize,
        sparse: bool,
    ) -> Result<(), StepError> {
        let (fg, bg) = (self.fg, self.bg);
        let (fc, fa) = (
            crate::reg!(dp.cfg, accum_color),
            crate::reg!(dp.cfg, accum_alpha),
        );
        let fm = dp.cfg.merge;
        let prows = fg.counts()[1] as i64;
        let my = bg.lo[1] + i as i64;
        let py = my.div_euclid(2);
        let rows = [py, py + my.rem_euclid(2)].map(|p| p - fg.lo[1]);
        let taps = pe.pass.line.taps(pe.k, rows, prows, c, sparse)?;
        let col = &mut pe.pass.next[c];
        for (ch, o) in col.acc[i].raw.iter_mut().enumerate() {
            let to = if ch < 3 { fc } else { fa };
            *o = dp
                .halve([taps[0][ch], taps[1][ch]], fm, to, &mut pe.model.stats)
                .raw();
        }
        col.ftb[i] = FtbState {
            inh: col.acc[i],
            // A child of terminated parents is terminated: the
            // comparator checks every child as it is written.
            done: dp.terminated(&col.acc[i]),
        };
        pe.counters.split_outputs += 1;
        Ok(())
    }

    /// Children with a non-zero parent in the x row, or a valid
    /// line-buffer entry for the y row; children left out stay
    /// transparent, live and inheriting nothing, which is what the dense
    /// split writes for them.
    fn work_list(&self, pe: &mut Pe, bus: &PassBus) -> Result<(), StepError> {
        let (fg, bg) = (self.fg, self.bg);
        let prows = fg.counts()[1] as i64;
        let grid = (fg.lo[0], fg.hi[0]);
        let right = pe.pass.edges.right;
        pe.set_work_list(|pe, c| {
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

    /// [`Pe::split_drive`].
    fn drive(&self, pe: &mut Pe, _dp: &Datapath, row: usize, out: &mut Ports) {
        pe.split_drive(row, out);
    }
}

/// The dense split's cycle on a PE with what it reads and writes recorded
/// for the co-simulation ([`crate::cosim::split`]): the [`PassStep`] of a
/// [`SplitPass`] (twin of [`golden::merge::split`]) and, per PE, one
/// [`SplitTick`] a cycle: the bus, the
/// parents the x pass reads and what both passes write.
struct CapturedSplit<'a> {
    step: PassStep<'a, SplitPass<'a>>,
    /// The parents' columns.
    grid: (i64, i64),
    /// Each PE's children.
    children: &'a mut [usize],
    per_pe: Vec<Vec<SplitTick>>,
}

impl Step for CapturedSplit<'_> {
    fn ctrl(&self) -> Ctrl {
        self.step.ctrl()
    }

    fn step(&mut self, pe: &mut Pe, links: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        let bus = *self.step.bus();
        let (c, n) = (bus.col, pe.pass.children.len());
        let mut t = SplitTick {
            x: bus.x,
            y: bus.y,
            col: c,
            ..Default::default()
        };
        if let Some(q) = bus.x.filter(|_| c < n) {
            if let Ok((a, b)) = pe.split_parents(c, q, self.grid, Edges::on(&links).right) {
                t.parents = [a.raw, b.raw];
            }
        }
        self.step.step(pe, links, out)?;
        if let Some(q) = bus.x.filter(|_| c < n) {
            t.line = pe.pass.line.read(pe.k, q, c).ok();
        }
        if let Some(i) = bus.y.filter(|_| c < n) {
            let col = &pe.pass.next[c];
            t.child = Some((col.acc[i].raw, col.ftb[i].done));
        }
        self.children[pe.k] = n;
        self.per_pe[pe.k].push(t);
        Ok(())
    }
}

impl OnPassBus for CapturedSplit<'_> {
    fn show(&mut self, bus: PassBus, row: usize) {
        self.step.show(bus, row);
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
        if let Some(c) = self.clock.capture().cloned() {
            self.split_captured(&c, &dp, (fg, bg), (prows, &needs))?;
            return Ok((rays(fg), rays(bg)));
        }
        self.run_pass(
            (prows, &needs),
            Broadcast::BeginSplit {
                front: fg,
                back: bg,
            },
            &mut PassStep::new(Stage::Split, SplitPass { fg, bg }, &dp, false),
            Broadcast::EndSplit,
        )?;
        Ok((rays(fg), rays(bg)))
    }

    /// The dense split of [`Array::split`] with each PE's clocks recorded
    /// for the co-simulation ([`crate::cosim::split`]): the broadcast, the
    /// parents the x pass reads and what both passes write. The same
    /// clocks as the uncaptured split.
    fn split_captured(
        &mut self,
        capture: &crate::cosim::capture::Capture,
        dp: &Datapath,
        (fg, bg): (&RayGrid, &RayGrid),
        (prows, needs): (usize, &[Option<(usize, usize)>]),
    ) -> Result<(), RunError> {
        use crate::cosim::split::SplitCapture;
        let p = self.clock.pes().len();
        let mut rec = SplitCapture {
            first: self.clock.now(),
            grids: (fg.lo[1], prows, bg.lo[1]),
            children: vec![0; p],
            ticks: Vec::new(),
        };
        let mut step = CapturedSplit {
            step: PassStep::new(Stage::Split, SplitPass { fg, bg }, dp, false),
            grid: (fg.lo[0], fg.hi[0]),
            children: &mut rec.children,
            per_pe: vec![Vec::new(); p],
        };
        self.run_pass(
            (prows, needs),
            Broadcast::BeginSplit {
                front: fg,
                back: bg,
            },
            &mut step,
            Broadcast::EndSplit,
        )?;
        rec.ticks = crate::cosim::pass::by_clock(&step.per_pe);
        crate::cosim::split::captured(capture, &rec);
        Ok(())
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
            &slots,
            Broadcast::BeginSplit {
                front: fg,
                back: bg,
            },
            &mut PassStep::new(Stage::Split, SplitPass { fg, bg }, dp, true),
            Broadcast::EndSplit,
        )?;
        Ok((reads, written(self) - before))
    }
}
