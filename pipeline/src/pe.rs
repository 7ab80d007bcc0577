//! One processing element: its voxel memory (a block of columns of every
//! slice), the compositing buffer of the rays it holds, its ports to the
//! left and right neighbour, and its counters.
//!
//! A PE's clock step receives only its own state, the outputs its two
//! neighbours drove on their ports in the previous cycle, and the
//! controller's broadcast; it returns what it drives on its own ports.
//! No PE can read another PE's state: the step's signature makes that
//! structural, and the array commits every PE's new port outputs only after
//! all PEs have stepped, so the order in which PEs step cannot matter.

use std::collections::VecDeque;

use crate::config::Order;
use crate::datapath::{Acc, Datapath, SampleTrace};
use crate::fixed::{Format, Fx, FxError, QuantStats};
use crate::host::SlicePlan;

/// A column of rays (one ray index `mx`, every row of the region).
#[derive(Debug, Clone, PartialEq)]
pub struct RayColumn {
    /// Ray index along x.
    pub mx: i64,
    /// Accumulators of rows `lo_y ..= hi_y` of the region.
    pub acc: Vec<Acc>,
    /// Front to back, per row: what the ray inherited at the split and its
    /// termination flag; empty back to front.
    pub ftb: Vec<FtbState>,
}

/// What a front-to-back ray carries beside its accumulators, in the
/// compositing buffer and over the links: the state it inherited at its
/// region's split (the fold subtracts it from the ray's result) and its
/// termination flag (set once its opacity word reaches the threshold, read
/// to skip it). One more accumulator word set and one bit per ray: the
/// front-to-back compositing buffer is twice as wide.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FtbState {
    /// Accumulators inherited at the split (zero in region 0).
    pub inh: Acc,
    /// Early ray termination flag.
    pub done: bool,
}

/// A ray in transit over a link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RayMove {
    /// Ray index along x.
    pub mx: i64,
    /// Row within the region.
    pub row: u32,
    /// Rows in the region (so the receiver knows when a column is whole).
    pub rows: u32,
    /// The ray's accumulators.
    pub acc: Acc,
    /// Front to back: its inherited state and flag, on a link as wide as
    /// both (so a move still takes one cycle).
    pub ftb: Option<FtbState>,
}

/// What a PE drives towards one neighbour in a cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Port {
    /// Voxels of the PE's first column (to the left neighbour) at rows
    /// `y0, y0 + 1` of the row sampled next cycle; in a merge, the edge
    /// ray's accumulators instead (see [`Port::edge_acc`]).
    pub edge: [u16; 2],
    /// Whether `edge` holds voxels for a row still to be sampled (the
    /// neighbour reads them next cycle); only the waveforms read it.
    pub edge_valid: bool,
    /// Edge ray of a merge row.
    pub edge_acc: Acc,
    /// The index `mx` of the edge ray on `edge_acc`, `None` when no edge
    /// ray is driven: the valid of the parent crossing the link (the
    /// split and the fold check the index; the back-to-front merge finds
    /// its parents by position and sets it for the waveforms only).
    pub edge_mx: Option<i64>,
    /// A ray migrating to the neighbour.
    pub ray: Option<RayMove>,
}

/// Both ports of a PE.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Ports {
    /// Towards PE `k - 1`.
    pub left: Port,
    /// Towards PE `k + 1`.
    pub right: Port,
}

/// What the controller broadcasts in a sampling cycle.
#[derive(Debug, Clone, Copy)]
pub struct SampleBus<'a> {
    /// The slice being sampled.
    pub slice: &'a SlicePlan,
    /// Ray row sampled this cycle.
    pub my: i64,
    /// Row in the region's buffer.
    pub row: usize,
    /// Clamped voxel rows `y0, y0 + 1` and the y weight of this row.
    pub y: (usize, usize, Fx),
    /// Cycle within the row.
    pub cycle: usize,
    /// Spacing-scaled y slope of this row and the region's z term.
    pub slope_yz: (Fx, Fx),
    /// Region slope constants on x: `b + m k`.
    pub slope_x: (Fx, Fx),
    /// Voxel rows and slice of the row sampled next cycle (for the edge
    /// voxels this PE drives now).
    pub next: Option<(usize, usize, usize)>,
}

