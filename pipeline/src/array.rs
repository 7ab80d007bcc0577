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

use golden::geometry::View;
use golden::volume::Volume;
use golden::warp::Baseplane;
use waves::{ScopePath, SignalId, Tracer};

use crate::config::PipelineConfig;
use crate::datapath::{Acc, Datapath};
use crate::fixed::{Fx, QuantStats, Wide};
use crate::host::{plan, voxel_words, FramePlan, PlanError, RegionPlan, SlicePlan};
use crate::pe::{Pe, PeCounters, Ports, RayColumn, RowBus, SampleBus, StepError};
use crate::tables::Tables;

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
}

/// A frame's results.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The baseplane in float (accumulator words scaled), for the warp.
    pub baseplane: Baseplane,
    /// The baseplane's raw accumulator words, row-major, R G B A.
    pub raw: Vec<[i64; 4]>,
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

/// Waveform signals of one PE.
struct PeSignals {
    busy: SignalId,
    mx: SignalId,
    row: SignalId,
    sample: SignalId,
    alpha: SignalId,
    corrected: SignalId,
    acc: [SignalId; 4],
    rays_sent: SignalId,
}

/// The probes of a run.
struct Probes {
    tracer: Tracer,
    stage: SignalId,
    z: SignalId,
    row: SignalId,
    pes: Vec<PeSignals>,
}

impl Probes {
    fn new(
        mut tracer: Tracer,
        p: usize,
        cfg: &PipelineConfig,
    ) -> Result<Probes, waves::WavesError> {
        let ctrl = ScopePath::top().child("ctrl");
        let stage = tracer.register(&ctrl, "stage", 2)?;
        let z = tracer.register(&ctrl, "slice", 16)?;
        let row = tracer.register(&ctrl, "row", 16)?;
        let mut pes = Vec::with_capacity(p);
        for k in 0..p {
            let s = ScopePath::pe(k as u32);
            let w = |f: crate::fixed::Format| u32::from(f.bits());
            pes.push(PeSignals {
                busy: tracer.register(&s, "busy", 1)?,
                mx: tracer.register(&s, "ray_mx", 16)?,
                row: tracer.register(&s, "ray_row", 16)?,
                sample: tracer.register(&s, "sample", w(cfg.sample))?,
                alpha: tracer.register(&s, "alpha", w(cfg.alpha))?,
                corrected: tracer.register(&s, "alpha_corr", w(cfg.opacity_corr))?,
                acc: [
                    tracer.register(&s, "acc_r", w(cfg.accum_color))?,
                    tracer.register(&s, "acc_g", w(cfg.accum_color))?,
                    tracer.register(&s, "acc_b", w(cfg.accum_color))?,
                    tracer.register(&s, "acc_a", w(cfg.accum_alpha))?,
                ],
                rays_sent: tracer.register(&s, "rays_sent", 32)?,
            });
        }
        Ok(Probes {
            tracer,
            stage,
            z,
            row,
            pes,
        })
    }
}

/// Stage codes on `top.ctrl.stage`.
const STAGE_SAMPLE: u64 = 0;
const STAGE_MIGRATE: u64 = 1;
const STAGE_MERGE: u64 = 2;
const STAGE_READOUT: u64 = 3;

/// The PE array for one frame.
pub struct Array {
    dp: Datapath,
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
        let dp = Datapath::new(*cfg, tables);
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

    /// Who holds which ray in `slice`.
    fn owners<'a>(&'a self, slice: &'a SlicePlan) -> Owners<'a> {
        Owners {
            dp: &self.dp,
            slice,
            nx: self.nx,
            block: self.block,
            pes: self.pes.len(),
        }
    }

