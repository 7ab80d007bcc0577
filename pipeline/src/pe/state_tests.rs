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
            geo.clone().with_shading(true),
        ),
        (base, geo.clone().with_shading(true)),
        (base, geo.clone().with_preint(true)),
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
        StateKind::Fifo | StateKind::Register => MemPorts::Sdp,
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
            .filter(|d| d.depth > 0 && d.kind != StateKind::Register)
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
                i.name.contains("table") || decls.iter().any(|d| d.what == i.name),
                "{} is charged but not declared",
                i.name
            );
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
    // Two slices in two row banks of W columns x ny / 2 rows of 12-bit
    // voxels, and the neighbour's edge column.
    assert_eq!(shape("slice_buffer"), (4, 16 * 128, 12));
    assert_eq!(shape("edge_column"), (4, 128, 12));
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
