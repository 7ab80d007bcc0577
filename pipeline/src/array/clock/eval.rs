//! The clock's untraced evaluators: a whole stage on every PE at once,
//! without ticking, for the controller's broadcast alone; each gives the
//! bits, counters and cycles the clocked stage gives (the
//! clocked-against-untraced frame tests compare every field) and counts
//! the cycles that stage would have ticked. Only the clock runs them, so
//! no stage reaches into a PE.

use golden::geometry::RayGrid;
use rayon::prelude::*;

use super::events::migrate_events;
use super::{each_mut, Clock};
use crate::datapath::{Acc, Datapath};
use crate::mapping::Route;
use crate::pe::{Ports, StepError};
use crate::probes::Stage;
use crate::stages::passes::Slot;
use crate::stages::sample::WholeSlice;

/// Baseplane rows the untraced readout writes per task.
const BAND: usize = 8;

impl Clock {
    /// Samples a whole slice on every PE, the PEs in parallel: each PE
    /// samples its rays with its neighbours' edge words (read with the row
    /// plans, [`crate::pe::EdgeRead`]) at the issue cycles the
    /// controller's row plan gives ([`WholeSlice`]); then counts the
    /// plan, memory, stall and sampling cycles the clocked path ticks.
    pub(crate) fn sample_untraced(&mut self, w: &WholeSlice<'_>) -> Result<(), StepError> {
        let p = self.pes.len();
        let edges = std::mem::take(&mut self.edge_rows);
        let (lens, times) = (&w.times.lens, w.times);
        let stalls: u64 = times.stalls.iter().sum();
        let results: Vec<Result<(), StepError>> = each_mut(&mut self.pes, |k, pe| {
            pe.latch_edges(w.seq.iter().copied(), w.shade);
            if p > 1 {
                pe.counters.idle += 1;
            }
            pe.sample_slice(
                w.dp,
                w.buses,
                (lens, &times.starts),
                stalls,
                (
                    edges.get(k + 1).map(Vec::as_slice),
                    k.checked_sub(1).map(|l| edges[l].as_slice()),
                ),
                w.nx,
            )
        });
        self.edge_rows = edges;
        for r in results {
            r?;
        }
        let cycles = u64::from(p > 1) + lens.iter().sum::<usize>() as u64;
        self.ran_untraced(Stage::Plan, times.plan.iter().sum());
        self.ran_untraced(Stage::Memory, times.memory.iter().sum());
        self.ran_untraced(Stage::Stall, stalls);
        self.ran_untraced(Stage::Sample, cycles);
        Ok(())
    }

    /// The dense merge of `grids` (back, front) on every PE, the PEs in
    /// parallel ([`Pe::merge_whole`](crate::pe::Pe::merge_whole)), each
    /// with the edge rays its neighbours drive for each of the `prows`
    /// parent rows; then the cycles the clocked pass ticks for the same
    /// `slots` of `width` cycles, after a `prologue` cycle. A failing step
    /// reports the error of the earliest cycle, the lowest PE within it,
    /// as the clocked pass's step order does.
    pub(crate) fn merge_untraced(
        &mut self,
        dp: &Datapath,
        (slots, width, prologue): (&[Slot], usize, bool),
        prows: usize,
        grids: (&RayGrid, &RayGrid),
    ) -> Result<(), StepError> {
        if width == 0 {
            return Ok(());
        }
        // What each PE drives for each parent row ([`Pe::merge_drive`],
        // the clocked pass's own drive), and so what its neighbours see.
        let drives: Vec<Vec<(Acc, Acc)>> = self
            .pes
            .iter()
            .map(|pe| {
                (0..prows)
                    .map(|q| {
                        // From idle, as the clock hands a step its ports.
                        let mut port = Ports::default();
                        pe.merge_drive(q, &mut port);
                        (port.left.edge_acc, port.right.edge_acc)
                    })
                    .collect()
            })
            .collect();
        let edges: Vec<Vec<(Acc, Acc)>> = (0..self.pes.len())
            .map(|k| {
                (0..prows)
                    .map(|q| {
                        let l = k.checked_sub(1).map_or(Acc::default(), |n| drives[n][q].1);
                        let r = drives.get(k + 1).map_or(Acc::default(), |d| d[q].0);
                        (l, r)
                    })
                    .collect()
            })
            .collect();
        let failed = each_mut(&mut self.pes, |k, pe| {
            pe.merge_whole(dp, (slots, width), &edges[k], grids).err()
        });
        let first = failed.into_iter().flatten().min_by_key(|&(cycle, _)| cycle);
        if let Some((_, e)) = first {
            return Err(e);
        }
        let cycles = u64::from(prologue) + (slots.len() * width) as u64;
        if cycles > 0 {
            self.ran_untraced(Stage::Merge, cycles);
        }
        Ok(())
    }

