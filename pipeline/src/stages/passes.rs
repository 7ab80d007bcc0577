//! What the merge, the split and the fold share: two passes over a region
//! boundary's ray grid, one output per PE per cycle each.
//!
//! - The **x pass** takes one parent row at a time (the PE's edge rays of
//!   that row cross the links, driven in the cycle before the row starts)
//!   and writes one x-filtered child column per cycle into the PE's line
//!   buffer.
//! - The **y pass** reads the line buffer and writes one child ray per
//!   cycle into the children's bank of the compositing buffer.
//!
//! The controller runs both in **slots** of `width` cycles (the most
//! children any PE computes, from the PEs' reports): in each slot the x
//! pass filters the next parent row if the line buffer has room for it
//! and the y pass writes the next child row if the x pass has produced
//! every parent row it needs. In a cycle the y pass reads before the x
//! pass writes (a read-first RAM), so the x pass may overwrite, column by
//! column, the oldest row the current y row is still reading. The line
//! buffer is [`LINE_ROWS`] rows deep, as the cost model charges; every read
//! checks the row it finds, so a schedule that overran the buffer fails.
//!
//! A cycle ahead of the first slot (with more than one PE) the PEs drive
//! the first row's edge rays: the prologue.

use golden::geometry::RayGrid;

use super::boundary::{Edges, OnPassBus};

use crate::array::{Array, RunError};
use crate::datapath::Tally;
use crate::pe::{Broadcast, Pe, RayColumn, StepError};

/// Rows of the line buffer (as `crate::cost` charges).
pub const LINE_ROWS: usize = 3;

/// One line-buffer entry: the parent row it holds and the x-filtered
/// R, G, B, A words.
type Entry = Option<(usize, [i64; 4])>;

/// The PE's line buffer: [`LINE_ROWS`] rows of x-filtered children, each
/// entry tagged with the parent row it holds.
#[derive(Debug, Clone, Default)]
pub struct LineBuffer {
    slots: Vec<Vec<Entry>>,
}

impl LineBuffer {
    /// Empties the buffer for rows of `width` entries.
    fn reset(&mut self, width: usize) {
        self.slots.resize(LINE_ROWS, Vec::new());
        for s in &mut self.slots {
            s.clear();
            s.resize(width, None);
        }
    }

    /// Writes child `c` of parent row `row`.
    #[inline]
    pub(crate) fn write(&mut self, row: usize, c: usize, v: [i64; 4]) {
        self.slots[row % LINE_ROWS][c] = Some((row, v));
    }

    /// Child `c` of parent row `row`, if the buffer still holds it.
    #[inline]
    pub(crate) fn read(&self, pe: usize, row: usize, c: usize) -> Result<[i64; 4], StepError> {
        match self.slots[row % LINE_ROWS][c] {
            Some((r, v)) if r == row => Ok(v),
            _ => Err(StepError::LineBuffer { pe, row }),
        }
    }

    /// Whether entry `c` holds parent row `row` (its valid bit: the sparse
    /// x pass writes only entries that can be non-zero).
    pub(crate) fn holds(&self, row: usize, c: usize) -> bool {
        matches!(self.slots[row % LINE_ROWS][c], Some((r, _)) if r == row)
    }

    /// Whether entry `c` holds any of parent rows `rows` (relative to the
    /// parent grid, whose `prows` rows the rest fall outside of): the y
    /// pass has something to read for child `c`.
    pub(crate) fn holds_any(
        &self,
        rows: impl IntoIterator<Item = i64>,
        prows: i64,
        c: usize,
    ) -> bool {
        rows.into_iter()
            .any(|row| (0..prows).contains(&row) && self.holds(row as usize, c))
    }

    /// The y pass's `N` taps of child `c`: parent rows `rows` (relative to
    /// the parent grid; rows outside its `prows` read zero), each through
    /// [`LineBuffer::read`], or [`LineBuffer::read_sparse`] when `sparse`.
    #[inline]
    pub(crate) fn taps<const N: usize>(
        &self,
        pe: usize,
        rows: [i64; N],
        prows: i64,
        c: usize,
        sparse: bool,
    ) -> Result<[[i64; 4]; N], StepError> {
        let mut taps = [[0i64; 4]; N];
        for (t, row) in taps.iter_mut().zip(rows) {
            if (0..prows).contains(&row) {
                *t = if sparse {
                    self.read_sparse(pe, row as usize, c)?
                } else {
                    self.read(pe, row as usize, c)?
                };
            }
        }
        Ok(taps)
    }

