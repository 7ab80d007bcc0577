//! The Bartlett merge at a region boundary (back to front), the bit-exact
//! twin of [`golden::merge::merge`]: child ray `m` of the front region is
//! the tent `(1/4, 1/2, 1/4)` of parents `2m - 1 ..= 2m + 1`, per axis.
//! After a migration to the rays' positions on the boundary plane, a child
//! is computed by the PE holding its centre parent `clamp(2m)`; the
//! parents beyond the PE's held span are its neighbours' edge rays, which
//! cross the links (see [`super::passes`] for the x pass, line buffer and
//! y pass the cycles come from).

use golden::geometry::RayGrid;

use super::boundary::{BoundaryPass, Edges, PassStep};
use super::passes::{inside, plan_slots, plan_slots_where, tent_needs, PassBus, Slot};
use crate::array::{Array, RunError};
use crate::datapath::{Acc, Datapath, Tents};
use crate::pe::{Broadcast, Pe, Ports, RayColumn, StepError};
use crate::probes::Stage;
use crate::schedule::btf::rays;

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
    /// rays `(left, right)` when `mx` is just beyond the held span; empty
    /// rays otherwise.
    fn parent(&self, mx: i64, row: usize, e: &Edges) -> Acc {
        let (left, right) = (e.left.0, e.right.0);
        let Some((lo, hi)) = self.span() else {
            return Acc::default();
        };
        if mx < lo {
            return if mx == lo - 1 { left } else { Acc::default() };
        }
        if mx > hi {
            return if mx == hi + 1 { right } else { Acc::default() };
        }
        self.rays[(mx - lo) as usize].acc[row]
    }

    /// Drives this PE's edge rays of parent row `row`: its first held
    /// column to the left, its last to the right.
    pub fn merge_drive(&self, row: usize, out: &mut Ports) {
        if let (Some(f), Some(l)) = (self.rays.front(), self.rays.back()) {
            out.left.edge_acc = f.acc[row];
            out.left.edge_mx = Some(f.mx);
            out.right.edge_acc = l.acc[row];
            out.right.edge_mx = Some(l.mx);
        }
    }

    /// Runs a whole dense merge's clocks, `slots` of `width` cycles each,
    /// without ticking: what [`Pe::pass_step`] computes in each, with the
    /// neighbours' edge rays of each parent row from `edges` (what they
    /// drive on their ports: their parents stay put during the pass, so
    /// the rays are known before it starts). Returns the index of the
    /// earliest cycle a step failed in, with its error.
    ///
    /// The cycle of slot `s` and column `col` is `s * width + col`, but
    /// the model evaluates them column by column: a column's steps read
    /// and write only its own line-buffer entries and child (and the
    /// parents, which stay put), so each column sees the same words in
    /// either order, and reading a parent column down its rows follows
    /// its accumulator memory where slot by slot each read is another
    /// column's.
    pub(crate) fn merge_whole(
        &mut self,
        dp: &Datapath,
        (slots, width): (&[Slot], usize),
        edges: &[(Acc, Acc)],
        (bg, fg): (&RayGrid, &RayGrid),
    ) -> Result<(), (usize, StepError)> {
        if let Some(&tents) = dp.tents() {
            return self.merge_columns(&tents, (slots, width), edges, (bg, fg));
        }
        let pass = MergePass { bg, fg };
        let mut first: Option<(usize, StepError)> = None;
        for col in 0..width {
            for (s, slot) in slots.iter().enumerate() {
                let cycle = s * width + col;
                // A later cycle's failure cannot be the earliest.
                if first.as_ref().is_some_and(|&(at, _)| at < cycle) {
                    break;
                }
                let (l, r) = slot.x.map_or_else(Default::default, |q| edges[q]);
                let bus = PassBus {
                    x: slot.x,
                    y: slot.y,
                    col,
                    drive: None,
                };
                let e = Edges {
                    left: (l, None),
                    right: (r, None),
                };
                if let Err(err) = self.pass_work(&pass, dp, &bus, e) {
                    first = Some((cycle, err));
                    break;
                }
            }
        }
        first.map_or(Ok(()), Err)
    }

    /// [`Pe::merge_whole`] through the tents worked out once per frame
    /// ([`Tents`]): the same steps in the same order, each column's
    /// parents found once (a held column, a neighbour's edge ray or
    /// neither: the parents stay put during the pass) instead of at
    /// every slot, and the tents' events kept in the pass's tally.
    fn merge_columns(
        &mut self,
        tents: &Tents,
        (slots, width): (&[Slot], usize),
        edges: &[(Acc, Acc)],
        (bg, fg): (&RayGrid, &RayGrid),
    ) -> Result<(), (usize, StepError)> {
        let prows = bg.counts()[1] as i64;
        let span = self.span();
        self.rays.make_contiguous();
        let mut tally = std::mem::take(&mut self.pass.tents);
        let mut first: Option<(usize, StepError)> = None;
        // A column past the children computes nothing in any slot.
        for c in 0..width.min(self.pass.children.len()) {
            let m = self.pass.children[c];
            let src = [2 * m - 1, 2 * m, 2 * m + 1].map(|mx| Parent::of(span, mx));
            for (s, slot) in slots.iter().enumerate() {
                let cycle = s * width + c;
                // A later cycle's failure cannot be the earliest.
                if first.as_ref().is_some_and(|&(at, _)| at < cycle) {
                    break;
                }
                if let Some(i) = slot.y {
                    let my = fg.lo[1] + i as i64;
                    let rows = [2 * my - 1, 2 * my, 2 * my + 1].map(|py| py - bg.lo[1]);
                    match self.pass.line.taps(self.k, rows, prows, c, false) {
                        Ok(taps) => {
                            self.pass.next[c].acc[i].raw = tents.apply_rgba(true, taps, &mut tally);
                            self.counters.merge_outputs += 1;
                        }
                        Err(err) => {
                            first = Some((cycle, err));
                            break;
                        }
                    }
                }
                if let Some(q) = slot.x {
                    let (l, r) = &edges[q];
                    let rays = self.rays.as_slices().0;
                    let p = src.map(|p| match p {
                        Parent::Held(j) => rays[j].acc[q].raw,
                        Parent::Left => l.raw,
                        Parent::Right => r.raw,
                        Parent::None => [0; 4],
                    });
                    let out = tents.apply_rgba(false, p, &mut tally);
                    self.pass.line.write(q, c, out);
                }
            }
        }
        self.pass.tents = tally;
        first.map_or(Ok(()), Err)
    }

    /// Ends a merge: the children become the held columns (the bank
    /// select flips), and the merge's tent events join the PE's stats.
    pub fn end_merge(&mut self) {
        std::mem::take(&mut self.pass.tents).add_to(&mut self.model.stats);
        let next = std::mem::take(&mut self.pass.next);
        self.set_rays(next);
    }

    /// The row valid bits of the held rays, ORed into `live` (a row is
    /// valid when some held ray in it is non-zero); returns how many
    /// non-zero rays it holds.
    pub fn valid_rows(&self, live: &mut [bool]) -> u64 {
        let mut count = 0;
        for col in &self.rays {
            for (l, a) in live.iter_mut().zip(&col.acc) {
                let set = a.raw != [0; 4];
                *l |= set;
                count += u64::from(set);
            }
        }
        count
    }
}

