//! Sampling: the slice's ray rows in order; in cycle `c` of a row each PE
//! samples its `c`-th scheduled ray of that row, so a row takes as many
//! cycles as the busiest PE has rays (the rest idle). The voxel column
//! right of a block comes from the right neighbour's port, driven one
//! cycle ahead (a prologue cycle drives the first row's). A row whose rays
//! are still in the datapath from the previous slice waits (stall cycles)
//! until the first of them may issue; a ray's sample issues in its cycle
//! and is written back `datapath_latency` cycles later.
//!
//! The arithmetic is golden's [`golden::sampling::sample_region`] bit for
//! bit in fixed point ([`crate::datapath`]). Two paths run it: the clocked
//! one (every cycle ticked; always when tracing) and the whole-slice one
//! (`fast.rs`), which gives the same bits, cycles and counters.

mod edges;
mod fast;
mod pe;
mod plain;
mod plan;
mod preint;
mod step;

pub use edges::EdgeWords;
pub(crate) use fast::WholeSlice;
pub use pe::{RowBus, SampleBus};
pub use plain::ColumnOrder;
pub(crate) use plain::ColumnTaps;
pub use plan::{RowPlan, RowRuns};
pub use preint::{PrePlan, PreRuns};
pub use step::{Hold, RowStep, Stall};

use crate::array::{Array, RunError};
use crate::config::Order;
use crate::fixed::{Fx, QuantStats, Wide};
use crate::host::{RegionPlan, SlicePlan};
use crate::pe::{Broadcast, EdgeRead};
use crate::probes::{Ctrl, Stage};

/// One ray row of a slice as the controller broadcasts it: the row index
/// `my`, the clamped voxel rows `y0, y0 + 1` with the y weight, the
/// spacing-scaled y slope and the row's y position (the volume of
/// interest's comparator reads it).
pub type Row = (i64, (usize, usize, Fx), Fx, Fx);

/// The controller's plan of a slice's rows: each row's cycles (the
/// busiest PE's count), the cycle its first sample issues, and the stall
/// cycles before it: waiting for the row's plan to be written (`plan`),
/// for the external ray buffer (`memory`), then for rays still in the
/// datapath (`stalls`).
pub(crate) struct RowTimes {
    pub lens: Vec<usize>,
    pub starts: Vec<u64>,
    pub stalls: Vec<u64>,
    pub memory: Vec<u64>,
    pub plan: Vec<u64>,
}

/// Clocks from a run's beat on the PEs' plan ports to the first sampling
/// clock that may issue from the word it completes: the plan memory is
/// written at the end of the beat's clock, and the control reads a row's
/// word in the clock before the row's first issue
/// ([`crate::hw::pe_sample_rtl`]).
pub const PLAN_TO_ISSUE: u64 = 2;

/// A row's report to the controller: the busiest PE's scheduled rays, the
/// latest start the scoreboards allow, and the rays of every PE.
type RowReport = (usize, u64, u64);

