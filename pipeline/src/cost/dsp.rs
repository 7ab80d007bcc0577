//! How a multiplier of given operand widths maps onto multiplier blocks.
//!
//! The decomposition is the one yosys applies (`techmap -map +/mul2dsp.v`
//! with each family's block limits, as `synth_xilinx`, `synth_ecp5` and
//! `synth_ice40 -dsp` invoke it), rewritten as a function so the estimator
//! predicts the same block count: an operand wider than the block is cut
//! into slices, each slice product is mapped again, and the partial
//! products are summed with shifted adders. Slices narrower than the
//! block's minimum widths become soft (LUT) multipliers. Vivado and
//! Radiant decompose the same way (a 25x18 signed block needs two blocks
//! for an 18x18 unsigned product); the synthesis test in
//! `pipeline/tests/it/cost.rs` checks the counts against yosys.

use super::target::Target;
use serde::Serialize;

/// The limits of one family's multiplier block, as passed to `mul2dsp.v`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DspLimits {
    /// Widest A operand (`DSP_A_MAXWIDTH`).
    pub a_max: u32,
    /// Widest B operand (`DSP_B_MAXWIDTH`).
    pub b_max: u32,
    /// Width of the A slices when A is cut (`DSP_A_MAXWIDTH_PARTIAL`).
    pub a_partial: u32,
    /// Width of the B slices when B is cut.
    pub b_partial: u32,
    /// Narrowest operands and product that still use a block
    /// (`DSP_A_MINWIDTH`, `DSP_B_MINWIDTH`, `DSP_Y_MINWIDTH`; 0: none).
    pub a_min: u32,
    /// See `a_min`.
    pub b_min: u32,
    /// See `a_min`.
    pub y_min: u32,
    /// The block multiplies signed operands only (`DSP_SIGNEDONLY`):
    /// unsigned operands get a zero sign bit, and every slice keeps one bit
    /// of sign headroom.
    pub signed_only: bool,
}

impl DspLimits {
    /// The limits yosys 0.23 uses for `target`.
    pub fn of(target: Target) -> DspLimits {
        match target {
            // synth_xilinx -family xc7: $__MUL25X18, A slices of 18 bits.
            Target::Xc7 => DspLimits {
                a_max: 25,
                b_max: 18,
                a_partial: 18,
                b_partial: 18,
                a_min: 2,
                b_min: 2,
                y_min: 9,
                signed_only: true,
            },
            // synth_ecp5: $__MUL18X18, no product minimum.
            Target::Ecp5 => DspLimits {
                a_max: 18,
                b_max: 18,
                a_partial: 18,
                b_partial: 18,
                a_min: 2,
                b_min: 2,
                y_min: 0,
                signed_only: false,
            },
            // synth_ice40 -dsp: $__MUL16X16, products narrower than 11
            // bits stay in LUTs.
            Target::Ice40 => DspLimits {
                a_max: 16,
                b_max: 16,
                a_partial: 16,
                b_partial: 16,
                a_min: 2,
                b_min: 2,
                y_min: 11,
                signed_only: false,
            },
        }
    }
}

/// One node of a multiplier's decomposition.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum MulNode {
    /// One multiplier block.
    Block {
        /// A operand width.
        a: u32,
        /// B operand width.
        b: u32,
    },
    /// A multiplier too narrow for a block, built from LUTs.
    Soft {
        /// A operand width.
        a: u32,
        /// B operand width.
        b: u32,
    },
    /// A slice holding only the constant-zero sign bit of a zero-extended
    /// unsigned operand: its product is zero and synthesis removes it.
    Zero,
    /// An operand cut into slices: `parts[i]` is shifted left by
    /// `i * shift` and the parts are summed in a chain of adders.
    Split {
        /// Slice products, least significant first.
        parts: Vec<MulNode>,
        /// Bits between slices.
        shift: u32,
        /// Width of the summed product.
        y: u32,
    },
}

impl MulNode {
    /// Multiplier blocks used.
    pub fn blocks(&self) -> u64 {
        match self {
            MulNode::Block { .. } => 1,
            MulNode::Soft { .. } | MulNode::Zero => 0,
            MulNode::Split { parts, .. } => parts.iter().map(MulNode::blocks).sum(),
        }
    }