    /// The sparse y pass's read: entry `c` of parent row `row`, zero when
    /// the x pass left it unwritten (the entry is empty or holds an older
    /// row); a newer row there means the schedule overran the buffer.
    pub(crate) fn read_sparse(
        &self,
        pe: usize,
        row: usize,
        c: usize,
    ) -> Result<[i64; 4], StepError> {
        match self.slots[row % LINE_ROWS][c] {
            Some((r, v)) if r == row => Ok(v),
            Some((r, _)) if r > row => Err(StepError::LineBuffer { pe, row }),
            _ => Ok([0; 4]),
        }
    }
}

/// One cycle of a sparse slot for one PE: the child column, and whether
/// the x pass and the y pass each work it.
pub(crate) type SlotWork = (usize, bool, bool);

/// A PE's registers for the pass in progress.
#[derive(Debug, Clone, Default)]
pub struct PassState {
    /// The child ray indices this PE computes, in order (one per cycle).
    pub children: Vec<i64>,
    /// The line buffer.
    pub line: LineBuffer,
    /// The children's bank of the compositing buffer, being written.
    pub next: Vec<RayColumn>,
    /// Fold: the differences of the row in the x pass, per held column.
    pub(crate) dline: Option<(usize, Vec<[i64; 4]>)>,
    /// Fold: the next row's, formed when its edge is driven.
    pub(crate) dnext: Option<(usize, Vec<[i64; 4]>)>,
    /// Sparse merge: this slot's work list, formed in its first cycle
    /// from the valid bits (one entry a cycle, ascending columns).
    pub(crate) slot: Vec<SlotWork>,
    /// Sparse passes: the neighbours' edge rays of the slot's parent row,
    /// latched in its first cycle ([`Pe::pass_step_sparse`]).
    pub edges: Edges,
    /// The merge's tent events ([`crate::datapath::Datapath::tent_rgba`]),
    /// added to the PE's stats when the merge ends ([`Pe::end_merge`]).
    pub(crate) tents: Tally,
}

impl PassState {
    /// Starts a pass computing `children`, building `next`.
    pub(crate) fn begin(&mut self, children: Vec<i64>, next: Vec<RayColumn>) {
        self.line.reset(children.len());
        self.children = children;
        self.next = next;
        self.dline = None;
        self.dnext = None;
        self.slot.clear();
    }
}

impl Pe {
    /// Forms a sparse slot's work list, in ascending child order: `work(pe,
    /// c)` says whether the x pass and the y pass each have child `c` to
    /// work this slot; children with neither are left out.
    pub(crate) fn set_work_list(
        &mut self,
        work: impl Fn(&Pe, usize) -> Result<(bool, bool), StepError>,
    ) -> Result<(), StepError> {
        let mut slot = std::mem::take(&mut self.pass.slot);
        slot.clear();
        for c in 0..self.pass.children.len() {
            match work(self, c) {
                Ok((x, y)) if x || y => slot.push((c, x, y)),
                Ok(_) => {}
                Err(e) => {
                    self.pass.slot = slot;
                    return Err(e);
                }
            }
        }
        self.pass.slot = slot;
        Ok(())
    }
}

/// What the controller broadcasts in a cycle of a pass.
#[derive(Debug, Clone, Copy, Default)]
pub struct PassBus {
    /// The parent row the x pass filters this cycle.
    pub x: Option<usize>,
    /// The child row the y pass writes this cycle.
    pub y: Option<usize>,
    /// The column (child index) both passes are at.
    pub col: usize,
    /// The parent row whose edge rays the PEs drive this cycle (the x
    /// pass's row next cycle).
    pub drive: Option<usize>,
}

/// One slot of a pass: the x pass's row and the y pass's row, if any.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slot {
    /// Parent row filtered.
    pub x: Option<usize>,
    /// Child row written.
    pub y: Option<usize>,
}

/// The slots of a pass over `prows` parent rows whose child rows need the
/// parent rows `needs[i]` (an inclusive range, `None` when every tap falls
/// outside the parent grid): as soon as possible within the line buffer's
/// depth, child rows that read the buffer in order, and those that read
/// nothing (they are written transparent) in the slots where the y pass
/// would otherwise wait for the x pass, the rest at the end. Parent rows no
/// child row reads are not filtered at all.
pub fn plan_slots(prows: usize, needs: &[Option<(usize, usize)>]) -> Result<Vec<Slot>, RunError> {
    let lows: Vec<Option<usize>> = needs.iter().map(|n| n.map(|n| n.0)).collect();
    plan_slots_where(prows, needs, &lows, |_| true, true)
}