impl Array {
    /// Samples one slice, row by row.
    pub(crate) fn sample(
        &mut self,
        region: &RegionPlan,
        slice: &SlicePlan,
    ) -> Result<(), RunError> {
        let (ylo, yhi) = slice.range[1];
        let (xlo, xhi) = slice.range[0];
        if ylo > yhi || xlo > xhi {
            return Ok(());
        }
        self.clock
            .broadcast(&Broadcast::BeginSlice { x: (xlo, xhi) });
        if let Some(c) = self.clock.capture() {
            crate::cosim::pe_sample::slice_begin(c, self.clock.cycle(), slice.z, self.clock.pes());
        }
        let row_len = self
            .clock
            .reports()
            .map(|r| r.active as usize)
            .max()
            .unwrap_or(0);
        let nrows = (yhi - ylo + 1) as usize;
        let glo = region.grid.lo[1];
        let p = self.clock.pes().len();
        let ftb = self.dp.cfg.order == Order::FrontToBack;
        // The controller's runs per row: the whole slice range, or what the
        // occupancy memory and the clip planes leave (golden's planner, on
        // the exact geometry the host holds).
        let mut runs = std::mem::take(&mut self.runs);
        runs.clear();
        let mut pre_runs = std::mem::take(&mut self.pre_runs);
        let pre_skip = match (&self.skip, slice.pre) {
            (Some(sk), Some(pre)) => {
                self.plan_pre_runs(sk, region, slice.range, &pre, &mut runs, &mut pre_runs);
                true
            }
            _ => false,
        };
        match &self.skip {
            _ if pre_skip => {}
            None => (0..nrows).for_each(|_| runs.push_row(&[(xlo, xhi)])),
            Some(sk) => {
                let ([px, py], _) = golden::sampling::slice_rays(&sk.view, &region.grid, slice.z);
                let mut tmp = std::mem::take(&mut self.run_tmp);
                for my in ylo..=yhi {
                    let y = py.a + my as f64 * py.t;
                    sk.mask.row_runs(slice.z, px, y, (xlo, xhi), &mut tmp);
                    runs.push_row(&tmp);
                }
                self.run_tmp = tmp;
            }
        }
        // The PEs plan their rows independently, so in parallel.
        let first_row = (ylo - glo) as usize;
        let pre = slice.pre.map(|p| PrePlan {
            step: p,
            my0: ylo,
            runs: pre_skip.then_some(&pre_runs),
        });
        // Every held ray's scoreboard stamp was written by a sample or a
        // migration: when none is later than now (front to back, none is
        // now, as a terminated ray's flag must land before its row's first
        // clock), no row can wait.
        let lands_by = self.clock.reports().map(|r| r.lands_by).max().unwrap_or(0);
        let waits = lands_by + u64::from(ftb) > self.clock.now();
        let mut host = QuantStats::default();
        let rows = self.rows(region, slice, &mut host);
        let whole = !(self.clock.tracing() || self.clocked);
        let shade = self.dp.loaded.shade.is_some();
        self.clock.broadcast(&Broadcast::PlanRows {
            first_row,
            rows: nrows,
            runs: &runs,
            ftb,
            waits,
            pre: pre.as_ref(),
            edges: rows.as_ref().ok().filter(|_| whole).map(|rows| EdgeRead {
                z: slice.z,
                rows,
                shade,
            }),
        });
        if let Some(c) = self.clock.capture() {
            crate::cosim::pe_sample::rows_planned(
                c,
                self.clock.cycle(),
                first_row,
                self.clock.pes(),
                &runs,
            );
        }
        // Each row's cycles: as many as the busiest PE has scheduled rays
        // (in the runs, and front to back live); and the earliest start the
        // PEs' scoreboards allow.
        let mut reports: Vec<RowReport> = vec![(0, 0, 0); nrows];
        for pe_rows in self.clock.row_reports() {
            for (out, &(n, at)) in reports.iter_mut().zip(pe_rows) {
                *out = (out.0.max(n), out.1.max(at), out.2 + n as u64);
            }
        }
        let taken: u64 = reports.iter().map(|r| r.2).sum();
        self.samples_per_slice[slice.z] += taken;
        self.skipped.beams += reports.iter().filter(|r| r.0 == 0).count() as u64;
        let full = if row_len == 0 {
            0
        } else {
            u64::from(p > 1) + (nrows * row_len) as u64
        };
        let sum: usize = reports.iter().map(|r| r.0).sum();
        let took = if sum == 0 {
            0
        } else {
            u64::from(p > 1) + sum as u64
        };
        self.cycles_saved += full - took;
        if sum == 0 {
            // Nothing to sample (empty, clipped or terminated): no cycle, no
            // read; the schedules only count the terminated rays.
            for r in 0..nrows {
                self.clock.broadcast(&Broadcast::BeginRow(r));
            }
            self.runs = runs;
            self.pre_runs = pre_runs;
            return Ok(());
        }
        let times = self.row_times(&reports, &runs);
        if let Some(c) = self.clock.capture() {
            let from = self.clock.now();
            crate::cosim::pe_sample::plan_runs(c, from, first_row, &runs, &times.lens);
        }
        // The next slice's rays may start moving from here.
        self.links_from = self.clock.now();
        let rows = rows?;
        self.host_stats.merge(&host);
        let r = if !whole {
            self.sample_clocked(region, slice, &rows, &times)
        } else {
            self.sample_whole(region, slice, &rows, &times)
        };
        self.runs = runs;
        self.pre_runs = pre_runs;
        r
    }