    /// Runs a frame of `view`.
    pub fn run(mut self, view: &View) -> Result<Frame, RunError> {
        let plan: FramePlan = plan(&self.dp.cfg, view)?;
        self.host_stats.merge(&plan.stats);
        let k = plan.regions.len();
        let mut merges = 0;
        for i in (0..k).rev() {
            let region = &plan.regions[i];
            if i == k - 1 {
                self.distribute(region);
            }
            for slice in &region.slices {
                self.migrate(slice)?;
                self.sample(region, slice)?;
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
        let (base, raw) = self.readout(&plan.regions[0], view);
        self.finish(base, raw, merges)
    }

    /// Creates the last region's (empty) rays in the PEs that sample them
    /// first.
    fn distribute(&mut self, region: &RegionPlan) {
        let g = &region.grid;
        let rows = g.counts()[1];
        let first = region.slices.first();
        for mx in g.lo[0]..=g.hi[0] {
            let k = match first {
                Some(s) => self.owners(s).of(mx),
                None => 0,
            };
            self.pes[k].rays.push_back(RayColumn {
                mx,
                acc: vec![Acc::default(); rows],
            });
        }
    }

    fn trace(&mut self, stage: u64, z: usize, row: usize) {
        trace(&mut self.probes, &self.pes, self.cycle, stage, z, row);
    }
}

/// Records one cycle of every traced signal; a single branch when tracing
/// is off.
fn trace(probes: &mut Option<Probes>, pes: &[Pe], cycle: u64, stage: u64, z: usize, row: usize) {
    let Some(pr) = probes.as_mut() else { return };
    pr.tracer.sample(cycle, |s| {
        s.set(pr.stage, stage);
        s.set(pr.z, z as u64 & 0xffff);
        s.set(pr.row, row as u64 & 0xffff);
        for (pe, sig) in pes.iter().zip(&pr.pes) {
            let l = &pe.last;
            let busy = stage == STAGE_SAMPLE && l.busy;
            s.set(sig.busy, u64::from(busy));
            // Ray indices are traced as 16-bit two's complement.
            s.set(sig.mx, l.mx as u64 & 0xffff);
            s.set(sig.row, l.row as u64 & 0xffff);
            s.set(sig.sample, l.sample as u64);
            s.set(sig.alpha, l.alpha as u64);
            s.set(sig.corrected, l.corrected as u64);
            s.set(sig.rays_sent, pe.counters.rays_sent & 0xffff_ffff);
            for ch in 0..4 {
                s.set(sig.acc[ch], l.acc.raw[ch] as u64);
            }
        }
    });
}

impl Array {
    /// Migration before `slice`: clocks until every ray sits in its owner.
    fn migrate(&mut self, slice: &SlicePlan) -> Result<(), RunError> {
        let owners = Owners {
            dp: &self.dp,
            slice,
            nx: self.nx,
            block: self.block,
            pes: self.pes.len(),
        };
        for pe in &mut self.pes {
            pe.plan_moves(|mx| owners.of(mx));
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
                self.spare[k] = self.pes[k].migrate_step(from_left, from_right, |mx| owners.of(mx));
            }
            std::mem::swap(&mut self.ports, &mut self.spare);
            self.cycle += 1;
            cycles += 1;
            trace(
                &mut self.probes,
                &self.pes,
                self.cycle,
                STAGE_MIGRATE,
                slice.z,
                0,
            );
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
        let counts: u64 = self.pes.iter().map(|pe| pe.active.1 as u64).sum();
        self.samples_per_slice[slice.z] += counts * (yhi - ylo + 1) as u64;
        if row_len == 0 {
            return Ok(());
        }
        let ny = self.ny;
        let glo = region.grid.lo[1];
        let dp = &self.dp;
        let mut st = QuantStats::default();
        let mut rows = Vec::with_capacity((yhi - ylo + 1) as usize);
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
        let p = self.pes.len();
        if self.probes.is_none() && !self.clocked {
            return self.sample_whole(region, slice, &rows, row_len);
        }
        // Prologue: one cycle in which every PE only drives its edge voxels
        // for the first row (the previous stage's ports carried rays). A
        // lone PE has no neighbour to wait for.
        let (my0, y_first, sy0) = rows[0];
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
            self.trace(STAGE_SAMPLE, slice.z, setup.row);
        }
        for (r, &(my, y, sy)) in rows.iter().enumerate() {
            for cycle in 0..row_len {
                let next = if cycle + 1 < row_len {
                    Some((slice.z, y.0, y.1))
                } else {
                    rows.get(r + 1).map(|n| (slice.z, n.1 .0, n.1 .1))
                };
                let bus = SampleBus {
                    slice,
                    my,
                    row: (my - glo) as usize,
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
                self.trace(STAGE_SAMPLE, slice.z, (my - glo) as usize);
            }
            self.stages.sample += row_len as u64;
        }
        Ok(())
    }

    /// The sampling stage of one slice without per-cycle stepping: the
    /// same arithmetic and counters as the clocked path (proved by the
    /// tests), each PE's whole slice at once, PEs in parallel. Each PE
    /// first produces the edge voxels it would drive in each row; each PE
    /// then samples its rays with its right neighbour's.
    fn sample_whole(
        &mut self,
        region: &RegionPlan,
        slice: &SlicePlan,
        rows: &[(i64, (usize, usize, Fx), Fx)],
        row_len: usize,
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
        let skip = usize::from(p == 1 && row_len == 1);
        let seq: Vec<(usize, usize, usize)> = buses
            .iter()
            .skip(skip)
            .map(|b| (slice.z, b.y.0, b.y.1))
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
                pe.sample_slice(dp, &buses, row_len, edges.get(k + 1).map(Vec::as_slice), nx)
            })
            .collect();
        for r in results {
            r?;
        }
        let cycles = u64::from(p > 1) + (rows.len() * row_len) as u64;
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
            for _ in 0..width {
                self.cycle += 1;
                self.trace(STAGE_MERGE, 0, row);
            }
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
        for _ in 0..2 * width {
            self.cycle += 1;
            self.trace(STAGE_MERGE, 0, prow);
        }
        self.stages.merge += prow as u64 * width + 2 * width;
        Ok(())
    }

    /// Streams region 0's rays out, one per PE per cycle.
    fn readout(&mut self, region: &RegionPlan, view: &View) -> (Baseplane, Vec<[i64; 4]>) {
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
        for _ in 0..most {
            self.cycle += 1;
            self.trace(STAGE_READOUT, 0, 0);
        }
        self.stages.readout += most as u64;
        let (fc, fa) = (self.dp.cfg.accum_color.lsb(), self.dp.cfg.accum_alpha.lsb());
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
        merges: u64,
    ) -> Result<Frame, RunError> {
        let mut quant = self.host_stats;
        for pe in &self.pes {
            quant.merge(&pe.stats);
        }
        let samples: u64 = self.pes.iter().map(|p| p.counters.samples).sum();
        if let Some(pr) = self.probes.take() {
            if let Some(info) = pr.tracer.finish()? {
                let gtkw = info.vcd_path.with_extension("gtkw");
                info.write_gtkw(&gtkw)?;
            }
        }
        Ok(Frame {
            baseplane,
            raw,
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
