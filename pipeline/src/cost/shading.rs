//! The gradient and shading unit's hardware ([`crate::shading`]), for an
//! array built with it ([`Geometry::shading`]): its datapath units and
//! pipeline steps, the wider slice buffer and edge columns it reads, and
//! its port.
//!
//! - **Gradient**: twelve central differences (three axes at the four
//!   corners), each a subtract and a multiply by the axis scale, then the
//!   scalar's two interpolation stages per component.
//! - **Shading**, built for one light (each further light adds a dot
//!   product pair, two dividers and a power-table read per sample; the
//!   golden model takes up to four): three squares, a sum and an integer
//!   square root for `|g|`; `g . L` and `g . H` as three multiply-adds
//!   each; two non-restoring dividers (one stage per quotient bit); the
//!   specular power table and its interpolation; the normal fade and the
//!   light mix; the gain `ka + kd D`, the highlight `ks r S`, and per
//!   channel `c gain + highlight` with the clamp at 1; the gradient-opacity
//!   multiply before the opacity correction.
//! - **Memories**: the slice buffer holds four slices (`z - 1`, `z`,
//!   `z + 1` and the one loading) in four row banks and two column banks
//!   (rows `y0 - 1 ..= y0 + 2` and columns `x0 - 1 ..= x0 + 2` in one
//!   cycle: two reads of each dual-read bank); the edge columns are the
//!   block's first two and last columns in the same banks.
//! - **Port**: ten voxel words to the left neighbour, two to the right,
//!   beside the scalar's two.

use super::inventory::{Item, Step};
use super::memory::MemPorts;
use super::shapes::{Lerp, Quantizer, Word};
use super::units::Unit;
use crate::config::PipelineConfig;

fn bits(f: crate::fixed::Format) -> u32 {
    u32::from(f.bits())
}

/// Bits of the integer square root of `|g|^2` before any saturation.
pub fn norm_root(cfg: &PipelineConfig) -> u32 {
    let gb = bits(cfg.gradient);
    let shift = 2 * i32::from(cfg.grad_norm.frac()) - 2 * i32::from(cfg.gradient.frac());
    let radicand = (2 * gb as i32 + 2 + shift).max(2) as u32;
    radicand.div_ceil(2).min(bits(cfg.grad_norm))
}

fn mul(a: u32, a_signed: bool, b: u32, b_signed: bool, y: u32, post_add: Option<u32>) -> Unit {
    Unit::Mul {
        a,
        a_signed,
        b,
        b_signed,
        y,
        post_add,
        registered: true,
        operand_reg: 0,
    }
}

/// The square root `|g|` with its output register (one per shading unit;
/// also the calibration module [`crate::rtl::sqrt_norm`]).
pub fn sqrt_units(cfg: &PipelineConfig) -> Vec<Unit> {
    vec![
        Unit::Sqrt {
            root: norm_root(cfg),
        },
        Unit::Reg {
            bits: bits(cfg.grad_norm),
        },
    ]
}

/// One divider `|g . v| / |g|` with its cap at 1 and output register (two
/// per light; also the calibration module [`crate::rtl::divider`]).
pub fn divider_units(cfg: &PipelineConfig) -> Vec<Unit> {
    let (nd, nb) = (bits(cfg.normal_dot), bits(cfg.grad_norm));
    vec![
        Unit::Div {
            quotient: nd,
            divisor: nb,
        },
        Unit::Cmp { width: nd },
        Unit::Mux {
            width: nd,
            inputs: 2,
        },
        Unit::Reg { bits: nd },
    ]
}

