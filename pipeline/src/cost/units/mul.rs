//! Multipliers: the block decomposition of [`super::super::dsp`], the
//! fabric around it (soft slices, partial-product adders, post-adders) and
//! the registers the blocks take in.

use super::super::dsp::{decompose, DspLimits, MulNode};
use super::super::target::{Resources, Target};
use super::fabric::{adder, ceil_div};
use serde::Serialize;

/// A multiplier's shape: `a x b` with a `y`-bit product. `post_add` is
/// the width of an adder right behind it (`c + a b`), which a DSP48E1 or
/// SB_MAC16 takes in when the product fits one block; `registered` says
/// the product goes straight into a register, which the block can hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct MulShape {
    /// A operand width (its true width: an unsigned operand multiplied
    /// with a signed one gets its zero sign bit from the decomposition).
    pub a: u32,
    /// A is two's complement.
    pub a_signed: bool,
    /// B operand width.
    pub b: u32,
    /// B is two's complement.
    pub b_signed: bool,
    /// Product width.
    pub y: u32,
    /// Width of the adder fed by the product, if any.
    pub post_add: Option<u32>,
    /// The product is registered directly.
    pub registered: bool,
    /// Bits of a pipeline register feeding an operand and nothing
    /// else: the block's input register (DSP48E1 AREG/BREG, SB_MAC16
    /// A/B hold registers) takes it when the product is one block (on
    /// iCE40 also a chain of blocks, and only a register filling the
    /// 16-bit port), otherwise it stays in the fabric.
    pub operand_reg: u32,
}

/// A soft (LUT) multiplier.
fn soft_mul(t: Target, a: u32, b: u32) -> Resources {
    let (a, b) = (u64::from(a), u64::from(b));
    if a == 1 || b == 1 {
        // A one-bit operand is a row of AND gates.
        return Resources::luts(a.max(b));
    }
    let pp = a * b;
    match t {
        // Array multiplier: a 4x4 is 22 LUTs + 2 CARRY4 in yosys.
        Target::Xc7 => Resources::luts(ceil_div(pp * 14, 10)),
        // A 4x4 is 26 LUT4s.
        Target::Ecp5 | Target::Ice40 => Resources::luts(ceil_div(pp * 16, 10)),
    }
}

/// Whether the partial products of `node` are summed inside the blocks.
pub(crate) fn absorbed(t: Target, node: &MulNode) -> bool {
    match t {
        Target::Xc7 => node.is_block_chain(),
        Target::Ice40 => node.is_flat_block_chain(),
        Target::Ecp5 => false,
    }
}

/// LUTs of a decomposition outside the blocks: soft slices and the
/// partial-product adders the blocks do not take in.
fn mul_fabric(t: Target, node: &MulNode) -> Resources {
    match node {
        MulNode::Block { .. } | MulNode::Zero => Resources::default(),
        MulNode::Soft { a, b } => soft_mul(t, *a, *b),
        MulNode::Split { parts, shift, y } => {
            let mut r: Resources = parts.iter().map(|p| mul_fabric(t, p)).sum();
            if !absorbed(t, node) {
                for (i, p) in parts.iter().enumerate().skip(1) {
                    if *p == MulNode::Zero {
                        continue;
                    }
                    // The low i * shift bits pass straight through.
                    let w = y.saturating_sub(i as u32 * shift);
                    if w > 0 {
                        r += adder(t, w, false);
                    }
                }
            }
            r
        }
    }
}

/// Flip-flops left in the fabric when the `y`-bit product of `node` is
/// registered directly.
fn mul_register(t: Target, node: &MulNode, y: u32) -> u64 {
    let y64 = u64::from(y);
    match (t, node) {
        // PREG holds a single block's product.
        (Target::Xc7 | Target::Ice40, n) if !n.top_is_zero() && n.is_single_block() => 0,
        // DSP48E1 cascade: the last block's PREG holds the top bits; the
        // low `shift` bits of each earlier block leave through the fabric.
        (Target::Xc7, MulNode::Split { shift, .. }) if node.is_block_chain() => {
            (u64::from(*shift) * (node.live_parts().len() as u64 - 1)).min(y64)
        }
        // SB_MAC16 packs its 32-bit output register only when the register
        // takes exactly its O port; when the top slice was a dropped zero
        // the product is sign-extended past the block and only the lower
        // 16 bits pack, leaving the block's upper product bits outside.
        (Target::Ice40, MulNode::Split { parts, shift, .. }) => {
            if node.top_is_zero() {
                match node.live_parts().last() {
                    Some(MulNode::Block { a, b }) => u64::from(a + b).saturating_sub(16),
                    _ => y64,
                }
            } else if node.is_flat_block_chain() {
                0
            } else if parts[0].is_single_block() || parts[0].is_block_chain() {
                y64.saturating_sub(u64::from(*shift))
            } else {
                y64
            }
        }
        _ => y64,
    }
}

/// A multiplier's resources.
pub(super) fn multiplier(t: Target, m: &MulShape) -> Resources {
    let MulShape {
        a,
        a_signed,
        b,
        b_signed,
        y,
        post_add,
        registered,
        operand_reg,
    } = *m;
    let node = decompose(&DspLimits::of(t), a, a_signed, b, b_signed, y);
    let single = node.is_single_block();
    let takes_input_reg = match t {
        Target::Xc7 => single,
        // ice40_dsp packs a hold register only when it drives the whole
        // 16-bit A or B port (yosys leaves a narrower one in the fabric).
        Target::Ice40 => (single || node.is_block_chain()) && operand_reg >= 16,
        Target::Ecp5 => false,
    };
    let mut r = Resources {
        dsp: node.blocks(),
        ..Resources::default()
    };
    r += mul_fabric(t, &node);
    if let Some(w) = post_add {
        // The DSP48E1's C port and the SB_MAC16's accumulator adder take
        // one adder behind a single-block product; MULT18X18D has none.
        let in_block = t != Target::Ecp5 && single;
        if !in_block {
            r += adder(t, w, false);
        }
    }
    if registered {
        r.ff += mul_register(t, &node, y);
    }
    if !takes_input_reg {
        r.ff += u64::from(operand_reg);
    }
    r
}

/// The decomposition of a multiplier on `t`, for reports.
pub fn mul_tree(t: Target, a: u32, a_signed: bool, b: u32, b_signed: bool, y: u32) -> MulNode {
    decompose(&DspLimits::of(t), a, a_signed, b, b_signed, y)
}

/// `a x k + c` for a constant `k` (see [`super::Unit::ConstMulAdd`]).
pub(super) fn const_mul_add(t: Target, a: u32, k: u64, y: u32) -> Resources {
    let kb = (64 - k.leading_zeros()).max(1);
    let node = decompose(&DspLimits::of(t), a, false, kb, false, y);
    if node.blocks() > 0 {
        let shape = MulShape {
            a,
            a_signed: false,
            b: kb,
            b_signed: false,
            y,
            post_add: Some(y),
            registered: false,
            operand_reg: 0,
        };
        multiplier(t, &shape)
    } else {
        // popcount(k) - 1 shift-adds and the `+ c`.
        adder(t, y, false) * u64::from(k.count_ones().max(1))
    }
}