/// [`plan_slots`] filtering only the parent rows `filtered` accepts, and
/// without the child rows that read nothing when `keep_empty` is false
/// (the sparse merge: such rows stay invalid, which reads as zero).
/// `lows[i]` is the lowest parent row child row `i` reads at all, filtered
/// or not: its y pass reads an unfiltered row's entry too (and takes zero
/// from the older row it finds there), so the x pass may not overwrite
/// that entry with a newer row before the child row is written, even
/// though the child row waits only for the filtered rows `needs[i]`.
pub fn plan_slots_where(
    prows: usize,
    needs: &[Option<(usize, usize)>],
    lows: &[Option<usize>],
    filtered: impl Fn(usize) -> bool,
    keep_empty: bool,
) -> Result<Vec<Slot>, RunError> {
    let reading: Vec<(usize, (usize, usize))> = needs
        .iter()
        .enumerate()
        .filter_map(|(i, n)| n.map(|n| (i, n)))
        .collect();
    let mut empty = needs
        .iter()
        .enumerate()
        .filter(|(_, n)| keep_empty && n.is_none())
        .map(|(i, _)| i);
    let xrows: Vec<usize> = (0..prows)
        .filter(|&q| filtered(q) && reading.iter().any(|(_, (lo, hi))| (*lo..=*hi).contains(&q)))
        .collect();
    let mut left = if keep_empty {
        needs.len()
    } else {
        reading.len()
    };
    let (mut xd, mut yd) = (0, 0);
    let mut slots = Vec::with_capacity(xrows.len() + needs.len());
    while xd < xrows.len() || left > 0 {
        let done = |row: usize| xd > 0 && xrows[xd - 1] >= row;
        let ready = reading.get(yd).filter(|(_, (_, hi))| done(*hi));
        let y = match ready {
            Some(&(i, _)) => {
                yd += 1;
                Some(i)
            }
            None => empty.next(),
        };
        // The first reading child row still to come after this slot: the
        // x pass may not overwrite a row it needs.
        let room = |q: usize| {
            q < LINE_ROWS
                || reading.get(yd).is_none_or(|&(i, (lo, _))| {
                    q - LINE_ROWS < lows.get(i).copied().flatten().map_or(lo, |l| l.min(lo))
                })
        };
        let x = xrows.get(xd).copied().filter(|&q| room(q));
        if x.is_none() && y.is_none() {
            return Err(RunError::Schedule(format!(
                "pass stuck at parent row {} of {prows}, child row {yd} of {}",
                xrows.get(xd).copied().unwrap_or(prows),
                reading.len()
            )));
        }
        xd += usize::from(x.is_some());
        left -= usize::from(y.is_some());
        slots.push(Slot { x, y });
    }
    Ok(slots)
}

/// The parent rows each child row of `child` reads through the tent
/// `2 my - 1 ..= 2 my + 1` of `parent`'s rows (the merge's and the fold's
/// y pass).
pub(crate) fn tent_needs(child: &RayGrid, parent: &RayGrid) -> Vec<Option<(usize, usize)>> {
    let prows = parent.counts()[1];
    (child.lo[1]..=child.hi[1])
        .map(|my| inside((2 * my - 1..=2 * my + 1).map(|py| py - parent.lo[1]), prows))
        .collect()
}

/// The parent rows `taps` (relative to the parent grid) that fall inside
/// its `prows` rows, as an inclusive range.
pub(crate) fn inside(taps: impl Iterator<Item = i64>, prows: usize) -> Option<(usize, usize)> {
    let rows: Vec<usize> = taps
        .filter(|&r| r >= 0 && (r as usize) < prows)
        .map(|r| r as usize)
        .collect();
    Some((*rows.iter().min()?, *rows.iter().max()?))
}

impl Array {
    /// Runs a pass over `prows` parent rows whose child rows need
    /// `needs`: the controller broadcasts `begin` (each PE reports how many
    /// children it computes; the slots are as wide as the most), clocks
    /// the prologue and the slots, each PE running `step` (its stage's)
    /// on the cycle's bus, and broadcasts `end` (the bank select).
    pub(crate) fn run_pass(
        &mut self,
        (prows, needs): (usize, &[Option<(usize, usize)>]),
        begin: Broadcast<'_>,
        step: &mut impl OnPassBus,
        end: Broadcast<'_>,
    ) -> Result<(), RunError> {
        let width = self.begin_pass(begin);
        let slots = plan_slots(prows, needs)?;
        self.clock_slots(width, &slots, step)?;
        self.clock.broadcast(&end);
        Ok(())
    }