/// The unit's datapath items.
pub(super) fn items(cfg: &PipelineConfig) -> Vec<Item> {
    let (v, gb, gs, nb, lb) = (
        bits(cfg.voxel),
        bits(cfg.gradient),
        bits(cfg.grad_scale),
        bits(cfg.grad_norm),
        bits(cfg.light),
    );
    let (nd, sb, mb, rb, c, al) = (
        bits(cfg.normal_dot),
        bits(cfg.specular),
        bits(cfg.material),
        bits(cfg.grad_recip),
        bits(cfg.color),
        bits(cfg.alpha),
    );
    let mut out = Vec::new();
    let dq = Quantizer::new(
        Word::signed(v + 1 + gs, i32::from(cfg.grad_scale.frac())),
        cfg.gradient,
    );
    let mut u = vec![
        Unit::Sub { width: v },
        mul(v + 1, true, gs, false, v + 1 + gs, None),
    ];
    u.extend(dq.units());
    u.push(Unit::Reg { bits: gb });
    out.push(Item::new("gradient", "central difference x scale", 12, u));
    let g: Word = cfg.gradient.into();
    let l = Lerp::new(g, Some(g), cfg.weight.into(), cfg.gradient);
    let mut u = l.units();
    u.push(Unit::Reg { bits: gb });
    out.push(Item::new(
        "gradient",
        "x lerp (3 components, 2 rows)",
        6,
        u.clone(),
    ));
    out.push(Item::new("gradient", "y lerp (3 components)", 3, u));
    out.push(Item::new(
        "shading",
        "squares of the gradient",
        3,
        vec![mul(gb, true, gb, true, 2 * gb, None)],
    ));
    out.push(Item::new(
        "shading",
        "sum of squares",
        1,
        vec![
            Unit::Add { width: 2 * gb },
            Unit::Add { width: 2 * gb + 1 },
            Unit::Reg { bits: 2 * gb + 2 },
        ],
    ));
    out.push(Item::new("shading", "|g|: square root", 1, sqrt_units(cfg)));
    let dot = gb + lb + 2;
    out.push(Item::new(
        "shading",
        "g . L, g . H (3 multiply-adds each)",
        2,
        vec![
            mul(gb, true, lb, true, gb + lb, None),
            mul(gb, true, lb, true, gb + lb, Some(gb + lb + 1)),
            mul(gb, true, lb, true, gb + lb, Some(dot)),
            Unit::Reg { bits: dot },
        ],
    ));
    out.push(Item::new(
        "shading",
        "divider |g . v| / |g|",
        2,
        divider_units(cfg),
    ));
    out.push(Item::new(
        "shading",
        "specular power table x^p",
        1,
        vec![Unit::Mem {
            depth: (1u64 << cfg.shade_table_bits) + 1,
            width: sb,
            ports: MemPorts::DualRead,
        }],
    ));
    let s: Word = cfg.specular.into();
    let mut u = Lerp::new(s, Some(s), cfg.weight.into(), cfg.specular).units();
    u.push(Unit::Reg { bits: sb });
    out.push(Item::new("shading", "power lerp", 1, u));
    let minunit = |w: u32| {
        vec![
            Unit::Cmp { width: w },
            Unit::Mux {
                width: w,
                inputs: 2,
            },
        ]
    };
    let mut u = vec![mul(nb, false, rb, false, nb + rb, None)];
    u.extend(minunit(nb + rb));
    u.push(Unit::Reg { bits: nd });
    out.push(Item::new("shading", "normal fade min(1, |g| / F)", 1, u));
    out.push(Item::new(
        "shading",
        "light mix r D + (1 - r) n_L",
        1,
        vec![
            mul(nd, false, nd + 1, true, 2 * nd + 1, Some(2 * nd + 2)),
            Unit::Reg { bits: 2 * nd + 2 },
        ],
    ));
    out.push(Item::new(
        "shading",
        "gain ka + kd D, highlight ks r S",
        2,
        vec![
            mul(
                mb,
                false,
                2 * nd + 2,
                false,
                mb + 2 * nd + 2,
                Some(mb + 2 * nd + 3),
            ),
            Unit::Reg {
                bits: mb + 2 * nd + 3,
            },
        ],
    ));
    let gain = mb + 2 * nd + 3;
    let cq = Quantizer::new(Word::unsigned(c + gain, 0), cfg.color);
    let mut u = vec![mul(c, false, gain, false, c + gain, Some(c + gain + 1))];
    u.extend(minunit(c + gain));
    u.extend(cq.units());
    u.push(Unit::Reg { bits: c });
    out.push(Item::new("shading", "c gain + highlight, clamp at 1", 3, u));
    let mut u = vec![mul(nb, false, rb, false, nb + rb, None)];
    u.extend(minunit(nb + rb));
    u.push(mul(al, false, nd, false, al + nd, None));
    u.push(Unit::Reg { bits: al });
    out.push(Item::new(
        "shading",
        "gradient opacity a min(1, |g| / G)",
        1,
        u,
    ));
    out
}

/// The unit's pipeline steps, after the scalar's `address` and beside its
/// interpolation and classification; the steps the caller rewires read
/// `shade` (colour) and `gradient opacity` (opacity).
pub(super) fn steps(cfg: &PipelineConfig, col_bits: u32) -> Vec<Step<'static>> {
    let (v, gb, nb, lb, nd, sb, mb, c, al, wt) = (
        bits(cfg.voxel),
        bits(cfg.gradient),
        bits(cfg.grad_norm),
        bits(cfg.light),
        bits(cfg.normal_dot),
        bits(cfg.specular),
        bits(cfg.material),
        bits(cfg.color),
        bits(cfg.alpha),
        bits(cfg.weight),
    );
    vec![
        ("gradient taps", vec![("address", 2 * col_bits)], 1),
        ("differences", vec![("gradient taps", 20 * v)], 2),
        (
            "gradient x lerp",
            vec![("differences", 12 * gb), ("address", wt)],
            1,
        ),
        ("gradient y lerp", vec![("gradient x lerp", 6 * gb)], 1),
        ("gradient squares", vec![("gradient y lerp", 3 * gb)], 1),
        ("norm sum", vec![("gradient squares", 6 * gb)], 1),
        (
            "norm sqrt",
            vec![("norm sum", 2 * gb + 2)],
            norm_root(cfg).max(1),
        ),
        ("dots", vec![("gradient y lerp", 3 * gb)], 1),
        (
            "divide",
            vec![("dots", 2 * (gb + lb + 2)), ("norm sqrt", nb)],
            nd.max(1),
        ),
        ("power table", vec![("divide", nd)], 1),
        (
            "power lerp",
            vec![("power table", 2 * sb), ("divide", nd)],
            1,
        ),
        ("fade", vec![("norm sqrt", nb)], 1),
        ("light mix", vec![("divide", nd), ("fade", nd)], 1),
        ("gain", vec![("light mix", 2 * nd + 2)], 1),
        ("highlight", vec![("power lerp", sb), ("fade", nd)], 1),
        (
            "shade",
            vec![("class lerp", 3 * c), ("gain", mb), ("highlight", mb)],
            2,
        ),
        (
            "gradient opacity",
            vec![("class lerp", al), ("norm sqrt", nb)],
            2,
        ),
    ]
}

/// The shading port: the halo to the left, the last column to the right.
pub(super) fn link(cfg: &PipelineConfig) -> Item {
    Item::new(
        "links",
        "gradient halo port (10 words left, 2 right)",
        1,
        vec![Unit::Reg {
            bits: 12 * bits(cfg.voxel),
        }],
    )
}