    /// The migration between slices to the owners `owner` gives along
    /// `route`, from its link queues' departures ([`migrate_events`]);
    /// counts the cycles the clocked migration ticks.
    pub(crate) fn migrate_untraced(&mut self, owner: impl Fn(i64) -> usize, route: Route) {
        let start = self.now();
        let cycles = migrate_events(&mut self.pes, start, owner, route);
        self.ran_untraced(Stage::Migrate, cycles);
    }

    /// Hands every ray to its owner between cycles (the external ray
    /// buffer's migration: the new owner fetches it from the shared
    /// buffer), keeping each PE's columns in ascending `mx`.
    pub(crate) fn reassign(&mut self, owner: impl Fn(i64) -> usize) {
        let mut moving = Vec::new();
        for pe in self.pes.iter_mut() {
            let k = pe.k;
            let held = std::mem::take(&mut pe.rays);
            for c in held {
                let dest = owner(c.mx);
                if dest == k {
                    pe.rays.push_back(c);
                } else {
                    moving.push((dest, c));
                }
            }
        }
        for (dest, c) in moving {
            let rays = &mut self.pes[dest].rays;
            let at = rays.partition_point(|h| h.mx < c.mx);
            rays.insert(at, c);
        }
    }

    /// The readout of region 0 (grid `g`) into `raw` (row-major, cleared)
    /// without ticking: each PE streams its words (it shares nothing with
    /// the others), and the readout lasts as many cycles as the longest
    /// stream ([`Pe::readout_clocks`](crate::pe::Pe::readout_clocks)), as
    /// the clocked loop ticks. The PEs' readouts have begun.
    pub(crate) fn readout_untraced(&mut self, g: &RayGrid, raw: &mut [[i64; 4]]) {
        let w = g.counts()[0];
        let longest = self
            .pes
            .par_iter_mut()
            .map(|pe| pe.readout_clocks())
            .max()
            .unwrap_or(0);
        // The host's writes, a band of rows at a time: each ray's word
        // lands where its index puts it, the words a sparse stream leaves
        // out being the cleared zeros, a later PE's over an earlier's as
        // the streams' order has it.
        let pes = &self.pes;
        raw.par_chunks_mut((w * BAND).max(1))
            .enumerate()
            .for_each(|(b, band)| {
                let rows = b * BAND..b * BAND + band.len() / w.max(1);
                for col in pes.iter().flat_map(|pe| pe.rays.iter()) {
                    let x = (col.mx - g.lo[0]) as usize;
                    let end = rows.end.min(col.acc.len());
                    for r in rows.start..end {
                        band[(r - rows.start) * w + x] = col.acc[r].raw;
                    }
                }
            });
        if longest > 0 {
            self.ran_untraced(Stage::Readout, longest);
        }
    }

    /// The parent rows some PE holds a non-zero ray in (each PE's row
    /// valid bits, ORed over the report lines), and how many non-zero rays
    /// the PEs hold.
    pub fn live_rows(&self, prows: usize) -> (Vec<bool>, u64) {
        let mut live = vec![false; prows];
        let count = self.pes.iter().map(|pe| pe.valid_rows(&mut live)).sum();
        (live, count)
    }
}