/// Where a merge's parent column lies for a PE holding columns `span`
/// ([`Pe::parent`]'s cases).
#[derive(Debug, Clone, Copy)]
enum Parent {
    /// Held, at this index of the held columns.
    Held(usize),
    /// The left neighbour's edge ray.
    Left,
    /// The right neighbour's edge ray.
    Right,
    /// Beyond both: an empty ray.
    None,
}

impl Parent {
    fn of(span: Option<(i64, i64)>, mx: i64) -> Parent {
        match span {
            None => Parent::None,
            Some((lo, _)) if mx < lo => {
                if mx == lo - 1 {
                    Parent::Left
                } else {
                    Parent::None
                }
            }
            Some((_, hi)) if mx > hi => {
                if mx == hi + 1 {
                    Parent::Right
                } else {
                    Parent::None
                }
            }
            Some((lo, _)) => Parent::Held((mx - lo) as usize),
        }
    }
}

/// The merge as a [`BoundaryPass`]: the back grid `bg`'s rays into the
/// front grid `fg`'s. Parents beyond the held span are both neighbours'
/// edge rays, found by position.
#[derive(Debug, Clone, Copy)]
pub struct MergePass<'a> {
    /// The back grid (the parents, the x pass's rows).
    pub bg: &'a RayGrid,
    /// The front grid (the children).
    pub fg: &'a RayGrid,
}