/// The runs of ray indices each row of a slice samples, as the controller
/// broadcasts them (mirroring `golden::skip::SampleMask::row_runs`): one
/// flat list with per-row offsets, reused from slice to slice.
#[derive(Debug, Clone, Default)]
pub struct RowRuns {
    runs: Vec<(i64, i64)>,
    starts: Vec<usize>,
}

impl RowRuns {
    /// Forgets every row.
    pub fn clear(&mut self) {
        self.runs.clear();
        self.starts.clear();
    }

    /// Appends the next row's runs (ascending, disjoint).
    pub fn push_row(&mut self, runs: &[(i64, i64)]) {
        self.starts.push(self.runs.len());
        self.runs.extend_from_slice(runs);
    }

    /// Row `r`'s runs.
    pub fn row(&self, r: usize) -> &[(i64, i64)] {
        let end = self.starts.get(r + 1).copied().unwrap_or(self.runs.len());
        &self.runs[self.starts[r]..end]
    }
}

/// The part of the bus that is constant over a row.
#[derive(Debug, Clone, Copy)]
pub struct RowBus<'a> {
    /// The slice being sampled.
    pub slice: &'a SlicePlan,
    /// Row in the region's buffer.
    pub row: usize,
    /// Clamped voxel rows `y0, y0 + 1` and the y weight.
    pub y: (usize, usize, Fx),
    /// Spacing-scaled y slope of the row and the region's z term.
    pub slope_yz: (Fx, Fx),
    /// Region slope constants on x.
    pub slope_x: (Fx, Fx),
}

impl<'a> RowBus<'a> {
    /// The row part of a cycle's bus.
    pub fn of(b: &SampleBus<'a>) -> RowBus<'a> {
        RowBus {
            slice: b.slice,
            row: b.row,
            y: b.y,
            slope_yz: b.slope_yz,
            slope_x: b.slope_x,
        }
    }
}

/// Per-PE event counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct PeCounters {
    /// Samples taken.
    pub samples: u64,
    /// Sampling cycles with a sample.
    pub busy: u64,
    /// Sampling cycles without one (load imbalance).
    pub idle: u64,
    /// Voxel words read from this PE's memory (samples and edge drives).
    pub mem_reads: u64,
    /// Voxel words received from the right neighbour.
    pub edge_voxels: u64,
    /// Rays sent to a neighbour.
    pub rays_sent: u64,
    /// Rays received from a neighbour.
    pub rays_received: u64,
    /// Merge outputs computed (child rays; front to back, the fold's).
    pub merge_outputs: u64,
    /// Front to back: split outputs computed (child rays).
    pub split_outputs: u64,
    /// Front to back: samples not taken because the ray was terminated.
    pub terminated: u64,
}

