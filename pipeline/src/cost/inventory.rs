//! The hardware of one PE, and of the controller, as a list of units at
//! the configured widths, for a volume of given (view-space) dimensions
//! split over `P` PEs.
//!
//! The datapath is its description's (one sample per clock, fully
//! pipelined): the sample with the configuration's units composed
//! ([`crate::hw::compose::sample`]: ray position and slope `A + m t`,
//! weight, bilinear interpolation, classification, path length (three
//! squares, a sum, a square root), opacity correction (log table,
//! multiply, interpolated exp table, shift, `1 - T`) and compositing, the
//! units between), the PE's address step around it
//! ([`crate::hw::address`]) and the Bartlett merge unit
//! ([`crate::hw::tents`]). The pipeline registers and delay lines are the
//! ones the composed module declares on its schedule
//! ([`crate::hw::schedule`]).
//!
//! Memories, sized for the geometry's view (the voxel memories for the
//! volume, the ray memories for what that view's frames hold,
//! [`crate::capacity`]):
//!
//! - **slice buffer**: the PE's `W = ceil(nx / P)` columns of one slice,
//!   `W x ny` voxels, double-buffered (one slice is sampled while the next
//!   loads from external memory) and split by row parity so the four
//!   bilinear taps (rows `y0`, `y0 + 1`, columns `c0`, `c0 + 1`) are two
//!   reads of each bank;
//! - **edge column**: a copy of the block's first column, which the left
//!   neighbour reads every cycle (two rows), also double-buffered;
//! - **compositing buffer**: the accumulators of every ray the PE holds,
//!   the view's ray columns of its tallest region's rows (a middle PE
//!   owns `2W + 1` columns, rays being between half a voxel and a voxel
//!   apart in every slice of their region; the end PEs also hold the rays
//!   beyond the volume's sides, and only they are that deep: each PE is
//!   declared at its own depths), in two banks by ray column parity so the merge reads both new parents of a child in one
//!   cycle; children overwrite their centre parent's slot, which the y pass
//!   no longer needs;
//! - **occupancy memory**: per column slot of the compositing buffer,
//!   whether it holds a ray column and its index `m` (the model's
//!   `VecDeque` of held columns);
//! - **line buffer**: three rows of x-merged children (`W + 1` each) for
//!   the merge's y pass;
//! - **link FIFOs**: `link_fifo_depth` rows per side, fed from the
//!   compositing buffer;
//! - the three **tables** (classification, `-log2(1 - a)`, `2^-f`), loaded
//!   by the host between frames; a pre-integrating PE holds the
//!   pre-integration table in place of the first two
//!   ([`super::preint`]).
//!
//! Voxel memory (all `W x ny x nz` voxels of the PE's block) is external:
//! at 128^3 and beyond it is megabits per PE, far beyond on-chip RAM. The
//! throughput model charges its bandwidth instead.

mod datapath;
mod dsp_regs;
mod memories;

use datapath::datapath;
pub use datapath::{in_module, Schedule, PIPELINE_REGISTERS, SAMPLE_STAGE};
use memories::memories;
pub use memories::{is_datapath_table, off_chip_bits};

use super::arch;
use super::memory::MemPorts;
use super::shapes::{MulAdd, Quantizer, Word, RAY_INDEX_BITS};
use super::target::{Resources, Target};
use super::units::{total, Unit};
use crate::config::PipelineConfig;
use serde::Serialize;

/// One line of the inventory: `count` copies of a group of units.
#[derive(Debug, Clone, Serialize)]
pub struct Item {
    /// Pipeline stage or block: position, interpolation, ...
    pub group: &'static str,
    /// What the units do.
    pub name: String,
    /// Copies.
    pub count: u32,
    /// The units of one copy.
    pub units: Vec<Unit>,
    /// Its registers are the emitted sample datapath's, counted once in
    /// that module's pipeline-register item (`datapath::emitted`): the
    /// units price logic, multipliers and memories only (no flip-flops,
    /// no shift-register LUTs; every emitted register resets, so none is
    /// an SRL). Left out of the JSON when false.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub registers_declared: bool,
}

