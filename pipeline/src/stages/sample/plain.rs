//! Plain samples on the whole-slice path through the datapath's
//! [`Kernel`], a slice column by column ([`Pe::sample_columns`]): the PE's
//! half (the rays' addresses, the ownership rules, the voxel and edge
//! reads, the scoreboard and counters) around the kernel's lanes, with
//! the general path's effects. The general path, [`Pe::sample_ray`]'s, is
//! the twin of [`golden::sampling::sample_at`]; this is how the model
//! evaluates it quickly, not a second datapath.

use super::edges::EdgeWords;
use super::pe::RowBus;
use crate::datapath::{Batch, Kernel, Ray, Tally, LANES};
use rayon::prelude::*;

use crate::pe::{Pe, RayColumn, VoxelMem};

/// What the plain samples of a slice add to a PE's counters, kept in
/// registers while the slice samples and added once at its end (sums and
/// a maximum, which commute with the general path's own updates).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct PlainCounts {
    samples: u64,
    mem_reads: u64,
    edge_voxels: u64,
    drained_at: u64,
}

impl PlainCounts {
    fn add(&mut self, o: &PlainCounts) {
        self.samples += o.samples;
        self.mem_reads += o.mem_reads;
        self.edge_voxels += o.edge_voxels;
        self.drained_at = self.drained_at.max(o.drained_at);
    }
}

impl Pe {
    /// Adds a slice's plain samples' counts to the PE's counters.
    pub(super) fn add_plain_counts(&mut self, n: &PlainCounts) {
        self.counters.busy += n.samples;
        self.counters.samples += n.samples;
        self.counters.mem_reads += n.mem_reads;
        self.counters.edge_voxels += n.edge_voxels;
        self.drained_at = self.drained_at.max(n.drained_at);
    }
}

/// The whole-slice path's buckets for sampling a slice column by column:
/// each held column's samples (slice row and issue cycle), reused from
/// slice to slice.
#[derive(Debug, Clone, Default)]
pub struct ColumnOrder {
    /// Where each active column's samples start in `items` (one more
    /// entry than columns).
    starts: Vec<u32>,
    /// `(slice row, issue cycle)` of every sample, column after column,
    /// each column's in row order.
    items: Vec<(u32, u64)>,
    /// The next free entry of each column while bucketing.
    at: Vec<u32>,
}

/// Where a column's voxel taps lie in a PE's memory `[z][y][l]`: the
/// local columns of `c0` and (when held) `c1`, in slice `z`.
struct Taps {
    cols: [usize; 2],
    held: bool,
    z: usize,
    ny: usize,
    width: usize,
}

impl Taps {
    /// Loads the taps of each of `chunk`'s rows into `b`'s lanes
    /// (`read`: the word at a memory index), with the right neighbour's
    /// edge voxels where the PE does not hold `c1`, and the rows' y
    /// weights and slope terms.
    #[inline(always)]
    fn load(
        &self,
        read: impl Fn(usize) -> u16,
        chunk: &[(u32, u64)],
        rows: &[RowBus],
        right_edges: Option<&[EdgeWords]>,
        b: &mut Batch,
    ) {
        for (l, &(r, _)) in chunk.iter().enumerate() {
            let bus = &rows[r as usize];
            let (y0, y1, _) = bus.y;
            let base = |y: usize| (self.z * self.ny + y) * self.width;
            let (base0, base1) = (base(y0), base(y1));
            b.v[0][l] = i64::from(read(base0 + self.cols[0]));
            b.v[2][l] = i64::from(read(base1 + self.cols[0]));
            let right = if self.held {
                [read(base0 + self.cols[1]), read(base1 + self.cols[1])]
            } else {
                right_edges.map_or([0; 2], |e| e[r as usize].left)
            };
            b.v[1][l] = i64::from(right[0]);
            b.v[3][l] = i64::from(right[1]);
            let (wy, yz) = bus.plain.map_or((0, 0), |p| p.lane_constants());
            b.wy[l] = wy;
            b.yz[l] = yz;
        }
    }
}