    /// The parts of a split that are not constant zero.
    pub fn live_parts(&self) -> Vec<&MulNode> {
        match self {
            MulNode::Split { parts, .. } => parts.iter().filter(|p| **p != MulNode::Zero).collect(),
            _ => Vec::new(),
        }
    }

    /// Whether this is one block: a block, or a split whose only live
    /// part is one block (the other slices were constant zero).
    pub fn is_single_block(&self) -> bool {
        match self {
            MulNode::Block { .. } => true,
            MulNode::Split { .. } => {
                let live = self.live_parts();
                live.len() == 1 && live[0].is_single_block()
            }
            _ => false,
        }
    }

    /// Whether every live part of a split is a single block, so the
    /// partial products can be summed inside the blocks (the DSP48E1
    /// cascade's 17-bit shifted `PCIN`, the SB_MAC16 accumulator adder).
    pub fn is_block_chain(&self) -> bool {
        let live = self.live_parts();
        !live.is_empty() && live.iter().all(|p| p.is_single_block())
    }

    /// Whether every live part of a split is a block itself, not a split
    /// whose other slices were constant zero. yosys's `ice40_dsp` sums the
    /// partial products in the SB_MAC16s only then: when both operands were
    /// cut (a signed operand wider than 16 bits times an unsigned 16-bit
    /// one, whose zero sign bit is a slice of its own), the partial sum and
    /// the product's register stay in the fabric.
    pub fn is_flat_block_chain(&self) -> bool {
        let live = self.live_parts();
        !live.is_empty() && live.iter().all(|p| matches!(p, MulNode::Block { .. }))
    }

    /// Whether a split's most significant slice was constant zero.
    pub fn top_is_zero(&self) -> bool {
        matches!(self, MulNode::Split { parts, .. } if parts.last() == Some(&MulNode::Zero))
    }
}

/// A multiplier operand as the Verilog presents it to synthesis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Operand {
    bits: u32,
    signed: bool,
    /// The top bit is a constant zero (an unsigned value zero-extended to
    /// be multiplied as signed).
    zero_top: bool,
}

/// Decomposes an `a x b` multiplier with a `y`-bit product, the operands
/// being `a_signed` / `b_signed` two's complement values of their true
/// widths. As Verilog multiplies signed only when both operands are, an
/// unsigned operand beside a signed one is zero-extended by a bit (what
/// `crate::rtl` emits); two unsigned operands stay unsigned.
pub fn decompose(
    lim: &DspLimits,
    a: u32,
    a_signed: bool,
    b: u32,
    b_signed: bool,
    y: u32,
) -> MulNode {
    let ext = |bits: u32, signed: bool| {
        if a_signed == b_signed || signed {
            Operand {
                bits,
                signed,
                zero_top: false,
            }
        } else {
            Operand {
                bits: bits + 1,
                signed: true,
                zero_top: true,
            }
        }
    };
    node(lim, ext(a, a_signed), ext(b, b_signed), y, true)
}

