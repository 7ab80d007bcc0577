//! `ercube rtl`'s PE boundary-pass modules (`pipeline::hw::split_rtl`,
//! written front to back, the only order that splits;
//! `pipeline::hw::merge_rtl`, written back to front, the only order that
//! merges; `pipeline::hw::fold_rtl`, written front to back, the only
//! order that folds), each with its README section
//! ([`super::pass::section`]).

use pipeline::config::PipelineConfig;
use pipeline::cost::inventory::Geometry;

use super::pass::{section, CliPass};

/// Pass `K`'s module for `cfg` at the depths the PE declares for `dims`,
/// or the one line saying why it is not written.
pub fn module<K: CliPass>(
    cfg: &PipelineConfig,
    dims: [usize; 3],
) -> Result<(K::Shape, String), String> {
    K::shape(cfg, &Geometry::new(dims, cfg.pes))
        .and_then(|shape| {
            K::emit(cfg, &shape)
                .map(|v| (shape, v))
                .map_err(|e| e.to_string())
        })
        .map_err(|e| format!("rtl: {} not written: {e}", K::MODULE))
}

/// Pass `K`'s module for `cfg` as `ercube rtl` writes it: its name, its
/// Verilog, what the run says of it and its README section; or the one
/// line saying why it is not written.
pub fn written<K: CliPass>(
    cfg: &PipelineConfig,
    dims: [usize; 3],
) -> Result<(&'static str, String, String, String), String> {
    let (shape, v) = module::<K>(cfg, dims)?;
    let f = K::dims(&shape);
    let said = format!(
        "{}.v ({} lines), {} memory bits (the line buffer) and {} register bits a PE",
        K::MODULE,
        v.lines().count(),
        f.memory_bits,
        f.register_bits
    );
    Ok((K::MODULE, v, said, section::<K>(&shape, dims)))
}
