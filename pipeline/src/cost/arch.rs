//! What the architecture choices of the config cost: the ownership
//! [`Mapping`] (which PE owns which voxel columns while sampling) and the
//! [`RayBuffer`] placement (where the rays' accumulators live).
//!
//! - **Column blocks** (the original): PE `k` owns `W = ceil(nx / P)`
//!   columns; its left neighbour reads the block's first column through the
//!   edge-voxel port, so each PE keeps that column twice (the edge-column
//!   memories of [`super::inventory`]).
//! - **Interleave and cyclic** (`B` = 1 or `cyclic_width`): PE `k` owns the
//!   blocks `b` with `b mod P = k`, `ceil(ceil(nx / B) / P)` blocks of `B`
//!   columns. The host loads each block with an apron, one column to the
//!   right unshaded (the bilinear right tap), one left and two right shaded
//!   (the central differences), so sampling reads no neighbour and the edge
//!   columns and voxel ports go: the slice buffer holds `(B + 1) / B` of
//!   the owned columns unshaded, `(B + 3) / B` shaded. A ray's owner
//!   changes at every block edge; a PE tells by comparing the ray's base
//!   column with its current block's two edges ([`owner_logic`]). Rays
//!   reach PE 0 from PE `P - 1` over a wrap link ([`wrap_link`]).
//! - **External ray buffer**: the accumulators of every ray (and front to
//!   back the inherited states and the kept final states) live in DDR; on
//!   chip each PE keeps `ray_buffer_rows` row buffers of its rays of one
//!   row ([`rays_per_row`]): the row sampling and the rows the controller
//!   reads ahead (and writes back) meanwhile; the array has one
//!   memory-controller interface ([`memory_controller`]).

use super::inventory::{addr_bits, Geometry, Item};
use super::shapes::{accum_word, RAY_INDEX_BITS};
use super::units::Unit;
use crate::config::{Mapping, Migration, Order, PipelineConfig, RayBuffer};

/// Columns per round-robin block: `None` for column blocks, 1 for the
/// interleave, `cyclic_width` for cyclic.
pub fn round_robin_width(cfg: &PipelineConfig) -> Option<u64> {
    match cfg.mapping {
        Mapping::Blocks => None,
        Mapping::Interleave => Some(1),
        Mapping::Cyclic => Some(u64::from(cfg.cyclic_width.max(1))),
    }
}

/// Apron columns the host loads beside each round-robin block: 1 (the
/// bilinear right tap) unshaded, 3 (one left, two right: the gradient's
/// central differences) shaded.
pub fn apron(shading: bool) -> u64 {
    if shading {
        3
    } else {
        1
    }
}

/// Round-robin blocks per PE, `ceil(ceil(nx / B) / P)` (1 for column
/// blocks).
pub fn blocks_per_pe(cfg: &PipelineConfig, geo: &Geometry) -> u64 {
    match round_robin_width(cfg) {
        None => 1,
        Some(b) => (geo.dims[0] as u64)
            .div_ceil(b)
            .div_ceil(u64::from(geo.pes.max(1))),
    }
}

/// Voxel columns a PE owns (samples the rays of): `W`, or its blocks'
/// `B` columns each.
pub fn owned_columns(cfg: &PipelineConfig, geo: &Geometry) -> u64 {
    match round_robin_width(cfg) {
        None => geo.block(),
        Some(b) => blocks_per_pe(cfg, geo) * b,
    }
}

/// Voxel columns a PE stores per slice: its own, and under a round-robin
/// mapping each block's apron.
pub fn stored_columns(cfg: &PipelineConfig, geo: &Geometry) -> u64 {
    match round_robin_width(cfg) {
        None => geo.block(),
        Some(b) => blocks_per_pe(cfg, geo) * (b + apron(geo.units.shading())),
    }
}

/// Ray columns a PE may hold at once (the column map's slots): what the
/// geometry's view needs in the PE it describes ([`crate::capacity`]:
/// about `2 C + 1` for `C` owned columns in a middle PE; in an end PE also
/// the rays beyond the volume's sides, clamped to it).
pub fn rays_per_row(_cfg: &PipelineConfig, geo: &Geometry) -> u64 {
    geo.rays.columns.max(1)
}

/// Rows of a ray column: the tallest region grid's rows.
pub fn ray_rows(geo: &Geometry) -> u64 {
    geo.rays.rows.max(1)
}

/// Rays a PE may hold in a frame: [`rays_per_row`] slots of
/// [`ray_rows`] rows.
pub fn rays_per_pe(cfg: &PipelineConfig, geo: &Geometry) -> u64 {
    rays_per_row(cfg, geo) * ray_rows(geo)
}