impl Item {
    pub(super) fn new(
        group: &'static str,
        name: impl Into<String>,
        count: u32,
        units: Vec<Unit>,
    ) -> Item {
        Item {
            group,
            name: name.into(),
            count,
            units,
            registers_declared: false,
        }
    }

    /// Resources of all copies on `t`.
    pub fn cost(&self, t: Target) -> Resources {
        let mut r = total(t, &self.units);
        if self.registers_declared {
            r.ff = 0;
            r.lut -= r.lutram;
            r.lutram = 0;
        }
        r * u64::from(self.count)
    }

    /// The widths, for the report: the memory or multiplier if there is
    /// one, a summary of delay lines, or the first unit and how many more.
    pub fn shape(&self) -> String {
        let find = |f: fn(&Unit) -> bool| self.units.iter().find(|u| f(u));
        if let Some(u) =
            find(|u| matches!(u, Unit::Mem { .. })).or_else(|| find(|u| matches!(u, Unit::Mul(_))))
        {
            return u.shape();
        }
        if !self.units.is_empty() && self.units.iter().all(|u| matches!(u, Unit::Delay { .. })) {
            let bit_clocks: u32 = self
                .units
                .iter()
                .map(|u| match u {
                    Unit::Delay { bits, cycles } => bits * cycles,
                    _ => 0,
                })
                .sum();
            return format!("{} lines, {bit_clocks} bit-clocks", self.units.len());
        }
        let logic: Vec<&Unit> = self
            .units
            .iter()
            .filter(|u| !matches!(u, Unit::Reg { .. }))
            .collect();
        match logic.as_slice() {
            [] => self.units.first().map(Unit::shape).unwrap_or_default(),
            [one] => one.shape(),
            [first, rest @ ..] => format!("{} +{}", first.shape(), rest.len()),
        }
    }
}

/// The array's geometry: view-space volume dimensions, PE count, the
/// view's regions and each PE's ray depths.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Geometry {
    /// View-space dimensions `[nx, ny, nz]` (x across the PEs, z along
    /// the principal axis).
    pub dims: [usize; 3],
    /// PEs.
    pub pes: u16,
    /// Exponential regions `K` of the view (front to back keeps the final
    /// states of `K - 1` boundaries for the fold).
    pub regions: u32,
    /// The units its PEs' sample datapath carries besides the plain
    /// sample, as [`crate::hw::compose::sample`] composes them (the cost
    /// prices the shading unit built for one light).
    #[serde(flatten)]
    pub units: crate::hw::compose::Units,
    /// What the PE this geometry describes declares in its ray memories:
    /// columns, rows, a pass's children, kept finals
    /// ([`crate::capacity`]). For the whole array (as made) the deepest
    /// PE's, field by field; [`Geometry::pe`] gives each PE's own.
    pub rays: crate::capacity::RayDepths,
    /// Each PE's own ray depths, by PE index, for the views the geometry
    /// was made for: each PE declares its ray memories at these
    /// ([`Geometry::pe`]) and the array's cost sums them
    /// ([`super::design::array`]).
    pub pe_rays: crate::capacity::PeDepths,
}

impl Geometry {
    /// The geometry of `pes` PEs for a volume of `dims` seen from half its
    /// depth in front of its centre (the eye the report's tables assume),
    /// each PE's ray memories sized for that view in both orders under
    /// every mapping (PE by PE, the most over them:
    /// [`crate::capacity::PeDepths::cover`]).
    pub fn new(dims: [usize; 3], pes: u16) -> Geometry {
        use crate::config::{Mapping, Order};
        let d = (dims[2] as f64 / 2.0).max(golden::geometry::MIN_D);
        let view = default_view(dims);
        let mut pe_rays =
            crate::capacity::PeDepths::uniform(usize::from(pes.max(1)), Default::default());
        for mapping in [Mapping::Blocks, Mapping::Interleave, Mapping::Cyclic] {
            for order in [Order::BackToFront, Order::FrontToBack] {
                let cfg = PipelineConfig {
                    pes,
                    mapping,
                    order,
                    ..PipelineConfig::default()
                };
                if let Some(v) = &view {
                    if let Ok(need) = crate::capacity::need(&cfg, v) {
                        pe_rays = pe_rays.cover(&need);
                    }
                }
            }
        }
        Geometry {
            dims,
            pes,
            regions: golden::geometry::Regions::new(d, dims[2]).count() as u32,
            units: Default::default(),
            rays: pe_rays.max(),
            pe_rays,
        }
    }