/// One processing element.
#[derive(Debug, Clone)]
pub struct Pe {
    /// Index in the array.
    pub k: usize,
    /// Owned voxel columns `c0..c1`.
    pub cols: std::ops::Range<usize>,
    /// Voxel words `[z][y][x - c0]`.
    mem: Vec<u16>,
    ny: usize,
    /// Ray columns held, in increasing `mx`.
    pub rays: VecDeque<RayColumn>,
    /// First held column sampled in the current slice, and how many.
    pub active: (usize, usize),
    /// Rays waiting to go left / right.
    pub out_left: VecDeque<RayMove>,
    /// See `out_left`.
    pub out_right: VecDeque<RayMove>,
    /// Columns being received, by `mx`.
    incoming: Vec<RayColumn>,
    /// Counters.
    pub counters: PeCounters,
    /// Quantisation events.
    pub stats: QuantStats,
    /// What the last sampling cycle did (for waveforms).
    pub last: SampleTrace,
    /// Rows whose edge voxels the edge register holds.
    edge_latch: Option<(usize, usize, usize)>,
    /// The edge register.
    edge_value: [u16; 2],
    /// The held columns (indices into `rays`) sampled in the current row,
    /// in order: the row's schedule, one per cycle.
    row_live: Vec<usize>,
    /// Front to back: the final states of the rays this PE held at each
    /// split (one entry per boundary passed, innermost last), kept for the
    /// fold. With the inherited states this is the front-to-back mode's
    /// memory cost: every region's rays, about `(W + 1)(ny + 1)` per region
    /// boundary per PE, on top of the twice-as-wide compositing buffer.
    pub finals: Vec<Vec<RayColumn>>,
    /// Front to back: the fold's differences of the current row, one per
    /// held column (raw `merge` words).
    dline: Vec<[i64; 4]>,
}

impl Pe {
    /// A PE owning columns `cols` of a `[nx, ny, nz]` volume whose voxel
    /// words are `words` (`[z][y][x]`).
    pub fn new(k: usize, cols: std::ops::Range<usize>, words: &[u16], dims: [usize; 3]) -> Pe {
        let [nx, ny, nz] = dims;
        let w = cols.len();
        let mut mem = Vec::with_capacity(w * ny * nz);
        for z in 0..nz {
            for y in 0..ny {
                let base = (z * ny + y) * nx;
                mem.extend_from_slice(&words[base + cols.start..base + cols.end]);
            }
        }
        Pe {
            k,
            cols,
            mem,
            ny,
            rays: VecDeque::new(),
            active: (0, 0),
            out_left: VecDeque::new(),
            out_right: VecDeque::new(),
            incoming: Vec::new(),
            counters: PeCounters::default(),
            stats: QuantStats::default(),
            last: SampleTrace::default(),
            edge_latch: None,
            edge_value: [0; 2],
            row_live: Vec::new(),
            finals: Vec::new(),
            dline: Vec::new(),
        }
    }

    #[inline]
    fn voxel(&mut self, z: usize, y: usize, x: usize) -> u16 {
        self.counters.mem_reads += 1;
        let w = self.cols.len();
        self.mem[(z * self.ny + y) * w + (x - self.cols.start)]
    }

    /// The columns this PE samples in `slice`: the held columns whose `mx`
    /// lies in the slice's x range (contiguous, since both are sorted).
    pub fn select(&mut self, slice: &SlicePlan) -> usize {
        let (lo, hi) = slice.range[0];
        let first = self.rays.partition_point(|c| c.mx < lo);
        let end = self.rays.partition_point(|c| c.mx <= hi);
        self.active = (first, end.saturating_sub(first));
        self.active.1
    }

    /// Drives the edge register: the voxels of this PE's first column at
    /// the rows of `next` (the row sampled next cycle), read from memory
    /// only when the row changes (the register holds its value otherwise).
    #[inline]
    fn drive_edge(&mut self, next: Option<(usize, usize, usize)>) -> [u16; 2] {
        if let Some(n) = next {
            if self.edge_latch != Some(n) && !self.cols.is_empty() {
                let (z, y0, y1) = n;
                let c0 = self.cols.start;
                self.edge_value = [self.voxel(z, y0, c0), self.voxel(z, y1, c0)];
                self.edge_latch = Some(n);
            }
        }
        self.edge_value
    }

    /// One sampling clock. `from_right` is what the right neighbour drove
    /// last cycle (its first column's voxels for this row).
    pub fn sample_step(
        &mut self,
        dp: &Datapath,
        bus: &SampleBus,
        from_right: &Ports,
        nx: usize,
    ) -> Result<Ports, StepError> {
        let mut out = Ports::default();
        out.left.edge = self.drive_edge(bus.next);
        out.left.edge_valid = bus.next.is_some() && !self.cols.is_empty();
        if bus.cycle >= self.row_live.len() {
            self.counters.idle += 1;
            self.last.busy = false;
            return Ok(out);
        }
        let j = self.row_live[bus.cycle];
        self.last = self.sample_ray(dp, &RowBus::of(bus), j, from_right.left.edge, nx)?;
        Ok(out)
    }

