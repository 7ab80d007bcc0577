//! The volume-of-interest stage's pipeline steps ([`crate::voi`]), for an
//! array built with it ([`Geometry::voi`]); its units come from its
//! description ([`crate::hw::voi`]): per axis a subtract, an absolute
//! value and the axis-scale multiplier; the box's subtract and the
//! sphere's square per axis (both shapes are built: the host picks one
//! per frame); the sum of squares and the integer square root; the
//! comparators (every `e <= 0`, `|q|^2 <= r^2`, the max of `e`, the
//! weight's clamp at 0 and 1); `1 - w`; the factor's multiply-add; and the
//! multiplier scaling the classified opacity. Everything but that last
//! multiplier depends only on the sample's position, so it runs beside the
//! interpolation and classification; the multiplier sits between the
//! classification and the opacity correction.
//!
//! [`Geometry::voi`]: super::inventory::Geometry::voi

use super::inventory::Step;
use crate::config::PipelineConfig;

fn bits(f: crate::fixed::Format) -> u32 {
    u32::from(f.bits())
}

/// Bits of the square root of a sum of three `voi_dist` squares.
fn root_bits(cfg: &PipelineConfig) -> u32 {
    (2 * bits(cfg.voi_dist) + 2)
        .div_ceil(2)
        .min(bits(cfg.voi_dist))
}

/// The stage's pipeline steps: from the position (`x`) beside the
/// interpolation, and the opacity multiply after `class lerp`; the caller
/// rewires the next step to read `voi opacity`.
pub(super) fn steps(cfg: &PipelineConfig) -> Vec<Step<'static>> {
    let (pn, db, wb, fb, al) = (
        bits(cfg.position),
        bits(cfg.voi_dist),
        bits(cfg.voi_weight),
        bits(cfg.voi_factor),
        bits(cfg.alpha),
    );
    vec![
        ("voi delta", vec![("x", pn)], 1),
        ("voi q", vec![("voi delta", 3 * pn)], 1),
        ("voi e squares", vec![("voi q", 3 * db)], 1),
        ("voi sum", vec![("voi e squares", 6 * db)], 1),
        (
            "voi sqrt",
            vec![("voi sum", 2 * db + 2)],
            root_bits(cfg).max(1),
        ),
        (
            "voi compare",
            vec![("voi e squares", 3 * db), ("voi sqrt", db)],
            1,
        ),
        ("voi weight", vec![("voi compare", db)], 1),
        ("voi factor", vec![("voi weight", wb)], 1),
        (
            "voi opacity",
            vec![("class lerp", al), ("voi factor", fb)],
            1,
        ),
    ]
}