    /// Broadcasts the start of a pass; the widest PE's row length.
    pub(super) fn begin_pass(&mut self, begin: Broadcast<'_>) -> usize {
        self.clock.broadcast(&begin);
        self.clock
            .reports()
            .map(|r| r.pass_width as usize)
            .max()
            .unwrap_or(0)
    }

    /// [`Array::run_pass`] with the PEs' work lists setting each slot's
    /// length (`pass_skip_empty`), over `slots` the caller planned
    /// ([`plan_slots_where`]).
    pub(crate) fn run_sparse_pass(
        &mut self,
        slots: &[Slot],
        begin: Broadcast<'_>,
        step: &mut impl OnPassBus,
        end: Broadcast<'_>,
    ) -> Result<(), RunError> {
        let width = self.begin_pass(begin);
        if width > 0 {
            self.clock_sparse_slots(slots, step)?;
        }
        self.clock.broadcast(&end);
        Ok(())
    }

    /// Whether a pass over `slots` has a prologue: several PEs, and a first
    /// slot that filters a parent row.
    pub(super) fn has_prologue(&self, slots: &[Slot]) -> bool {
        self.clock.pes().len() > 1 && slots.first().and_then(|s| s.x).is_some()
    }

    /// The cycle ahead of a pass's first slot (with more than one PE) in
    /// which the PEs drive the first row's edge rays.
    fn prologue(&mut self, slots: &[Slot], step: &mut impl OnPassBus) -> Result<(), RunError> {
        let first = slots.first().and_then(|s| s.x);
        if self.has_prologue(slots) {
            let bus = PassBus {
                drive: first,
                ..PassBus::default()
            };
            step.show(bus, 0);
            self.clock.tick(step)?;
        }
        Ok(())
    }

    /// Clocks `slots` whose lengths the PEs' work lists set (the sparse
    /// merge): in a slot's first cycle every PE forms its list and drives
    /// the next slot's edge rays (its neighbours latched this slot's in
    /// the same cycle); the slot ends after the cycle in which the last
    /// PE works its last entry (the PEs' done lines, an AND tree like the
    /// sampling's report lines). The prologue drives the first row's edges.
    fn clock_sparse_slots(
        &mut self,
        slots: &[Slot],
        step: &mut impl OnPassBus,
    ) -> Result<(), RunError> {
        self.prologue(slots, step)?;
        for (s, slot) in slots.iter().enumerate() {
            let after = slots.get(s + 1).and_then(|n| n.x);
            let shown = slot.x.or(slot.y).unwrap_or(0);
            for col in 0.. {
                let bus = PassBus {
                    x: slot.x,
                    y: slot.y,
                    col,
                    drive: after,
                };
                step.show(bus, shown);
                self.clock.tick(step)?;
                if self
                    .clock
                    .reports()
                    .all(|r| r.slot_work as usize <= col + 1)
                {
                    break;
                }
            }
        }
        Ok(())
    }

