//! The cost of the architecture choices (`pipeline::cost::arch`): the
//! aprons of the round-robin mappings, the external ray buffer, and what a
//! 256^3 array needs on chip.

use pipeline::config::{Mapping, PipelineConfig, RayBuffer};
use pipeline::cost::design;
use pipeline::cost::inventory::{controller_inventory, pe_inventory, Geometry, Item};
use pipeline::cost::parts::{fit_memories, parts, Part};
use pipeline::cost::Target;

fn cfg(mapping: Mapping, width: u16, ray_buffer: RayBuffer) -> PipelineConfig {
    PipelineConfig {
        mapping,
        cyclic_width: width,
        ray_buffer,
        ..PipelineConfig::default()
    }
}

/// The one item whose name starts with `name`.
fn item<'a>(items: &'a [Item], name: &str) -> &'a Item {
    let found: Vec<&Item> = items.iter().filter(|i| i.name.starts_with(name)).collect();
    assert_eq!(found.len(), 1, "one '{name}' item");
    found[0]
}

fn mem_depth(i: &Item) -> u64 {
    match i.units.first() {
        Some(pipeline::cost::units::Unit::Mem { depth, .. }) => *depth,
        other => panic!("{} is not a memory: {other:?}", i.name),
    }
}

fn has(items: &[Item], name: &str) -> bool {
    items.iter().any(|i| i.name.starts_with(name))
}

/// A round-robin PE stores each block of `B` columns with its apron:
/// `(B + 1) / B` of the blocks' slice buffer unshaded, `(B + 3) / B`
/// shaded, in on-chip slice buffers and in its external voxel memory; it
/// drops the edge-column copies and the edge voxel port, and gains the
/// owner compares; the array gains the wrap link.
#[test]
fn round_robin_aprons() {
    let geo = Geometry::new([256, 256, 256], 16);
    let blocks = pe_inventory(&cfg(Mapping::Blocks, 4, RayBuffer::OnChip), &geo);
    let base = mem_depth(item(&blocks.items, "slice buffer"));
    assert!(has(&blocks.items, "edge column"));
    assert!(has(&blocks.items, "edge voxel port"));
    assert!(!has(&blocks.items, "ray owner"));
    for (mapping, b) in [
        (Mapping::Interleave, 1u64),
        (Mapping::Cyclic, 2),
        (Mapping::Cyclic, 4),
        (Mapping::Cyclic, 8),
    ] {
        let c = cfg(mapping, b as u16, RayBuffer::OnChip);
        let pe = pe_inventory(&c, &geo);
        // 256 columns over 16 PEs: W = 16 columns each in every mapping.
        assert_eq!(
            mem_depth(item(&pe.items, "slice buffer")) * b,
            base * (b + 1),
            "{mapping:?} width {b}: slice buffer (B + 1) / B"
        );
        assert_eq!(
            pe.voxel_memory_bits * b,
            blocks.voxel_memory_bits * (b + 1),
            "{mapping:?} width {b}: voxel memory (B + 1) / B"
        );
        assert!(
            !has(&pe.items, "edge column"),
            "{mapping:?}: no edge columns"
        );
        assert!(
            !has(&pe.items, "edge voxel port"),
            "{mapping:?}: no voxel port"
        );
        assert!(has(&pe.items, "ray owner"), "{mapping:?}: owner compares");
        assert!(has(&controller_inventory(&c, &geo), "wrap link"));
        // Shaded: one apron column left, two right.
        let shaded = geo.clone().with_units(pipeline::hw::compose::Units {
            lights: Some(1),
            ..Default::default()
        });
        let sb = pe_inventory(&cfg(Mapping::Blocks, 4, RayBuffer::OnChip), &shaded);
        let sp = pe_inventory(&c, &shaded);
        assert_eq!(
            mem_depth(item(&sp.items, "slice buffer")) * b,
            mem_depth(item(&sb.items, "slice buffer")) * (b + 3),
            "{mapping:?} width {b}: shaded slice buffer (B + 3) / B"
        );
    }
    assert!(!has(
        &controller_inventory(&cfg(Mapping::Blocks, 4, RayBuffer::OnChip), &geo),
        "wrap link"
    ));
}

/// An external ray buffer takes the compositing buffer's block RAM off
/// chip: what remains is the row buffers (the row sampling and the rows
/// read ahead), and the memory controller's interface.
#[test]
fn external_ray_buffer_removes_the_compositing_buffer() {
    let geo = Geometry::new([256, 256, 256], 16);
    let on = pe_inventory(&cfg(Mapping::Blocks, 4, RayBuffer::OnChip), &geo);
    let ext_cfg = cfg(Mapping::Blocks, 4, RayBuffer::External);
    let ext = pe_inventory(&ext_cfg, &geo);
    let comp = item(&on.items, "compositing buffer");
    let row = item(&ext.items, "row buffer");
    assert!(!has(&ext.items, "compositing buffer"));
    // The view's ray columns times rows in two banks; the row buffers
    // hold `ray_buffer_rows` (8) rows of those columns in two banks.
    let r = geo.rays;
    assert_eq!(mem_depth(comp), (r.columns * r.rows).div_ceil(2));
    assert_eq!(ext_cfg.ray_buffer_rows, 8);
    assert_eq!(mem_depth(row), (8 * r.columns).div_ceil(2));
    let t = Target::Xc7;
    let comp_bram = comp.cost(t).bram;
    assert!(
        comp_bram >= 60,
        "the compositing buffer is {comp_bram} RAMB18"
    );
    assert_eq!(
        on.cost(t).bram - ext.cost(t).bram,
        comp_bram - row.cost(t).bram,
        "only the ray buffer's block RAM changes"
    );
    let ctrl = controller_inventory(&ext_cfg, &geo);
    let mc = item(&ctrl, "DDR4 interface");
    assert!(mc.cost(t).lut >= 10_000);
}