    /// Visits the held columns this PE samples in `row`: the active
    /// columns whose index lies in one of the row's `runs` (ascending: what
    /// the controller broadcasts from the occupancy memory and the clip
    /// planes, a comparator pair per PE), front to back only those whose
    /// termination flag is clear. Calls `take(j)` for each, in order, and
    /// returns how many in-run columns were terminated.
    fn schedule(
        &self,
        row: usize,
        runs: &[(i64, i64)],
        ftb: bool,
        mut take: impl FnMut(usize),
    ) -> u64 {
        let (first, n) = self.active;
        let mut terminated = 0;
        let mut run = runs.iter().peekable();
        for j in first..first + n {
            let mx = self.rays[j].mx;
            while run.next_if(|r| r.1 < mx).is_some() {}
            let Some(&&(lo, _)) = run.peek() else { break };
            if mx < lo {
                continue;
            }
            if ftb && self.rays[j].ftb[row].done {
                terminated += 1;
            } else {
                take(j);
            }
        }
        terminated
    }

    /// How many columns this PE samples in `row` (see [`Pe::begin_row`]).
    /// The PE reports it at the start of the row; the controller runs the
    /// row for as many cycles as the largest report (an AND of "done"
    /// lines in hardware, the one signal besides the broadcast that is not
    /// nearest-neighbour).
    pub fn count_in_row(&self, row: usize, runs: &[(i64, i64)], ftb: bool) -> usize {
        let mut n = 0;
        self.schedule(row, runs, ftb, |_| n += 1);
        n
    }

    /// Schedules `row`: its columns inside the row's runs (front to back
    /// only the live ones), one per cycle; rays left out cost no cycle.
    /// Counts the terminated ones.
    pub fn begin_row(&mut self, row: usize, runs: &[(i64, i64)], ftb: bool) {
        let mut live = std::mem::take(&mut self.row_live);
        live.clear();
        self.counters.terminated += self.schedule(row, runs, ftb, |j| live.push(j));
        self.row_live = live;
    }

    /// The sample of held column `j` in the bus's row: the datapath of one
    /// busy cycle, shared by the clocked and the whole-slice paths.
    #[inline]
    fn sample_ray(
        &mut self,
        dp: &Datapath,
        bus: &RowBus,
        j: usize,
        edge_in: [u16; 2],
        nx: usize,
    ) -> Result<SampleTrace, StepError> {
        self.counters.busy += 1;
        self.counters.samples += 1;
        let mx = self.rays[j].mx;
        let s = bus.slice;
        let st = &mut self.stats;
        let x = dp.position(s.a[0], s.t[0], mx, st)?;
        let (x0, wx) = dp.address(x, st);
        let last = nx as i64 - 1;
        let (c0, c1) = (x0.clamp(0, last) as usize, (x0 + 1).clamp(0, last) as usize);
        if !self.cols.contains(&c0) {
            return Err(StepError::Ownership {
                pe: self.k,
                mx,
                column: c0,
            });
        }
        let (y0, y1, wy) = bus.y;
        let left = [self.voxel(s.z, y0, c0), self.voxel(s.z, y1, c0)];
        let right = if self.cols.contains(&c1) {
            [self.voxel(s.z, y0, c1), self.voxel(s.z, y1, c1)]
        } else if c1 == self.cols.end {
            self.counters.edge_voxels += 2;
            edge_in
        } else {
            return Err(StepError::Ownership {
                pe: self.k,
                mx,
                column: c1,
            });
        };
        let st = &mut self.stats;
        let sample = dp.bilinear([[left[0], right[0]], [left[1], right[1]]], wx, wy, st)?;
        let (rgb, alpha) = dp.classify(sample, st)?;
        let mut corrected = 0;
        let mut terminated = false;
        let row = bus.row;
        if alpha.raw() > 0 {
            let (b, k) = bus.slope_x;
            let mt = crate::fixed::Wide::new(i128::from(mx), 0).checked_mul(k)?;
            let sx = dp
                .cfg
                .position
                .assign(crate::fixed::Wide::from(b).checked_add(mt)?, st);
            let ds = dp.path(sx, bus.slope_yz.0, bus.slope_yz.1, st)?;
            let a = dp.correct(alpha, ds, st)?;
            corrected = a.raw();
            let ray = &mut self.rays[j];
            if dp.cfg.order == Order::FrontToBack {
                dp.composite_ftb(&mut ray.acc[row], rgb, a, st)?;
                // The comparator behind the accumulator sets the flag the
                // next slice's schedule reads.
                terminated = dp.terminated(&ray.acc[row]);
                ray.ftb[row].done = terminated;
            } else {
                dp.composite_btf(&mut ray.acc[row], rgb, a, st)?;
            }
        }
        Ok(SampleTrace {
            busy: true,
            mx,
            row,
            acc: self.rays[j].acc[row],
            sample: sample.raw(),
            alpha: alpha.raw(),
            corrected,
            terminated,
        })
    }