/// `mul2dsp.v`'s `_80_mul`, one level. `top` is true for the original
/// `$mul` cell (only it is widened for signed-only blocks and has its
/// operands swapped so A is the wider); slices are `$__mul` cells.
fn node(lim: &DspLimits, a: Operand, b: Operand, y: u32, top: bool) -> MulNode {
    if (a.zero_top && a.bits == 1) || (b.zero_top && b.bits == 1) {
        return MulNode::Zero;
    }
    if a.bits < lim.a_min || b.bits < lim.b_min || y < lim.y_min {
        return MulNode::Soft {
            a: a.bits,
            b: b.bits,
        };
    }
    if lim.signed_only && top && !a.signed && !b.signed {
        let widen = |o: Operand| Operand {
            bits: o.bits + 1,
            signed: true,
            zero_top: true,
        };
        return node(lim, widen(a), widen(b), y, true);
    }
    if top && a.bits < b.bits {
        return node(lim, b, a, y, true);
    }
    let headroom = u32::from(lim.signed_only);
    if a.bits > lim.a_max {
        let step = lim.a_partial - headroom;
        let n = (a.bits - lim.a_max).div_ceil(step);
        let partial_y = y.min(b.bits + lim.a_partial);
        let last = a.bits - n * step;
        let slice = Operand {
            bits: lim.a_partial,
            signed: headroom == 1,
            zero_top: headroom == 1,
        };
        let mut parts: Vec<MulNode> = (0..n)
            .map(|_| node(lim, slice, b, partial_y, false))
            .collect();
        let last_op = Operand { bits: last, ..a };
        parts.push(node(lim, last_op, b, b.bits + last, false));
        return MulNode::Split {
            parts,
            shift: step,
            y,
        };
    }
    if b.bits > lim.b_max {
        let step = lim.b_partial - headroom;
        let n = (b.bits - lim.b_max).div_ceil(step);
        let partial_y = y.min(a.bits + lim.b_partial);
        let last = b.bits - n * step;
        let slice = Operand {
            bits: lim.b_partial,
            signed: headroom == 1,
            zero_top: headroom == 1,
        };
        let mut parts: Vec<MulNode> = (0..n)
            .map(|_| node(lim, a, slice, partial_y, false))
            .collect();
        let last_op = Operand { bits: last, ..b };
        parts.push(node(lim, a, last_op, a.bits + last, false));
        return MulNode::Split {
            parts,
            shift: step,
            y,
        };
    }
    MulNode::Block {
        a: a.bits,
        b: b.bits,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blocks(t: Target, a: u32, b: u32, signed: bool) -> u64 {
        decompose(&DspLimits::of(t), a, signed, b, signed, a + b).blocks()
    }

    /// The counts yosys 0.23 reports for unsigned squares on xc7 (the
    /// issue's known figures) and a few mixed shapes.
    #[test]
    fn xc7_block_counts() {
        assert_eq!(blocks(Target::Xc7, 8, 8, false), 1);
        assert_eq!(blocks(Target::Xc7, 16, 16, false), 1);
        assert_eq!(blocks(Target::Xc7, 18, 18, false), 2);
        assert_eq!(blocks(Target::Xc7, 25, 25, false), 4);
        assert_eq!(blocks(Target::Xc7, 32, 32, false), 4);
        assert_eq!(blocks(Target::Xc7, 28, 28, true), 4);
        assert_eq!(blocks(Target::Xc7, 24, 17, false), 1);
        // 4x4 has an 8-bit product, under DSP_Y_MINWIDTH = 9.
        assert_eq!(blocks(Target::Xc7, 4, 4, false), 0);
    }

    #[test]
    fn ice40_and_ecp5_block_counts() {
        assert_eq!(blocks(Target::Ice40, 16, 16, false), 1);
        assert_eq!(blocks(Target::Ice40, 18, 18, false), 3);
        assert_eq!(blocks(Target::Ice40, 24, 17, false), 2);
        assert_eq!(blocks(Target::Ice40, 32, 32, false), 4);
        assert_eq!(blocks(Target::Ecp5, 18, 18, false), 1);
        assert_eq!(blocks(Target::Ecp5, 20, 20, false), 4);
        assert_eq!(blocks(Target::Ecp5, 24, 17, false), 2);
    }

    /// A 16-bit signed ray index times an unsigned step: the zero sign bit
    /// of the step is a slice of its own on iCE40 when the step is 16 or
    /// 32 bits, and synthesis drops it.
    #[test]
    fn zero_sign_slices_vanish() {
        let lim = DspLimits::of(Target::Ice40);
        let d = decompose(&lim, 16, true, 16, false, 32);
        assert_eq!(d.blocks(), 1);
        assert!(d.top_is_zero());
        assert_eq!(decompose(&lim, 16, true, 32, false, 48).blocks(), 2);
        assert_eq!(decompose(&lim, 16, true, 25, false, 41).blocks(), 2);
        let x = DspLimits::of(Target::Xc7);
        assert_eq!(decompose(&x, 16, true, 25, false, 41).blocks(), 2);
        assert_eq!(decompose(&x, 16, true, 16, false, 32).blocks(), 1);
    }
}
