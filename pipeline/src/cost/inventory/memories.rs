//! The PE's memories as cost items, sized for the geometry's view (see the
//! parent module): the PE's declared state ([`Pe::declaration`]: the
//! slice buffer, the edge column, the compositing buffer and its column
//! map, the line buffer, the link FIFOs, and its registers: ports, edge,
//! broadcast copy, readout, pass latches) and the tables.

use super::{fmt_bits, Geometry, Item};
use crate::config::PipelineConfig;
use crate::cost::memory::MemPorts;
use crate::cost::shapes::table_word;
use crate::cost::units::Unit;
use crate::hw::state::{StateDecl, StateKind};
use crate::pe::Pe;

/// A declared on-chip state element as a cost item: a memory (a FIFO is
/// a simple dual-port memory) of its depth and width, once per copy.
/// Off-chip elements are not items: [`off_chip_bits`] counts them.
fn charge(d: StateDecl) -> Item {
    let ports = match d.kind {
        StateKind::Memory(p) => p,
        StateKind::Fifo | StateKind::Register | StateKind::OffChip => MemPorts::Sdp,
    };
    let unit = match d.kind {
        StateKind::Register => Unit::Reg { bits: d.width },
        _ => Unit::Mem {
            depth: d.depth,
            width: d.width,
            ports,
        },
    };
    let group = match d.kind {
        StateKind::Register => "registers",
        _ => "memories",
    };
    Item::new(group, d.what, d.copies, vec![unit])
}

/// What each table of the emitted sample datapath is, by its name there
/// ([`crate::hw::sample::MEMORIES`]).
pub(crate) fn table_name(name: &str) -> String {
    match name {
        "class_r" | "class_g" | "class_b" | "class_a" => {
            format!("classification table ({name})")
        }
        "log_table" => "-log2(1 - a) table".to_owned(),
        "exp_table" => "2^-f table".to_owned(),
        other => format!("table {other}"),
    }
}

/// Whether a memory item is one of the sample datapath's tables.
pub fn is_datapath_table(name: &str) -> bool {
    name.starts_with("classification table") || name == "-log2(1 - a) table" || name == "2^-f table"
}

/// A table of the emitted datapath as a memory: its depth and word, one
/// host write port and its read ports (two reads keep two copies), each
/// read's data register reset as the module resets it.
fn table_item(t: &crate::hw::pipeline_rtl::Table) -> Item {
    let ports = if t.reads >= 2 {
        MemPorts::WriteTwoReads
    } else {
        MemPorts::Sdp
    };
    Item::new(
        "memories",
        table_name(&t.name),
        1,
        std::iter::once(Unit::Mem {
            depth: t.depth,
            width: t.bits,
            ports,
        })
        .chain(std::iter::once(Unit::ReadReset {
            depth: t.depth,
            width: t.bits,
            ports,
        }))
        .collect(),
    )
}

/// The PE's memories: its declared voxel and ray state
/// ([`Pe::declaration`]) and the datapath's tables.
pub(super) fn memories(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Item> {
    let mem = |depth: u64, width: u32, ports: MemPorts| Unit::Mem {
        depth,
        width,
        ports,
    };
    let mut items: Vec<Item> = Pe::voxel_state(cfg, geo).into_iter().map(charge).collect();
    // The plain sample's tables the emitted datapath declares
    // (`super::datapath::emitted`; a pre-integrating PE reads its own
    // table instead of the classification and `-log2(1 - a)` tables); the
    // units' tables are block RAM loaded between frames, priced with their
    // units.
    let mut tables: Vec<Item> = match super::datapath::emitted(cfg, geo) {
        Some(e) => e
            .tables
            .iter()
            .filter(|t| crate::hw::sample::MEMORIES.contains(&t.name.as_str()))
            .map(table_item)
            .collect(),
        None => {
            let mut v = Vec::new();
            if !geo.units.preint {
                v.push(Item::new(
                    "memories",
                    "classification table",
                    1,
                    vec![mem(
                        u64::from(cfg.table_entries),
                        table_word(cfg),
                        MemPorts::DualRead,
                    )],
                ));
                v.push(Item::new(
                    "memories",
                    "-log2(1 - a) table",
                    1,
                    vec![mem(
                        1u64 << cfg.alpha.bits(),
                        fmt_bits(cfg.log_transmittance),
                        MemPorts::Sdp,
                    )],
                ));
            }
            v.push(Item::new(
                "memories",
                "2^-f table",
                1,
                vec![mem(
                    (1u64 << cfg.exp_table_bits) + 1,
                    fmt_bits(cfg.opacity_corr),
                    MemPorts::DualRead,
                )],
            ));
            v
        }
    };
    if geo.units.preint {
        tables.extend(crate::cost::preint::memories(cfg));
    }
    items.extend(tables);
    items.extend(
        Pe::ray_state(cfg, geo)
            .into_iter()
            .filter(StateDecl::on_chip)
            .map(charge),
    );
    items.extend(Pe::register_state(cfg, geo).into_iter().map(charge));
    items.retain(|i| {
        !i.units
            .iter()
            .any(|u| matches!(u, Unit::Mem { depth: 0, .. }))
    });
    items
}

/// Bits of the PE's declared off-chip memories ([`StateKind::OffChip`]:
/// with the rays in external memory, its rays and kept finals), every
/// copy: external memory, priced as bits beside the voxel memory, never as
/// block RAM.
pub fn off_chip_bits(cfg: &PipelineConfig, geo: &Geometry) -> u64 {
    Pe::declaration(cfg, geo)
        .iter()
        .filter(|d| !d.on_chip())
        .map(|d| u64::from(d.copies) * d.bits())
        .sum()
}