impl ColumnOrder {
    /// Active column `c`'s samples.
    fn column(&self, c: usize) -> &[(u32, u64)] {
        &self.items[self.starts[c] as usize..self.starts[c + 1] as usize]
    }
}

/// The samples a PE's slice needs before its columns are sampled in
/// parallel (below, the column loop's overhead outweighs the gain).
const PARALLEL_SAMPLES: usize = 4096;

/// What every column of a slice's column-major sampling shares.
struct ColumnJob<'a> {
    kernel: &'a Kernel,
    rows: &'a [RowBus<'a>],
    right_edges: Option<&'a [EdgeWords]>,
    latency: u64,
    z: usize,
    ny: usize,
    width: usize,
    /// Each column's local index in the PE's memory.
    locals: &'a [u32],
}

impl ColumnJob<'_> {
    /// Samples column `col` (its address and taps `taps`) at its rows
    /// `items`, counting into `out`.
    fn column(
        &self,
        mem: &VoxelMem,
        col: &mut RayColumn,
        &(ray, t, c0, c1, held): &ColumnTaps,
        items: &[(u32, u64)],
        (total, n): &mut (Tally, PlainCounts),
    ) {
        if items.is_empty() {
            return;
        }
        let k = items.len() as u64;
        // The address's events, once per sample.
        total.add_times(&t, k);
        n.samples += k;
        n.mem_reads += k * if held { 4 } else { 2 };
        n.edge_voxels += if held { 0 } else { 2 * k };
        let mut b = Batch {
            wx: ray.wx,
            slope: ray.slope,
            ..Batch::default()
        };
        let local = |c: usize| self.locals[c] as usize;
        // The taps' local columns, and the memory read once per column
        // (the voxel words, or the bytes and their words).
        let taps = Taps {
            cols: [local(c0), if held { local(c1) } else { 0 }],
            held,
            z: self.z,
            ny: self.ny,
            width: self.width,
        };
        let rows = self.rows;
        for chunk in items.chunks(LANES) {
            b.n = chunk.len();
            match mem {
                VoxelMem::Words(w) => taps.load(|i| w[i], chunk, rows, self.right_edges, &mut b),
                VoxelMem::Codes { codes, words } => {
                    let read = |i: usize| words[usize::from(codes[i])];
                    taps.load(read, chunk, rows, self.right_edges, &mut b);
                }
            }
            for (l, &(r, now)) in chunk.iter().enumerate() {
                let row = rows[r as usize].row;
                let land = now + self.latency;
                n.drained_at = n.drained_at.max(land);
                col.land[row] = land;
                for (w, &a) in b.acc.iter_mut().zip(&col.acc[row].raw) {
                    w[l] = a;
                }
            }
            b.pad();
            self.kernel.sample_lanes(&mut b, total);
            for (l, &(r, _)) in chunk.iter().enumerate() {
                if b.visible[l] {
                    let row = rows[r as usize].row;
                    for (a, w) in col.acc[row].raw.iter_mut().zip(&b.acc) {
                        *a = w[l];
                    }
                    if self.kernel.front_to_back() {
                        // The comparator behind the accumulator sets the
                        // flag the next slice's schedule reads.
                        col.ftb[row].done = b.done[l];
                    }
                }
            }
        }
    }
}

/// An active column's address and taps' columns for
/// [`Pe::sample_columns`]: the ray's address, its assignments' events,
/// the clamped columns `c0`, `c1` and whether this PE holds `c1`.
pub(crate) type ColumnTaps = (Ray, Tally, usize, usize, bool);

