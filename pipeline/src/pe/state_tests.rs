//! The PE's declared state against the cost model's memory inventory.

use crate::config::{Mapping, Order, PipelineConfig, RayBuffer};
use crate::cost::inventory::{pe_inventory, Geometry};
use crate::cost::memory::MemPorts;
use crate::cost::units::Unit;
use crate::hw::state::{StateDecl, StateKind};
use crate::pe::Pe;

/// The configurations and geometries the checks run over: both orders,
/// every mapping, the external ray buffer, shading, pre-integration and
/// link FIFOs shallower and deeper than the default.
fn cases() -> Vec<(PipelineConfig, Geometry)> {
    let geo = Geometry::new([256, 256, 256], 16);
    let base = PipelineConfig::default();
    let with = |f: &dyn Fn(&mut PipelineConfig)| {
        let mut c = base;
        f(&mut c);
        c
    };
    vec![
        (base, geo.clone()),
        (with(&|c| c.order = Order::FrontToBack), geo.clone()),
        (with(&|c| c.ray_buffer = RayBuffer::External), geo.clone()),
        (
            with(&|c| {
                c.order = Order::FrontToBack;
                c.ray_buffer = RayBuffer::External;
            }),
            geo.clone(),
        ),
        (with(&|c| c.mapping = Mapping::Interleave), geo.clone()),
        (
            with(&|c| {
                c.mapping = Mapping::Cyclic;
                c.cyclic_width = 4;
            }),
            geo.clone().with_units(crate::hw::compose::Units {
                lights: Some(1),
                ..Default::default()
            }),
        ),
        (
            base,
            geo.clone().with_units(crate::hw::compose::Units {
                lights: Some(1),
                ..Default::default()
            }),
        ),
        (
            base,
            geo.clone().with_units(crate::hw::compose::Units {
                preint: true,
                ..Default::default()
            }),
        ),
        (base, Geometry::new([100, 64, 64], 8)),
        (with(&|c| c.link_fifo_depth = 1), geo.clone()),
        (with(&|c| c.link_fifo_depth = 300), geo.clone()),
    ]
}

/// What a declared element costs as a memory: its ports (a FIFO is a
/// simple dual-port memory).
fn ports(d: &StateDecl) -> MemPorts {
    match d.kind {
        StateKind::Memory(p) => p,
        StateKind::Fifo | StateKind::Register | StateKind::OffChip => MemPorts::Sdp,
    }
}

/// Every declared memory and FIFO is charged by the cost inventory with
/// its copies, depth, width and ports, and every memory the inventory
/// charges is a declared element or one of the datapath's tables.
#[test]
fn the_cost_inventory_charges_every_declared_state_element() {
    for (cfg, geo) in cases() {
        let decls = Pe::declaration(&cfg, &geo);
        let inv = pe_inventory(&cfg, &geo);
        let mems: Vec<_> = inv.items.iter().filter(|i| i.group == "memories").collect();
        let regs: Vec<_> = inv
            .items
            .iter()
            .filter(|i| i.group == "registers")
            .collect();
        for d in decls.iter().filter(|d| d.kind == StateKind::Register) {
            let item = regs
                .iter()
                .find(|i| i.name == d.what)
                .unwrap_or_else(|| panic!("register {} is not charged", d.name));
            assert_eq!(item.count, d.copies, "{}", d.name);
            assert_eq!(item.units, vec![Unit::Reg { bits: d.width }], "{}", d.name);
        }
        for i in &regs {
            assert!(
                decls
                    .iter()
                    .any(|d| d.kind == StateKind::Register && d.what == i.name),
                "register {} is charged but not declared",
                i.name
            );
        }
        for d in decls
            .iter()
            .filter(|d| d.depth > 0 && d.kind != StateKind::Register && d.on_chip())
        {
            let item = mems
                .iter()
                .find(|i| i.name == d.what)
                .unwrap_or_else(|| panic!("{} is not charged ({cfg:?}, {geo:?})", d.name));
            assert_eq!(item.count, d.copies, "{}", d.name);
            assert_eq!(
                item.units,
                vec![Unit::Mem {
                    depth: d.depth,
                    width: d.width,
                    ports: ports(d),
                }],
                "{}",
                d.name
            );
        }
        for i in &mems {
            assert!(
                i.name.contains("table") || decls.iter().any(|d| d.what == i.name && d.on_chip()),
                "{} is charged but not declared on chip",
                i.name
            );
        }
        // The off-chip memories are external bits, never block RAM.
        let off: Vec<_> = decls.iter().filter(|d| !d.on_chip()).collect();
        assert_eq!(
            inv.ray_memory_bits,
            off.iter()
                .map(|d| u64::from(d.copies) * d.bits())
                .sum::<u64>()
        );
        assert_eq!(
            off.is_empty(),
            cfg.ray_buffer == RayBuffer::OnChip,
            "{cfg:?}"
        );
    }
}