/// Ray slots a PE addresses on chip: every ray it may hold, or with an
/// external buffer the two rows of its row buffer.
pub fn slots(cfg: &PipelineConfig, geo: &Geometry) -> u64 {
    match cfg.ray_buffer {
        RayBuffer::OnChip => rays_per_pe(cfg, geo),
        RayBuffer::External => row_buffers(cfg) * rays_per_row(cfg, geo),
    }
}

/// Row buffers per PE with an external ray buffer: the row sampling and
/// the `ray_buffer_rows - 1` rows the controller reads ahead.
pub fn row_buffers(cfg: &PipelineConfig) -> u64 {
    u64::from(cfg.ray_buffer_rows.max(2))
}

/// Bits of one ray's state in the compositing buffer: the accumulators,
/// and front to back also the inherited state and the termination flag.
pub fn ray_bits(cfg: &PipelineConfig) -> u32 {
    let acc = accum_word(cfg);
    match cfg.order {
        Order::BackToFront => acc,
        Order::FrontToBack => 2 * acc + 1,
    }
}

/// The round-robin owner test of one PE: the ray's base column against the
/// current block's left and right edges (which way it leaves), and the
/// next block's edges (`+ B P`) as the ray moves on; the edges live in
/// registers. Column blocks have no such unit: their edges are constants.
pub fn owner_logic(cfg: &PipelineConfig) -> Option<Item> {
    round_robin_width(cfg)?;
    let int_bits = (i32::from(cfg.position.int_bits())).max(1) as u32;
    Some(Item::new(
        "mapping",
        "ray owner: base column vs block edges",
        1,
        vec![
            Unit::Cmp { width: int_bits },
            Unit::Cmp { width: int_bits },
            Unit::Add { width: int_bits },
            Unit::Add { width: int_bits },
            Unit::Reg { bits: 2 * int_bits },
        ],
    ))
}

/// The extra lanes of the ray ports (`link_lanes` above 1): each lane a
/// port register of its own per side (accumulators, index, row, valid).
/// The compositing buffer takes a write per arriving lane; the model
/// charges the registers, not the buffer's extra write ports (a banked or
/// multi-pumped buffer), which stay a designer's choice.
pub fn lane_ports(cfg: &PipelineConfig, geo: &Geometry) -> Option<Item> {
    let extra = u32::from(cfg.link_lanes.max(1)) - 1;
    if extra == 0 {
        return None;
    }
    let row_bits = addr_bits(ray_rows(geo) + 1);
    Some(Item::new(
        "links",
        format!("ray port lanes 2..={} (left, right)", extra + 1),
        2 * extra,
        vec![Unit::Reg {
            bits: ray_bits(cfg) + super::preint::ray_bits(cfg, geo) + RAY_INDEX_BITS + row_bits + 1,
        }],
    ))
}

