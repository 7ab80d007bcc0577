//! The array and its controller: P PEs in a line, clocked by one
//! two-phase tick ([`Clock`]), the controller's state (the frame plan,
//! skipping, the row runs), the counters and the frame's results.
//!
//! A PE holds every ray whose sample's base column `clamp(floor(x), 0,
//! nx - 1)` it owns ([`crate::mapping`]): under column blocks PE `k` owns
//! columns `k W .. (k + 1) W` (`W = ceil(nx / P)`, the last PEs may own
//! fewer or none) of every slice; under a round-robin mapping blocks of
//! `cyclic_width` columns (1 for the interleave) are dealt out in turn, and
//! rays migrate around a ring. Merges, splits and folds run on column
//! blocks in every mapping.
//!
//! What each stage does, PE side and controller side, is in
//! [`crate::stages`]; the order in which a frame runs them (back to front,
//! front to back) is in [`crate::schedule`]. Every cycle of every stage is
//! a tick of the clock; [`StageCycles`] is what the ticks counted.
//!
//! The front-to-back order costs more memory than back to front: the
//! compositing buffer twice as wide (accumulators plus inherited state, and
//! a flag bit) and the kept final states, about `(W + 1)(ny + 1)` rays per
//! region boundary per PE; `crate::cost`'s inventory sizes both for a
//! front-to-back configuration.

mod clock;
mod frame;
mod memory;
mod owners;
mod run;
pub(crate) mod warm;

pub use clock::{Clock, Links};
pub use frame::{Frame, LinkFifoProbe, RunError, StageCycles};
pub use memory::{Resident, VoxelLoad};
pub use run::{FrameRun, Voxels};

use golden::geometry::View;
use golden::volume::Volume;
use golden::warp::Baseplane;
use rayon::prelude::*;
use waves::Tracer;

use std::sync::Arc;

use crate::config::{Order, PipelineConfig};
use crate::datapath::Datapath;
use crate::fixed::{Format, QuantStats};
use crate::host::{plan, FramePlan, PreStep, RegionPlan, SlicePlan, VoxelSource, NONE};
use crate::mapping::ColumnMap;
use crate::pe::{Pe, RayColumn};
use crate::probes::{Ctrl, Probes, Stage};
use crate::skip::SkipCounts;
use crate::stages::raybuf::Channel;
use crate::stages::sample::RowRuns;
use crate::stages::Idle;
use crate::tables::Tables;
use golden::skip::SampleMask;

/// The PE array for one frame.
pub struct Array {
    /// Shared so that owner functions can borrow it while the PEs step.
    pub(crate) dp: Arc<Datapath>,
    /// The PEs, their ports and the cycle counter.
    pub(crate) clock: Clock,
    /// Who owns which columns while the array samples.
    pub(crate) map: ColumnMap,
    /// The column blocks the merges, splits and folds run on.
    pub(crate) blocks: ColumnMap,
    pub(crate) nx: usize,
    pub(crate) ny: usize,
    pub(crate) samples_per_slice: Vec<u64>,
    pub(crate) host_stats: QuantStats,
    pub(crate) clocked: bool,
    pub(crate) cycles_saved: u64,
    /// What the controller skips, when it skips (see [`Array::set_skipping`]).
    pub(crate) skip: Option<Skipper>,
    /// The current slice's runs per row (reused).
    pub(crate) runs: RowRuns,
    /// A pre-integrated pass's runs of compositing and keeping rays.
    pub(crate) pre_runs: crate::stages::sample::PreRuns,
    pub(crate) run_tmp: Vec<(i64, i64)>,
    pub(crate) skipped: SkipCounts,
    /// The external ray buffer's channel (`None` on chip).
    pub(crate) channel: Option<Channel>,
    /// Overlapped migration: the first cycle the links may carry the next
    /// slice's rays (the previous slice's first sampling cycle, or the end
    /// of the last stage that needed every ray home) and the cycle the
    /// links' last move ended.
    pub(crate) links_from: u64,
    pub(crate) links_free: u64,
    /// The waveform tracer until the frame starts (see [`Array::run`]).
    pending: Option<Tracer>,
    /// The description's nodes the waveform traces (`--trace-nodes`).
    pub(crate) trace_nodes: Vec<String>,
    /// What the PE memories' contents depend on, and the host's
    /// quantisation events in loading them (kept with them, see
    /// [`Resident`]).
    resident_key: memory::Key,
    /// The datapath as loaded, before the frame's units (kept with the
    /// memories, see [`Resident`]).
    unit: (memory::UnitKey, Arc<Datapath>),
    load_stats: QuantStats,
    voxel_load: VoxelLoad,
}

