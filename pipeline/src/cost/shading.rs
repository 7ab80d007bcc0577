//! The gradient and shading unit's hardware ([`crate::shading`]), for an
//! array built with it (`Geometry::shading`): its pipeline steps, the
//! wider slice buffer and edge columns it reads, and its port. Its
//! datapath units come from its description ([`crate::hw::shading`],
//! built for one light) and its power table from the description's
//! memory (`table_item`); what they are:
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

/// The specular power table of the unit's description `g`: two reads
/// per light of a dual-read memory (its datapath items come from the
/// description, [`crate::hw::shading`]).
pub(super) fn table_item(g: &crate::hw::Graph) -> Vec<Item> {
    g.mems
        .iter()
        .filter(|m| m.name == crate::hw::shading::POWER_TABLE)
        .map(|m| {
            Item::new(
                "shading",
                "specular power table x^p",
                1,
                vec![Unit::Mem {
                    depth: m.depth,
                    width: bits(m.fmt),
                    ports: MemPorts::DualRead,
                }],
            )
        })
        .collect()
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
