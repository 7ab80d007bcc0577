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

/// The whole-slice path's table of a slice's sampled rows for sampling it
/// column by column, reused from slice to slice: each row's constants
/// (from its broadcast) and which active columns sample in it when.
#[derive(Debug, Clone, Default)]
pub struct ColumnOrder {
    rows: Vec<PlainRow>,
}

/// A sampled row of a slice as the column loop reads it.
#[derive(Debug, Clone, Copy, Default)]
struct PlainRow {
    /// The row's index in the slice (its bus and its edge words).
    r: u32,
    /// Its row in the region's buffer (the rays' accumulators and
    /// scoreboards).
    row: u32,
    /// Its first and last sampled column (active columns, counted from
    /// the first).
    lo: u32,
    hi: u32,
    /// Where its columns start in the row plan's `live`, and how many
    /// (all of `lo..=hi` when `hi - lo + 1`: then a column's place in the
    /// row is its distance from `lo`).
    at: u32,
    len: u32,
    /// The memory indices of its taps' voxel rows `y0`, `y0 + 1` in the
    /// slice, before the column.
    base: [usize; 2],
    /// Its y weight word and `sy^2 + sz^2` ([`crate::datapath::KernelRow`]).
    wy: i64,
    yz: i64,
    /// The cycle its first sample issues.
    start: u64,
}

impl PlainRow {
    /// Where column `c` (an active column's index from the first, held
    /// ray `j`) samples in this row, `None` when it does not: its place
    /// in the row's issue order, the distance from `lo` when the row
    /// samples every column between its ends, else found in the row's
    /// `live` columns.
    #[inline(always)]
    fn place(&self, c: u32, j: usize, live: &[usize]) -> Option<u32> {
        if c < self.lo || c > self.hi {
            return None;
        }
        if self.hi - self.lo + 1 == self.len {
            return Some(c - self.lo);
        }
        let at = self.at as usize;
        live[at..at + self.len as usize]
            .binary_search(&j)
            .ok()
            .map(|p| p as u32)
    }
}

/// Where a column's voxel taps lie in a PE's memory `[z][y][l]`: the
/// local columns of `c0` and (when held) `c1`, in the slice.
struct Taps {
    cols: [usize; 2],
    held: bool,
}

impl Taps {
    /// Loads the taps of a sample in row `row` into lane `l` of `b`
    /// (`read`: the word at a memory index), with the right neighbour's
    /// edge voxels where the PE does not hold `c1`, and the row's y
    /// weight and slope term.
    #[inline(always)]
    fn load(
        &self,
        read: &impl Fn(usize) -> u16,
        row: &PlainRow,
        right_edges: Option<&[EdgeWords]>,
        b: &mut Batch,
        l: usize,
    ) {
        let [base0, base1] = row.base;
        b.v[0][l] = i64::from(read(base0 + self.cols[0]));
        b.v[2][l] = i64::from(read(base1 + self.cols[0]));
        let right = if self.held {
            [read(base0 + self.cols[1]), read(base1 + self.cols[1])]
        } else {
            right_edges.map_or([0; 2], |e| e[row.r as usize].left)
        };
        b.v[1][l] = i64::from(right[0]);
        b.v[3][l] = i64::from(right[1]);
        b.wy[l] = row.wy;
        b.yz[l] = row.yz;
    }
}

/// The samples a PE's slice needs before its columns are sampled in
/// parallel (below, the column loop's overhead outweighs the gain).
const PARALLEL_SAMPLES: usize = 4096;

/// PEs per thread from which the PEs' slices, which the clock samples in
/// parallel, keep the threads busy without splitting a PE's columns too.
const PES_PER_THREAD: usize = 4;

/// What every column of a slice's column-major sampling shares.
struct ColumnJob<'a> {
    kernel: &'a Kernel,
    /// The slice's sampled rows.
    rows: &'a [PlainRow],
    /// The row plan's columns, row after row.
    live: &'a [usize],
    right_edges: Option<&'a [EdgeWords]>,
    latency: u64,
    /// The first active column's index into the rays.
    first: usize,
    /// Each column's local index in the PE's memory.
    locals: &'a [u32],
}