    /// The geometry of `cfg`'s array for a frame of `view`: its
    /// dimensions and regions, each PE's ray memories sized for the view
    /// ([`crate::capacity::need`]).
    pub fn for_view(
        cfg: &PipelineConfig,
        view: &golden::geometry::View,
    ) -> Result<Geometry, golden::Error> {
        let layout = golden::methods::Method::Er.layout(view)?;
        let pe_rays = crate::capacity::need_of(cfg, view, &layout);
        Ok(Geometry {
            dims: view.dims,
            pes: cfg.pes,
            regions: layout.grids.len() as u32,
            units: Default::default(),
            rays: pe_rays.max(),
            pe_rays,
        })
    }

    /// This geometry with every PE's ray memories sized for `rays` (a
    /// uniform declaration).
    pub fn with_rays(self, rays: crate::capacity::RayDepths) -> Geometry {
        let pe_rays = crate::capacity::PeDepths::uniform(usize::from(self.pes.max(1)), rays);
        Geometry {
            rays,
            pe_rays,
            ..self
        }
    }

    /// This geometry with each PE's ray memories sized for `pe_rays`
    /// (one entry per PE).
    pub fn with_pe_rays(self, pe_rays: crate::capacity::PeDepths) -> Geometry {
        Geometry {
            rays: pe_rays.max(),
            pe_rays,
            ..self
        }
    }

    /// This geometry as `cfg`'s array declares it: each PE's columns its
    /// own where `cfg`'s migration allows ([`crate::capacity::own_columns`]),
    /// else every PE's the deepest PE's. [`Geometry::new`] sizes for the
    /// migration between slices on dense links.
    pub fn declared_by(self, cfg: &PipelineConfig) -> Geometry {
        if crate::capacity::own_columns(cfg) {
            return self;
        }
        let columns = self.rays.columns;
        let pe_rays = crate::capacity::PeDepths(
            self.pe_rays
                .0
                .iter()
                .map(|r| crate::capacity::RayDepths { columns, ..*r })
                .collect(),
        );
        Geometry { pe_rays, ..self }
    }

    /// PE `k`'s geometry: the array's, its ray memories at PE `k`'s own
    /// depths.
    pub fn pe(&self, k: usize) -> Geometry {
        Geometry {
            rays: self.pe_rays.pe(k),
            ..self.clone()
        }
    }

    /// This geometry with its PEs carrying `units`.
    pub fn with_units(self, units: crate::hw::compose::Units) -> Geometry {
        Geometry { units, ..self }
    }

    /// Columns per PE, `W = ceil(nx / P)`.
    pub fn block(&self) -> u64 {
        (self.dims[0] as u64).div_ceil(u64::from(self.pes.max(1)))
    }

    /// Rays a PE samples in a slice at most: `(2W + 1) (2 ny + 1)` (rays
    /// are at least half a voxel apart in a slice, and only the rays
    /// inside the volume sample it).
    pub fn sampled_per_slice(&self) -> u64 {
        (2 * self.block() + 1) * (2 * self.dims[1] as u64 + 1)
    }

    /// Rays the PE this geometry describes may hold: its ray columns times
    /// their rows ([`crate::capacity::RayDepths`]).
    pub fn rays_per_pe(&self) -> u64 {
        self.rays.columns.max(1) * self.rays.rows.max(1)
    }

