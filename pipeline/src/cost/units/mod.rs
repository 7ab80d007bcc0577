//! Hardware units and what each costs on each family.
//!
//! Every model is structural: a ripple-carry adder is one LUT per bit on
//! the carry chain, a multiplier is the block decomposition of
//! [`super::dsp`], a memory is the mapping of [`super::memory`]. The
//! constants (LUTs per bit of a subtractor on iCE40, of a saturation
//! multiplexer, ...) are the ones yosys 0.23 produces for these shapes;
//! `pipeline/tests/it/cost.rs` re-synthesises the PE's units and checks the sums.

mod fabric;
mod mul;
mod staged;

use super::memory::{map_memory, read_reset, MemPorts};
use super::target::{Resources, Target};
use fabric::adder;
use serde::Serialize;

pub(crate) use mul::absorbed;
pub use mul::{mul_tree, MulShape};

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
    /// `a x b` multiplier with a `y`-bit product, and the adder and
    /// registers around it ([`MulShape`]).
    Mul(MulShape),
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

impl Unit {
    /// What the unit costs on `t`.
    pub fn cost(&self, t: Target) -> Resources {
        match *self {
            Unit::Add { width } => adder(t, width, false),
            Unit::Sub { width } => adder(t, width, true),
            Unit::Inc { width } => fabric::inc(t, width),
            Unit::Sat { input, output } => fabric::sat(t, input, output),
            Unit::Cmp { width } => fabric::cmp(t, width),
            Unit::Reduce { width } => fabric::reduce(t, width),
            Unit::Mux { width, inputs } => fabric::mux(t, width, inputs),
            Unit::Encode { width } => fabric::encode(width),
            Unit::Decode { width } => fabric::decode(width),
            Unit::ConstMulAdd { a, k, y } => mul::const_mul_add(t, a, k, y),
            Unit::Shift { width, amount } => fabric::shift(t, width, amount),
            Unit::Mul(ref m) => mul::multiplier(t, m),
            Unit::Sqrt { root } => staged::sqrt(t, root),
            Unit::Div { quotient, divisor } => staged::div(t, quotient, divisor),
            Unit::Reg { bits } => Resources::ffs(u64::from(bits)),
            Unit::PipeReg { bits, dsp } => Resources::ffs(u64::from(if t == Target::Xc7 {
                bits.saturating_sub(dsp)
            } else {
                bits
            })),
            Unit::Delay { bits, cycles } => fabric::delay(t, bits, cycles),
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
            Unit::Mul(MulShape {
                a,
                a_signed,
                b,
                b_signed,
                y,
                ..
            }) => {
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
        let mul = |a, b| {
            Unit::Mul(MulShape {
                a,
                a_signed: false,
                b,
                b_signed: false,
                y: a + b,
                post_add: None,
                registered: true,
                operand_reg: 0,
            })
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