fn part(name: &str) -> Part {
    parts(Target::Xc7)
        .into_iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("{name} is listed"))
}

/// 256^3 at 32 PEs: with every ray on chip the array fits no listed part
/// (every PE's ray memories as deep as the end PEs'); with the rays in DDR
/// it fits the XCKU15P but not the mid-range XCKU5P. At 16 PEs on chip the XCKU5P holds it only
/// by giving the compositing buffers its UltraRAM.
#[test]
fn a_256_cubed_array_fits_ultrascale_plus() {
    let t = Target::Xc7;
    let fits = |c: &PipelineConfig, p: u16, name: &str| {
        let geo = Geometry::new([256, 256, 256], p);
        let (r, _, mems) = design::array(&PipelineConfig { pes: p, ..*c }, &geo, t);
        fit_memories(&part(name), &r, &mems)
    };
    let on = cfg(Mapping::Cyclic, 4, RayBuffer::OnChip);
    let ext = cfg(Mapping::Cyclic, 4, RayBuffer::External);
    for name in ["XCKU5P", "XCZU7EV", "XC7A200T"] {
        assert!(!fits(&on, 32, name).fits, "on chip, 32 PEs, {name}");
    }
    // Every PE's ray memories as deep as the end PEs': on chip, 32 PEs
    // no longer fit the XCKU15P either.
    assert!(!fits(&on, 32, "XCKU15P").fits);
    // With the rays in DDR, 32 PEs' datapath tables (every table at its
    // emitted depth, twice where it is read twice) and line buffers
    // overflow the XCKU5P's block RAM; the XCKU15P holds them.
    let f = fits(&ext, 32, "XCKU5P");
    assert!(
        !f.fits && f.limit == "BRAM",
        "external, 32 PEs, XCKU5P: {f:?}"
    );
    let f = fits(&ext, 32, "XCKU15P");
    assert!(f.fits, "external, 32 PEs, XCKU15P: {f:?}");
    let blocks = cfg(Mapping::Blocks, 4, RayBuffer::OnChip);
    let f = fits(&blocks, 16, "XCKU5P");
    // The end PEs' depth in every PE: column blocks on chip at 16 PEs
    // fill the UltraRAM and still overflow the block RAM.
    assert!(!f.fits && f.uram > 0, "blocks on chip at 16 PEs: {f:?}");
    // The same memories without UltraRAM overflow the block RAM.
    let no_uram = Part {
        uram: 0,
        ..part("XCKU5P")
    };
    let geo = Geometry::new([256, 256, 256], 16);
    let (r, _, mems) = design::array(&blocks, &geo, t);
    assert!(!fit_memories(&no_uram, &r, &mems).fits);
    // UltraRAM never holds more than the part has.
    assert!(fits(&on, 32, "XCKU5P").uram <= 64);
}

/// The skipping options cost what they add: the valid bits (a row of a
/// bank per word, two banks of `2 ny + 1` rows) for either sparse option,
/// the work-list logic for the sparse merge, and one more pair of ray
/// port registers per extra lane; none of them changes the datapath's DSPs.
#[test]
fn sparse_options_and_lanes_are_charged() {
    let geo = Geometry::new([256, 256, 256], 16);
    let base = cfg(Mapping::Interleave, 1, RayBuffer::OnChip);
    let plain = pe_inventory(&base, &geo);
    assert!(!has(&plain.items, "ray valid bits") && !has(&plain.items, "work list"));
    assert!(!has(&plain.items, "ray port lanes"));
    let sparse = PipelineConfig {
        link_skip_empty: true,
        pass_skip_empty: true,
        migration: pipeline::config::Migration::Overlapped,
        link_lanes: 3,
        ..base
    };
    let pe = pe_inventory(&sparse, &geo);
    let valid = item(&pe.items, "ray valid bits");
    assert_eq!(mem_depth(valid), geo.rays.rows);
    assert_eq!(valid.count, 2);
    assert!(has(&pe.items, "work list"));
    let lanes = item(&pe.items, "ray port lanes");
    assert_eq!(lanes.count, 4);
    let (a, b) = (plain.cost(Target::Xc7), pe.cost(Target::Xc7));
    assert_eq!(a.dsp, b.dsp);
    assert!(b.lut > a.lut && b.ff > a.ff, "{a:?} -> {b:?}");
    // The links alone need the valid bits, not the work list.
    let links_only = pe_inventory(
        &PipelineConfig {
            link_skip_empty: true,
            ..base
        },
        &geo,
    );
    assert!(has(&links_only.items, "ray valid bits") && !has(&links_only.items, "work list"));
}