    /// The edge voxels this PE presents during each of `rows` (its first
    /// column at each row's voxel rows): what its left neighbour receives
    /// over the port in that row. Reads nothing it would not drive anyway;
    /// the reads are counted by [`Pe::latch_edges`].
    pub fn edges_for(&self, z: usize, rows: &[RowBus]) -> Vec<[u16; 2]> {
        if self.cols.is_empty() {
            return vec![[0; 2]; rows.len()];
        }
        let w = self.cols.len();
        let at = |y: usize| self.mem[(z * self.ny + y) * w];
        rows.iter().map(|r| [at(r.y.0), at(r.y.1)]).collect()
    }

    /// Steps the edge register through `seq`, the rows the bus announces
    /// as "next" in order, counting the memory reads the clocked path makes.
    pub fn latch_edges(&mut self, seq: impl Iterator<Item = (usize, usize, usize)>) {
        for n in seq {
            self.drive_edge(Some(n));
        }
    }

    /// Samples a whole slice without stepping cycle by cycle: row by row,
    /// each of this PE's rays in order, with the right neighbour's edge
    /// voxels for each row (`right_edges`, from [`Pe::edges_for`]). The
    /// arithmetic and every counter equal the clocked path's (a test proves
    /// it); only the interleaving of PEs within a cycle is gone, which no
    /// result can observe because PEs share nothing within a cycle.
    ///
    /// `lens[r]` is row `r`'s length in cycles (the busiest PE's count);
    /// rows of length 0 are skipped, and each row samples only its
    /// scheduled columns ([`Pe::begin_row`] with `runs.row(r)`), in order,
    /// as the clocked schedule does.
    pub fn sample_slice(
        &mut self,
        dp: &Datapath,
        rows: &[RowBus],
        runs: &RowRuns,
        lens: &[usize],
        right_edges: Option<&[[u16; 2]]>,
        nx: usize,
    ) -> Result<(), StepError> {
        let ftb = dp.cfg.order == Order::FrontToBack;
        for (r, bus) in rows.iter().enumerate() {
            self.begin_row(bus.row, runs.row(r), ftb);
            if lens[r] == 0 {
                continue;
            }
            let edge = right_edges.map_or([0; 2], |e| e[r]);
            let live = std::mem::take(&mut self.row_live);
            for &j in &live {
                self.last = self.sample_ray(dp, bus, j, edge, nx)?;
            }
            self.counters.idle += (lens[r] - live.len()) as u64;
            self.row_live = live;
        }
        Ok(())
    }