    /// Each row's start: after the previous row (and the prologue before
    /// the first, with several PEs), held back until the row's plan is
    /// written (the controller sends the runs of the slice's sampled rows
    /// to the PEs' plan ports one a clock, row after row, from the slice's
    /// first clock: the row's last run's beat [`PLAN_TO_ISSUE`] clocks
    /// before; a row no PE samples is not sent, its word never read), to the
    /// latest start the PEs reported and, with the rays' buffer external,
    /// until the row's rays have arrived (read while the row before
    /// samples; written back after its last sample has).
    fn row_times(&mut self, reports: &[RowReport], runs: &RowRuns) -> RowTimes {
        let prologue = u64::from(self.clock.pes().len() > 1);
        let latency = self.dp.latency;
        let mut next = self.clock.now();
        // The beat after the last run sent so far.
        let mut beat = self.clock.now();
        // Row `r`'s read issues when row `r - (rows - 1)` starts (the
        // slice's start for the first rows): its buffer is free then.
        let ahead = usize::from(self.dp.cfg.ray_buffer_rows) - 1;
        let mut started: std::collections::VecDeque<u64> = std::collections::VecDeque::new();
        let mut first = true;
        let mut times = RowTimes {
            lens: Vec::with_capacity(reports.len()),
            starts: Vec::with_capacity(reports.len()),
            stalls: Vec::with_capacity(reports.len()),
            memory: Vec::with_capacity(reports.len()),
            plan: Vec::with_capacity(reports.len()),
        };
        for (r, &(len, ready, rays)) in reports.iter().enumerate() {
            let (mut start, mut stall, mut memory, mut plan) = (0, 0, 0, 0);
            if len > 0 {
                beat += runs.row(r).len() as u64;
                let mut earliest = next + if first { prologue } else { 0 };
                plan = (beat - 1 + PLAN_TO_ISSUE).saturating_sub(earliest);
                earliest += plan;
                stall = ready.saturating_sub(earliest);
                start = earliest + stall;
                if let Some(ch) = self.channel.as_mut() {
                    let issue = if started.len() >= ahead {
                        started[started.len() - ahead]
                    } else {
                        self.clock.now()
                    };
                    let arrived = ch.read(issue, rays);
                    memory = arrived.saturating_sub(start);
                    start += memory;
                    ch.write(start + len as u64 - 1 + latency, rays);
                    started.push_back(start);
                    if started.len() > ahead {
                        started.pop_front();
                    }
                }
                next = start + len as u64;
                first = false;
            }
            times.lens.push(len);
            times.starts.push(start);
            times.stalls.push(stall);
            times.memory.push(memory);
            times.plan.push(plan);
        }
        times
    }

