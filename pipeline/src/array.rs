//! The array and its controller: P PEs in a line, the clock loop of each
//! stage (migrate, sample, merge, readout), the counters and the
//! waveform probes. Column blocks: PE `k` owns voxel columns
//! `k W .. (k + 1) W` (`W = ceil(nx / P)`, the last PEs may own fewer or
//! none) of every slice, and holds every ray whose sample's base column
//! `clamp(floor(x), 0, nx - 1)` falls in its block.
//!
//! Stage by stage, mirroring `golden::methods` back-to-front:
//! - **migrate** (before each slice): rays whose base column moved to
//!   another block travel one link per cycle, one ray per link and
//!   direction per cycle, until every PE holds exactly its rays.
//! - **sample**: the slice's ray rows in order; in cycle `c` of a row each
//!   PE samples its `c`-th ray of that row, so a row takes as many cycles
//!   as the busiest PE has rays (the rest idle). The voxel column right of
//!   a block comes from the right neighbour's port, driven one cycle ahead.
//! - **merge** (at each region boundary): after a migration to the rays'
//!   positions on the boundary plane, the Bartlett merge, x pass then
//!   y pass through a line buffer; edge parents come over the ports. It is
//!   modelled at row granularity: one port exchange per parent row, and as
//!   many cycles as the busiest PE has child columns (the y pass runs
//!   pipelined behind the x pass).
//! - **readout**: each PE streams its region-0 rays to the host, one per
//!   cycle.
//!
//! Front to back (`order = "front-to-back"`, mirroring golden `er-ftb`),
//! the same stages walk the regions from the front, with two more:
//! - **sample** composites `C += (1 - A) a c`, `A += (1 - A) a`, and sets a
//!   ray's termination flag once its opacity word reaches the threshold. A
//!   row runs for as many cycles as the busiest PE has *live* rays in it;
//!   terminated rays are skipped without a cycle, and a row in which every
//!   PE's rays are terminated costs nothing (the PEs report their live
//!   counts at the start of a row).
//! - **split** (at each region boundary, after a migration to the rays'
//!   positions on the boundary plane, one voxel apart there): the bilinear
//!   split, the merge's adjoint, x pass then y pass through a line buffer;
//!   a child is computed by the PE holding its parent `floor(n / 2)`, the
//!   other parent comes over the port. Each PE keeps its parents' final
//!   states for the fold, and each child carries what it inherited.
//! - **fold** (after the last region, boundary by boundary from the back):
//!   the back region's rays go to the PE that kept their split parent's
//!   final state; each PE forms the differences `result - inherited`, runs
//!   them through the Bartlett merge (x pass, port exchange, y pass, as the
//!   merge) and adds its kept final states: `result_(i-1) = final_(i-1) +
//!   merge(result_i - inherited_i)`. The results live in `merge` words
//!   (they can exceed 1), so the front-to-back baseplane's raw words are
//!   `merge` words ([`Frame::raw_format`]).
//!
//! Memory this costs (not in `crate::cost`'s inventory, which sizes the
//! back-to-front PE): the compositing buffer twice as wide (accumulators
//! plus inherited state, and a flag bit), and the kept final states, about
//! `(W + 1)(ny + 1)` rays per region boundary per PE.

use golden::geometry::View;
use golden::volume::Volume;
use golden::warp::Baseplane;
use waves::Tracer;

use std::sync::Arc;

use crate::config::{Order, PipelineConfig};
use crate::datapath::{Acc, Datapath};
use crate::fixed::{Format, Fx, QuantStats, Wide};
use crate::host::{plan, voxel_words, FramePlan, PlanError, RegionPlan, SlicePlan};
use crate::pe::{
    FtbState, Pe, PeCounters, Ports, RayColumn, RowBus, RowRuns, SampleBus, StepError,
};
use crate::probes::{Ctrl, Probes, Stage};
use crate::skip::SkipCounts;
use crate::tables::Tables;
use golden::skip::SampleMask;

/// Cycles spent in each stage of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct StageCycles {
    /// Ray migration before slices.
    pub migrate: u64,
    /// Sampling.
    pub sample: u64,
    /// Bartlett merges.
    pub merge: u64,
    /// Baseplane readout.
    pub readout: u64,
    /// Front to back: bilinear splits (left out of the JSON when zero, so
    /// a back-to-front frame reports the four stages it has).
    #[serde(skip_serializing_if = "is_zero")]
    pub split: u64,
    /// Front to back: the fold (merges of differences and adds).
    #[serde(skip_serializing_if = "is_zero")]
    pub fold: u64,
    /// Slices skipped whole by the controller, one cycle each (left out of
    /// the JSON when zero).
    #[serde(skip_serializing_if = "is_zero")]
    pub skip: u64,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

/// A frame's results.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The baseplane in float (accumulator words scaled), for the warp.
    pub baseplane: Baseplane,
    /// The baseplane's raw words, row-major, R G B A, in
    /// [`Frame::raw_format`].
    pub raw: Vec<[i64; 4]>,
    /// Formats of the raw words (colour, opacity): the accumulators back to
    /// front; front to back the fold's `merge` words (the accumulators when
    /// there is one region and so no fold).
    pub raw_format: [Format; 2],
    /// The compositing order the frame ran in.
    pub order: Order,
    /// Cycles per frame.
    pub cycles: u64,
    /// Cycles per stage.
    pub stages: StageCycles,
    /// Samples taken in all.
    pub samples: u64,
    /// Samples per slice, front (slice 0) to back.
    pub samples_per_slice: Vec<u64>,
    /// `samples / P`, the cycles of a perfectly busy array.
    pub ideal_cycles: f64,
    /// Per-PE counters.
    pub pes: Vec<PeCounters>,
    /// Merges performed.
    pub merges: u64,
    /// Quantisation events over the whole datapath.
    pub quant: QuantStats,
    /// Front to back: samples not taken because their ray was terminated.
    pub terminated_samples: u64,
    /// Sampling cycles saved within sampled slices by termination and by
    /// the rows' runs (empty space, clipping), against the same slices with
    /// every active ray sampled (rows as long as the busiest PE's active
    /// rays, and each slice's prologue). Skipped slices and regions save
    /// more; compare with a run without skipping for the total.
    pub cycles_saved: u64,
    /// What the controller skipped.
    pub skipped: SkipCounts,
}

