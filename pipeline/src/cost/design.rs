//! One design point: a configuration's array resources, on-chip memory,
//! external traffic and measured cycles, and how it fits (and how fast it
//! runs) on each listed part of the family.

use super::arch;
use super::inventory::{controller_inventory, pe_inventory, Geometry, Item, PeInventory};
use super::memory::{map_memory, MemKind};
use super::parts::{fit_memories, parts, uram_blocks, MemDemand, Part};
use super::target::{Resources, Target};
use super::throughput::{voxel_bytes, RunSummary};
use crate::config::PipelineConfig;
use serde::Serialize;

/// A design on one part.
#[derive(Debug, Clone, Serialize)]
pub struct PartFit {
    /// The part.
    pub part: &'static str,
    /// Whether the array fits.
    pub fits: bool,
    /// The most used resource.
    pub limit: &'static str,
    /// UltraRAM blocks the fit gave memories.
    pub uram: u64,
    /// The part's clock, MHz ([`Part::clock_mhz`]).
    pub clock_mhz: u32,
    /// Frames per second of the measured cycles at that clock.
    pub fps: f64,
    /// External bytes per second at that rate (voxels and rays).
    pub bandwidth: f64,
}

/// One configuration's cost and run.
#[derive(Debug, Clone, Serialize)]
pub struct Design {
    /// `mapping/placement`, e.g. `cyclic:4/external`.
    pub arch: String,
    /// PEs.
    pub pes: u16,
    /// Array resources (every PE and the controller).
    pub resources: Resources,
    /// On-chip memory of the array: data bits of every memory (block RAM,
    /// LUT-RAM and registers alike).
    pub on_chip_bits: u64,
    /// Measured cycles per frame.
    pub cycles: u64,
    /// Measured sampling utilisation.
    pub utilization: f64,
    /// The mapping, e.g. `cyclic:4`.
    pub mapping: String,
    /// The migration (`between-slices`, `overlapped`, `overlapped:2` with
    /// two lanes).
    pub migration: String,
    /// The ray-buffer placement (`on-chip`, `external`).
    pub ray_buffer: &'static str,
    /// Stall cycles of the run (rows waiting for a ray in the datapath or
    /// on a link).
    pub stall: u64,
    /// Cycles the run waited for the external ray buffer.
    pub memory: u64,
    /// Voxel bytes per frame from external memory: the volume once, each
    /// slice broadcast to every PE, which keeps its columns and aprons.
    pub voxel_bytes: f64,
    /// Ray-buffer bytes per frame to and from external memory, as the run
    /// counted them (0 on chip).
    pub ray_bytes: f64,
    /// The design on each part of the family.
    pub parts: Vec<PartFit>,
}

impl Design {
    /// External bytes per frame.
    pub fn external_bytes(&self) -> f64 {
        self.voxel_bytes + self.ray_bytes
    }

    /// Frames per second at `clock_mhz`.
    pub fn fps(&self, clock_mhz: f64) -> f64 {
        if self.cycles == 0 {
            0.0
        } else {
            clock_mhz * 1e6 / self.cycles as f64
        }
    }

    /// Names of the parts it fits.
    pub fn fitting(&self) -> Vec<&'static str> {
        self.parts
            .iter()
            .filter(|p| p.fits)
            .map(|p| p.part)
            .collect()
    }
}

/// Data bits of every memory in `items`, `copies` times.
fn item_bits(items: &[Item], copies: u64) -> u64 {
    items
        .iter()
        .map(|i| {
            i.units
                .iter()
                .map(|u| match u {
                    super::units::Unit::Mem { depth, width, .. } => depth * u64::from(*width),
                    _ => 0,
                })
                .sum::<u64>()
                * u64::from(i.count)
                * copies
        })
        .sum()
}

/// The block-RAM memories of `items` (`copies` times), as the UltraRAM
/// allocation sees them.
fn item_demands(t: Target, items: &[Item], copies: u64) -> Vec<MemDemand> {
    let mut out = Vec::new();
    for i in items {
        for u in &i.units {
            if let super::units::Unit::Mem {
                depth,
                width,
                ports,
            } = *u
            {
                let m = map_memory(t, depth, u64::from(width), ports);
                if m.kind == MemKind::Block {
                    out.push(MemDemand {
                        bram: m.res.bram,
                        uram: uram_blocks(depth, u64::from(width)),
                        copies: u64::from(i.count) * copies,
                    });
                }
            }
        }
    }
    out
}