    /// Queues every held column whose owner for the next slice is another
    /// PE, given the owner function.
    pub fn plan_moves(&mut self, owner: impl Fn(i64) -> usize) {
        while let Some(c) = self.rays.front() {
            if owner(c.mx) >= self.k {
                break;
            }
            let c = self.rays.pop_front().expect("front exists");
            queue(&mut self.out_left, c);
        }
        while let Some(c) = self.rays.back() {
            if owner(c.mx) <= self.k {
                break;
            }
            let c = self.rays.pop_back().expect("back exists");
            queue(&mut self.out_right, c);
        }
    }

    /// One migration clock: sends one ray each way, receives what the
    /// neighbours sent last cycle; a column that is whole joins the held
    /// columns (or moves on if its owner is further along).
    pub fn migrate_step(
        &mut self,
        from_left: &Ports,
        from_right: &Ports,
        owner: impl Fn(i64) -> usize,
    ) -> Ports {
        let mut out = Ports::default();
        for (incoming, from_left_side) in
            [(from_left.right.ray, true), (from_right.left.ray, false)]
        {
            let Some(m) = incoming else { continue };
            self.counters.rays_received += 1;
            let pos = match self.incoming.iter().position(|c| c.mx == m.mx) {
                Some(p) => p,
                None => {
                    self.incoming.push(RayColumn {
                        mx: m.mx,
                        acc: Vec::with_capacity(m.rows as usize),
                        ftb: Vec::with_capacity(if m.ftb.is_some() { m.rows as usize } else { 0 }),
                    });
                    self.incoming.len() - 1
                }
            };
            self.incoming[pos].acc.push(m.acc);
            if let Some(f) = m.ftb {
                self.incoming[pos].ftb.push(f);
            }
            if self.incoming[pos].acc.len() == m.rows as usize {
                let col = self.incoming.swap_remove(pos);
                let dest = owner(col.mx);
                if dest < self.k {
                    queue(&mut self.out_left, col);
                } else if dest > self.k {
                    queue(&mut self.out_right, col);
                } else if from_left_side {
                    self.rays.push_front(col);
                } else {
                    self.rays.push_back(col);
                }
            }
        }
        if let Some(m) = self.out_left.pop_front() {
            self.counters.rays_sent += 1;
            out.left.ray = Some(m);
        }
        if let Some(m) = self.out_right.pop_front() {
            self.counters.rays_sent += 1;
            out.right.ray = Some(m);
        }
        out
    }

    /// True when nothing is waiting to move or being received.
    pub fn settled(&self) -> bool {
        self.out_left.is_empty() && self.out_right.is_empty() && self.incoming.is_empty()
    }

    /// Drives this PE's edge rays of merge row `row`: its first held
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

    /// `mx` of the first and last held column.
    pub fn span(&self) -> Option<(i64, i64)> {
        Some((self.rays.front()?.mx, self.rays.back()?.mx))
    }

    /// Accumulators of held column `mx` at `row`, or the neighbours' edge
    /// rays when `mx` is just beyond the held span; empty rays otherwise.
    fn parent(&self, mx: i64, row: usize, from_left: &Ports, from_right: &Ports) -> Acc {
        let Some((lo, hi)) = self.span() else {
            return Acc::default();
        };
        if mx < lo {
            return if mx == lo - 1 {
                from_left.right.edge_acc
            } else {
                Acc::default()
            };
        }
        if mx > hi {
            return if mx == hi + 1 {
                from_right.left.edge_acc
            } else {
                Acc::default()
            };
        }
        self.rays[(mx - lo) as usize].acc[row]
    }