    /// Rays all the PEs may hold: each PE's own ray columns times their
    /// rows, summed.
    pub fn rays_in_array(&self) -> u64 {
        self.pe_rays
            .0
            .iter()
            .map(|r| r.columns.max(1) * r.rows.max(1))
            .sum()
    }
}

/// The view [`Geometry::new`] assumes: the eye half the volume's depth in
/// front of its centre.
fn default_view(dims: [usize; 3]) -> Option<golden::geometry::View> {
    let c = glam::DVec3::new(
        (dims[0] as f64 - 1.0) / 2.0,
        (dims[1] as f64 - 1.0) / 2.0,
        (dims[2] as f64 - 1.0) / 2.0,
    );
    let eye = glam::DVec3::new(
        c.x,
        c.y,
        -(dims[2] as f64 / 2.0).max(golden::geometry::MIN_D),
    );
    let cam = golden::camera::Camera::new(eye, c, glam::DVec3::Y, 90.0, 2, 2).ok()?;
    golden::geometry::View::new(dims, [1.0; 3], &cam, 1.0).ok()
}

/// `ceil(log2(n))`, at least 1.
pub fn addr_bits(n: u64) -> u32 {
    (64 - n.saturating_sub(1).leading_zeros()).max(1)
}

pub(super) fn fmt_bits(f: crate::fixed::Format) -> u32 {
    u32::from(f.bits())
}