/// The PEs of `geo`'s array grouped by their ray depths: each distinct
/// PE's inventory (at its own depths, [`Geometry::pe`]) and how many PEs
/// declare it.
pub fn pe_groups(cfg: &PipelineConfig, geo: &Geometry) -> Vec<(PeInventory, u64)> {
    let pes = usize::from(geo.pes.max(1));
    let depths = geo.pe_rays.groups();
    // Without per-PE depths (a bare geometry) every PE is the one described.
    if depths.is_empty() || geo.pe_rays.pes() != pes {
        return vec![(pe_inventory(cfg, geo), pes as u64)];
    }
    depths
        .into_iter()
        .map(|(_, ks)| (pe_inventory(cfg, &geo.pe(ks[0])), ks.len() as u64))
        .collect()
}

/// Array resources, on-chip memory bits and block-RAM memories of `cfg`
/// on `geo`: every PE at its own ray depths, summed, and the controller.
pub fn array(cfg: &PipelineConfig, geo: &Geometry, t: Target) -> (Resources, u64, Vec<MemDemand>) {
    let ctrl = controller_inventory(cfg, geo);
    let mut res = ctrl.iter().map(|i| i.cost(t)).sum::<Resources>();
    let mut bits = item_bits(&ctrl, 1);
    let mut mems = Vec::new();
    for (pe, n) in pe_groups(cfg, geo) {
        res += pe.cost(t) * n;
        bits += item_bits(&pe.items, n);
        mems.extend(item_demands(t, &pe.items, n));
    }
    mems.extend(item_demands(t, &ctrl, 1));
    (res, bits, mems)
}

/// The design point of `cfg` (at `run.geometry`'s `P`) measured by `run`,
/// on every part of `t`'s family.
pub fn design(cfg: &PipelineConfig, t: Target, run: &RunSummary) -> Design {
    let geo = &run.geometry;
    let (resources, on_chip_bits, mems) = array(cfg, geo, t);
    let vbytes = voxel_bytes(geo, u32::from(cfg.voxel.bits()));
    let rbytes = run.ray_buffer_bytes as f64;
    let fit_on = |part: &Part| {
        let f = fit_memories(part, &resources, &mems);
        let fps = if run.cycles == 0 {
            0.0
        } else {
            f64::from(part.clock_mhz) * 1e6 / run.cycles as f64
        };
        PartFit {
            part: part.name,
            fits: f.fits,
            limit: f.limit,
            uram: f.uram,
            clock_mhz: part.clock_mhz,
            fps,
            bandwidth: (vbytes + rbytes) * fps,
        }
    };
    Design {
        arch: arch::label(cfg),
        pes: geo.pes,
        resources,
        on_chip_bits,
        cycles: run.cycles,
        utilization: run.utilization,
        mapping: arch::mapping_name(cfg),
        migration: arch::migration_name(cfg),
        ray_buffer: cfg.ray_buffer.name(),
        stall: run.stages.stall,
        memory: run.stages.memory,
        voxel_bytes: vbytes,
        ray_bytes: rbytes,
        parts: parts(t).iter().map(fit_on).collect(),
    }
}

/// Renders `designs` as a text table: resources, memory, cycles, traffic
/// and, per part it fits, the frame rate and external bandwidth at the
/// part's clock.
pub fn text(o: &mut String, t: Target, designs: &[Design]) {
    use super::report::{si, table};
    let rows: Vec<Vec<String>> = designs
        .iter()
        .map(|d| {
            let fits = d
                .parts
                .iter()
                .filter(|p| p.fits)
                .map(|p| {
                    format!(
                        "{} {:.1} fps {}B/s{}",
                        p.part,
                        p.fps,
                        si(p.bandwidth),
                        if p.uram > 0 {
                            format!(" ({} URAM)", p.uram)
                        } else {
                            String::new()
                        }
                    )
                })
                .collect::<Vec<_>>();
            vec![
                d.arch.clone(),
                d.pes.to_string(),
                d.resources.dsp.to_string(),
                d.resources.lut.to_string(),
                d.resources.ff.to_string(),
                d.resources.bram.to_string(),
                format!("{:.2}", d.on_chip_bits as f64 / 1e6),
                d.cycles.to_string(),
                format!("{:.3}", d.utilization),
                d.stall.to_string(),
                d.memory.to_string(),
                format!("{:.1}", d.voxel_bytes / 1e6),
                format!("{:.1}", d.ray_bytes / 1e6),
                if fits.is_empty() {
                    "-".to_owned()
                } else {
                    fits.join("; ")
                },
            ]
        })
        .collect();
    table(
        o,
        &[
            "architecture",
            "P",
            t.dsp_name(),
            t.lut_name(),
            "FF",
            t.bram_name(),
            "on-chip Mbit",
            "cycles",
            "util",
            "stall",
            "memory",
            "voxel MB/frame",
            "ray MB/frame",
            "fits (frames/s and external bandwidth at the part's clock)",
        ],
        &rows,
    );
}
