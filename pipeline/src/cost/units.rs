//! Hardware units and what each costs on each family.
//!
//! Every model is structural: a ripple-carry adder is one LUT per bit on
//! the carry chain, a multiplier is the block decomposition of
//! [`super::dsp`], a memory is the mapping of [`super::memory`]. The
//! constants (LUTs per bit of a subtractor on iCE40, of a saturation
//! multiplexer, ...) are the ones yosys 0.23 produces for these shapes;
//! `pipeline/tests/it/cost.rs` re-synthesises the PE's units and checks the sums.

use super::dsp::{decompose, DspLimits, MulNode};
use super::memory::{map_memory, read_reset, MemPorts};
use super::target::{Resources, Target};
use serde::Serialize;

/// One hardware unit of a datapath.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(tag = "unit", rename_all = "snake_case")]
pub enum Unit {
    /// `a + b` of `width`-bit operands.
    Add {
        /// Operand width.
        width: u32,
    },
    /// `a - b` of `width`-bit operands.
    Sub {
        /// Operand width.
        width: u32,
    },
    /// `a + 1` (a rounding half-LSB carry) of a `width`-bit word.
    Inc {
        /// Word width.
        width: u32,
    },
    /// Overflow handling of a `input`-bit word assigned into `output` bits:
    /// detect (an OR of the excess bits and the sign) and clamp (a mux per
    /// output bit).
    Sat {
        /// Width of the word before the assignment.
        input: u32,
        /// Width of the assigned format.
        output: u32,
    },
    /// Magnitude comparison of two `width`-bit words.
    Cmp {
        /// Operand width.
        width: u32,
    },
    /// OR (or AND) reduction of `width` bits, e.g. "opacity is not zero".
    Reduce {
        /// Input bits.
        width: u32,
    },
    /// `inputs`-to-1 multiplexer of `width`-bit words.
    Mux {
        /// Word width.
        width: u32,
        /// Number of inputs.
        inputs: u32,
    },
    /// Priority encoder: the index of the lowest set bit of a `width`-bit
    /// word.
    Encode {
        /// Input bits.
        width: u32,
    },
    /// Decoder of a small index into `width` output bits, each a function
    /// of the index alone (a one-hot or thermometer code).
    Decode {
        /// Output bits.
        width: u32,
    },
    /// `a x k + c` for a constant `k`, into `y` bits: a multiplier block
    /// where the family's block takes the product (as for
    /// [`Unit::Mul`]), else one adder per further set bit of `k` (shift
    /// and add); the `+ c` is an adder either way.
    ConstMulAdd {
        /// Variable operand bits (unsigned).
        a: u32,
        /// The constant.
        k: u64,
        /// Result bits.
        y: u32,
    },
    /// Barrel shifter of a `width`-bit word by an `amount`-bit count.
    Shift {
        /// Word width.
        width: u32,
        /// Shift-count bits.
        amount: u32,
    },
    /// `a x b` multiplier with a `y`-bit product. `post_add` is the width of
    /// an adder right behind it (`c + a b`), which a DSP48E1 or SB_MAC16
    /// takes in when the product fits one block; `registered` says the
    /// product goes straight into a register, which the block can hold.
    Mul {
        /// A operand width (its true width: an unsigned operand multiplied
        /// with a signed one gets its zero sign bit from the decomposition).
        a: u32,
        /// A is two's complement.
        a_signed: bool,
        /// B operand width.
        b: u32,
        /// B is two's complement.
        b_signed: bool,
        /// Product width.
        y: u32,
        /// Width of the adder fed by the product, if any.
        post_add: Option<u32>,
        /// The product is registered directly.
        registered: bool,
        /// Bits of a pipeline register feeding an operand and nothing
        /// else: the block's input register (DSP48E1 AREG/BREG, SB_MAC16
        /// A/B hold registers) takes it when the product is one block (on
        /// iCE40 also a chain of blocks, and only a register filling the
        /// 16-bit port), otherwise it stays in the fabric.
        operand_reg: u32,
    },
    /// Pipelined integer square root with a `root`-bit result: one
    /// add/subtract stage per result bit (non-restoring).
    Sqrt {
        /// Result bits.
        root: u32,
    },
    /// Pipelined non-restoring divider with a `quotient`-bit result of a
    /// dividend by a `divisor`-bit word: one add/subtract stage per
    /// quotient bit.
    Div {
        /// Quotient bits.
        quotient: u32,
        /// Divisor bits.
        divisor: u32,
    },
    /// A register of `bits` flip-flops.
    Reg {
        /// Bits.
        bits: u32,
    },
    /// Pipeline registers of `bits` flip-flops, `dsp` of which are the
    /// operand, product and post-adder registers of multipliers that a
    /// DSP48E1 takes in (its A/B, M and P registers; yosys's
    /// `xilinx_dsp`): no flip-flops of the fabric on xc7. SB_MAC16 and
    /// MULT18X18D are not modelled as taking them.
    PipeReg {
        /// Bits.
        bits: u32,
        /// Of them, the bits the DSP48E1s take in.
        dsp: u32,
    },
    /// A delay line of `bits` wires over `cycles` clocks (on xc7, SRL32
    /// shift registers from three cycles on, as `xilinx_srl -minlen 3`).
    Delay {
        /// Bits.
        bits: u32,
        /// Cycles.
        cycles: u32,
    },
    /// A vendor IP core charged at its published size (the same on every
    /// family it is charged on), e.g. a DDR memory-controller interface.
    Ip {
        /// LUTs.
        lut: u32,
        /// Flip-flops.
        ff: u32,
        /// Block-RAM units.
        bram: u32,
    },
    /// The synchronous reset of a table's read-data registers, every read
    /// port ([`super::memory::read_reset`]).
    ReadReset {
        /// Words.
        depth: u64,
        /// Bits per word.
        width: u32,
        /// Ports.
        ports: MemPorts,
    },
    /// A memory.
    Mem {
        /// Words.
        depth: u64,
        /// Bits per word.
        width: u32,
        /// Ports.
        ports: MemPorts,
    },
}

