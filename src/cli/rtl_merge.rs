//! `ercube rtl`'s PE merge module (`pipeline::hw::merge_rtl`): written
//! back to front (the only order that merges), with its README section.

use std::fmt::Write as _;

use pipeline::config::PipelineConfig;
use pipeline::cost::inventory::Geometry;
use pipeline::hw::merge_rtl::{emit, MergeShape, MODULE};

/// The merge module for `cfg` at the depths the PE declares for `dims`, or
/// the one line saying why it is not written.
pub fn merge(cfg: &PipelineConfig, dims: [usize; 3]) -> Result<(MergeShape, String), String> {
    MergeShape::new(cfg, &Geometry::new(dims, cfg.pes))
        .and_then(|shape| {
            emit(cfg, &shape)
                .map(|v| (shape, v))
                .map_err(|e| e.to_string())
        })
        .map_err(|e| format!("rtl: {MODULE} not written: {e}"))
}

/// The merge module for `cfg` as `ercube rtl` writes it: its name, its
/// Verilog, what the run says of it and its README section; or the one
/// line saying why it is not written.
pub fn written(
    cfg: &PipelineConfig,
    dims: [usize; 3],
) -> Result<(&'static str, String, String, String), String> {
    let (shape, v) = merge(cfg, dims)?;
    let said = summary(&shape, &v);
    Ok((MODULE, v, said, section(&shape, dims)))
}

/// What `ercube rtl` says of the written module.
pub fn summary(shape: &MergeShape, v: &str) -> String {
    format!(
        "{MODULE}.v ({} lines), {} memory bits (the line buffer) and {} register bits a PE",
        v.lines().count(),
        shape.memory_bits(),
        shape.register_bits()
    )
}

/// The README's section on the module.
pub fn section(s: &MergeShape, dims: [usize; 3]) -> String {
    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(w, "\n## {MODULE}: the PE's dense merge\n");
    let _ = writeln!(
        w,
        "From `pipeline::hw::merge_rtl`, for a view-space volume of {}x{}x{} (`--dims`): the \
         Bartlett merge's x tent (parents 2m - 1, 2m, 2m + 1 of child m, each a held column's \
         accumulator word on `h0_*` .. `h2_*`, the left or right neighbour's edge ray on \
         `el_*`, `er_*`, or zero, into `merge`), its line buffer as the PE declares it ({} rows \
         x {} children x {} bits, a register file read without a clock) and its y tent (parent \
         rows 2 my - 1 ..= 2 my + 1 of child row my, back into the accumulators). {} memory \
         bits and {} register bits a PE. `begin_merge` latches the PE's child count, first \
         child and held span and the grids' rows; `x_valid`, `x_row`, `y_valid`, `y_row`, \
         `col` are the pass broadcast; `lx_*` and `w_*` are the registered line-buffer and bank \
         writes. Not in the module: the held parents' fetch (the compositing buffer's read), \
         the edge drive, the children's bank, the sparse merge's work lists and the bank swap.\n",
        dims[0],
        dims[1],
        dims[2],
        s.rows,
        s.width,
        4 * u32::from(s.merge.bits()),
        s.memory_bits(),
        s.register_bits()
    );
    t
}
