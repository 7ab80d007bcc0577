//! The untraced whole-slice sampling path: the same arithmetic, cycles
//! and counters as the clocked path (the tests compare every field over
//! many scenes, views, PE counts, orders and skips), each PE's whole
//! slice at once, PEs in parallel. Each PE first produces the edge voxels
//! it would drive in each row; each PE then samples its rays with its
//! right neighbour's, at the issue cycles the controller's row plan gives.

use super::{Row, RowBus, RowTimes};
use crate::array::{Array, RunError};
use crate::datapath::Datapath;
use crate::host::{RegionPlan, SlicePlan};

impl Array {
    /// Samples `slice` without per-cycle stepping (the clock's untraced
    /// sampler), which then counts the cycles the clocked path would have
    /// ticked.
    pub(super) fn sample_whole(
        &mut self,
        region: &RegionPlan,
        slice: &SlicePlan,
        rows: &[Row],
        times: &RowTimes,
    ) -> Result<(), RunError> {
        let p = self.clock.pes().len();
        let glo = region.grid.lo[1];
        let lens = &times.lens;
        let kernel = self.dp.kernel();
        let slope_x = (region.slope_b[0], region.slope_k[0]);
        let buses: Vec<RowBus> = rows
            .iter()
            .map(|&(my, y, sy, yp)| RowBus {
                slice,
                my,
                row: (my - glo) as usize,
                y,
                yp,
                slope_yz: (sy, region.slope_z),
                slope_x,
                plain: kernel.and_then(|k| {
                    k.row((slice.a[0], slice.t[0]), slope_x, y.2, (sy, region.slope_z))
                }),
            })
            .collect();
        // The rows the bus announces as next, in the clocked path's order:
        // the prologue announces the first row (several PEs only); with
        // rows one cycle long a lone PE never announces the first.
        let first = lens.iter().position(|&n| n > 0).unwrap_or(0);
        let skip = usize::from(p == 1 && lens[first] == 1);
        let seq: Vec<(usize, usize, usize)> = buses
            .iter()
            .zip(lens)
            .filter(|(_, &n)| n > 0)
            .skip(skip)
            .map(|(b, _)| (slice.z, b.y.0, b.y.1))
            .collect();
        let whole = WholeSlice {
            dp: &self.dp,
            buses: &buses,
            times,
            seq: &seq,
            shade: self.dp.loaded.shade.is_some(),
            nx: self.nx,
        };
        self.clock.sample_untraced(&whole)?;
        Ok(())
    }
}

/// A whole slice as the controller broadcasts it to the clock's untraced
/// sampler ([`crate::array::Clock::sample_untraced`]).
pub(crate) struct WholeSlice<'a> {
    /// The datapath.
    pub dp: &'a Datapath,
    /// Every row's bus.
    pub buses: &'a [RowBus<'a>],
    /// The controller's row plan: lengths, starts, stalls.
    pub times: &'a RowTimes,
    /// The rows the bus announces as next, in order (the edge registers
    /// step through them).
    pub seq: &'a [(usize, usize, usize)],
    /// Whether the array shades.
    pub shade: bool,
    /// Voxel columns.
    pub nx: usize,
}