impl Frame {
    /// `ideal_cycles / cycles`.
    pub fn utilization(&self) -> f64 {
        if self.cycles == 0 {
            0.0
        } else {
            self.ideal_cycles / self.cycles as f64
        }
    }
}

/// Why a frame failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Planning failed.
    #[error("{0}")]
    Plan(#[from] PlanError),
    /// A PE's clock step failed.
    #[error("{0}")]
    Step(#[from] StepError),
    /// The tables could not be built.
    #[error("{0}")]
    Fixed(#[from] crate::fixed::FxError),
    /// The configuration does not fit the volume.
    #[error("{0}")]
    Config(#[from] crate::config::ConfigError),
    /// Writing the waveform failed.
    #[error("{0}")]
    Waves(#[from] waves::WavesError),
}

/// The PE array for one frame.
pub struct Array {
    /// Shared so that owner functions can borrow it while the PEs step.
    dp: Arc<Datapath>,
    pes: Vec<Pe>,
    ports: Vec<Ports>,
    spare: Vec<Ports>,
    block: usize,
    nx: usize,
    ny: usize,
    cycle: u64,
    stages: StageCycles,
    samples_per_slice: Vec<u64>,
    probes: Option<Probes>,
    host_stats: QuantStats,
    order: Vec<usize>,
    clocked: bool,
    cycles_saved: u64,
    /// What the controller skips, when it skips (see [`Array::set_skipping`]).
    skip: Option<Skipper>,
    /// The current slice's runs per row (reused).
    runs: RowRuns,
    run_tmp: Vec<(i64, i64)>,
    skipped: SkipCounts,
}

/// The controller's skipping state for one frame.
struct Skipper {
    mask: SampleMask,
    view: View,
}

impl Array {
    /// Loads `volume` (seen through `view`) into `cfg.pes` PEs with the
    /// classification table `lut`. `tracer` records waveforms (use
    /// `Tracer::disabled()` for none).
    pub fn new(
        cfg: &PipelineConfig,
        volume: &Volume,
        lut: &golden::tf::Lut,
        view: &View,
        tracer: Tracer,
    ) -> Result<Array, RunError> {
        cfg.validate()?;
        for &n in &view.dims {
            cfg.check_extent(n as u32)?;
        }
        let tables = Tables::new(cfg, lut)?;
        let dp = Arc::new(Datapath::new(*cfg, tables));
        let mut host_stats = QuantStats::default();
        let words = voxel_words(cfg, volume, view, &mut host_stats);
        let p = usize::from(cfg.pes);
        let nx = view.dims[0];
        let block = nx.div_ceil(p);
        let pes = (0..p)
            .map(|k| {
                let c0 = (k * block).min(nx);
                let c1 = ((k + 1) * block).min(nx);
                Pe::new(k, c0..c1, &words, view.dims)
            })
            .collect();
        let probes = if tracer.is_enabled() {
            Some(Probes::new(tracer, p, cfg)?)
        } else {
            None
        };
        Ok(Array {
            dp,
            pes,
            ports: vec![Ports::default(); p],
            spare: vec![Ports::default(); p],
            block,
            nx,
            ny: view.dims[1],
            cycle: 0,
            stages: StageCycles::default(),
            samples_per_slice: vec![0; view.dims[2]],
            probes,
            host_stats,
            order: (0..p).collect(),
            clocked: false,
            cycles_saved: 0,
            skip: None,
            runs: RowRuns::default(),
            run_tmp: Vec::new(),
            skipped: SkipCounts::default(),
        })
    }

    /// Skips what `mask` (golden's planner over this pipeline's occupancy
    /// memory, see [`crate::skip`]) leaves out of a frame of `view`: empty
    /// and clipped-away slices cost one cycle each (the controller reads
    /// the slice's summary bit and moves on, without migrating), rows and
    /// runs of rays outside the mask cost nothing (the controller plans a
    /// row's runs while the previous row samples; the PEs compare ray
    /// indices with the broadcast runs), culled rays are held and migrate
    /// but never sample, and regions behind the last visible slice do not
    /// run.
    pub fn set_skipping(&mut self, mask: SampleMask, counts: SkipCounts, view: &View) {
        self.skipped = SkipCounts {
            rays_culled: mask.culled_rays,
            ..counts
        };
        self.skip = Some(Skipper {
            mask,
            view: view.clone(),
        });
    }

    /// Regions to run, front ones first: all, or up to the one holding the
    /// last visible slice (the rest would composite nothing).
    fn regions_to_run(&mut self, plan: &FramePlan) -> usize {
        let k = plan.regions.len();
        let Some(sk) = &self.skip else { return k };
        let runs = sk.mask.regions_to_run();
        self.skipped.regions = (k - runs) as u64;
        self.skipped.slices += plan.regions[runs..]
            .iter()
            .map(|r| r.slices.len() as u64)
            .sum::<u64>();
        runs
    }

    /// The slice as the controller runs it: `None` when skipped whole
    /// (one cycle), else with its ray ranges narrowed by culling.
    fn visit(&mut self, i: usize, slice: &SlicePlan) -> Option<SlicePlan> {
        let Some(sk) = &self.skip else {
            return Some(*slice);
        };
        if !sk.mask.slice_visible(slice.z) {
            self.skipped.slices += 1;
            self.stages.skip += 1;
            self.advance(Stage::Skip, slice.z, 0, 1);
            return None;
        }
        Some(SlicePlan {
            range: sk.mask.rays(i, slice.range),
            ..*slice
        })
    }

    /// Steps the sampling stage cycle by cycle even without tracing (it
    /// always does when tracing). By default an untraced run samples each
    /// slice PE by PE, in parallel: the same bits and cycle counts, faster.
    pub fn set_clocked(&mut self, on: bool) {
        self.clocked = on;
    }

    /// Steps PEs in this order within a cycle (any order gives the same
    /// result; tests use it to prove that).
    pub fn set_step_order(&mut self, order: Vec<usize>) {
        assert_eq!(order.len(), self.pes.len());
        self.order = order;
    }

    /// Who holds which ray in `slice`, computed with `dp` (the array's
    /// datapath, borrowed apart from the array so the PEs can step).
    fn owners<'a>(&self, dp: &'a Datapath, slice: &'a SlicePlan) -> Owners<'a> {
        Owners {
            dp,
            slice,
            nx: self.nx,
            block: self.block,
            pes: self.pes.len(),
        }
    }

    /// Runs a frame of `view`, in the configuration's compositing order.
    pub fn run(mut self, view: &View) -> Result<Frame, RunError> {
        let plan: FramePlan = plan(&self.dp.cfg, view)?;
        self.host_stats.merge(&plan.stats);
        if self.dp.cfg.order == Order::FrontToBack {
            return self.run_ftb(&plan, view);
        }
        let k = self.regions_to_run(&plan);
        let mut merges = 0;
        for i in (0..k).rev() {
            let region = &plan.regions[i];
            if i == k - 1 {
                self.distribute(region);
            }
            for slice in &region.slices {
                let Some(slice) = self.visit(i, slice) else {
                    continue;
                };
                self.migrate(&slice)?;
                self.sample(region, &slice)?;
            }
            if i > 0 {
                // Rays merge on the boundary plane: first bring each to the
                // PE of its position there, so that every PE holds rays and
                // a merge's neighbours are one link away even when regions
                // without slices follow one another (eyes closer than half a
                // voxel).
                self.migrate(&region.front)?;
                self.merge(region, &plan.regions[i - 1])?;
                merges += 1;
            }
        }
        let fmt = [self.dp.cfg.accum_color, self.dp.cfg.accum_alpha];
        let (base, raw) = self.readout(&plan.regions[0], view, fmt);
        self.finish(base, raw, fmt, merges)
    }

    /// Front to back: regions from the front, a split at each boundary,
    /// then the fold from the back.
    fn run_ftb(mut self, plan: &FramePlan, view: &View) -> Result<Frame, RunError> {
        let k = self.regions_to_run(plan);
        self.distribute(&plan.regions[0]);
        let mut merges = 0;
        for i in 0..k {
            let region = &plan.regions[i];
            if i > 0 {
                // Parents split on the boundary plane, one voxel apart:
                // every PE in their span holds some, so each child's second
                // parent is held or one link away.
                let front = &plan.regions[i - 1];
                self.migrate(&front.rear)?;
                self.split(front, region)?;
                merges += 1;
            }
            for slice in region.slices.iter().rev() {
                let Some(slice) = self.visit(i, slice) else {
                    continue;
                };
                self.migrate(&slice)?;
                self.sample(region, &slice)?;
            }
        }
        let acc = [self.dp.cfg.accum_color, self.dp.cfg.accum_alpha];
        let merge = [self.dp.cfg.merge, self.dp.cfg.merge];
        let mut fmt = acc;
        for i in (1..k).rev() {
            let (back, front) = (&plan.regions[i], &plan.regions[i - 1]);
            // Each back ray goes to the PE that kept its split parent's
            // final state, where its difference joins the merge.
            let dp = Arc::clone(&self.dp);
            let owners = self.owners(&dp, &front.rear);
            let (lo, hi) = (front.grid.lo[0], front.grid.hi[0]);
            self.migrate_by(front.rear.z, |n| owners.of(clamp(n.div_euclid(2), lo, hi)))?;
            self.fold(back, front, fmt)?;
            fmt = merge;
        }
        // The fold leaves region 0's rays where their parents sat on the
        // region-1 boundary (the rays beyond the volume's sides piled into
        // the end PEs); bring them back to their slice-0 owners so the
        // readout streams from every PE.
        if let Some(front) = plan.regions[0].slices.last() {
            self.migrate(front)?;
        }
        let (base, raw) = self.readout(&plan.regions[0], view, fmt);
        self.finish(base, raw, fmt, merges)
    }

    /// Creates a region's (empty, live) rays in the PEs that sample them
    /// first: region 0's front to back (from its front slice), the last
    /// region's back to front (from its rear slice).
    fn distribute(&mut self, region: &RegionPlan) {
        let g = &region.grid;
        let rows = g.counts()[1];
        let ftb = self.dp.cfg.order == Order::FrontToBack;
        let dp = Arc::clone(&self.dp);
        // Slices are planned back to front.
        let first = if ftb {
            region.slices.last()
        } else {
            region.slices.first()
        };
        let first = first.map(|s| self.owners(&dp, s));
        for mx in g.lo[0]..=g.hi[0] {
            let k = first.as_ref().map_or(0, |o| o.of(mx));
            self.pes[k].rays.push_back(RayColumn {
                mx,
                acc: vec![Acc::default(); rows],
                ftb: if ftb {
                    vec![FtbState::default(); rows]
                } else {
                    Vec::new()
                },
            });
        }
    }

    /// Traces the current cycle with the committed port outputs
    /// `self.ports` (migration and sampling drive them).
    fn trace(&mut self, stage: Stage, z: usize, row: usize) {
        trace(
            &mut self.probes,
            &self.pes,
            &self.ports,
            self.cycle,
            stage,
            z,
            row,
        );
    }

    /// `n` cycles in which only the controller's state shows: the stage,
    /// slice and row, traced each cycle; no PE drives a link.
    fn advance(&mut self, stage: Stage, z: usize, row: usize, n: u64) {
        self.advance_driving(stage, z, row, n, &[]);
    }

    /// `n` cycles in which the PEs hold `ports` on their links (a merge,
    /// split or fold row's edge rays; empty: nothing driven).
    fn advance_driving(&mut self, stage: Stage, z: usize, row: usize, n: u64, ports: &[Ports]) {
        for _ in 0..n {
            self.cycle += 1;
            trace(
                &mut self.probes,
                &self.pes,
                ports,
                self.cycle,
                stage,
                z,
                row,
            );
        }
    }
}

/// Records one cycle of every traced signal, `ports` being what the PEs
/// drove on their links in it; a single branch when tracing is off.
fn trace(
    probes: &mut Option<Probes>,
    pes: &[Pe],
    ports: &[Ports],
    cycle: u64,
    stage: Stage,
    slice: usize,
    row: usize,
) {
    let Some(pr) = probes.as_mut() else { return };
    pr.sample(cycle, pes, ports, Ctrl { stage, slice, row });
}

impl Array {
    /// Migration before `slice`: clocks until every ray sits in its owner.
    fn migrate(&mut self, slice: &SlicePlan) -> Result<(), RunError> {
        let dp = Arc::clone(&self.dp);
        let owners = self.owners(&dp, slice);
        self.migrate_by(slice.z, |mx| owners.of(mx))
    }

    /// Migration to the owners `owner` gives (traced at slice `z`): clocks
    /// until every ray sits in its owner.
    fn migrate_by(&mut self, z: usize, owner: impl Fn(i64) -> usize) -> Result<(), RunError> {
        for pe in &mut self.pes {
            pe.plan_moves(&owner);
        }
        let p = self.pes.len();
        let mut cycles = 0u64;
        while !(self.pes.iter().all(Pe::settled)
            && self
                .ports
                .iter()
                .all(|p| p.left.ray.is_none() && p.right.ray.is_none()))
        {
            let none = Ports::default();
            for &k in &self.order {
                let from_left = if k > 0 { &self.ports[k - 1] } else { &none };
                let from_right = if k + 1 < p { &self.ports[k + 1] } else { &none };
                self.spare[k] = self.pes[k].migrate_step(from_left, from_right, &owner);
            }
            std::mem::swap(&mut self.ports, &mut self.spare);
            self.cycle += 1;
            cycles += 1;
            self.trace(Stage::Migrate, z, 0);
        }
        self.stages.migrate += cycles;
        Ok(())
    }

    /// Samples one slice, row by row, cycle by cycle.
    fn sample(&mut self, region: &RegionPlan, slice: &SlicePlan) -> Result<(), RunError> {
        let (ylo, yhi) = slice.range[1];
        let (xlo, xhi) = slice.range[0];
        if ylo > yhi || xlo > xhi {
            return Ok(());
        }
        let row_len = self
            .pes
            .iter_mut()
            .map(|pe| pe.select(slice))
            .max()
            .unwrap_or(0);
        let nrows = (yhi - ylo + 1) as usize;
        let glo = region.grid.lo[1];
        let p = self.pes.len();
        let ftb = self.dp.cfg.order == Order::FrontToBack;
        // The controller's runs per row: the whole slice range, or what the
        // occupancy memory and the clip planes leave (golden's planner, on
        // the exact geometry the host holds).
        let mut runs = std::mem::take(&mut self.runs);
        runs.clear();
        match &self.skip {
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
        // Cycles of each row: as many as the busiest PE has scheduled rays
        // (in the runs, and front to back live).
        let mut taken = 0u64;
        let lens: Vec<usize> = (0..nrows)
            .map(|r| {
                let row = (ylo + r as i64 - glo) as usize;
                self.pes.iter().fold(0, |most, pe| {
                    let n = pe.count_in_row(row, runs.row(r), ftb);
                    taken += n as u64;
                    most.max(n)
                })
            })
            .collect();
        self.samples_per_slice[slice.z] += taken;
        self.skipped.beams += lens.iter().filter(|&&n| n == 0).count() as u64;
        let full = if row_len == 0 {
            0
        } else {
            u64::from(p > 1) + (nrows * row_len) as u64
        };
        let sum: usize = lens.iter().sum();
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
                let row = (ylo + r as i64 - glo) as usize;
                for pe in &mut self.pes {
                    pe.begin_row(row, runs.row(r), ftb);
                }
            }
            self.runs = runs;
            return Ok(());
        }
        let ny = self.ny;
        let dp = &self.dp;
        let mut st = QuantStats::default();
        let mut rows = Vec::with_capacity(nrows);
        for my in ylo..=yhi {
            let y = dp.position(slice.a[1], slice.t[1], my, &mut st)?;
            let (y0, wy) = dp.address(y, &mut st);
            let last = ny as i64 - 1;
            let mt = Wide::new(i128::from(my), 0).checked_mul(region.slope_k[1])?;
            let sy = dp
                .cfg
                .position
                .assign(Wide::from(region.slope_b[1]).checked_add(mt)?, &mut st);
            rows.push((
                my,
                (
                    y0.clamp(0, last) as usize,
                    (y0 + 1).clamp(0, last) as usize,
                    wy,
                ),
                sy,
            ));
        }
        self.host_stats.merge(&st);
        if self.probes.is_none() && !self.clocked {
            let r = self.sample_whole(region, slice, &rows, &runs, &lens);
            self.runs = runs;
            return r;
        }
        // The rows that take cycles, and for each the next one (whose edge
        // voxels the PEs drive during its last cycle).
        let sampled: Vec<usize> = (0..nrows).filter(|&r| lens[r] > 0).collect();
        // Prologue: one cycle in which every PE only drives its edge voxels
        // for the first row (the previous stage's ports carried rays). A
        // lone PE has no neighbour to wait for.
        let (my0, y_first, sy0) = rows[sampled[0]];
        let setup = SampleBus {
            slice,
            my: my0,
            row: (my0 - glo) as usize,
            y: y_first,
            cycle: usize::MAX,
            slope_yz: (sy0, region.slope_z),
            slope_x: (region.slope_b[0], region.slope_k[0]),
            next: Some((slice.z, y_first.0, y_first.1)),
        };
        let none = Ports::default();
        if p > 1 {
            for &k in &self.order {
                let from_right = if k + 1 < p { &self.ports[k + 1] } else { &none };
                self.spare[k] = self.pes[k].sample_step(&self.dp, &setup, from_right, self.nx)?;
            }
            std::mem::swap(&mut self.ports, &mut self.spare);
            self.cycle += 1;
            self.stages.sample += 1;
            self.trace(Stage::Sample, slice.z, setup.row);
        }
        let mut following = sampled.iter().skip(1);
        for (r, &(my, y, sy)) in rows.iter().enumerate() {
            let row = (my - glo) as usize;
            // Each PE schedules its rays in the row's runs (front to back
            // its live ones, counting the rest).
            for pe in &mut self.pes {
                pe.begin_row(row, runs.row(r), ftb);
            }
            let len = lens[r];
            if len == 0 {
                continue;
            }
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
                    cycle,
                    slope_yz: (sy, region.slope_z),
                    slope_x: (region.slope_b[0], region.slope_k[0]),
                    next,
                };
                // Two-phase clock: every PE reads last cycle's port outputs
                // (`ports`) and drives next cycle's (`spare`), then they swap.
                for &k in &self.order {
                    let from_right = if k + 1 < p { &self.ports[k + 1] } else { &none };
                    self.spare[k] = self.pes[k].sample_step(&self.dp, &bus, from_right, self.nx)?;
                }
                std::mem::swap(&mut self.ports, &mut self.spare);
                self.cycle += 1;
                self.trace(Stage::Sample, slice.z, row);
            }
            self.stages.sample += len as u64;
        }
        self.runs = runs;
        Ok(())
    }

    /// The sampling stage of one slice without per-cycle stepping: the
    /// same arithmetic and counters as the clocked path (proved by the
    /// tests), each PE's whole slice at once, PEs in parallel. Each PE
    /// first produces the edge voxels it would drive in each row; each PE
    /// then samples its rays with its right neighbour's. `lens` holds each
    /// row's cycles (front to back, rows of 0 cycles are skipped).
    fn sample_whole(
        &mut self,
        region: &RegionPlan,
        slice: &SlicePlan,
        rows: &[(i64, (usize, usize, Fx), Fx)],
        runs: &RowRuns,
        lens: &[usize],
    ) -> Result<(), RunError> {
        use rayon::prelude::*;
        let p = self.pes.len();
        let glo = region.grid.lo[1];
        let buses: Vec<RowBus> = rows
            .iter()
            .map(|&(my, y, sy)| RowBus {
                slice,
                row: (my - glo) as usize,
                y,
                slope_yz: (sy, region.slope_z),
                slope_x: (region.slope_b[0], region.slope_k[0]),
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
        let edges: Vec<Vec<[u16; 2]>> = self
            .pes
            .iter()
            .map(|pe| pe.edges_for(slice.z, &buses))
            .collect();
        let dp = &self.dp;
        let nx = self.nx;
        let results: Vec<Result<(), StepError>> = self
            .pes
            .par_iter_mut()
            .enumerate()
            .map(|(k, pe)| {
                pe.latch_edges(seq.iter().copied());
                if p > 1 {
                    pe.counters.idle += 1;
                }
                pe.sample_slice(
                    dp,
                    &buses,
                    runs,
                    lens,
                    edges.get(k + 1).map(Vec::as_slice),
                    nx,
                )
            })
            .collect();
        for r in results {
            r?;
        }
        let cycles = u64::from(p > 1) + lens.iter().sum::<usize>() as u64;
        self.cycle += cycles;
        self.stages.sample += cycles;
        Ok(())
    }

    /// Bartlett merge of `back`'s rays into `front`'s.
    fn merge(&mut self, back: &RegionPlan, front: &RegionPlan) -> Result<(), RunError> {
        let (bg, fg) = (&back.grid, &front.grid);
        let prow = bg.counts()[1];
        let frows = fg.counts()[1];
        // Which child columns each PE computes: centre parent clamped into
        // the parent rectangle, held by that PE.
        let spans: Vec<Option<(i64, i64)>> = self.pes.iter().map(|pe| pe.span()).collect();
        let mut children: Vec<Vec<i64>> = vec![Vec::new(); self.pes.len()];
        for m in fg.lo[0]..=fg.hi[0] {
            let centre = (2 * m).clamp(bg.lo[0], bg.hi[0]);
            let k = spans
                .iter()
                .position(|s| matches!(s, Some((lo, hi)) if (*lo..=*hi).contains(&centre)))
                .unwrap_or(0);
            children[k].push(m);
        }
        let width = children.iter().map(Vec::len).max().unwrap_or(0) as u64;
        // x pass, one parent row per step; the line buffer keeps every
        // x-merged row for the y pass (three rows deep in hardware).
        let p = self.pes.len();
        // lines[row][pe][child] = the x-merged R, G, B, A words.
        let mut lines: Vec<Vec<Vec<[i64; 4]>>> = vec![vec![Vec::new(); p]; prow];
        for (row, row_lines) in lines.iter_mut().enumerate() {
            let drive: Vec<Ports> = self.pes.iter().map(|pe| pe.merge_drive(row)).collect();
            for &k in &self.order {
                let none = Ports::default();
                let from_left = if k > 0 { &drive[k - 1] } else { &none };
                let from_right = if k + 1 < p { &drive[k + 1] } else { &none };
                let mut line = Vec::new();
                self.pes[k].merge_x(
                    &self.dp,
                    row,
                    &children[k],
                    from_left,
                    from_right,
                    &mut line,
                );
                row_lines[k] = line;
            }
            self.advance_driving(Stage::Merge, 0, row, width, &drive);
        }
        // y pass: child row r takes parent rows 2 r - 1 ..= 2 r + 1.
        let (fc, fa, fm) = (
            self.dp.cfg.accum_color,
            self.dp.cfg.accum_alpha,
            self.dp.cfg.merge,
        );
        for k in 0..p {
            let pe = &mut self.pes[k];
            let mut cols: Vec<RayColumn> = children[k]
                .iter()
                .map(|&mx| RayColumn {
                    mx,
                    acc: vec![Acc::default(); frows],
                    ftb: Vec::new(),
                })
                .collect();
            for (r, my) in (fg.lo[1]..=fg.hi[1]).enumerate() {
                let at = |py: i64, c: usize, ch: usize| -> i64 {
                    let row = py - bg.lo[1];
                    if row < 0 || row >= prow as i64 {
                        0
                    } else {
                        lines[row as usize][k][c][ch]
                    }
                };
                for (c, col) in cols.iter_mut().enumerate() {
                    for ch in 0..4 {
                        let to = if ch < 3 { fc } else { fa };
                        let v = self.dp.tent(
                            [
                                at(2 * my - 1, c, ch),
                                at(2 * my, c, ch),
                                at(2 * my + 1, c, ch),
                            ],
                            fm,
                            to,
                            &mut pe.stats,
                        );
                        col.acc[r].raw[ch] = v.raw();
                    }
                }
            }
            pe.counters.merge_outputs += (cols.len() * frows) as u64;
            pe.set_rays(cols);
        }
        // The y pass drains two rows behind the x pass.
        self.advance(Stage::Merge, 0, prow, 2 * width);
        self.stages.merge += prow as u64 * width + 2 * width;
        Ok(())
    }

    /// Front to back: the bilinear split of `front`'s rays (on their rear
    /// plane) into `back`'s, the merge's adjoint. Back ray `n` continues
    /// front ray `n / 2` when `n` is even and takes the mean of front rays
    /// `floor(n / 2)` and `floor(n / 2) + 1` when odd, per axis. Like the
    /// merge it runs at row granularity: an x pass per parent row into the
    /// line buffer (the right neighbour's first column over the port), a y
    /// pass behind it (child rows take parent row `floor(my / 2)` and the
    /// next, from the PE's own buffer). One child is written per PE per
    /// cycle, so it takes the child rows times the busiest PE's child
    /// columns, plus a row of latency (an odd child row needs the next
    /// parent row). Each PE keeps its parents' final states for the fold
    /// and gives each child its initial state as its inheritance.
    fn split(&mut self, front: &RegionPlan, back: &RegionPlan) -> Result<(), RunError> {
        let (fg, bg) = (&front.grid, &back.grid);
        let prow = fg.counts()[1];
        let brows = bg.counts()[1];
        let p = self.pes.len();
        let dp = Arc::clone(&self.dp);
        let spans: Vec<Option<(i64, i64)>> = self.pes.iter().map(|pe| pe.span()).collect();
        let mut children: Vec<Vec<i64>> = vec![Vec::new(); p];
        for n in bg.lo[0]..=bg.hi[0] {
            let parent = clamp(n.div_euclid(2), fg.lo[0], fg.hi[0]);
            let k = spans
                .iter()
                .position(|s| matches!(s, Some((lo, hi)) if (*lo..=*hi).contains(&parent)))
                .unwrap_or(0);
            children[k].push(n);
        }
        let width = children.iter().map(Vec::len).max().unwrap_or(0) as u64;
        // x pass: lines[parent row][pe][child] = the x-split R, G, B, A words.
        let mut lines: Vec<Vec<Vec<[i64; 4]>>> = vec![vec![Vec::new(); p]; prow];
        let grid = (fg.lo[0], fg.hi[0]);
        // The ports of each parent row, kept for the waveforms only.
        let mut drives: Vec<Vec<Ports>> = Vec::new();
        for (row, row_lines) in lines.iter_mut().enumerate() {
            let drive: Vec<Ports> = self.pes.iter().map(|pe| pe.split_drive(row)).collect();
            for &k in &self.order {
                let none = Ports::default();
                let from_right = if k + 1 < p { &drive[k + 1] } else { &none };
                let mut line = Vec::new();
                self.pes[k].split_x(&dp, row, &children[k], grid, from_right, &mut line)?;
                row_lines[k] = line;
            }
            if self.probes.is_some() {
                drives.push(drive);
            }
        }
        // y pass, per PE from its own line buffer.
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        for k in 0..p {
            let pe = &mut self.pes[k];
            let mut cols: Vec<RayColumn> = children[k]
                .iter()
                .map(|&mx| RayColumn {
                    mx,
                    acc: vec![Acc::default(); brows],
                    ftb: vec![FtbState::default(); brows],
                })
                .collect();
            for (r, my) in (bg.lo[1]..=bg.hi[1]).enumerate() {
                let at = |py: i64, c: usize, ch: usize| -> i64 {
                    let row = py - fg.lo[1];
                    if row < 0 || row >= prow as i64 {
                        0
                    } else {
                        lines[row as usize][k][c][ch]
                    }
                };
                let py = my.div_euclid(2);
                let py2 = py + my.rem_euclid(2);
                for (c, col) in cols.iter_mut().enumerate() {
                    for ch in 0..4 {
                        let to = if ch < 3 { fc } else { fa };
                        let v = dp.halve([at(py, c, ch), at(py2, c, ch)], fm, to, &mut pe.stats);
                        col.acc[r].raw[ch] = v.raw();
                    }
                    col.ftb[r] = FtbState {
                        inh: col.acc[r],
                        // A child of terminated parents is terminated: the
                        // comparator checks every child as it is written.
                        done: dp.terminated(&col.acc[r]),
                    };
                }
            }
            pe.counters.split_outputs += (cols.len() * brows) as u64;
            let parents = std::mem::take(&mut pe.rays);
            pe.finals.push(parents.into());
            pe.set_rays(cols);
        }
        let cycles = brows as u64 * width + width;
        for c in 0..cycles {
            // Child row r is written from parent rows r / 2 and the next:
            // its cycles show parent row r / 2 on the links (the last row
            // of latency, none).
            let r = (c / width.max(1)) as usize;
            let shown = drives.get(r / 2).filter(|_| r < brows);
            self.advance_driving(Stage::Split, 0, r, 1, shown.map_or(&[], Vec::as_slice));
        }
        self.stages.split += cycles;
        Ok(())
    }

    /// Front to back: one step of the fold, `back`'s rays (results in
    /// formats `rf`: colour, opacity) into `front`'s, whose final states
    /// the PEs kept at the split: `result = final + merge(result_back -
    /// inherited_back)`. The merge is the back-to-front one (x pass with
    /// the left neighbour's last difference over the port, y pass behind
    /// it, row granularity, the same cycles: back rows times the busiest
    /// PE's children, plus two rows of drain); the difference is formed
    /// as a row enters the x pass and the add as a child leaves the y
    /// pass, each in the pipeline without a cycle of its own. Differences,
    /// merge passes and results are `merge` words.
    fn fold(
        &mut self,
        back: &RegionPlan,
        front: &RegionPlan,
        rf: [Format; 2],
    ) -> Result<(), RunError> {
        let (bg, fg) = (&back.grid, &front.grid);
        let brows = bg.counts()[1];
        let frows = fg.counts()[1];
        let p = self.pes.len();
        let dp = Arc::clone(&self.dp);
        let width = self
            .pes
            .iter()
            .map(|pe| pe.finals.last().map_or(0, Vec::len))
            .max()
            .unwrap_or(0) as u64;
        let grid = (bg.lo[0], bg.hi[0]);
        let mut lines: Vec<Vec<Vec<[i64; 4]>>> = vec![vec![Vec::new(); p]; brows];
        for (row, row_lines) in lines.iter_mut().enumerate() {
            let drive: Vec<Ports> = self
                .pes
                .iter_mut()
                .map(|pe| pe.fold_prepare(&dp, row, rf))
                .collect();
            for &k in &self.order {
                let none = Ports::default();
                let from_left = if k > 0 { &drive[k - 1] } else { &none };
                let mut line = Vec::new();
                self.pes[k].fold_x(&dp, grid, from_left, &mut line)?;
                row_lines[k] = line;
            }
            self.advance_driving(Stage::Fold, 0, row, width, &drive);
        }
        let (fc, fa, fm) = (dp.cfg.accum_color, dp.cfg.accum_alpha, dp.cfg.merge);
        for (k, pe) in self.pes.iter_mut().enumerate() {
            let kept = pe.finals.pop().unwrap_or_default();
            let mut cols = Vec::with_capacity(kept.len());
            for (c, fin) in kept.into_iter().enumerate() {
                let mut acc = vec![Acc::default(); frows];
                for (r, my) in (fg.lo[1]..=fg.hi[1]).enumerate() {
                    let at = |py: i64, ch: usize| -> i64 {
                        let row = py - bg.lo[1];
                        if row < 0 || row >= brows as i64 {
                            0
                        } else {
                            lines[row as usize][k][c][ch]
                        }
                    };
                    for ch in 0..4 {
                        let merged = dp.tent(
                            [at(2 * my - 1, ch), at(2 * my, ch), at(2 * my + 1, ch)],
                            fm,
                            fm,
                            &mut pe.stats,
                        );
                        let ff = if ch < 3 { fc } else { fa };
                        acc[r].raw[ch] = dp
                            .fold_add(fin.acc[r].raw[ch], ff, merged.raw(), &mut pe.stats)
                            .raw();
                    }
                }
                cols.push(RayColumn {
                    mx: fin.mx,
                    acc,
                    ftb: fin.ftb,
                });
            }
            pe.counters.merge_outputs += (cols.len() * frows) as u64;
            pe.set_rays(cols);
        }
        self.advance(Stage::Fold, 0, brows, 2 * width);
        self.stages.fold += brows as u64 * width + 2 * width;
        Ok(())
    }

    /// Streams region 0's rays out, one per PE per cycle; `fmt` gives the
    /// words' formats (colour, opacity).
    fn readout(
        &mut self,
        region: &RegionPlan,
        view: &View,
        fmt: [Format; 2],
    ) -> (Baseplane, Vec<[i64; 4]>) {
        let g = &region.grid;
        let [w, h] = g.counts();
        let mut raw = vec![[0i64; 4]; w * h];
        let mut most = 0;
        for pe in &self.pes {
            let mut n = 0;
            for c in &pe.rays {
                let x = (c.mx - g.lo[0]) as usize;
                for (r, a) in c.acc.iter().enumerate() {
                    raw[r * w + x] = a.raw;
                    n += 1;
                }
            }
            most = most.max(n);
        }
        self.advance(Stage::Readout, 0, 0, most as u64);
        self.stages.readout += most as u64;
        let (fc, fa) = (fmt[0].lsb(), fmt[1].lsb());
        let data = raw
            .iter()
            .map(|p| {
                [
                    (p[0] as f64 * fc) as f32,
                    (p[1] as f64 * fc) as f32,
                    (p[2] as f64 * fc) as f32,
                    (p[3] as f64 * fa) as f32,
                ]
            })
            .collect();
        let layout_base = golden::methods::Method::Er
            .layout(view)
            .map(|l| l.baseplane())
            .expect("the plan's layout was built from the same view");
        (
            Baseplane {
                grid: layout_base,
                data,
            },
            raw,
        )
    }

    fn finish(
        mut self,
        baseplane: Baseplane,
        raw: Vec<[i64; 4]>,
        raw_format: [Format; 2],
        merges: u64,
    ) -> Result<Frame, RunError> {
        let mut quant = self.host_stats;
        for pe in &self.pes {
            quant.merge(&pe.stats);
        }
        let samples: u64 = self.pes.iter().map(|p| p.counters.samples).sum();
        if let Some(pr) = self.probes.take() {
            if let Some(info) = pr.finish()? {
                // A save file beside each dump, opening it (one for both
                // when they share a name: the VCD's).
                let mut written = Vec::new();
                for dump in [&info.vcd_path, &info.fst_path].into_iter().flatten() {
                    let gtkw = dump.with_extension("gtkw");
                    if !written.contains(&gtkw) {
                        info.write_gtkw_for(&gtkw, dump)?;
                        written.push(gtkw);
                    }
                }
            }
        }
        let terminated_samples = self.pes.iter().map(|p| p.counters.terminated).sum();
        Ok(Frame {
            baseplane,
            raw,
            raw_format,
            order: self.dp.cfg.order,
            terminated_samples,
            cycles_saved: self.cycles_saved,
            skipped: self.skipped,
            cycles: self.cycle,
            stages: self.stages,
            samples,
            samples_per_slice: self.samples_per_slice,
            ideal_cycles: samples as f64 / self.pes.len() as f64,
            pes: self.pes.iter().map(|p| p.counters).collect(),
            merges,
            quant,
        })
    }
}

/// Runs one frame: plans, loads, clocks and reads out.
pub fn run_frame(
    cfg: &PipelineConfig,
    volume: &Volume,
    lut: &golden::tf::Lut,
    view: &View,
    tracer: Tracer,
) -> Result<Frame, RunError> {
    Array::new(cfg, volume, lut, view, tracer)?.run(view)
}

/// Runs one frame of `prep` with the controller skipping what `skips`
/// allows and clipping to `prep`'s planes: the occupancy memory is built
/// from the volume's min-max blocks (`occupancy_block` voxels) and this
/// pipeline's classification table (see [`crate::skip`]).
pub fn run_frame_with(
    cfg: &PipelineConfig,
    volume: &Volume,
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    skips: golden::skip::Skips,
    tracer: Tracer,
) -> Result<Frame, RunError> {
    let mut array = Array::new(cfg, volume, lut, &prep.view, tracer)?;
    let block = usize::from(cfg.occupancy_block);
    let mm = if prep.blocks.block == block {
        prep.blocks.clone()
    } else {
        golden::occupancy::MinMax::new(volume, block)
            .map_err(|e| RunError::Plan(PlanError::Golden(e)))?
    };
    let layout = golden::methods::Method::Er
        .layout(&prep.view)
        .map_err(|e| RunError::Plan(PlanError::Golden(e)))?;
    let (mask, counts) =
        crate::skip::plan_mask(&array.dp, &mm, volume.kind().bits(), prep, &layout, skips);
    array.set_skipping(mask, counts, &prep.view);
    array.run(&prep.view)
}

/// `v` clamped into `lo..=hi`; `lo` when the range is empty (an empty
/// grid), where `i64::clamp` would panic.
fn clamp(v: i64, lo: i64, hi: i64) -> i64 {
    v.min(hi).max(lo)
}

/// The owner function of one slice: the PE whose block holds the ray's
/// base column, computed with the same fixed-point position a PE uses.
struct Owners<'a> {
    dp: &'a Datapath,
    slice: &'a SlicePlan,
    nx: usize,
    block: usize,
    pes: usize,
}

impl Owners<'_> {
    fn of(&self, mx: i64) -> usize {
        let mut st = QuantStats::default();
        let s = self.slice;
        match self.dp.position(s.a[0], s.t[0], mx, &mut st) {
            Ok(x) => {
                let x0 = self.dp.address(x, &mut st).0;
                let c = x0.clamp(0, self.nx as i64 - 1) as usize;
                (c / self.block).min(self.pes - 1)
            }
            // A position the model cannot form cannot be sampled either;
            // park the ray at the far end.
            Err(_) => self.pes - 1,
        }
    }
}
