//! The volume-of-interest stage's hardware ([`crate::voi`]), for an array
//! built with it ([`Geometry::voi`]): per axis a subtract, an absolute
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

use super::inventory::{Item, Step};
use super::shapes::{Quantizer, Word};
use super::units::Unit;
use crate::config::PipelineConfig;

fn bits(f: crate::fixed::Format) -> u32 {
    u32::from(f.bits())
}

fn mul(a: u32, a_signed: bool, b: u32, b_signed: bool, post_add: Option<u32>) -> Unit {
    Unit::Mul {
        a,
        a_signed,
        b,
        b_signed,
        y: a + b,
        post_add,
        registered: true,
        operand_reg: 0,
    }
}

/// Bits of the square root of a sum of three `voi_dist` squares.
fn root_bits(cfg: &PipelineConfig) -> u32 {
    (2 * bits(cfg.voi_dist) + 2)
        .div_ceil(2)
        .min(bits(cfg.voi_dist))
}

/// The stage's datapath items.
pub(super) fn items(cfg: &PipelineConfig) -> Vec<Item> {
    let (pn, ab, db, wb, gb, fb, al) = (
        bits(cfg.position),
        bits(cfg.voi_axis),
        bits(cfg.voi_dist),
        bits(cfg.voi_weight),
        bits(cfg.voi_gain),
        bits(cfg.voi_factor),
        bits(cfg.alpha),
    );
    let frac = |f: crate::fixed::Format| i32::from(f.frac());
    let mut out = Vec::new();
    out.push(Item::new(
        "voi",
        "|p - c| per axis",
        3,
        vec![
            Unit::Sub { width: pn },
            Unit::Sub { width: pn },
            Unit::Mux {
                width: pn,
                inputs: 2,
            },
            Unit::Reg { bits: pn },
        ],
    ));
    let q = Quantizer::new(
        Word::unsigned(pn + ab, frac(cfg.position) + frac(cfg.voi_axis)),
        cfg.voi_dist,
    );
    let mut u = vec![mul(pn, false, ab, false, None)];
    u.extend(q.units());
    u.push(Unit::Reg { bits: db });
    out.push(Item::new("voi", "q = |p - c| k per axis", 3, u));
    let e = Quantizer::new(Word::signed(db + 1, frac(cfg.voi_dist)), cfg.voi_dist);
    let mut u = vec![Unit::Sub { width: db }];
    u.extend(e.units());
    u.push(mul(db, true, db, true, None));
    u.push(Unit::Reg { bits: db + 2 * db });
    out.push(Item::new("voi", "box e = q - h, square per axis", 3, u));
    out.push(Item::new(
        "voi",
        "sum of squares",
        1,
        vec![
            Unit::Add { width: 2 * db },
            Unit::Add { width: 2 * db + 1 },
            Unit::Reg { bits: 2 * db + 2 },
        ],
    ));
    out.push(Item::new(
        "voi",
        "distance: square root",
        1,
        vec![
            Unit::Sqrt {
                root: root_bits(cfg),
            },
            Unit::Reg { bits: db },
        ],
    ));
    out.push(Item::new(
        "voi",
        "comparators: e <= 0, |q|^2 <= r^2, max e",
        1,
        vec![
            Unit::Cmp { width: db },
            Unit::Cmp { width: db },
            Unit::Cmp { width: db },
            Unit::Cmp { width: 2 * db + 2 },
            Unit::Cmp { width: db },
            Unit::Cmp { width: db },
            Unit::Mux {
                width: db,
                inputs: 3,
            },
            Unit::Sub { width: db },
            Unit::Reg { bits: db },
        ],
    ));
    let w = Quantizer::new(Word::signed(db + 1, frac(cfg.voi_dist)), cfg.voi_weight);
    let mut u = vec![
        Unit::Sub { width: db },
        Unit::Cmp { width: db + 1 },
        Unit::Cmp { width: db + 1 },
    ];
    u.extend(w.units());
    u.extend([
        Unit::Mux {
            width: wb,
            inputs: 3,
        },
        Unit::Sub { width: wb },
        Unit::Mux {
            width: wb,
            inputs: 2,
        },
        Unit::Reg { bits: wb },
    ]);
    out.push(Item::new("voi", "weight clamp(1/2 - d, 0, 1), 1 - w", 1, u));
    let f = Quantizer::new(
        Word::signed(gb + wb + 1, frac(cfg.voi_gain) + frac(cfg.voi_weight)),
        cfg.voi_factor,
    );
    let mut u = vec![mul(gb, true, wb, false, Some(gb + wb + 1))];
    u.extend(f.units());
    u.push(Unit::Reg { bits: fb });
    out.push(Item::new("voi", "factor 1 + (S - 1) w", 1, u));
    let a = Quantizer::new(
        Word::unsigned(al + fb, frac(cfg.alpha) + frac(cfg.voi_factor)),
        cfg.alpha,
    );
    let mut u = vec![mul(al, false, fb, false, None)];
    u.extend(a.units());
    u.push(Unit::Reg { bits: al });
    out.push(Item::new("voi", "opacity a f", 1, u));
    out
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
