//! The untraced whole-slice sampling path: the same arithmetic, cycles
//! and counters as the clocked path (the tests compare every field over
//! many scenes, views, PE counts, orders and skips), each PE's whole
//! slice at once, PEs in parallel. Each PE first produces the edge voxels
//! it would drive in each row; each PE then samples its rays with its
//! right neighbour's, at the issue cycles the controller's row plan gives.

use super::{Row, RowBus, RowTimes};
use crate::array::warm::each_mut;
use crate::array::{Array, RunError};
use crate::host::{RegionPlan, SlicePlan};
use crate::pe::StepError;
use crate::probes::Stage;

impl Array {
    /// Samples `slice` without per-cycle stepping, then counts the cycles
    /// the clocked path would have ticked.
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
        let shade = self.dp.shade.is_some();
        // Each PE's edge words for the slice's rows (read while the PEs
        // planned their rows).
        let edges = std::mem::take(&mut self.edge_rows);
        let stalls: u64 = times.stalls.iter().sum();
        let dp = &self.dp;
        let nx = self.nx;
        let results: Vec<Result<(), StepError>> = each_mut(self.clock.pes_mut(), |k, pe| {
            pe.latch_edges(seq.iter().copied(), shade);
            if p > 1 {
                pe.counters.idle += 1;
            }
            pe.sample_slice(
                dp,
                &buses,
                (lens, &times.starts),
                stalls,
                (
                    edges.get(k + 1).map(Vec::as_slice),
                    k.checked_sub(1).map(|l| edges[l].as_slice()),
                ),
                nx,
            )
        });
        self.edge_rows = edges;
        for r in results {
            r?;
        }
        let cycles = u64::from(p > 1) + lens.iter().sum::<usize>() as u64;
        self.clock
            .ran_untraced(Stage::Memory, times.memory.iter().sum());
        self.clock.ran_untraced(Stage::Stall, stalls);
        self.clock.ran_untraced(Stage::Sample, cycles);
        Ok(())
    }
}