fn ceil_div(a: u64, b: u64) -> u64 {
    a.div_ceil(b)
}

/// An adder or subtractor on the carry chain.
fn adder(t: Target, width: u32, sub: bool) -> Resources {
    let w = u64::from(width);
    match t {
        // One LUT2 per bit (the propagate) feeding CARRY4; the carry-out
        // bit needs no LUT. yosys: a 16-bit add is 16 LUT2 + 5 CARRY4.
        Target::Xc7 => Resources {
            lut: w,
            carry: ceil_div(w + 1, 4),
            ..Resources::default()
        },
        // CCU2C: two bits per cell, each cell two LUT4 positions.
        Target::Ecp5 => {
            let cells = ceil_div(w + 1, 2);
            Resources {
                lut: 2 * cells,
                carry: cells,
                ..Resources::default()
            }
        }
        // SB_LUT4 (sum) + SB_CARRY per bit; a subtractor also inverts B in
        // a LUT of its own (yosys maps $sub's BI outside the carry cell).
        Target::Ice40 => Resources {
            lut: if sub { 2 * w + 1 } else { w },
            carry: w,
            ..Resources::default()
        },
    }
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
#[allow(clippy::too_many_arguments)]
fn multiplier(
    t: Target,
    a: u32,
    a_signed: bool,
    b: u32,
    b_signed: bool,
    y: u32,
    post_add: Option<u32>,
    registered: bool,
    operand_reg: u32,
) -> Resources {
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

impl Unit {
    /// What the unit costs on `t`.
    pub fn cost(&self, t: Target) -> Resources {
        match *self {
            Unit::Add { width } => adder(t, width, false),
            Unit::Sub { width } => adder(t, width, true),
            Unit::Inc { width } => {
                let w = u64::from(width);
                match t {
                    // The carry chain's S inputs take the bits themselves:
                    // one inverter for the constant, CARRY4s for the rest.
                    Target::Xc7 => Resources {
                        lut: 1,
                        carry: ceil_div(w, 4),
                        ..Resources::default()
                    },
                    Target::Ecp5 => {
                        let cells = ceil_div(w, 2);
                        Resources {
                            lut: 2 * cells,
                            carry: cells,
                            ..Resources::default()
                        }
                    }
                    Target::Ice40 => Resources {
                        lut: w,
                        carry: w.saturating_sub(1),
                        ..Resources::default()
                    },
                }
            }
            Unit::Sat { input, output } => {
                let (i, o) = (u64::from(input), u64::from(output));
                let excess = i.saturating_sub(o);
                match t {
                    // A LUT per output bit (clamp high, clamp low, pass)
                    // and a LUT6 OR tree over the excess bits.
                    Target::Xc7 => Resources::luts(o + ceil_div(excess, 5)),
                    // LUT4s: a mux per output bit and a 3-input OR tree.
                    Target::Ice40 => Resources::luts(o + ceil_div(excess, 3)),
                    // synth_ecp5's abc9 does the same while a bit's clamp
                    // (the bit, the sign and the excess bits) fits a LUT4;
                    // past that it does not share the OR tree and builds
                    // each bit as a LUT5 (two LUT4s and a PFUMX): the
                    // compositing unit's 21 -> 16 bit clamp is 32 LUT4s.
                    Target::Ecp5 if 1 + excess > 4 => Resources::luts(2 * o),
                    Target::Ecp5 => Resources::luts(o + ceil_div(excess, 3)),
                }
            }
            Unit::Cmp { width } => {
                let w = u64::from(width);
                match t {
                    Target::Xc7 => Resources {
                        lut: ceil_div(2 * w, 3) + 1,
                        carry: ceil_div(w, 8),
                        ..Resources::default()
                    },
                    Target::Ecp5 => {
                        let cells = ceil_div(w + 1, 2);
                        Resources {
                            lut: 2 * cells + 1,
                            carry: cells,
                            ..Resources::default()
                        }
                    }
                    Target::Ice40 => Resources {
                        lut: w + 1,
                        carry: w,
                        ..Resources::default()
                    },
                }
            }
            Unit::Reduce { width } => {
                let w = u64::from(width);
                let per = match t {
                    Target::Xc7 => 5,
                    Target::Ecp5 | Target::Ice40 => 3,
                };
                Resources::luts(ceil_div(w.saturating_sub(1), per))
            }
            Unit::Mux { width, inputs } => {
                let (w, k) = (u64::from(width), u64::from(inputs));
                let per_bit = match t {
                    Target::Xc7 => ceil_div(k.saturating_sub(1), 3),
                    Target::Ecp5 | Target::Ice40 => k.saturating_sub(1),
                };
                Resources::luts(w * per_bit)
            }
            // Measured with yosys 0.23 on the readout's encoder at 12, 26,
            // 38 and 64 bits: a LUT per input bit (its "lowest set" term)
            // and one per four inputs to fold the index bits (iCE40 13,
            // 33, 50, 90 LUT4s; xc7 32 LUTs at 26).
            Unit::Encode { width } => {
                let w = u64::from(width);
                Resources::luts(w + ceil_div(w, 4))
            }
            // One LUT per output bit, the index's decode shared.
            Unit::Decode { width } => Resources::luts(u64::from(width)),
            Unit::ConstMulAdd { a, k, y } => {
                let kb = (64 - k.leading_zeros()).max(1);
                let node = decompose(&DspLimits::of(t), a, false, kb, false, y);
                if node.blocks() > 0 {
                    multiplier(t, a, false, kb, false, y, Some(y), false, 0)
                } else {
                    // popcount(k) - 1 shift-adds and the `+ c`.
                    adder(t, y, false) * u64::from(k.count_ones().max(1))
                }
            }
            Unit::Shift { width, amount } => {
                let (w, s) = (u64::from(width), u64::from(amount));
                match t {
                    // Two shift bits per LUT6 level (a 4:1 mux per bit).
                    Target::Xc7 => Resources::luts(ceil_div(w * s, 2)),
                    // One shift bit per LUT4 level, less the zero fill.
                    Target::Ecp5 | Target::Ice40 => Resources::luts(ceil_div(w * s * 3, 4)),
                }
            }
            Unit::Mul {
                a,
                a_signed,
                b,
                b_signed,
                y,
                post_add,
                registered,
                operand_reg,
            } => multiplier(
                t,
                a,
                a_signed,
                b,
                b_signed,
                y,
                post_add,
                registered,
                operand_reg,
            ),
            Unit::Sqrt { root } => {
                // As `rtl::sqrt_norm` builds it and yosys 0.23 maps it
                // (pipeline/tests/it/cost.rs, shading_units_agree_with_yosys):
                // stage k is one adder over the whole (root + 2)-bit
                // remainder plus a LUT per root bit known so far (the
                // operand's conditional inversion is not folded into the
                // carry chain's LUTs); it registers the remainder and the
                // k root bits. The radicand pair stage k consumes waits
                // k - 1 cycles in a delay line (SRLs on xc7).
                let r = u64::from(root);
                let mut res = Resources::default();
                for k in 1..=r {
                    res += adder(t, root + 2, false);
                    res += Resources::luts(k);
                    res.ff += k + if k < r { r + 2 } else { 0 };
                    if k > 1 {
                        res += Unit::Delay {
                            bits: 2,
                            cycles: (k - 1) as u32,
                        }
                        .cost(t);
                    }
                }
                res
            }
            Unit::Div { quotient, divisor } => {
                // As `rtl::divider` builds it and yosys maps it: each of the
                // `quotient` stages is a (divisor + 1)-bit adder plus a LUT
                // per bit for the conditional inversion of the divisor, and
                // registers the remainder and its own copy of the divisor.
                // The dividend bit stage i consumes, the saturation flag and
                // each quotient bit wait in delay lines (SRLs on xc7).
                let (q, d) = (u64::from(quotient), u64::from(divisor));
                let mut res = Resources::default();
                let delay = |cycles: u64| {
                    Unit::Delay {
                        bits: 1,
                        cycles: cycles as u32,
                    }
                    .cost(t)
                };
                for i in 1..=q {
                    res += adder(t, divisor + 1, false);
                    res += Resources::luts(d + 1);
                    if i < q {
                        res.ff += (d + 1) + d;
                        // The dividend bit of stage i + 1, and quotient bit i.
                        res += delay(i);
                        res += delay(q - i);
                    }
                }
                // The saturation flag of stage 0.
                res += delay(q.saturating_sub(1));
                res
            }
            Unit::Reg { bits } => Resources::ffs(u64::from(bits)),
            Unit::PipeReg { bits, dsp } => Resources::ffs(u64::from(if t == Target::Xc7 {
                bits.saturating_sub(dsp)
            } else {
                bits
            })),
            Unit::Delay { bits, cycles } => {
                let (b, c) = (u64::from(bits), u64::from(cycles));
                if t == Target::Xc7 && c >= 3 {
                    let l = b * ceil_div(c, 32);
                    Resources {
                        lut: l,
                        lutram: l,
                        ..Resources::default()
                    }
                } else {
                    Resources::ffs(b * c)
                }
            }
            Unit::Ip { lut, ff, bram } => Resources {
                lut: u64::from(lut),
                ff: u64::from(ff),
                bram: u64::from(bram),
                ..Resources::default()
            },
            Unit::ReadReset {
                depth,
                width,
                ports,
            } => read_reset(t, depth, u64::from(width), ports),
            Unit::Mem {
                depth,
                width,
                ports,
            } => map_memory(t, depth, u64::from(width), ports).res,
        }
    }

    /// A short description of the unit's shape, e.g. `16s x 26s -> 42`.
    pub fn shape(&self) -> String {
        match *self {
            Unit::Add { width } => format!("{width}b add"),
            Unit::Sub { width } => format!("{width}b sub"),
            Unit::Inc { width } => format!("{width}b round"),
            Unit::Sat { input, output } => format!("sat {input}b->{output}b"),
            Unit::Cmp { width } => format!("{width}b cmp"),
            Unit::Reduce { width } => format!("{width}b reduce"),
            Unit::Mux { width, inputs } => format!("{inputs}:1 mux {width}b"),
            Unit::Encode { width } => format!("{width}b encode"),
            Unit::Decode { width } => format!("decode {width}b"),
            Unit::ConstMulAdd { a, k, y } => format!("{a}u x {k} + c -> {y}"),
            Unit::Shift { width, amount } => format!("{width}b >> {amount}b"),
            Unit::Mul {
                a,
                a_signed,
                b,
                b_signed,
                y,
                ..
            } => {
                let s = |x: bool| if x { "s" } else { "u" };
                format!("{a}{} x {b}{} -> {y}", s(a_signed), s(b_signed))
            }
            Unit::Sqrt { root } => format!("sqrt -> {root}b"),
            Unit::Div { quotient, divisor } => format!("div / {divisor}b -> {quotient}b"),
            Unit::Reg { bits } => format!("{bits} FF"),
            Unit::PipeReg { bits, dsp } => format!("{bits} FF ({dsp} in DSP48E1)"),
            Unit::Delay { bits, cycles } => format!("{bits}b x {cycles} cycles"),
            Unit::Ip { lut, ff, bram } => format!("IP {lut} LUT, {ff} FF, {bram} BRAM"),
            Unit::ReadReset { depth, width, .. } => format!("{depth} x {width} read reset"),
            Unit::Mem {
                depth,
                width,
                ports,
            } => {
                let p = match ports {
                    MemPorts::Sdp => "1W1R",
                    MemPorts::DualRead => "RW+R",
                    MemPorts::WriteTwoReads => "1W2R",
                };
                format!("{depth} x {width} {p}")
            }
        }
    }
}

/// Sum of a list of units' costs.
pub fn total(t: Target, units: &[Unit]) -> Resources {
    units.iter().map(|u| u.cost(t)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The known figures from yosys 0.23.
    #[test]
    fn known_yosys_figures() {
        let add = Unit::Add { width: 16 }.cost(Target::Xc7);
        assert_eq!((add.lut, add.carry), (16, 5));
        let mul = |a, b| Unit::Mul {
            a,
            a_signed: false,
            b,
            b_signed: false,
            y: a + b,
            post_add: None,
            registered: true,
            operand_reg: 0,
        };
        assert_eq!(mul(8, 8).cost(Target::Xc7).dsp, 1);
        assert_eq!(mul(16, 16).cost(Target::Xc7).dsp, 1);
        assert_eq!(mul(18, 18).cost(Target::Xc7).dsp, 2);
        assert_eq!(mul(25, 25).cost(Target::Xc7).dsp, 4);
        assert_eq!(mul(32, 32).cost(Target::Xc7).dsp, 4);
        // Registered products: PREG absorbs a single block's register; a
        // two-block cascade leaves the first block's 17 low bits outside;
        // a fabric-summed 25x25 registers all 50 bits (33 LUT adder).
        assert_eq!(mul(16, 16).cost(Target::Xc7).ff, 0);
        assert_eq!(mul(18, 18).cost(Target::Xc7).ff, 17);
        let m25 = mul(25, 25).cost(Target::Xc7);
        assert_eq!((m25.lut, m25.ff), (33, 50));
        let mem = Unit::Mem {
            depth: 1024,
            width: 16,
            ports: MemPorts::Sdp,
        };
        assert_eq!(mem.cost(Target::Xc7).bram, 1);
    }
}
