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

use crate::datapath::{Acc, Datapath, SampleTrace};
use crate::fixed::{Fx, FxError, QuantStats};
use crate::host::SlicePlan;

/// A column of rays (one ray index `mx`, every row of the region).
#[derive(Debug, Clone, PartialEq)]
pub struct RayColumn {
    /// Ray index along x.
    pub mx: i64,
    /// Accumulators of rows `lo_y ..= hi_y` of the region.
    pub acc: Vec<Acc>,
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
}

/// What a PE drives towards one neighbour in a cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Port {
    /// Voxels of the PE's first column (to the left neighbour) at rows
    /// `y0, y0 + 1` of the row sampled next cycle; in a merge, the edge
    /// ray's accumulators instead (see [`Port::edge_acc`]).
    pub edge: [u16; 2],
    /// Edge ray of a merge row.
    pub edge_acc: Acc,
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
    /// Merge outputs computed (child rays).
    pub merge_outputs: u64,
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
        if bus.cycle >= self.active.1 {
            self.counters.idle += 1;
            self.last.busy = false;
            return Ok(out);
        }
        let j = self.active.0 + bus.cycle;
        self.last = self.sample_ray(dp, &RowBus::of(bus), j, from_right.left.edge, nx)?;
        Ok(out)
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
            let acc = &mut self.rays[j].acc[row];
            dp.composite_btf(acc, rgb, a, st)?;
        }
        Ok(SampleTrace {
            busy: true,
            mx,
            row,
            acc: self.rays[j].acc[row],
            sample: sample.raw(),
            alpha: alpha.raw(),
            corrected,
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
    pub fn sample_slice(
        &mut self,
        dp: &Datapath,
        rows: &[RowBus],
        row_len: usize,
        right_edges: Option<&[[u16; 2]]>,
        nx: usize,
    ) -> Result<(), StepError> {
        let n = self.active.1;
        for (r, bus) in rows.iter().enumerate() {
            let edge = right_edges.map_or([0; 2], |e| e[r]);
            for c in 0..n {
                self.last = self.sample_ray(dp, bus, self.active.0 + c, edge, nx)?;
            }
            self.counters.idle += (row_len - n) as u64;
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
                    });
                    self.incoming.len() - 1
                }
            };
            self.incoming[pos].acc.push(m.acc);
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
            out.right.edge_acc = l.acc[row];
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
    /// An intermediate outgrew the 128-bit model.
    #[error("{0}")]
    Fixed(#[from] FxError),
}
