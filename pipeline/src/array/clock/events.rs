//! The untraced migration between slices, from its link queues'
//! departures instead of cycle by cycle: the moves, the cycles and the
//! counters [`Pe::migrate_step`]'s clock gives (the clocked-against-untraced
//! frame tests compare every field), at a cost per ray row moved instead
//! of per PE and cycle, and with each column moved whole (what the
//! receiver rebuilds from its rows).
//!
//! Each PE's two link queues are FIFOs that send one ray row per cycle:
//! a row enqueued in cycle `e` whose last sample lands in `land` leaves
//! in `d = max(free, e, land)`, `free` being the cycle after the queue's
//! previous departure, and the cycles from `max(free, e)` to `d` are the
//! front's waits. It arrives at the neighbour in `d + 1` (readable from
//! `d + 2`); a column is whole with its last row, and is held there or
//! enqueued onwards in that cycle, behind what that queue holds. A queue's
//! enqueues come in time order, so handling every column's arrival in
//! time order (a heap) reproduces the clock. The link queue counter sums,
//! over the cycles, the rows queued and not sent: each row's `d - e`, less
//! one per waiting cycle.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::mapping::Route;
use crate::pe::{Pe, RayColumn};
use crate::stages::migrate::stays;

/// A link queue of PE `k`: 0 sends left, 1 right.
type Side = usize;

/// Where a column in flight arrives: the cycle, the receiving PE, whether
/// it came from that PE's right (the clock's step takes the left link's
/// arrival first), then its index in the columns in flight.
type Arrival = Reverse<(u64, usize, bool, usize)>;

/// The migration's running state: each queue's next free cycle, each
/// PE's waiting intervals, the columns in flight and the last departure.
struct Links {
    route: Route,
    free: Vec<[u64; 2]>,
    waits: Vec<Vec<(u64, u64)>>,
    flying: Vec<Option<RayColumn>>,
    heap: BinaryHeap<Arrival>,
    last: Option<u64>,
}

impl Links {
    /// Sends column `c` from PE `k`'s queue `side`, enqueued in cycle `e`,
    /// row by row as [`super::queue`] splits it: each row's departure, the
    /// sender's and the receiver's counters, and the column's arrival at
    /// the neighbour (the column as the receiver rebuilds it from the
    /// moves: each sent row readable from the cycle after it arrives, the
    /// rows left behind never written, the previous samples kept only when
    /// one is not zero).
    fn send(&mut self, pes: &mut [Pe], (k, side): (usize, Side), mut c: RayColumn, e: u64) {
        let nb = self.route.next(k, side == 1);
        let sparse = pes[k].sparse_links;
        let rows = c.acc.len();
        let mut free = self.free[k][side];
        let (mut queued, mut n) = (0, 0);
        for row in 0..rows {
            if sparse && stays(&c, row) {
                c.land[row] = 0;
                continue;
            }
            // The row is the queue's front from `from` on, and leaves once
            // its last sample has been written back.
            let from = free.max(e);
            let d = from.max(c.land[row]);
            if d > from {
                self.waits[k].push((from, d));
            }
            // Queued and not sent: every cycle from `e` to `d` but the
            // waiting ones, in which the front is not counted.
            queued += from - e;
            free = d + 1;
            // Received in `d + 1`, readable from the next cycle.
            c.land[row] = d + 2;
            n += 1;
        }
        if n == 0 {
            // A column without rows sends nothing (nor does the clock).
            return;
        }
        if c.prev.iter().all(|&p| p == 0) {
            c.prev = Vec::new();
        }
        let at = self.flying.len();
        self.heap.push(Reverse((free, nb, side == 0, at)));
        self.flying.push(Some(c));
        self.free[k][side] = free;
        self.last = Some(self.last.map_or(free - 1, |l| l.max(free - 1)));
        pes[k].counters.rays_sent += n;
        pes[k].counters.link_queue += queued;
        pes[nb].counters.rays_received += n;
        pes[nb].model.arrived_by = pes[nb].model.arrived_by.max(free + 1);
    }
}

/// Runs the migration to the owners `owner` gives along `route` on
/// `pes` from cycle `start` (every PE's link queues and `incoming` empty):
/// every ray ends in its owner, each PE's counters grow by what the clock
/// counts. Returns the cycles the clock ticks.
pub(super) fn migrate_events(
    pes: &mut [Pe],
    start: u64,
    owner: impl Fn(i64) -> usize,
    route: Route,
) -> u64 {
    debug_assert!(pes.iter().all(Pe::settled));
    let p = pes.len();
    let mut links = Links {
        route,
        free: vec![[start; 2]; p],
        waits: vec![Vec::new(); p],
        flying: Vec::new(),
        heap: BinaryHeap::new(),
        last: None,
    };
    for k in 0..p {
        let leaving = pes[k].take_leaving(&owner, route);
        for (side, cols) in leaving.into_iter().enumerate() {
            for c in cols {
                links.send(pes, (k, side), c, start);
            }
        }
    }
    while let Some(Reverse((t, k, from_right, at))) = links.heap.pop() {
        let col = links.flying[at].take().expect("each column arrives once");
        let dest = owner(col.mx);
        let pe = &mut pes[k];
        if dest == k {
            let at = pe.rays.partition_point(|c| c.mx < col.mx);
            pe.rays.insert(at, col);
            continue;
        }
        // Passing through: on along a line, the way it came around a ring
        // (as [`Pe::migrate_step`] forwards it).
        let side = match route {
            Route::Line => usize::from(dest > k),
            Route::Ring(_) => usize::from(!from_right),
        };
        links.send(pes, (k, side), col, t);
    }
    for (pe, waits) in pes.iter_mut().zip(&mut links.waits) {
        // A cycle in which either queue's front waits counts once.
        waits.sort_unstable();
        let (mut n, mut upto) = (0, 0);
        for &(a, b) in waits.iter() {
            n += b.saturating_sub(a.max(upto));
            upto = upto.max(b);
        }
        pe.counters.waits += n;
        pe.note_occupancy();
    }
    // The last row is received the cycle after it leaves; the clock stops
    // after that cycle.
    links.last.map_or(0, |d| d + 2 - start)
}