impl ColumnJob<'_> {
    /// Samples active column `c` (its address and taps `taps`) in every
    /// row that samples it, in row order, counting into `out`.
    fn column(
        &self,
        mem: &VoxelMem,
        col: &mut RayColumn,
        c: usize,
        taps: &ColumnTaps,
        out: &mut (Tally, PlainCounts),
    ) {
        // The memory read once per column (the voxel words, or the bytes
        // and their words), each case its own loop.
        match mem {
            VoxelMem::Words(w) => self.column_with(|i| w[i], col, c, taps, out),
            VoxelMem::Codes { codes, words } => {
                let read = |i: usize| words[usize::from(codes[i])];
                self.column_with(read, col, c, taps, out);
            }
        }
    }

    /// [`ColumnJob::column`] reading the memory through `read`: each
    /// sampling row's taps, constants and write-back cycle go straight
    /// into the batch's next lane, eight lanes a batch.
    #[inline(always)]
    fn column_with(
        &self,
        read: impl Fn(usize) -> u16,
        col: &mut RayColumn,
        c: usize,
        &(ray, t, c0, c1, held): &ColumnTaps,
        (total, n): &mut (Tally, PlainCounts),
    ) {
        let mut b = Batch {
            wx: ray.wx,
            slope: ray.slope,
            ..Batch::default()
        };
        let local = |c: usize| self.locals[c] as usize;
        let taps = Taps {
            cols: [local(c0), if held { local(c1) } else { 0 }],
            held,
        };
        let j = self.first + c;
        let mut k = 0;
        // Each lane's row in the region's buffer.
        let mut rows = [0usize; LANES];
        let mut lanes = 0;
        for pr in self.rows {
            let Some(place) = pr.place(c as u32, j, self.live) else {
                continue;
            };
            taps.load(&read, pr, self.right_edges, &mut b, lanes);
            let row = pr.row as usize;
            let land = pr.start + u64::from(place) + self.latency;
            n.drained_at = n.drained_at.max(land);
            col.land[row] = land;
            rows[lanes] = row;
            lanes += 1;
            if lanes == LANES {
                self.batch(col, &rows, &mut b, LANES, total);
                k += LANES as u64;
                lanes = 0;
            }
        }
        if lanes > 0 {
            self.batch(col, &rows, &mut b, lanes, total);
            k += lanes as u64;
        }
        // The address's events, once per sample.
        total.add_times(&t, k);
        n.samples += k;
        n.mem_reads += k * if held { 4 } else { 2 };
        n.edge_voxels += if held { 0 } else { 2 * k };
    }

    /// Samples the first `lanes` lanes of `b` (taps and row constants
    /// loaded, the column's address set), rays in buffer rows `rows`,
    /// through the kernel.
    #[inline(always)]
    fn batch(
        &self,
        col: &mut RayColumn,
        rows: &[usize; LANES],
        b: &mut Batch,
        lanes: usize,
        total: &mut Tally,
    ) {
        b.n = lanes;
        b.pad();
        // The rays' accumulators, read only when some sample is visible.
        let acc = &col.acc;
        let load = |b: &mut Batch| {
            for (l, &row) in rows[..lanes].iter().enumerate() {
                for (w, &a) in b.acc.iter_mut().zip(&acc[row].raw) {
                    w[l] = a;
                }
            }
        };
        self.kernel.sample_lanes_with(b, total, load);
        if b.visible == 0 {
            return;
        }
        for (l, &row) in rows[..lanes].iter().enumerate() {
            if (b.visible >> l) & 1 != 0 {
                for (a, w) in col.acc[row].raw.iter_mut().zip(&b.acc) {
                    *a = w[l];
                }
                if self.kernel.front_to_back() {
                    // The comparator behind the accumulator sets the
                    // flag the next slice's schedule reads.
                    col.ftb[row].done = (b.done >> l) & 1 != 0;
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
        // The sampled rows' table: each row's columns (from its plan) and
        // constants.
        let mut order = std::mem::take(&mut self.model.plain_order);
        order.rows.clear();
        let (z, ny, width) = (rows[0].slice.z, self.ny, self.held_columns());
        let mut samples = 0;
        for (r, &len) in lens.iter().enumerate() {
            self.begin_row(r);
            if len == 0 {
                continue;
            }
            let span = self.row_plan.span(r);
            self.counters.idle += (len - span.len()) as u64;
            let live = &self.row_plan.live[span.clone()];
            let (Some(&lo), Some(&hi)) = (live.first(), live.last()) else {
                continue;
            };
            samples += live.len();
            let bus = &rows[r];
            let (wy, yz) = bus.plain.map_or((0, 0), |p| p.lane_constants());
            let base = |y: usize| (z * ny + y) * width;
            order.rows.push(PlainRow {
                r: r as u32,
                row: bus.row as u32,
                lo: (lo - first) as u32,
                hi: (hi - first) as u32,
                at: span.start as u32,
                len: live.len() as u32,
                base: [base(bus.y.0), base(bus.y.1)],
                wy,
                yz,
                start: starts[r],
            });
        }
        let job = ColumnJob {
            kernel,
            rows: &order.rows,
            live: &self.row_plan.live,
            right_edges,
            latency,
            first,
            locals: &self.local,
        };
        // Columns share nothing: a big slice's spread over the threads
        // when the PEs are too few to share them out.
        let split = samples >= PARALLEL_SAMPLES
            && self.map.pes < PES_PER_THREAD * rayon::current_num_threads();
        let mem = &self.mem;
        let active = &mut self.rays.make_contiguous()[first..first + count];
        let work = |(c, col): (usize, &mut RayColumn)| {
            let mut out = (Tally::default(), PlainCounts::default());
            job.column(mem, col, c, &cols[c], &mut out);
            out
        };
        let join = |mut a: (Tally, PlainCounts), b: (Tally, PlainCounts)| {
            a.0.add(&b.0);
            a.1.add(&b.1);
            a
        };
        let zero = || (Tally::default(), PlainCounts::default());
        let (t, c) = if split {
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