    /// The rows' broadcast values: voxel rows, y weight, y slope, with the
    /// host's quantisation events computing them counted into `st` (which
    /// the caller adds once the slice samples).
    fn rows(
        &self,
        region: &RegionPlan,
        slice: &SlicePlan,
        st: &mut QuantStats,
    ) -> Result<Vec<Row>, RunError> {
        let (ylo, yhi) = slice.range[1];
        let ny = self.ny;
        let dp = &self.dp;
        let mut rows = Vec::with_capacity((yhi - ylo + 1) as usize);
        for my in ylo..=yhi {
            let y = dp.position(slice.a[1], slice.t[1], my, st)?;
            let (y0, wy) = dp.address(y, st);
            let last = ny as i64 - 1;
            let mt = Wide::new(i128::from(my), 0).checked_mul(region.slope_k[1])?;
            let sy = crate::reg!(dp.cfg, position)
                .assign(Wide::from(region.slope_b[1]).checked_add(mt)?, st);
            rows.push((
                my,
                (
                    y0.clamp(0, last) as usize,
                    (y0 + 1).clamp(0, last) as usize,
                    wy,
                ),
                sy,
                y,
            ));
        }
        Ok(rows)
    }

    /// The clocked sampling of a slice: stall cycles, the prologue, then
    /// every row cycle by cycle.
    fn sample_clocked(
        &mut self,
        region: &RegionPlan,
        slice: &SlicePlan,
        rows: &[Row],
        times: &RowTimes,
    ) -> Result<(), RunError> {
        let glo = region.grid.lo[1];
        let p = self.clock.pes().len();
        let dp = std::sync::Arc::clone(&self.dp);
        let nx = self.nx;
        let lens = &times.lens;
        // The rows that take cycles, and for each the next one (whose edge
        // voxels the PEs drive during its last cycle).
        let sampled: Vec<usize> = (0..rows.len()).filter(|&r| lens[r] > 0).collect();
        let mut following = sampled.iter().skip(1);
        let slope_x = (region.slope_b[0], region.slope_k[0]);
        for (r, &(my, y, sy, yp)) in rows.iter().enumerate() {
            let row = (my - glo) as usize;
            // Each PE schedules its rays in the row's runs (front to back
            // its live ones, counting the rest).
            self.clock.broadcast(&Broadcast::BeginRow(r));
            let len = lens[r];
            if len == 0 {
                continue;
            }
            let (z, dp) = (slice.z, &*dp);
            for (n, stage) in [
                (times.plan[r], Stage::Plan),
                (times.memory[r], Stage::Memory),
            ] {
                let mut hold = Hold {
                    dp,
                    ctrl: Ctrl::at(stage, z, row),
                };
                for _ in 0..n {
                    self.clock.tick(&mut hold)?;
                }
            }
            for _ in 0..times.stalls[r] {
                self.clock.tick(&mut Stall { dp, z, row })?;
            }
            if r == sampled[0] && p > 1 {
                // Prologue: one cycle in which every PE only drives its edge
                // voxels for the first row (the previous stage's ports
                // carried rays). A lone PE has no neighbour to wait for.
                let bus = SampleBus {
                    slice,
                    my,
                    row,
                    y,
                    yp,
                    cycle: usize::MAX,
                    slope_yz: (sy, region.slope_z),
                    slope_x,
                    next: Some((slice.z, y.0, y.1)),
                    now: self.clock.now(),
                };
                if let Some(c) = self.clock.capture() {
                    crate::cosim::pe_sample::sample_bus(c, &bus);
                }
                self.clock.tick(&mut RowStep { dp, bus, nx })?;
            }
            debug_assert_eq!(self.clock.now(), times.starts[r]);
            let after = following
                .next()
                .map(|&n| (slice.z, rows[n].1 .0, rows[n].1 .1));
            for cycle in 0..len {
                let next = if cycle + 1 < len {
                    Some((slice.z, y.0, y.1))
                } else {
                    after
                };
                let bus = SampleBus {
                    slice,
                    my,
                    row,
                    y,
                    yp,
                    cycle,
                    slope_yz: (sy, region.slope_z),
                    slope_x,
                    next,
                    now: self.clock.now(),
                };
                if let Some(c) = self.clock.capture() {
                    crate::cosim::pe_sample::sample_bus(c, &bus);
                }
                self.clock.tick(&mut RowStep { dp, bus, nx })?;
            }
        }
        Ok(())
    }
}
