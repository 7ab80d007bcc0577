//! One side's link queue: the bounded link FIFO (`link_fifo` in
//! [`Pe::declaration`](crate::pe::Pe::declaration), depth
//! `link_fifo_depth`) and, behind it, the rows of the leaving columns that
//! are still in the compositing buffer.
//!
//! A chip cannot copy every leaving column into a queue at once, so the
//! rows wait where they already are, in the compositing buffer, and the
//! PE's feed reads them into the FIFO in order, one row a cycle (per
//! lane), while the FIFO has room. The feed runs ahead of the send in the
//! cycle (the buffer's read port is the link's; the model takes the read
//! and the send in one cycle, as it always took the copy and the send),
//! so the row at the FIFO's front is always the queue's next row: the
//! link sends exactly the rows, in exactly the cycles, of an unbounded
//! queue, at every depth from 1. The bound never stalls a link and so
//! cannot deadlock one: a receiver never refuses a row (it writes it into
//! its compositing buffer), and a full FIFO only holds back its own
//! PE's feed, which waits for that FIFO's front to leave, which waits
//! only for its own last sample's write-back (the scoreboard), never for
//! another PE.

use std::collections::VecDeque;

use crate::hw::state::Fifo;
use crate::pe::RayMove;

/// A row queued to leave: the move and the cycle from which it may (its
/// last sample written back).
pub(crate) type Row = (RayMove, u64);

/// The link FIFO of one side and the rows still to feed into it.
#[derive(Debug, Clone)]
pub struct LinkQueue {
    /// The FIFO of the declared depth.
    fifo: Fifo<Row>,
    /// Rows still in the compositing buffer, in the order they leave (the
    /// model's copy of what the chip reads by address).
    waiting: VecDeque<Row>,
    /// The most rows the FIFO held (a probe).
    peak: usize,
    /// Cycles in which the feed had a row but the FIFO was full (the
    /// front waiting for its write-back).
    feed_stalls: u64,
    /// Columns whose last row is still queued: they keep their slot in
    /// the compositing buffer until it leaves (the occupancy probe).
    columns: usize,
    /// Their rows in all, and the most rows one had.
    rows: (u64, u64),
}

impl LinkQueue {
    /// An empty queue whose FIFO holds `depth` rows.
    pub fn new(depth: usize) -> LinkQueue {
        LinkQueue {
            fifo: Fifo::new(depth),
            waiting: VecDeque::new(),
            peak: 0,
            feed_stalls: 0,
            columns: 0,
            rows: (0, 0),
        }
    }

    /// Queues a row of a leaving column (it stays in the compositing
    /// buffer until the feed reads it).
    pub(crate) fn enqueue(&mut self, row: Row) {
        if row.0.row + 1 == row.0.rows {
            self.columns += 1;
            self.rows.0 += u64::from(row.0.rows);
            self.rows.1 = self.rows.1.max(u64::from(row.0.rows));
        }
        self.waiting.push_back(row);
    }

    /// One cycle's feed: the next waiting row into the FIFO if it has
    /// room; a full FIFO holds the row back (a feed stall).
    pub(crate) fn feed(&mut self) {
        let Some(row) = self.waiting.pop_front() else {
            return;
        };
        match self.fifo.push(row) {
            Ok(()) => self.peak = self.peak.max(self.fifo.len()),
            Err(_) => {
                self.waiting.push_front(row);
                self.feed_stalls += 1;
            }
        }
    }

    /// The row at the FIFO's front.
    pub(crate) fn front(&self) -> Option<&Row> {
        self.fifo.front()
    }

    /// Sends the FIFO's front row.
    pub(crate) fn pop(&mut self) -> Option<Row> {
        let row = self.fifo.pop()?;
        if row.0.row + 1 == row.0.rows {
            self.columns -= 1;
            self.rows.0 -= u64::from(row.0.rows);
        }
        Some(row)
    }

    /// Leaving columns whose last row has not left yet (each still holds
    /// its slot in the compositing buffer).
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// Rows of those columns in all, and the most rows one has had.
    pub fn column_rows(&self) -> (u64, u64) {
        self.rows
    }

    /// Rows queued: in the FIFO and still to feed.
    pub fn len(&self) -> usize {
        self.fifo.len() + self.waiting.len()
    }

    /// Whether no row is queued.
    pub fn is_empty(&self) -> bool {
        self.fifo.is_empty() && self.waiting.is_empty()
    }

    /// The FIFO's declared depth.
    pub fn depth(&self) -> usize {
        self.fifo.depth()
    }

    /// The most rows the FIFO has held.
    pub fn peak(&self) -> usize {
        self.peak
    }

    /// Cycles the feed waited for room.
    pub fn feed_stalls(&self) -> u64 {
        self.feed_stalls
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(i: u32, land: u64) -> Row {
        let m = RayMove {
            mx: 0,
            row: i,
            rows: 8,
            acc: Default::default(),
            ftb: None,
            prev: 0,
        };
        (m, land)
    }

    /// Fed before each send, a FIFO of depth 1 sends the rows in order,
    /// one a cycle; while the front waits the feed fills the FIFO to its
    /// depth and stalls, and the FIFO never holds more than that.
    #[test]
    fn the_feed_keeps_the_front_next_and_the_fifo_within_its_depth() {
        for depth in [1, 2, 3] {
            let mut q = LinkQueue::new(depth);
            for i in 0..6 {
                // Row 2 may leave only from cycle 10.
                q.enqueue(row(i, if i == 2 { 10 } else { 0 }));
            }
            let mut sent = Vec::new();
            for now in 0..20 {
                q.feed();
                assert!(q.fifo.len() <= depth);
                if let Some(&(m, land)) = q.front() {
                    if land <= now {
                        q.pop();
                        sent.push((m.row, now));
                    }
                }
            }
            assert_eq!(
                sent,
                [(0, 0), (1, 1), (2, 10), (3, 11), (4, 12), (5, 13)],
                "depth {depth}"
            );
            assert_eq!(q.peak(), depth);
            assert!(q.is_empty());
            // The front waited cycles 2..10 with the FIFO full from the
            // cycle it reached its depth.
            assert_eq!(q.feed_stalls(), 8 - (depth as u64 - 1));
        }
    }
}
