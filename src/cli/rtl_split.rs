//! `ercube rtl`'s PE split module (`pipeline::hw::split_rtl`): written
//! front to back (the only order that splits), with its README section.

use std::fmt::Write as _;

use pipeline::config::PipelineConfig;
use pipeline::cost::inventory::Geometry;
use pipeline::hw::split_rtl::{emit, SplitShape, MODULE};

/// The split module for `cfg` at the depths the PE declares for `dims`, or
/// the one line saying why it is not written.
pub fn split(cfg: &PipelineConfig, dims: [usize; 3]) -> Result<(SplitShape, String), String> {
    SplitShape::new(cfg, &Geometry::new(dims, cfg.pes))
        .and_then(|shape| {
            emit(cfg, &shape)
                .map(|v| (shape, v))
                .map_err(|e| e.to_string())
        })
        .map_err(|e| format!("rtl: {MODULE} not written: {e}"))
}

/// The split module for `cfg` as `ercube rtl` writes it: its name, its
/// Verilog, what the run says of it and its README section; or the one
/// line saying why it is not written.
pub fn written(
    cfg: &PipelineConfig,
    dims: [usize; 3],
) -> Result<(&'static str, String, String, String), String> {
    let (shape, v) = split(cfg, dims)?;
    let said = summary(&shape, &v);
    Ok((MODULE, v, said, section(&shape, dims)))
}

/// What `ercube rtl` says of the written module.
pub fn summary(shape: &SplitShape, v: &str) -> String {
    format!(
        "{MODULE}.v ({} lines), {} memory bits (the line buffer) and {} register bits a PE",
        v.lines().count(),
        shape.memory_bits(),
        shape.register_bits()
    )
}

/// The README's section on the module.
pub fn section(s: &SplitShape, dims: [usize; 3]) -> String {
    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(w, "\n## {MODULE}: the PE's dense split\n");
    let _ = writeln!(
        w,
        "From `pipeline::hw::split_rtl`, for a view-space volume of {}x{}x{} (`--dims`): the \
         bilinear split's x filter (the mean of a child's two parents, accumulator words on \
         `a_*`, `b_*`, into `merge`), its line buffer as the PE declares it ({} rows x {} \
         children x {} bits, a register file read without a clock) and its y filter (the mean of \
         the one or two parent rows a child row takes, back into the accumulators, with the \
         termination comparator). {} memory bits and {} register bits a PE. `begin_split` \
         latches the PE's child count and the grids' rows; `x_valid`, `x_row`, `y_valid`, \
         `y_row`, `col` are the pass broadcast; `lx_*` and `w_*` are the registered line-buffer \
         and bank writes. Not in the module: the parents' fetch (compositing buffer and link), \
         the edge drive, the children's bank, the sparse split's work lists and the bank swap.\n",
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