impl BoundaryPass for MergePass<'_> {
    /// The tent of parents `2m - 1 ..= 2m + 1` (the neighbours' edge rays
    /// beyond the held span) into the line buffer.
    fn x(
        &self,
        pe: &mut Pe,
        dp: &Datapath,
        c: usize,
        q: usize,
        edges: Edges,
    ) -> Result<(), StepError> {
        let m = pe.pass.children[c];
        let p = [
            pe.parent(2 * m - 1, q, &edges),
            pe.parent(2 * m, q, &edges),
            pe.parent(2 * m + 1, q, &edges),
        ];
        let st = &mut pe.model.stats;
        let out = dp.tent_rgba(false, p.map(|a| a.raw), st, &mut pe.pass.tents);
        pe.pass.line.write(q, c, out);
        Ok(())
    }

    /// The tent of the line buffer's parent rows `2 my - 1 ..= 2 my + 1`
    /// into the children's bank.
    fn y(
        &self,
        pe: &mut Pe,
        dp: &Datapath,
        c: usize,
        i: usize,
        sparse: bool,
    ) -> Result<(), StepError> {
        let (bg, fg) = (self.bg, self.fg);
        let prows = bg.counts()[1] as i64;
        let my = fg.lo[1] + i as i64;
        let rows = [2 * my - 1, 2 * my, 2 * my + 1].map(|py| py - bg.lo[1]);
        let taps = pe.pass.line.taps(pe.k, rows, prows, c, sparse)?;
        let st = &mut pe.model.stats;
        pe.pass.next[c].acc[i].raw = dp.tent_rgba(true, taps, st, &mut pe.pass.tents);
        pe.counters.merge_outputs += 1;
        Ok(())
    }

    /// The children whose x-filtered value in parent row `bus.x` can be
    /// non-zero (a held parent's valid bit or a latched edge ray is set;
    /// the tent of zeros is zero), and those of child row `bus.y` with a
    /// valid line-buffer entry to read.
    fn work_list(&self, pe: &mut Pe, bus: &PassBus) -> Result<(), StepError> {
        let (bg, fg) = (self.bg, self.fg);
        let prows = bg.counts()[1] as i64;
        let edges = pe.pass.edges;
        pe.set_work_list(|pe, c| {
            let m = pe.pass.children[c];
            let x = bus.x.is_some_and(|q| {
                (2 * m - 1..=2 * m + 1).any(|p| pe.parent(p, q, &edges).raw != [0; 4])
            });
            let y = bus.y.is_some_and(|i| {
                let my = fg.lo[1] + i as i64;
                pe.pass
                    .line
                    .holds_any((2 * my - 1..=2 * my + 1).map(|py| py - bg.lo[1]), prows, c)
            });
            Ok((x, y))
        })
    }

    /// [`Pe::merge_drive`].
    fn drive(&self, pe: &mut Pe, _dp: &Datapath, row: usize, out: &mut Ports) {
        pe.merge_drive(row, out);
    }
}

impl Array {
    /// Bartlett merge of `back`'s rays into `front`'s. Returns the rays
    /// it read and wrote (an external ray buffer's traffic): every parent
    /// and child, or with `pass_skip_empty` the non-zero parents and the
    /// children written. With a capture attached, the dense pass records
    /// every clock for the co-simulation (`stages::merge_capture`).
    pub(crate) fn merge(&mut self, bg: &RayGrid, fg: &RayGrid) -> Result<(u64, u64), RunError> {
        let dp = std::sync::Arc::clone(&self.dp);
        if dp.cfg.pass_skip_empty {
            return self.merge_sparse(&dp, bg, fg);
        }
        let prows = bg.counts()[1];
        let needs = tent_needs(fg, bg);
        if let Some(c) = self.clock.capture().cloned() {
            self.merge_captured(&c, &dp, (bg, fg), (prows, &needs))?;
            return Ok((rays(bg), rays(fg)));
        }
        if !self.clock.tracing() && !self.clocked {
            self.merge_untraced(&dp, (prows, &needs), (bg, fg))?;
            return Ok((rays(bg), rays(fg)));
        }
        self.run_pass(
            (prows, &needs),
            Broadcast::BeginMerge {
                back: bg,
                front: fg,
            },
            &mut PassStep::new(Stage::Merge, MergePass { bg, fg }, &dp, false),
            Broadcast::EndMerge,
        )?;
        Ok((rays(bg), rays(fg)))
    }

