//! The PE's memories as cost items, sized for the worst view (see the
//! parent module): the slice buffer, the edge column, the compositing
//! buffer and its column map, the line buffer, the migration FIFOs and the
//! tables.

use super::{addr_bits, fmt_bits, Geometry, Item};
use crate::config::{PipelineConfig, RayBuffer};
use crate::cost::arch;
use crate::cost::memory::MemPorts;
use crate::cost::shapes::{accum_word, table_word, RAY_INDEX_BITS};
use crate::cost::units::Unit;

/// The PE's memories.
pub(super) fn memories(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Item> {
    let [_, ny, _] = geo.dims;
    let ny = ny as u64;
    let w = geo.block();
    let v = fmt_bits(cfg.voxel);
    let acc = accum_word(cfg);
    let row_bits = addr_bits(2 * ny + 2);
    let mem = |depth: u64, width: u32, ports: MemPorts| Unit::Mem {
        depth,
        width,
        ports,
    };
    let half_rows = ny.div_ceil(2);
    // Round-robin mappings store each block with its apron and read no
    // neighbour: no edge-column copies.
    let round_robin = arch::round_robin_width(cfg).is_some();
    let stored = arch::stored_columns(cfg, geo);
    let buffers = if geo.shading {
        crate::cost::shading::memories(cfg, geo, stored, !round_robin)
    } else {
        let mut b = vec![Item::new(
            "memories",
            "slice buffer (2 slices x 2 row banks)",
            4,
            vec![mem(stored * half_rows, v, MemPorts::DualRead)],
        )];
        if !round_robin {
            b.push(Item::new(
                "memories",
                "edge column (2 slices x 2 row banks)",
                4,
                vec![mem(half_rows, v, MemPorts::Sdp)],
            ));
        }
        b
    };
    let mut items = buffers;
    // A pre-integrating PE reads its own table instead of the
    // classification and `-log2(1 - a)` tables.
    let tables = if geo.preint {
        crate::cost::preint::memories(cfg)
    } else {
        vec![
            Item::new(
                "memories",
                "classification table",
                1,
                vec![mem(
                    u64::from(cfg.table_entries),
                    table_word(cfg),
                    MemPorts::DualRead,
                )],
            ),
            Item::new(
                "memories",
                "-log2(1 - a) table",
                1,
                vec![mem(
                    1u64 << cfg.alpha.bits(),
                    fmt_bits(cfg.log_transmittance),
                    MemPorts::Sdp,
                )],
            ),
        ]
    };
    items.extend(tables);
    items.extend(vec![Item::new(
        "memories",
        "2^-f table",
        1,
        vec![mem(
            (1u64 << cfg.exp_table_bits) + 1,
            fmt_bits(cfg.opacity_corr),
            MemPorts::DualRead,
        )],
    )]);
    let rays = arch::rays_per_pe(cfg, geo);
    let row = arch::rays_per_row(cfg, geo);
    // A pre-integrating ray keeps its previous sample beside its
    // accumulators, wherever they go.
    let prev = crate::cost::preint::ray_bits(cfg, geo);
    if cfg.ray_buffer == RayBuffer::External {
        // Every ray's state lives in DDR; the PE keeps the row it samples
        // and the rows the controller reads ahead (and writes back).
        let rows = arch::row_buffers(cfg);
        items.push(Item::new(
            "memories",
            format!("row buffers ({rows} rows x 2 column banks; rays in DDR)"),
            2,
            vec![mem(
                (rows * row).div_ceil(2),
                arch::ray_bits(cfg) + prev,
                MemPorts::Sdp,
            )],
        ));
    } else {
        items.push(Item::new(
            "memories",
            "compositing buffer (2 column banks)",
            2,
            vec![mem(rays.div_ceil(2), acc + prev, MemPorts::Sdp)],
        ));
    }
    items.extend(vec![
        Item::new(
            "memories",
            "column map (slot -> ray column)",
            1,
            vec![mem(row, RAY_INDEX_BITS + 1, MemPorts::Sdp)],
        ),
        Item::new(
            "memories",
            "merge line buffer (3 rows)",
            3,
            vec![mem(w + 1, 4 * fmt_bits(cfg.merge), MemPorts::Sdp)],
        ),
        Item::new(
            "memories",
            "migration FIFO (one column per side)",
            2,
            vec![mem(
                2 * ny + 1,
                acc + prev + RAY_INDEX_BITS + row_bits,
                MemPorts::Sdp,
            )],
        ),
    ]);
    if cfg.order == crate::config::Order::FrontToBack && cfg.ray_buffer == RayBuffer::OnChip {
        // Each ray also carries what it inherited at the split and its
        // termination flag; each PE keeps its rays' final states at every
        // split for the fold, about `(W + 1)(ny + 1)` per boundary. With
        // an external buffer both live in DDR (the row buffer carries the
        // inherited state and the flag: `arch::ray_bits`).
        items.push(Item::new(
            "memories",
            "inherited state + termination flag (front to back)",
            2,
            vec![mem(rays.div_ceil(2), acc + 1, MemPorts::Sdp)],
        ));
        items.push(Item::new(
            "memories",
            "kept final states, K - 1 boundaries (front to back)",
            1,
            vec![mem(
                (w + 1) * (ny + 1) * u64::from(geo.regions.saturating_sub(1)),
                acc,
                MemPorts::Sdp,
            )],
        ));
    }
    items.retain(|i| {
        !i.units
            .iter()
            .any(|u| matches!(u, Unit::Mem { depth: 0, .. }))
    });
    items
}