/// With the rays in external memory the PE declares its share of it as
/// off-chip memories at the depths they have on chip: its rays (with
/// their inherited states front to back) and, front to back, its kept
/// finals at the view's kept depth; the cost model prices them as
/// external bits and charges no block RAM for them.
#[test]
fn an_external_ray_buffer_declares_the_rays_and_kept_finals_off_chip() {
    let geo = Geometry::new([256, 256, 256], 16);
    for order in [Order::BackToFront, Order::FrontToBack] {
        let on = PipelineConfig {
            order,
            ..PipelineConfig::default()
        };
        let ext = PipelineConfig {
            ray_buffer: RayBuffer::External,
            ..on
        };
        let decls = Pe::declaration(&ext, &geo);
        let get = |n: &str| decls.iter().find(|d| d.name == n);
        let store = get("ray_store").expect("ray store declared");
        assert_eq!(store.kind, StateKind::OffChip);
        assert_eq!(store.depth, geo.rays.columns * geo.rays.rows);
        assert_eq!(
            store.width,
            crate::cost::arch::ray_bits(&ext) + crate::cost::preint::ray_bits(&ext, &geo)
        );
        let on_decls = Pe::declaration(&on, &geo);
        let on_kept = on_decls.iter().find(|d| d.name == "kept_finals");
        match order {
            Order::BackToFront => assert!(get("kept_finals").is_none() && on_kept.is_none()),
            Order::FrontToBack => {
                let kept = get("kept_finals").expect("kept finals declared");
                let on_kept = on_kept.expect("on chip too");
                assert_eq!(kept.kind, StateKind::OffChip);
                assert!(geo.rays.kept > 0);
                assert_eq!(
                    (kept.copies, kept.depth, kept.width),
                    (on_kept.copies, geo.rays.kept, on_kept.width)
                );
                assert!(get("inherited").is_none());
            }
        }
        let inv = pe_inventory(&ext, &geo);
        let off: u64 = decls
            .iter()
            .filter(|d| d.kind == StateKind::OffChip)
            .map(|d| u64::from(d.copies) * d.bits())
            .sum();
        assert!(off > 0 && inv.ray_memory_bits == off);
        assert_eq!(pe_inventory(&on, &geo).ray_memory_bits, 0);
        // None of it is an item (block RAM).
        for d in decls.iter().filter(|d| d.kind == StateKind::OffChip) {
            assert!(inv.items.iter().all(|i| i.name != d.what), "{}", d.name);
        }
    }
}