impl Pe {
    /// Samples a whole slice through `kernel`'s lanes, column by column:
    /// a column's rays in consecutive rows lie side by side in its
    /// accumulator memory, where row by row each sample reads another
    /// column's. The schedule is the row plan's (each sample keeps its
    /// issue cycle); the order the model evaluates them in cannot matter,
    /// since every sample reads and writes its own ray only. Returns
    /// `false`, having changed nothing, when a column's address does not
    /// fit the kernel or breaks the ownership rules: the caller then
    /// samples the slice row by row (which reports an error in issue
    /// order).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn sample_columns(
        &mut self,
        kernel: &Kernel,
        rows: &[RowBus],
        (lens, starts): (&[usize], &[u64]),
        right_edges: Option<&[EdgeWords]>,
        (nx, latency): (usize, u64),
        (total, n): (&mut Tally, &mut PlainCounts),
    ) -> bool {
        let Some(row0) = rows.iter().find_map(|b| b.plain) else {
            return true;
        };
        let (first, count) = self.active;
        // Each active column's address and taps' columns, once: they do
        // not depend on the row.
        let mut cols = std::mem::take(&mut self.model.plain_cols);
        cols.clear();
        let last = nx as i64 - 1;
        for j in first..first + count {
            let mut t = Tally::default();
            let Some(ray) = kernel.address(&row0, self.rays[j].mx, &mut t) else {
                self.model.plain_cols = cols;
                return false;
            };
            let (c0, c1) = (
                ray.x0.max(0).min(last) as usize,
                (ray.x0 + 1).max(0).min(last) as usize,
            );
            let held = self.holds(c1);
            if !self.owns(c0) || !(held || c1 == self.cols.end) {
                self.model.plain_cols = cols;
                return false;
            }
            cols.push((ray, t, c0, c1, held));
        }
        // Bucket the row plan's samples by column (a counting sort).
        let mut order = std::mem::take(&mut self.model.plain_order);
        order.starts.clear();
        order.starts.resize(count + 1, 0);
        for (r, &len) in lens.iter().enumerate() {
            self.begin_row(r);
            if len == 0 {
                continue;
            }
            let span = self.row_plan.span(r);
            self.counters.idle += (len - span.len()) as u64;
            for &j in &self.row_plan.live[span] {
                order.starts[j - first + 1] += 1;
            }
        }
        for c in 0..count {
            order.starts[c + 1] += order.starts[c];
        }
        order.items.resize(order.starts[count] as usize, (0, 0));
        order.at.clear();
        order.at.extend_from_slice(&order.starts[..count]);
        for (r, &len) in lens.iter().enumerate() {
            if len == 0 {
                continue;
            }
            let span = self.row_plan.span(r);
            for (c, &j) in self.row_plan.live[span].iter().enumerate() {
                let slot = &mut order.at[j - first];
                order.items[*slot as usize] = (r as u32, starts[r] + c as u64);
                *slot += 1;
            }
        }
        let job = ColumnJob {
            kernel,
            rows,
            right_edges,
            latency,
            z: rows[0].slice.z,
            ny: self.ny,
            width: self.held_columns(),
            locals: &self.local,
        };
        let mem = &self.mem;
        let active = &mut self.rays.make_contiguous()[first..first + count];
        let work = |(c, col): (usize, &mut RayColumn)| {
            let mut out = (Tally::default(), PlainCounts::default());
            job.column(mem, col, &cols[c], order.column(c), &mut out);
            out
        };
        let join = |mut a: (Tally, PlainCounts), b: (Tally, PlainCounts)| {
            a.0.add(&b.0);
            a.1.add(&b.1);
            a
        };
        let zero = || (Tally::default(), PlainCounts::default());
        // Columns share nothing: a big slice's spread over the threads.
        let (t, c) = if order.items.len() >= PARALLEL_SAMPLES {
            active
                .par_iter_mut()
                .enumerate()
                .map(work)
                .reduce(zero, join)
        } else {
            active.iter_mut().enumerate().map(work).fold(zero(), join)
        };
        total.add(&t);
        n.add(&c);
        self.model.plain_cols = cols;
        self.model.plain_order = order;
        true
    }
}
