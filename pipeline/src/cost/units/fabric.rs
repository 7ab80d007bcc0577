//! The fabric's logic units: carry-chain adders, comparators, clamps,
//! reductions, multiplexers, encoders and shifters, and delay lines, in
//! LUTs, carry cells and flip-flops per family.

use super::super::target::{Resources, Target};

pub(super) fn ceil_div(a: u64, b: u64) -> u64 {
    a.div_ceil(b)
}

/// An adder or subtractor on the carry chain.
pub(super) fn adder(t: Target, width: u32, sub: bool) -> Resources {
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

/// `a + 1` of a `width`-bit word (a rounding carry).
pub(super) fn inc(t: Target, width: u32) -> Resources {
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

/// Overflow detect and clamp of an `input`-bit word into `output` bits.
pub(super) fn sat(t: Target, input: u32, output: u32) -> Resources {
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

/// Magnitude comparison of two `width`-bit words.
pub(super) fn cmp(t: Target, width: u32) -> Resources {
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

/// OR (or AND) reduction of `width` bits.
pub(super) fn reduce(t: Target, width: u32) -> Resources {
    let w = u64::from(width);
    let per = match t {
        Target::Xc7 => 5,
        Target::Ecp5 | Target::Ice40 => 3,
    };
    Resources::luts(ceil_div(w.saturating_sub(1), per))
}

/// `inputs`-to-1 multiplexer of `width`-bit words.
pub(super) fn mux(t: Target, width: u32, inputs: u32) -> Resources {
    let (w, k) = (u64::from(width), u64::from(inputs));
    let per_bit = match t {
        Target::Xc7 => ceil_div(k.saturating_sub(1), 3),
        Target::Ecp5 | Target::Ice40 => k.saturating_sub(1),
    };
    Resources::luts(w * per_bit)
}

/// Priority encoder of a `width`-bit word: a LUT per input bit (its
/// "lowest set" term) and one per four inputs to fold the index bits, on
/// every family (yosys 0.23 on the readout's encoder at 12, 26, 38 and 64
/// bits: iCE40 13, 33, 50, 90 LUT4s; xc7 32 LUTs at 26).
pub(super) fn encode(width: u32) -> Resources {
    let w = u64::from(width);
    Resources::luts(w + ceil_div(w, 4))
}

/// Decoder of a small index into `width` bits: one LUT per output bit,
/// the index's decode shared.
pub(super) fn decode(width: u32) -> Resources {
    Resources::luts(u64::from(width))
}

/// Barrel shifter of a `width`-bit word by an `amount`-bit count.
pub(super) fn shift(t: Target, width: u32, amount: u32) -> Resources {
    let (w, s) = (u64::from(width), u64::from(amount));
    match t {
        // Two shift bits per LUT6 level (a 4:1 mux per bit).
        Target::Xc7 => Resources::luts(ceil_div(w * s, 2)),
        // One shift bit per LUT4 level, less the zero fill.
        Target::Ecp5 | Target::Ice40 => Resources::luts(ceil_div(w * s * 3, 4)),
    }
}

/// A delay line of `bits` wires over `cycles` clocks.
pub(super) fn delay(t: Target, bits: u32, cycles: u32) -> Resources {
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