/// The declaration's depths for 16 PEs over 256^3 (`W = 16` columns,
/// `ny = 256`), worked out by hand from the documented sizes.
#[test]
fn the_default_declaration_has_the_documented_depths() {
    let geo = Geometry::new([256, 256, 256], 16);
    let decls = Pe::declaration(&PipelineConfig::default(), &geo);
    let get = |n: &str| {
        decls
            .iter()
            .find(|d| d.name == n)
            .unwrap_or_else(|| panic!("{n} is declared"))
    };
    let shape = |n: &str| {
        let d = get(n);
        (d.copies, d.depth, d.width)
    };
    // Two row banks of two slices of W columns x ny / 2 rows of 12-bit
    // voxels, and the neighbour's edge column.
    assert_eq!(shape("slice_buffer"), (2, 2 * 16 * 128, 12));
    assert_eq!(shape("edge_column"), (2, 2 * 128, 12));
    // The view's ray columns (its end PEs hold the rays beyond the
    // volume's sides, far more than a middle PE's 2W + 1 = 33) of its
    // tallest region's rows (at most 2 ny + 1), in two column banks, 4 x
    // 16-bit accumulators each; each slot maps to a 16-bit index and a
    // valid bit.
    let r = geo.rays;
    assert!(r.columns > 33 && r.rows <= 513, "{r:?}");
    assert_eq!(
        shape("compositing_buffer"),
        (2, (r.columns * r.rows).div_ceil(2), 64)
    );
    assert_eq!(shape("column_map"), (1, r.columns, 17));
    // The row plan: a bit a column map slot for each ray row.
    assert_eq!(shape("row_plan"), (1, r.rows, r.columns as u32));
    // `link_fifo_depth` rows per side (default 2): the accumulators, the
    // ray index and a 10-bit row; and exactly the configured depth.
    assert_eq!(get("link_fifo").kind, StateKind::Fifo);
    assert_eq!(shape("link_fifo"), (2, 2, 64 + 16 + 10));
    for depth in [1, 7, 4096] {
        let cfg = PipelineConfig {
            link_fifo_depth: depth,
            ..PipelineConfig::default()
        };
        let d = Pe::declaration(&cfg, &geo);
        let fifo = d.iter().find(|d| d.name == "link_fifo").expect("declared");
        assert_eq!(fifo.depth, u64::from(depth));
    }
    // The passes' line buffer: LINE_ROWS rows of a pass's children on
    // one PE, four 20-bit merge words each.
    assert_eq!(shape("line_buffer"), (3, r.children, 80));
    // The registers: two ray ports of the accumulators, a 16-bit index, a
    // row and a valid bit.
    let row_bits = crate::cost::inventory::addr_bits(r.rows + 1);
    assert_eq!(get("ray_port").kind, StateKind::Register);
    assert_eq!(shape("ray_port"), (2, 1, 64 + 16 + row_bits + 1));
    assert_eq!(
        get("line_buffer").copies as usize,
        crate::stages::passes::LINE_ROWS
    );
    // Back to front keeps no finals.
    assert!(decls.iter().all(|d| d.name != "kept_finals"));
}

/// The row plan the emitted sample stage reads
/// (`PeSampleShape::plan_bits`) is what the cost inventory charges: one
/// simple dual-port memory of a word of `slots` bits for each ray row,
/// at the declared depths, and a register of `slots` bits for the word
/// being gathered, on the default 16 PEs over 256^3 and on a small 2-PE
/// volume.
#[test]
fn the_row_plan_is_charged_as_the_sample_stage_reads_it() {
    let cfg = PipelineConfig::default();
    for geo in [
        Geometry::new([256, 256, 256], 16),
        Geometry::new([24, 24, 24], 2),
    ] {
        let shape = crate::hw::pe_sample_rtl::PeSampleShape::new(&cfg, &geo).expect("emitted");
        let inv = pe_inventory(&cfg, &geo);
        let item = inv
            .items
            .iter()
            .find(|i| i.group == "memories" && i.name.starts_with("row plan"))
            .expect("the row plan is charged");
        assert_eq!(item.count, 1);
        assert_eq!(
            item.units,
            vec![Unit::Mem {
                depth: shape.rays.max_rows,
                width: shape.slots() as u32,
                ports: MemPorts::Sdp,
            }]
        );
        assert_eq!(shape.plan_bits(), geo.rays.rows * geo.rays.columns);
        assert!(shape.plan_bits() > 0);
        // And the row's word the comparators gather, a flip-flop a slot.
        let word = inv
            .items
            .iter()
            .find(|i| i.group == "registers" && i.name.starts_with("row plan"))
            .expect("the row plan's word is charged");
        assert_eq!(
            word.units,
            vec![Unit::Reg {
                bits: shape.slots() as u32
            }]
        );
    }
}