/// The valid bits that let transparent rays skip work
/// (`link_skip_empty`, `pass_skip_empty`): one per ray and bank (on chip
/// also when the rays live in DDR),
/// kept a row to a word so a pass reads a row's bits at once (cleared a
/// word a cycle while the other bank is in use); with `pass_skip_empty`
/// also the line buffer's valid bits and the encoder that turns a row's
/// bits into the slot's work list, one child a cycle.
pub fn valid_bits(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Item> {
    if !(cfg.link_skip_empty || cfg.pass_skip_empty) {
        return Vec::new();
    }
    let row = rays_per_row(cfg, geo);
    // Every ray's bit stays on chip, also with the rays in DDR: a pass
    // reads from DDR only the rays its bits say are non-zero.
    let rows = ray_rows(geo);
    let mut items = vec![Item::new(
        "memories",
        "ray valid bits (a row per word, 2 banks)",
        2,
        vec![Unit::Mem {
            depth: rows,
            width: row as u32,
            ports: super::memory::MemPorts::Sdp,
        }],
    )];
    if cfg.pass_skip_empty {
        let children = row.div_ceil(2) as u32;
        items.push(Item::new(
            "merge",
            "work list: line-buffer valid bits, row bits to next child",
            1,
            vec![
                Unit::Reg { bits: 3 * children },
                Unit::Reduce {
                    width: 3 * children,
                },
                Unit::Mux {
                    width: addr_bits(u64::from(children)),
                    inputs: children,
                },
            ],
        ));
    }
    items
}

/// The ring's wrap link from PE `P - 1` to PE 0 (round-robin mappings): one
/// more ray port, carrying only migrating rays (accumulators, index, row,
/// valid), once per array.
pub fn wrap_link(cfg: &PipelineConfig, geo: &Geometry) -> Option<Item> {
    round_robin_width(cfg)?;
    let row_bits = addr_bits(ray_rows(geo) + 1);
    Some(Item::new(
        "links",
        "wrap link P-1 -> 0 (migrating rays)",
        1,
        vec![Unit::Reg {
            bits: ray_bits(cfg) + super::preint::ray_bits(cfg, geo) + RAY_INDEX_BITS + row_bits + 1,
        }],
    ))
}

/// LUTs of the DDR4 memory-controller interface charged for an external
/// ray buffer: the order of AMD's DDR4 SDRAM controller (PG150, a 64-bit
/// UltraScale+ interface with its calibration microcontroller, AXI4 port
/// and the read and write DMA engines) — an estimate, not synthesized here.
pub const MEMORY_CONTROLLER_LUTS: u32 = 12_000;
/// Flip-flops of the same interface (estimate, as above).
pub const MEMORY_CONTROLLER_FFS: u32 = 14_000;
/// RAMB18 units of the same interface: the calibration microcontroller's
/// memory and the AXI FIFOs (estimate, as above).
pub const MEMORY_CONTROLLER_BRAM: u32 = 16;

/// The memory-controller interface of an external ray buffer, once per
/// array.
pub fn memory_controller(cfg: &PipelineConfig) -> Option<Item> {
    if cfg.ray_buffer != RayBuffer::External {
        return None;
    }
    Some(Item::new(
        "controller",
        "DDR4 interface for the external ray buffer (PG150 order, estimate)",
        1,
        vec![Unit::Ip {
            lut: MEMORY_CONTROLLER_LUTS,
            ff: MEMORY_CONTROLLER_FFS,
            bram: MEMORY_CONTROLLER_BRAM,
        }],
    ))
}

/// The mapping's name, with the width of `cyclic`: `cyclic:4`.
pub fn mapping_name(cfg: &PipelineConfig) -> String {
    match cfg.mapping {
        Mapping::Cyclic => format!("cyclic:{}", cfg.cyclic_width),
        m => m.name().to_owned(),
    }
}

/// The migration's name, with the links' lanes when there are more than
/// one: `overlapped:2`.
pub fn migration_name(cfg: &PipelineConfig) -> String {
    match cfg.link_lanes {
        0 | 1 => cfg.migration.name().to_owned(),
        n => format!("{}:{n}", cfg.migration.name()),
    }
}

/// A short name of the architecture: mapping, the migration when
/// overlapped (with its lanes), and placement, e.g.
/// `cyclic:4/overlapped:2/external`.
pub fn label(cfg: &PipelineConfig) -> String {
    match cfg.migration {
        Migration::BetweenSlices => {
            format!("{}/{}", mapping_name(cfg), cfg.ray_buffer.name())
        }
        _ => format!(
            "{}/{}/{}",
            mapping_name(cfg),
            migration_name(cfg),
            cfg.ray_buffer.name()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn owned_and_stored_columns() {
        let geo = Geometry::new([256, 256, 256], 16);
        let mut cfg = PipelineConfig::default();
        assert_eq!(owned_columns(&cfg, &geo), 16);
        assert_eq!(stored_columns(&cfg, &geo), 16);
        cfg.mapping = Mapping::Cyclic;
        cfg.cyclic_width = 4;
        // 64 blocks of 4 over 16 PEs: 4 blocks, 16 columns, 20 stored.
        assert_eq!(owned_columns(&cfg, &geo), 16);
        assert_eq!(stored_columns(&cfg, &geo), 20);
        assert_eq!(
            stored_columns(
                &cfg,
                &geo.clone().with_units(crate::hw::compose::Units {
                    lights: Some(1),
                    ..Default::default()
                })
            ),
            28
        );
        cfg.mapping = Mapping::Interleave;
        assert_eq!(stored_columns(&cfg, &geo), 32);
        // 100 columns over 16 PEs in blocks of 8: 13 blocks, 1 each.
        let geo = Geometry::new([100, 64, 64], 16);
        cfg.mapping = Mapping::Cyclic;
        cfg.cyclic_width = 8;
        assert_eq!(owned_columns(&cfg, &geo), 8);
        // A row's slots are the view's ray columns: the middle PEs' 2C + 1
        // and the end PEs' rays beyond the volume's sides.
        assert_eq!(rays_per_row(&cfg, &geo), geo.rays.columns);
        assert!(rays_per_row(&cfg, &geo) > 2 * 8 + 1);
    }
}
