//! A plain sample on the whole-slice path through the datapath's
//! [`Kernel`]: the PE's half (the ray's address, the ownership rules, the
//! voxel and edge reads, the scoreboard and counters) around the kernel's
//! arithmetic, with the general path's effects in the same order. The
//! general path, [`Pe::sample_ray`]'s, is the twin of
//! [`golden::sampling::sample_at`]; this is how the model evaluates it
//! quickly, not a second datapath.

use super::pe::{EdgeIn, RowBus};
use crate::datapath::{Kernel, KernelRow, Tally};
use crate::pe::Pe;

impl Pe {
    /// Samples held column `j` in `bus`'s row through `kernel` (`row`: the
    /// row's constants), issued in cycle `now` and written back `latency`
    /// cycles later, counting its quantisation events into `total`.
    /// Returns `false`, having changed nothing, when the sample must run
    /// the general path: a word the kernel cannot hold, or a column this
    /// PE neither owns nor reaches (the general path reports the error).
    #[inline(always)]
    pub(super) fn sample_plain(
        &mut self,
        (kernel, row): (&Kernel, &KernelRow),
        bus: &RowBus,
        j: usize,
        edge: &EdgeIn,
        (nx, now, latency): (usize, u64, u64),
        total: &mut Tally,
    ) -> bool {
        let mx = self.rays[j].mx;
        let mut t = Tally::default();
        let Some(ray) = kernel.address(row, mx, &mut t) else {
            return false;
        };
        let last = nx as i64 - 1;
        let (c0, c1) = (
            ray.x0.clamp(0, last) as usize,
            (ray.x0 + 1).clamp(0, last) as usize,
        );
        let held = self.holds(c1);
        if !self.owns(c0) || !(held || c1 == self.cols.end) {
            return false;
        }
        self.counters.busy += 1;
        self.counters.samples += 1;
        let land = now + latency;
        let r = bus.row;
        self.rays[j].land[r] = land;
        self.drained_at = self.drained_at.max(land);
        let z = bus.slice.z;
        let (y0, y1, _) = bus.y;
        let left = [self.voxel(z, y0, c0), self.voxel(z, y1, c0)];
        let right = if held {
            [self.voxel(z, y0, c1), self.voxel(z, y1, c1)]
        } else {
            self.counters.edge_voxels += 2;
            edge.right
        };
        let v = [[left[0], right[0]], [left[1], right[1]]];
        let col = &mut self.rays[j];
        if let Some(done) = kernel.sample(row, v, &ray, &mut col.acc[r], &mut t) {
            if kernel.front_to_back() {
                // The comparator behind the accumulator sets the flag the
                // next slice's schedule reads.
                col.ftb[r].done = done;
            }
        }
        total.add(&t);
        true
    }
}