/// The PE's counters and the links' logic beside its declared port
/// registers.
fn links(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Item> {
    let row_bits = addr_bits(arch::ray_rows(geo) + 1);
    let col_bits = addr_bits(geo.block() + 1);
    let slot_bits = addr_bits(arch::slots(cfg, geo));
    // The ports, the broadcast copy and the PE's other registers are
    // declared state ([`crate::pe::Pe::register_state`]), charged with the
    // memories.
    let mut items = vec![Item::new(
        "control",
        "counters: column, row, slot",
        1,
        vec![
            Unit::Inc { width: col_bits },
            Unit::Inc { width: row_bits },
            Unit::Inc { width: slot_bits },
            Unit::Cmp { width: col_bits },
            Unit::Cmp { width: row_bits },
            Unit::Reg {
                bits: col_bits + row_bits + slot_bits,
            },
        ],
    )];
    if arch::round_robin_width(cfg).is_none() && geo.units.shading() {
        items.push(super::shading::link(cfg));
    }
    items.extend(arch::owner_logic(cfg));
    items.extend(arch::lane_ports(cfg, geo));
    items.extend(arch::valid_bits(cfg, geo));
    items
}

/// Everything in one PE.
#[derive(Debug, Clone, Serialize)]
pub struct PeInventory {
    /// The geometry it was sized for.
    pub geometry: Geometry,
    /// Units, memories and registers.
    pub items: Vec<Item>,
    /// The sample pipeline's schedule.
    pub schedule: Schedule,
    /// Bits of external voxel memory behind this PE: `W x ny x nz` voxels.
    pub voxel_memory_bits: u64,
    /// Bits of external ray memory behind this PE: its declared off-chip
    /// memories (with an external ray buffer its rays and, front to back,
    /// its kept finals; 0 with the rays on chip).
    pub ray_memory_bits: u64,
}

impl PeInventory {
    /// One PE's resources on `t`.
    pub fn cost(&self, t: Target) -> Resources {
        self.items.iter().map(|i| i.cost(t)).sum()
    }
}

/// The PE for `cfg` in an array of `geo`.
pub fn pe_inventory(cfg: &PipelineConfig, geo: &Geometry) -> PeInventory {
    let dp = datapath(cfg, geo);
    let mut items = dp.items;
    // The merge unit: the x pass (a tent of three parents into `merge`)
    // and the y pass (back into the accumulators), one child per clock,
    // from its description.
    items.extend(datapath::described_items(&crate::hw::tents::tents(cfg)));
    items.extend(memories(cfg, geo));
    items.extend(links(cfg, geo));
    let [_, ny, nz] = geo.dims;
    PeInventory {
        geometry: geo.clone(),
        items,
        schedule: dp.schedule,
        voxel_memory_bits: arch::stored_columns(cfg, geo)
            * ny as u64
            * nz as u64
            * u64::from(cfg.voxel.bits()),
        ray_memory_bits: memories::off_chip_bits(cfg, geo),
    }
}

/// The controller, once per array: per row it computes the y position,
/// address, weight and slope the PEs share, and it holds the broadcast
/// registers. The host computes the per-slice and per-region constants.
pub fn controller_inventory(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Item> {
    let pos = Word::from(cfg.position);
    let m = Word::signed(RAY_INDEX_BITS, 0);
    let ypos = MulAdd::new(pos, m, cfg.step.into(), cfg.position);
    let pn = fmt_bits(cfg.position);
    let s = fmt_bits(cfg.step);
    let row_bits = addr_bits(arch::ray_rows(geo) + 1);
    let int_bits = pos.int_bits().max(1) as u32;
    let mut u = ypos.units();
    u.push(Unit::Reg { bits: pn });
    let mut addr = vec![
        Unit::Cmp { width: int_bits },
        Unit::Cmp { width: int_bits },
        Unit::Inc { width: int_bits },
    ];
    let weight_q = Quantizer::new(
        Word::unsigned(
            u32::from(cfg.position.frac()),
            i32::from(cfg.position.frac()),
        ),
        cfg.weight,
    );
    addr.extend(weight_q.units());
    addr.push(Unit::Reg {
        bits: 2 * row_bits + fmt_bits(cfg.weight),
    });
    // Empty-space skipping: one bit per block of the volume, and the row's
    // runs (a block edge's ray index, `(x_edge - A) / t`, as a multiply by
    // the host's `1 / t`, one edge per cycle while the previous row
    // samples).
    let b = u64::from(cfg.occupancy_block);
    let blocks: u64 = geo
        .dims
        .iter()
        .map(|&n| (n as u64).saturating_sub(1) / b + 1)
        .product();
    let runs = MulAdd::new(pos, pos, cfg.step.into(), cfg.position);
    let mut run_units = runs.units();
    run_units.push(Unit::Reg {
        bits: 2 * RAY_INDEX_BITS,
    });
    let mut items = vec![
        Item::new(
            "controller",
            "occupancy memory (1 bit per block)",
            1,
            vec![Unit::Mem {
                depth: blocks,
                width: 1,
                ports: MemPorts::Sdp,
            }],
        ),
        Item::new(
            "controller",
            "row runs: block edge to ray index",
            1,
            run_units,
        ),
        Item::new("controller", "row y: A + m t", 1, u.clone()),
        Item::new("controller", "row slope y: b + m k", 1, u),
        Item::new("controller", "row address and weight", 1, addr),
        Item::new(
            "controller",
            "broadcast registers: A, t, b, k, sz^2 (x and y)",
            1,
            vec![Unit::Reg {
                bits: 4 * pn + 4 * s + 2 * pn,
            }],
        ),
    ];
    items.extend(arch::wrap_link(cfg, geo));
    items.extend(arch::memory_controller(cfg));
    items
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_pe_on_xc7() {
        let cfg = PipelineConfig::default();
        let geo = Geometry::new([128, 128, 128], 16);
        let pe = pe_inventory(&cfg, &geo);
        let r = pe.cost(Target::Xc7);
        // 2 + 2 (ray and slope), 3 (bilinear), 4 (classification),
        // 3 x 4 (squares), 1 (log x path), 1 (exp lerp), 4 (compositing).
        assert_eq!(r.dsp, 29);
        assert!(r.bram > 0 && r.lut > 0 && r.ff > 0);
        assert!(pe.schedule.depth > 20, "{:?}", pe.schedule);
        assert_eq!(pe.voxel_memory_bits, 8 * 128 * 128 * 12);
    }
}