/// The controller's skipping state for one frame.
pub(crate) struct Skipper {
    pub(crate) mask: SampleMask,
    pub(crate) view: View,
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
        let bits = volume.kind().bits();
        Array::load(
            cfg,
            VoxelSource::Volume(volume, view),
            bits,
            lut,
            view,
            tracer,
        )
    }

    /// [`Array::new`], reading the `data_bits`-bit scalars from `source`
    /// (the volume, or golden's slice stack of the same view).
    pub fn load(
        cfg: &PipelineConfig,
        source: VoxelSource,
        data_bits: u32,
        lut: &golden::tf::Lut,
        view: &View,
        tracer: Tracer,
    ) -> Result<Array, RunError> {
        Array::load_reusing(cfg, source, data_bits, lut, view, tracer, None)
    }

    /// [`Array::load`], starting from the memories of `resident` when they
    /// hold this view's volume for this configuration (nothing is read
    /// from `source` then); see [`FrameRun::resident`].
    pub fn load_reusing(
        cfg: &PipelineConfig,
        source: VoxelSource,
        data_bits: u32,
        lut: &golden::tf::Lut,
        view: &View,
        tracer: Tracer,
        mut resident: Option<Resident>,
    ) -> Result<Array, RunError> {
        cfg.validate()?;
        for &n in &view.dims {
            cfg.check_extent(n as u32)?;
        }
        let unit_key = memory::UnitKey::of(cfg, lut);
        let dp = match resident.as_mut().and_then(|r| r.unit.take()) {
            Some((k, dp)) if k == unit_key => dp,
            _ => Arc::new(Datapath::new(*cfg, Tables::new(cfg, lut)?)),
        };
        let unit = (unit_key, Arc::clone(&dp));
        let mut host_stats = QuantStats::default();
        let p = usize::from(cfg.pes);
        let nx = view.dims[0];
        let map = ColumnMap::of(cfg, nx);
        let held: Vec<Vec<usize>> = (0..p).map(|k| map.held(k)).collect();
        let key = memory::Key::of(cfg, data_bits, view);
        let (mems, load_stats, reused) = match resident {
            Some(r) if r.key.as_ref() == Some(&key) => (r.mems, r.stats, true),
            other => {
                let mut st = QuantStats::default();
                let spare = other.map(|r| r.mems).unwrap_or_default();
                let mems = memory::load_memories(
                    cfg,
                    source,
                    data_bits,
                    &held,
                    view.dims,
                    (&mut st, spare),
                );
                (mems, st, false)
            }
        };
        host_stats.merge(&load_stats);
        let words: Vec<u64> = mems.iter().map(|m| m.len() as u64).collect();
        let voxel_load = VoxelLoad::new(cfg, &words, reused);
        let pes = mems
            .into_iter()
            .enumerate()
            .map(|(k, mem)| {
                let mut pe = Pe::new(k, map, &held[k], mem, view.dims);
                pe.sparse_links = cfg.link_skip_empty;
                pe.sparse_passes = cfg.pass_skip_empty;
                pe.set_link_fifo_depth(usize::from(cfg.link_fifo_depth));
                pe
            })
            .collect();
        let pending = if tracer.is_enabled() {
            Probes::check_groups(&tracer)?;
            Some(tracer)
        } else {
            None
        };
        let mut clock = Clock::new(pes, None);
        clock.set_ring(map.round_robin());
        Ok(Array {
            dp,
            clock,
            pending,
            trace_nodes: Vec::new(),
            map,
            blocks: ColumnMap::blocks(p, nx),
            nx,
            ny: view.dims[1],
            samples_per_slice: vec![0; view.dims[2]],
            host_stats,
            clocked: false,
            cycles_saved: 0,
            skip: None,
            runs: RowRuns::default(),
            pre_runs: Default::default(),
            run_tmp: Vec::new(),
            skipped: SkipCounts::default(),
            channel: Channel::of(cfg),
            links_from: 0,
            links_free: 0,
            resident_key: key,
            unit,
            load_stats,
            voxel_load,
        })
    }

    /// Loads `units`' per-frame constants (each unit's own
    /// [`FrameUnit`](crate::datapath::FrameUnit): shading, a volume of
    /// interest, pre-integration) for a frame of `view` with
    /// `data_bits`-bit data, clipped by planes when `clipped`, beside the
    /// units already loaded; units the composed sample does not combine
    /// are refused ([`FrameUnits::check`](crate::hw::compose::FrameUnits::check)).
    /// A skip plan is made for the datapath's units: loading drops it.
    pub fn set_units(
        &mut self,
        units: &[&dyn crate::datapath::FrameUnit],
        view: &View,
        data_bits: u32,
        clipped: bool,
    ) -> Result<(), RunError> {
        let mut dp = (*self.dp).clone();
        let mut loaded = std::mem::take(&mut dp.loaded);
        let mut st = QuantStats::default();
        let frame = crate::datapath::UnitFrame {
            dp: &dp,
            view,
            data_bits,
            map: self.map,
            clipped,
        };
        frame.load(units, &mut loaded, &mut st)?;
        self.host_stats.merge(&st);
        self.dp = Arc::new(dp.with_units(loaded));
        self.skip = None;
        Ok(())
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
    pub(crate) fn regions_to_run(&mut self, plan: &FramePlan) -> usize {
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
    pub(crate) fn visit(
        &mut self,
        i: usize,
        slice: &SlicePlan,
    ) -> Result<Option<SlicePlan>, RunError> {
        let Some(sk) = &self.skip else {
            return Ok(Some(*slice));
        };
        if let Some(pre) = slice.pre {
            // A pre-integrated pass serves two steps: each set keeps its
            // rays only where its step's slices hold something, narrowed
            // by culling like a slice's range.
            let visible = |z: Option<usize>| z.is_some_and(|z| sk.mask.slice_visible(z));
            let narrow = |r, on: bool| if on { sk.mask.rays(i, r) } else { NONE };
            let (c, k) = (visible(pre.comp_z), visible(pre.keep_z));
            let pre = PreStep {
                comp: narrow(pre.comp, c),
                keep: narrow(pre.keep, k),
                // Slice 0's half step goes with slice 0's step, which the
                // pass composites or keeps for.
                lead: narrow(pre.lead, visible(Some(0))),
                ..pre
            };
            if !(c || k) {
                self.skipped.slices += 1;
                self.skip_slice(slice.z)?;
                return Ok(None);
            }
            return Ok(Some(SlicePlan {
                range: pre.rays(),
                pre: Some(pre),
                ..*slice
            }));
        }
        if !sk.mask.slice_visible(slice.z) {
            self.skipped.slices += 1;
            self.skip_slice(slice.z)?;
            return Ok(None);
        }
        Ok(Some(SlicePlan {
            range: sk.mask.rays(i, slice.range),
            ..*slice
        }))
    }

    /// Steps the sampling stage cycle by cycle even without tracing (it
    /// always does when tracing). By default an untraced run samples each
    /// slice PE by PE, in parallel: the same bits and cycle counts, faster.
    pub fn set_clocked(&mut self, on: bool) {
        self.clocked = on;
    }

    /// The datapath the frame runs (its configuration, tables and units).
    pub fn datapath(&self) -> &Datapath {
        &self.dp
    }

    /// The datapath's units as the probes select their signals: shading,
    /// the VOI, pre-integration.
    fn unit_flags(&self) -> (bool, bool, bool) {
        let u = self.dp.units();
        (u.shading(), u.voi, u.preint)
    }

    /// Makes every sample of the whole-slice path run the general
    /// datapath instead of evaluating plain samples with the datapath's
    /// [`Kernel`](crate::datapath::Kernel), as it does by default. The same
    /// bits, counts and cycles either way: tests compare them.
    pub fn disable_kernel(&mut self) {
        self.dp = Arc::new((*self.dp).clone().without_kernel());
    }

    /// Steps PEs in this order within a cycle (any order gives the same
    /// result; tests use it to prove that).
    pub fn set_step_order(&mut self, order: Vec<usize>) {
        assert_eq!(order.len(), self.clock.pes().len());
        self.clock.set_order(order);
    }

    /// Runs a frame of `view`, in the configuration's compositing order
    /// (the schedule of [`crate::schedule`]).
    pub fn run(self, view: &View) -> Result<Frame, RunError> {
        self.run_keeping(view).map(|(frame, _)| frame)
    }

    /// [`Array::run`], handing back the PE memories for the next frame.
    pub fn run_keeping(mut self, view: &View) -> Result<(Frame, Resident), RunError> {
        // The signals depend on the datapath (the shading unit's), final
        // only now.
        if let Some(t) = self.pending.take() {
            let p = self.clock.pes().len();
            let units = self.unit_flags();
            let nodes = (!self.trace_nodes.is_empty()).then(|| (&*self.dp, &self.trace_nodes[..]));
            let probes = Probes::new(t, p, &self.dp.cfg, units, nodes)?;
            self.clock.attach(probes);
        }
        self.clock.begin_tap(crate::probes::SignalSet::new(
            &self.dp.cfg,
            self.unit_flags(),
        ));
        let mut plan: FramePlan = plan(&self.dp.cfg, view)?;
        if self.dp.units().preint {
            let mut st = QuantStats::default();
            plan.passes = plan
                .regions
                .iter()
                .map(|r| crate::host::preint_passes(&self.dp.cfg, view, r, &mut st))
                .collect::<Result<_, _>>()?;
            plan.stats.merge(&st);
        }
        self.host_stats.merge(&plan.stats);
        let order = self.dp.cfg.order;
        let run = |a: &mut Array| match order {
            Order::BackToFront => crate::schedule::back_to_front(a, &plan),
            Order::FrontToBack => crate::schedule::front_to_back(a, &plan),
        };
        // Traced or clocked, the frame ticks on one thread.
        let (raw, fmt, merges) = if self.clock.tracing() || self.clocked {
            run(&mut self)?
        } else {
            warm::with_warm_pool(|| run(&mut self))?
        };
        let base = self.baseplane(&raw, view, fmt);
        let kept = Resident {
            key: Some(self.resident_key.clone()),
            mems: self.clock.take_memories(),
            stats: self.load_stats,
            unit: Some(self.unit.clone()),
        };
        Ok((self.finish(base, raw, fmt, merges)?, kept))
    }

    /// Creates a region's (empty, live) rays in the PEs that sample them
    /// first: region 0's front to back (from its front slice), the last
    /// region's back to front (from its rear slice). The host's load of a
    /// frame, before the first cycle.
    pub(crate) fn distribute(&mut self, region: &RegionPlan) {
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
            self.clock.load_column(k, RayColumn::empty(mx, rows, ftb));
        }
    }

    /// The baseplane in float from the raw words, formats `fmt` (colour,
    /// opacity), on the golden layout's baseplane grid.
    fn baseplane(&self, raw: &[[i64; 4]], view: &View, fmt: [Format; 2]) -> Baseplane {
        let (fc, fa) = (fmt[0].lsb(), fmt[1].lsb());
        let data = raw
            .par_iter()
            .map(|p| {
                [
                    (p[0] as f64 * fc) as f32,
                    (p[1] as f64 * fc) as f32,
                    (p[2] as f64 * fc) as f32,
                    (p[3] as f64 * fa) as f32,
                ]
            })
            .collect();
        let grid = golden::methods::Method::Er
            .layout(view)
            .map(|l| l.baseplane())
            .expect("the plan's layout was built from the same view");
        Baseplane { grid, data }
    }

    /// A slice the controller skips: one cycle reading its summary bit.
    pub(crate) fn skip_slice(&mut self, z: usize) -> Result<(), RunError> {
        self.clock.tick(&mut Idle(Ctrl::at(Stage::Skip, z, 0)))?;
        Ok(())
    }

    fn finish(
        mut self,
        baseplane: Baseplane,
        raw: Vec<[i64; 4]>,
        raw_format: [Format; 2],
        merges: u64,
    ) -> Result<Frame, RunError> {
        debug_assert_eq!(self.clock.stages().total(), self.clock.cycle());
        let pes = self.clock.pes();
        let mut quant = self.host_stats;
        for pe in pes {
            quant.merge(&pe.model.stats);
        }
        let samples: u64 = pes.iter().map(|p| p.counters.samples).sum();
        let terminated_samples = pes.iter().map(|p| p.counters.terminated).sum();
        let counters = pes.iter().map(|p| p.counters).collect();
        let link_fifo = pes.iter().map(Pe::link_fifo_probe).fold(
            LinkFifoProbe::default(),
            |a, (peak, stalls)| LinkFifoProbe {
                peak: a.peak.max(peak as u64),
                feed_stalls: a.feed_stalls + stalls,
            },
        );
        let p = pes.len();
        let occupancy = pes.iter().map(Pe::occupancy).collect();
        if let Some(pr) = self.clock.take_probes() {
            if let Some(info) = pr.finish()? {
                // A save file beside each dump, opening it.
                for (gtkw, dump) in info.save_files() {
                    info.write_gtkw_for(&gtkw, &dump)?;
                }
            }
        }
        Ok(Frame {
            baseplane,
            raw,
            raw_format,
            order: self.dp.cfg.order,
            units: self.dp.units(),
            terminated_samples,
            cycles_saved: self.cycles_saved,
            skipped: self.skipped,
            ray_buffer: self.channel.as_ref().map(|c| c.stats),
            voxel_load: self.voxel_load,
            link_fifo,
            occupancy,
            cycles: self.clock.cycle(),
            stages: self.clock.stages(),
            samples,
            samples_per_slice: self.samples_per_slice,
            ideal_cycles: samples as f64 / p as f64,
            pes: counters,
            merges,
            quant,
        })
    }
}

/// `v` clamped into `lo..=hi`; `lo` when the range is empty (an empty
/// grid), where `i64::clamp` would panic.
pub(crate) fn clamp(v: i64, lo: i64, hi: i64) -> i64 {
    v.min(hi).max(lo)
}