    /// Clocks `slots` of `width` cycles (after the prologue).
    fn clock_slots(
        &mut self,
        width: usize,
        slots: &[Slot],
        step: &mut impl OnPassBus,
    ) -> Result<(), RunError> {
        if width == 0 {
            return Ok(());
        }
        self.prologue(slots, step)?;
        for (s, slot) in slots.iter().enumerate() {
            let after = slots.get(s + 1).and_then(|n| n.x);
            let shown = slot.x.or(slot.y).unwrap_or(0);
            for col in 0..width {
                let bus = PassBus {
                    x: slot.x,
                    y: slot.y,
                    col,
                    drive: if col + 1 < width { slot.x } else { after },
                };
                step.show(bus, shown);
                self.clock.tick(step)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A merge's child rows read parent rows `2i - 1 ..= 2i + 1`: the x
    /// pass runs every slot, the y pass every other one, and the last
    /// child row drains after the x pass.
    #[test]
    fn merge_shaped_pass_fits_three_rows() {
        let prows = 9;
        let needs: Vec<_> = (0..5)
            .map(|i: i64| inside(2 * i - 1..=2 * i + 1, prows))
            .collect();
        let slots = plan_slots(prows, &needs).unwrap();
        let xs: Vec<_> = slots.iter().filter_map(|s| s.x).collect();
        let ys: Vec<_> = slots.iter().filter_map(|s| s.y).collect();
        assert_eq!(xs, (0..9).collect::<Vec<_>>());
        assert_eq!(ys, (0..5).collect::<Vec<_>>());
        // y row i runs in the slot after x row 2i + 1 (clamped to 8).
        for (s, slot) in slots.iter().enumerate() {
            if let Some(i) = slot.y {
                let hi = needs[i].unwrap().1;
                let done = slots[..s].iter().filter(|t| t.x.is_some()).count();
                assert!(hi < done, "slot {s}: y row {i} before x row {hi}");
            }
        }
        assert_eq!(slots.len(), 10);
    }

    /// Nothing to read makes a child row ready at once; a pass with no
    /// rows has no slots; parent rows nobody reads are not filtered.
    #[test]
    fn empty_taps_and_empty_pass() {
        assert_eq!(plan_slots(0, &[]).unwrap(), vec![]);
        let slots = plan_slots(6, &[Some((2, 3))]).unwrap();
        let xs: Vec<_> = slots.iter().filter_map(|s| s.x).collect();
        assert_eq!(xs, vec![2, 3]);
        assert_eq!(slots.last().unwrap().y, Some(0));
        let slots = plan_slots(1, &[None, Some((0, 0))]).unwrap();
        assert_eq!(
            slots,
            vec![
                Slot {
                    x: Some(0),
                    y: Some(0)
                },
                Slot {
                    x: None,
                    y: Some(1)
                }
            ]
        );
    }

    /// The sparse merge's plan: parent rows the filter refuses are never
    /// filtered, child rows that read none are not written at all, and the
    /// rest keep the dense plan's order within the line buffer's depth.
    #[test]
    fn sparse_plan_skips_empty_rows() {
        let prows = 9;
        let live = [false, false, true, true, false, false, false, true, false];
        let needs: Vec<_> = (0..5i64)
            .map(|i| {
                inside(
                    (2 * i - 1..=2 * i + 1)
                        .filter(|&r| (0..prows as i64).contains(&r) && live[r as usize]),
                    prows,
                )
            })
            .collect();
        assert_eq!(
            needs,
            vec![None, Some((2, 3)), Some((3, 3)), Some((7, 7)), Some((7, 7))]
        );
        let lows: Vec<Option<usize>> = needs.iter().map(|n| n.map(|n| n.0)).collect();
        let slots = plan_slots_where(prows, &needs, &lows, |q| live[q], false).unwrap();
        let xs: Vec<_> = slots.iter().filter_map(|s| s.x).collect();
        let ys: Vec<_> = slots.iter().filter_map(|s| s.y).collect();
        assert_eq!(xs, vec![2, 3, 7]);
        assert_eq!(ys, vec![1, 2, 3, 4]);
        let dense: Vec<_> = (0..5i64)
            .map(|i| inside(2 * i - 1..=2 * i + 1, prows))
            .collect();
        // x 2; x 3; y 1 (row 7 would overwrite row 2's slot); x 7 with
        // y 2; y 3; y 4: six slots against the dense plan's ten.
        assert_eq!(slots.len(), 6);
        assert_eq!(plan_slots(prows, &dense).unwrap().len(), 10);
    }

    /// The sparse read: a written entry, zero for one the x pass skipped
    /// (empty or an older row), and a refusal for a newer row (overrun).
    #[test]
    fn sparse_reads_treat_skipped_entries_as_zero() {
        let mut b = LineBuffer::default();
        b.reset(2);
        assert_eq!(b.read_sparse(0, 0, 0).unwrap(), [0; 4]);
        b.write(1, 0, [1, 2, 3, 4]);
        assert!(b.holds(1, 0) && !b.holds(4, 0));
        assert_eq!(b.read_sparse(0, 1, 0).unwrap(), [1, 2, 3, 4]);
        assert_eq!(b.read_sparse(0, 4, 0).unwrap(), [0; 4]);
        b.write(4, 0, [5; 4]);
        assert!(b.read_sparse(0, 1, 0).is_err());
    }

    /// Rows the schedule let the x pass overwrite are refused on read.
    #[test]
    fn line_buffer_checks_rows() {
        let mut b = LineBuffer::default();
        b.reset(2);
        b.write(0, 1, [1, 2, 3, 4]);
        assert_eq!(b.read(0, 0, 1).unwrap(), [1, 2, 3, 4]);
        b.write(3, 1, [5; 4]);
        assert!(b.read(0, 0, 1).is_err());
        assert!(b.read(0, 0, 0).is_err());
    }
}
