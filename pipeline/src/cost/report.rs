//! The full cost report: per-PE and array resources, fit on real parts,
//! throughput from runs and from the bound, and scaling with `P` and `N`,
//! as JSON (serde) and as a readable table.

mod text;

pub(in crate::cost) use text::{si, table};

use super::design::{self, Design};
use super::inventory::{controller_inventory, pe_inventory, Geometry, Item, PeInventory};
use super::parts::{fit_memories, parts, Fit, Part};
use super::target::{Resources, Target};
use super::throughput::{bound_cycles, rate, Rate, RunSummary};
use crate::config::{PipelineConfig, MAX_PES};
use serde::Serialize;

/// Volume edges of the scaling table.
pub const SCALE_N: [usize; 4] = [128, 256, 512, 1024];
/// PE counts of the scaling table.
pub const SCALE_P: [u16; 6] = [8, 16, 32, 64, 128, 256];

/// One inventory line with its cost.
#[derive(Debug, Clone, Serialize)]
pub struct ItemRow {
    /// Stage or block.
    pub group: &'static str,
    /// What it is.
    pub name: String,
    /// Copies.
    pub count: u32,
    /// Main unit's widths.
    pub shape: String,
    /// All copies' resources.
    pub resources: Resources,
}

fn rows(items: &[Item], t: Target) -> Vec<ItemRow> {
    items
        .iter()
        .map(|i| ItemRow {
            group: i.group,
            name: i.name.clone(),
            count: i.count,
            shape: i.shape(),
            resources: i.cost(t),
        })
        .collect()
}

/// The largest PE count that fits a part.
#[derive(Debug, Clone, Serialize)]
pub struct MaxPes {
    /// Part.
    pub part: &'static str,
    /// Largest `P` whose array fits (0: not even one PE).
    pub pes: u16,
    /// What runs out first at `P + 1` (or at `P = 1`).
    pub limit: &'static str,
}

/// PEs declaring the same ray depths.
#[derive(Debug, Clone, Serialize)]
pub struct PeGroup {
    /// Their indices.
    pub pes: Vec<usize>,
    /// Their ray depths.
    pub rays: crate::capacity::RayDepths,
    /// One of them.
    pub resources: Resources,
}

/// One run of the `P` sweep.
#[derive(Debug, Clone, Serialize)]
pub struct SweepRow {
    /// PEs.
    pub pes: u16,
    /// Measured cycles per frame.
    pub cycles: u64,
    /// Measured utilisation.
    pub utilization: f64,
    /// Rate at the clock.
    pub rate: Rate,
    /// Array resources.
    pub resources: Resources,
    /// Parts it fits.
    pub fits: Vec<&'static str>,
}

/// One cell of the scaling table (cubic volumes, worst-case bound).
#[derive(Debug, Clone, Serialize)]
pub struct ScaleRow {
    /// Volume edge.
    pub n: usize,
    /// PEs.
    pub pes: u16,
    /// Worst-case sampling cycles ([`bound_cycles`]) and rate.
    pub bound: Rate,
    /// The bound scaled by the measured run's ratio of cycles to its own
    /// bound: a typical view like the measured one.
    pub scaled: Rate,
    /// Array resources.
    pub resources: Resources,
    /// Parts it fits.
    pub fits: Vec<&'static str>,
}

/// The report.
#[derive(Debug, Clone, Serialize)]
pub struct CostReport {
    /// Family.
    pub target: Target,
    /// Its primitives.
    pub target_description: &'static str,
    /// The clock the rates are quoted at (MHz).
    pub clock_mhz: f64,
    /// Where it comes from: assumed (a family default or `--clock-mhz`)
    /// or predicted from the schedule ([`super::fmax`]).
    pub clock_source: super::clock::ClockSource,
    /// The clock each family with an open timing flow is predicted to
    /// reach with the plain sample datapath's schedule ([`super::fmax`]).
    pub predicted_clocks: Vec<super::fmax::PePrediction>,
    /// The configuration.
    pub config: PipelineConfig,
    /// Volume and PEs of the main run.
    pub geometry: Geometry,
    /// The deepest PE's units (every ray depth at the most any PE
    /// declares: [`Geometry::rays`]).
    pub pe_items: Vec<ItemRow>,
    /// The deepest PE.
    pub pe: Resources,
    /// The PEs by their own ray depths: each distinct declaration, the PEs
    /// declaring it and one such PE's resources.
    pub pe_groups: Vec<PeGroup>,
    /// Sample pipeline depth in clocks: the latency the cycle model runs
    /// ([`super::latency::geometry_latency`]).
    pub pipeline_depth: u32,
    /// External voxel memory per PE (bits).
    pub voxel_memory_bits_per_pe: u64,
    /// External ray memory of the deepest PE (bits): its declared off-chip
    /// memories, with an external ray buffer its rays and, front to back,
    /// its kept finals (0 with the rays on chip).
    pub ray_memory_bits_per_pe: u64,
    /// External ray memory of the array (bits): every PE's at its own
    /// depths.
    pub ray_memory_bits: u64,
    /// The controller's units.
    pub controller_items: Vec<ItemRow>,
    /// The controller.
    pub controller: Resources,
    /// Every PE at its own depths plus the controller.
    pub array: Resources,
    /// The array on each part of the family.
    pub fits: Vec<Fit>,
    /// The most PEs each part holds, for this volume.
    pub max_pes: Vec<MaxPes>,
    /// The measured run.
    pub run: RunSummary,
    /// Its rate at the clock.
    pub run_rate: Rate,
    /// The worst-case bound's rate.
    pub bound_rate: Rate,
    /// Slice-buffer reads per PE per cycle in the run.
    pub buffer_reads_per_pe_cycle: f64,
    /// Runs at other `P`.
    pub sweep: Vec<SweepRow>,
    /// Cubic volumes and `P` by the bound.
    pub scaling: Vec<ScaleRow>,
    /// The mappings and placements at the main run's `P`, each from its
    /// own run.
    pub architectures: Vec<Design>,
    /// What the figures mean.
    pub notes: Vec<String>,
}