    /// x pass of merge row `row`: for each child column `m` this PE
    /// computes, the tent of parents `2m - 1 ..= 2m + 1` into `line`
    /// (raw `merge` words, R, G, B, A). Children are those whose centre
    /// parent `clamp(2m, lo, hi)` of the parent rectangle this PE holds.
    pub fn merge_x(
        &mut self,
        dp: &Datapath,
        row: usize,
        children: &[i64],
        from_left: &Ports,
        from_right: &Ports,
        line: &mut Vec<[i64; 4]>,
    ) {
        line.clear();
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        for &m in children {
            let p = [
                self.parent(2 * m - 1, row, from_left, from_right),
                self.parent(2 * m, row, from_left, from_right),
                self.parent(2 * m + 1, row, from_left, from_right),
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
            line.push(out);
        }
    }

    /// Replaces the held columns with the merged children.
    pub fn set_rays(&mut self, cols: Vec<RayColumn>) {
        self.rays = cols.into();
    }

    /// Front to back: drives this PE's first held column of split row
    /// `row`, with its index, to the left neighbour (whose last odd child
    /// averages it with its own last column).
    pub fn split_drive(&self, row: usize) -> Ports {
        let mut out = Ports::default();
        if let Some(f) = self.rays.front() {
            out.left.edge_acc = f.acc[row];
            out.left.edge_mx = Some(f.mx);
        }
        out
    }

    /// Front to back: a parent of the split, front ray `mx` at `row`:
    /// held here, or the right neighbour's first column on its port, or
    /// empty outside the parent rectangle `grid` (inclusive).
    fn split_parent(
        &self,
        mx: i64,
        row: usize,
        grid: (i64, i64),
        from_right: &Ports,
    ) -> Result<Acc, StepError> {
        if mx < grid.0 || mx > grid.1 {
            return Ok(Acc::default());
        }
        if let Some((lo, hi)) = self.span() {
            if (lo..=hi).contains(&mx) {
                return Ok(self.rays[(mx - lo) as usize].acc[row]);
            }
        }
        if from_right.left.edge_mx == Some(mx) {
            return Ok(from_right.left.edge_acc);
        }
        Err(StepError::Unreachable { pe: self.k, mx })
    }

    /// Front to back: x pass of split row `row` (the adjoint of
    /// [`Pe::merge_x`]): for each child column `n` this PE computes, the
    /// mean of parents `floor(n / 2)` and `floor(n / 2) + (n mod 2)` (an
    /// even child continues its parent), from the accumulators into `line`
    /// (raw `merge` words, R, G, B, A). Children are those whose parent
    /// `clamp(floor(n / 2), lo, hi)` of the parent rectangle `grid` this
    /// PE holds, so the second parent is held here or is the right
    /// neighbour's first column.
    pub fn split_x(
        &mut self,
        dp: &Datapath,
        row: usize,
        children: &[i64],
        grid: (i64, i64),
        from_right: &Ports,
        line: &mut Vec<[i64; 4]>,
    ) -> Result<(), StepError> {
        line.clear();
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        for &n in children {
            let m = n.div_euclid(2);
            let a = self.split_parent(m, row, grid, from_right)?;
            let b = if n.rem_euclid(2) == 0 {
                a
            } else {
                self.split_parent(m + 1, row, grid, from_right)?
            };
            let mut out = [0i64; 4];
            for (ch, o) in out.iter_mut().enumerate() {
                let f = if ch < 3 { fc } else { fa };
                *o = dp
                    .halve([a.raw[ch], b.raw[ch]], f, fm, &mut self.stats)
                    .raw();
            }
            line.push(out);
        }
        Ok(())
    }

    /// Front to back: the fold's differences of back row `row`, result
    /// minus inherited state (results in `rf`: colour, opacity; inherited
    /// states in the accumulators), for every held column, into `merge`
    /// words; drives the last, with its index, to the right neighbour
    /// (whose first child's left tap it is).
    pub fn fold_prepare(&mut self, dp: &Datapath, row: usize, rf: [Format; 2]) -> Ports {
        let (fc, fa) = (dp.cfg.accum_color, dp.cfg.accum_alpha);
        self.dline.clear();
        for c in &self.rays {
            let (r, h) = (c.acc[row].raw, c.ftb[row].inh.raw);
            let mut d = [0i64; 4];
            for (ch, o) in d.iter_mut().enumerate() {
                let (f, hf) = if ch < 3 { (rf[0], fc) } else { (rf[1], fa) };
                *o = dp.fold_diff(r[ch], f, h[ch], hf, &mut self.stats).raw();
            }
            self.dline.push(d);
        }
        let mut out = Ports::default();
        if let (Some(c), Some(d)) = (self.rays.back(), self.dline.last()) {
            out.right.edge_acc = Acc { raw: *d };
            out.right.edge_mx = Some(c.mx);
        }
        out
    }

    /// Front to back: a tap of the fold's x pass, back ray `n`'s difference
    /// in the current row: held here, or the left neighbour's last column
    /// on its port, or empty outside the back rectangle `grid`.
    fn fold_tap(&self, n: i64, grid: (i64, i64), from_left: &Ports) -> Result<[i64; 4], StepError> {
        if n < grid.0 || n > grid.1 {
            return Ok([0; 4]);
        }
        if let Some((lo, hi)) = self.span() {
            if (lo..=hi).contains(&n) {
                return Ok(self.dline[(n - lo) as usize]);
            }
        }
        if from_left.right.edge_mx == Some(n) {
            return Ok(from_left.right.edge_acc.raw);
        }
        Err(StepError::Unreachable { pe: self.k, mx: n })
    }

    /// Front to back: x pass of fold row `row` (after
    /// [`Pe::fold_prepare`]): for each front ray `m` whose final state this
    /// PE kept at the split, the tent of back rays `2m - 1 ..= 2m + 1`'s
    /// differences into `line` (raw `merge` words). The back rays were
    /// brought to the PE of their split parent `clamp(floor(n / 2))`, so
    /// `2m` and `2m + 1` are held here and `2m - 1` is here or the left
    /// neighbour's last column.
    pub fn fold_x(
        &mut self,
        dp: &Datapath,
        grid: (i64, i64),
        from_left: &Ports,
        line: &mut Vec<[i64; 4]>,
    ) -> Result<(), StepError> {
        line.clear();
        let fm = dp.cfg.merge;
        let kept = self.finals.last().map_or(0, Vec::len);
        for i in 0..kept {
            let m = self.finals.last().map_or(0, |f| f[i].mx);
            let p = [
                self.fold_tap(2 * m - 1, grid, from_left)?,
                self.fold_tap(2 * m, grid, from_left)?,
                self.fold_tap(2 * m + 1, grid, from_left)?,
            ];
            let mut out = [0i64; 4];
            for (ch, o) in out.iter_mut().enumerate() {
                *o = dp
                    .tent([p[0][ch], p[1][ch], p[2][ch]], fm, fm, &mut self.stats)
                    .raw();
            }
            line.push(out);
        }
        Ok(())
    }
}

/// Splits a column into ray moves, row by row.
fn queue(q: &mut VecDeque<RayMove>, c: RayColumn) {
    let rows = c.acc.len() as u32;
    for (row, acc) in c.acc.into_iter().enumerate() {
        q.push_back(RayMove {
            mx: c.mx,
            row: row as u32,
            rows,
            acc,
            ftb: c.ftb.get(row).copied(),
        });
    }
}

/// A clock step that cannot happen in correct hardware.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    /// A ray needed a voxel column its PE neither owns nor receives.
    #[error("PE {pe} holds ray {mx} but cannot reach voxel column {column}")]
    Ownership {
        /// The PE.
        pe: usize,
        /// The ray.
        mx: i64,
        /// The column.
        column: usize,
    },
    /// A split or fold needed a ray that is neither held by the PE nor on
    /// a neighbour's port (the array's ownership rule was broken).
    #[error("PE {pe} needs ray {mx} for a split or fold but cannot reach it")]
    Unreachable {
        /// The PE.
        pe: usize,
        /// The ray.
        mx: i64,
    },
    /// An intermediate outgrew the 128-bit model.
    #[error("{0}")]
    Fixed(#[from] FxError),
}
