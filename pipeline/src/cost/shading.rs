//! The gradient and shading unit's hardware ([`crate::shading`]), for an
//! array built with it (`Geometry::shading`): the
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

use super::inventory::Item;
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