/// Array resources for `geo`.
pub fn array_cost(cfg: &PipelineConfig, geo: &Geometry, t: Target) -> Resources {
    design::array(cfg, geo, t).0
}

/// The parts of `parts` that `cfg` on `geo` fits (UltraRAM taking memories
/// block RAM cannot hold).
fn fitting(cfg: &PipelineConfig, geo: &Geometry, parts: &[Part]) -> Vec<&'static str> {
    let Some(first) = parts.first() else {
        return Vec::new();
    };
    let (r, _, mems) = design::array(cfg, geo, first.target);
    parts
        .iter()
        .filter(|p| fit_memories(p, &r, &mems).fits)
        .map(|p| p.name)
        .collect()
}

/// The most PEs of `cfg` (with the shading unit, the volume-of-interest
/// stage and the pre-integration unit as `geo` has them) that fit `part`
/// for a volume of `geo.dims`.
pub fn max_pes(cfg: &PipelineConfig, geo: &Geometry, part: &Part) -> MaxPes {
    let dims = geo.dims;
    let top = (MAX_PES as usize).min(dims[0].max(1)) as u16;
    let fit_at = |p: u16| {
        let g = Geometry::new(dims, p)
            .declared_by(cfg)
            .with_units(geo.units);
        let (r, _, mems) = design::array(cfg, &g, part.target);
        fit_memories(part, &r, &mems)
    };
    let best = (1..=top).filter(|&p| fit_at(p).fits).max().unwrap_or(0);
    let limit = if best == top {
        "nothing up to one PE per column"
    } else {
        fit_at(best + 1).limit
    };
    MaxPes {
        part: part.name,
        pes: best,
        limit,
    }
}