    /// The dense merge without ticking (untraced, as the whole-slice
    /// sampling): the clock's evaluator runs each PE's whole merge
    /// ([`Pe::merge_whole`]) and counts the cycles [`Array::run_pass`]
    /// ticks for the same work: the prologue and every slot (a test
    /// compares both paths).
    fn merge_untraced(
        &mut self,
        dp: &Datapath,
        (prows, needs): (usize, &[Option<(usize, usize)>]),
        grids: (&RayGrid, &RayGrid),
    ) -> Result<(), RunError> {
        let (bg, fg) = grids;
        let width = self.begin_pass(Broadcast::BeginMerge {
            back: bg,
            front: fg,
        });
        let slots = plan_slots(prows, needs)?;
        let prologue = self.has_prologue(&slots);
        self.clock
            .merge_untraced(dp, (&slots, width, prologue), prows, grids)?;
        self.clock.broadcast(&Broadcast::EndMerge);
        Ok(())
    }

    /// The parent rows some PE holds a non-zero ray in (each PE's row
    /// valid bits, ORed over the report lines), and how many non-zero rays
    /// the PEs hold.
    pub(crate) fn live_rows(&self, prows: usize) -> (Vec<bool>, u64) {
        self.clock.live_rows(prows)
    }

    /// The sparse merge (`pass_skip_empty`): the controller filters only
    /// the parent rows some PE holds a non-zero ray in (each PE's row
    /// valid bits, ORed over the report lines) and writes only the child
    /// rows that read one; each slot lasts as long as the busiest PE's
    /// work list ([`Pe::pass_step_sparse`] of a [`MergePass`]). What it skips is zero, so
    /// the children's words equal the dense merge's.
    fn merge_sparse(
        &mut self,
        dp: &Datapath,
        bg: &RayGrid,
        fg: &RayGrid,
    ) -> Result<(u64, u64), RunError> {
        let prows = bg.counts()[1];
        let (live, reads) = self.live_rows(prows);
        let written = |a: &Array| -> u64 { a.clock.reports().map(|r| r.merge_outputs).sum() };
        let before = written(self);
        let needs: Vec<_> = (fg.lo[1]..=fg.hi[1])
            .map(|my| {
                let rows = (2 * my - 1..=2 * my + 1)
                    .map(|py| py - bg.lo[1])
                    .filter(|&r| r >= 0 && (r as usize) < prows && live[r as usize]);
                inside(rows, prows)
            })
            .collect();
        let lows: Vec<_> = tent_needs(fg, bg).iter().map(|n| n.map(|n| n.0)).collect();
        let slots = plan_slots_where(prows, &needs, &lows, |q| live[q], false)?;
        self.run_sparse_pass(
            &slots,
            Broadcast::BeginMerge {
                back: bg,
                front: fg,
            },
            &mut PassStep::new(Stage::Merge, MergePass { bg, fg }, dp, true),
            Broadcast::EndMerge,
        )?;
        Ok((reads, written(self) - before))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::ColumnMap;
    use crate::pe::VoxelMem;

    fn grid(n: i64) -> RayGrid {
        RayGrid {
            z_ref: 1.0,
            phi: [0.0; 2],
            lo: [0, 0],
            hi: [n - 1, n - 1],
            slices: 0..1,
        }
    }

    /// Evaluated column by column, a merge whose slots read a parent row
    /// the x pass never filtered still reports the clock's earliest
    /// failing cycle, slot after slot (`s * width + col`): the y pass of
    /// slot 1 in column 0.
    #[test]
    fn a_failing_merge_reports_the_earliest_cycle() {
        let cfg = crate::config::PipelineConfig::default();
        let tf = golden::scenes::tf_preset("ml").unwrap();
        let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, 8);
        let dp = Datapath::new(cfg, crate::tables::Tables::new(&cfg, &lut).unwrap());
        let dims = [8, 6, 2];
        let cols: Vec<usize> = (0..8).collect();
        let mem = VoxelMem::Words(vec![0; 8 * 6 * 2]);
        let mut pe = Pe::new(0, ColumnMap::blocks(1, 8), &cols, mem, dims);
        pe.set_rays((0..8).map(|mx| RayColumn::empty(mx, 8, false)).collect());
        let (bg, fg) = (grid(8), grid(4));
        let width = pe.begin_merge(&bg, &fg);
        assert_eq!(width, 4);
        // Child row 1 reads parent rows 1 to 3; only row 0 was filtered.
        let slots = [
            Slot {
                x: Some(0),
                y: None,
            },
            Slot {
                x: None,
                y: Some(1),
            },
        ];
        let edges = vec![(Acc::default(), Acc::default()); 8];
        let got = pe.merge_whole(&dp, (&slots, width), &edges, (&bg, &fg));
        match got {
            Err((cycle, StepError::LineBuffer { pe: 0, row: 1 })) => assert_eq!(cycle, width),
            other => panic!("expected a line-buffer failure at cycle {width}, got {other:?}"),
        }
    }
}