/// Builds the report for `cfg` on `target` at `clock_mhz` (from
/// `source`), from the main run (at `cfg.pes`) and the sweep's runs.
pub fn build(
    cfg: &PipelineConfig,
    target: Target,
    (clock_mhz, source): (f64, super::clock::ClockSource),
    run: RunSummary,
    sweep: &[RunSummary],
    archs: &[(PipelineConfig, RunSummary)],
) -> CostReport {
    let clock = clock_mhz * 1e6;
    let geo = run.geometry.clone();
    let vb = u32::from(cfg.voxel.bits());
    let pe: PeInventory = pe_inventory(cfg, &geo);
    let pe_res = pe.cost(target);
    let ctrl_items = controller_inventory(cfg, &geo);
    let ctrl: Resources = ctrl_items.iter().map(|i| i.cost(target)).sum();
    let family = parts(target);
    let (array, _, mems) = design::array(cfg, &geo, target);
    let groups = geo
        .pe_rays
        .groups()
        .into_iter()
        .map(|(rays, pes)| PeGroup {
            resources: pe_inventory(cfg, &geo.pe(pes[0])).cost(target),
            pes,
            rays,
        })
        .collect();
    let fits = family
        .iter()
        .map(|p| fit_memories(p, &array, &mems))
        .collect();
    let max = family.iter().map(|p| max_pes(cfg, &geo, p)).collect();
    let run_rate = rate(&geo, run.cycles, clock, vb);
    let bound = bound_cycles(&geo);
    let bound_rate = rate(&geo, bound, clock, vb);
    let ratio = if bound == 0 {
        1.0
    } else {
        run.cycles as f64 / bound as f64
    };
    let sweep_rows = sweep
        .iter()
        .map(|s| {
            let r = array_cost(cfg, &s.geometry, target);
            SweepRow {
                pes: s.geometry.pes,
                cycles: s.cycles,
                utilization: s.utilization,
                rate: rate(&s.geometry, s.cycles, clock, vb),
                resources: r,
                fits: fitting(cfg, &s.geometry, &family),
            }
        })
        .collect();
    let mut scaling = Vec::new();
    for n in SCALE_N {
        for p in SCALE_P {
            let g = Geometry::new([n, n, n], p)
                .declared_by(cfg)
                .with_units(geo.units);
            let b = bound_cycles(&g);
            let r = array_cost(cfg, &g, target);
            scaling.push(ScaleRow {
                n,
                pes: p,
                bound: rate(&g, b, clock, vb),
                scaled: rate(&g, (b as f64 * ratio).round() as u64, clock, vb),
                resources: r,
                fits: fitting(cfg, &g, &family),
            });
        }
    }
    let pes = u64::from(geo.pes.max(1));
    let ray_memory_bits: u64 = (0..usize::from(geo.pes.max(1)))
        .map(|k| super::inventory::off_chip_bits(cfg, &geo.pe(k)))
        .sum();
    let depth = super::latency::geometry_latency(cfg, &geo);
    let staging = if cfg.target_mhz > 0 {
        format!(
            "pipelined for {} MHz on {} ({depth} clocks deep)",
            cfg.target_mhz,
            cfg.target_family.name()
        )
    } else {
        format!("pipelined one multiplier or carry chain a stage ({depth} clocks deep)")
    };
    let mut notes = vec![
        if source == super::clock::ClockSource::Measured {
            format!(
                "Clock {clock_mhz} MHz is measured: the PE's sample stage of this volume's edge, PEs and widths placed and routed by ercube synth (pipeline/data/measured/stages.csv); its migration, merge, split, fold and readout are not placed. The datapath is {staging}."
            )
        } else if source == super::clock::ClockSource::Predicted {
            format!(
                "Clock {clock_mhz} MHz is predicted by delay models fitted to units and sample stages placed and routed with ercube synth: the slowest of the sample datapath's slowest scheduled stage and the PE sample stage's issue and tap address; the whole PE is not placed and routed. The datapath is {staging}."
            )
        } else {
            format!(
                "Clock {clock_mhz} MHz is an assumption; no timing analysis is done. The datapath is {staging}."
            )
        },
        format!(
            "Voxel memory is external: each PE's {} of the volume is {:.2} Mbit ({:.1} Mbit for the array), read once per frame into double-buffered slice buffers.",
            if super::arch::round_robin_width(cfg).is_some() { "share (its blocks with their aprons)" } else { "block" },
            pe.voxel_memory_bits as f64 / 1e6,
            pe.voxel_memory_bits as f64 * pes as f64 / 1e6
        ),
        format!(
            "Ray memories are sized for this view, each PE at its own depths (the end PEs hold the rays beyond the volume's sides; 'PE total' is the deepest PE, the array sums every PE's own); {} units are counted in {}.",
            target.bram_name(),
            if target == Target::Xc7 { "RAMB18 halves of a RAMB36" } else { "blocks" }
        ),
        "Worst-case cycles count sampling only (every slice at (2W+1)(2ny+1) rays per PE); migration, merges and readout add a few percent in measured runs. 'Scaled' rows multiply the bound by this run's ratio of measured to bound cycles.".to_owned(),
        "Resource models are calibrated against yosys 0.23 (synth_xilinx, synth_ice40 -dsp) on the PE's units at three width settings (pipeline/tests/it/cost.rs); vendor tools differ in packing, and place-and-route needs headroom (plan for 70-80% LUT use).".to_owned(),
    ];
    if ray_memory_bits > 0 {
        notes.push(format!(
            "Ray memory is external: the PEs' rays{} live in DRAM, {:.2} Mbit for the deepest PE ({:.1} Mbit for the array), none of it in block RAM; on chip each PE keeps its row buffers.",
            if cfg.order == crate::config::Order::FrontToBack { " and kept final states" } else { "" },
            pe.ray_memory_bits as f64 / 1e6,
            ray_memory_bits as f64 / 1e6
        ));
    }
    CostReport {
        target,
        target_description: target.describe(),
        clock_mhz,
        clock_source: source,
        predicted_clocks: [Target::Ecp5, Target::Ice40]
            .into_iter()
            .filter_map(|t| super::fmax::predicted_clock(cfg, &geo, t))
            .collect(),
        config: *cfg,
        geometry: geo,
        pe_items: rows(&pe.items, target),
        pe: pe_res,
        pe_groups: groups,
        pipeline_depth: depth,
        voxel_memory_bits_per_pe: pe.voxel_memory_bits,
        ray_memory_bits_per_pe: pe.ray_memory_bits,
        ray_memory_bits,
        controller_items: rows(&ctrl_items, target),
        controller: ctrl,
        array,
        fits,
        max_pes: max,
        buffer_reads_per_pe_cycle: if run.cycles == 0 {
            0.0
        } else {
            run.buffer_reads as f64 / (run.cycles as f64 * pes as f64)
        },
        run,
        run_rate,
        bound_rate,
        sweep: sweep_rows,
        scaling,
        architectures: archs
            .iter()
            .map(|(c, r)| design::design(c, target, r))
            .collect(),
        notes,
    }
}
