//! The pipelined iterative units: the non-restoring square root and
//! divider, one add/subtract stage per result bit.

use super::super::target::{Resources, Target};
use super::fabric::adder;
use super::Unit;

/// Pipelined integer square root with a `root`-bit result.
pub(super) fn sqrt(t: Target, root: u32) -> Resources {
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

/// Pipelined non-restoring divider: `quotient` bits by a `divisor`-bit word.
pub(super) fn div(t: Target, quotient: u32, divisor: u32) -> Resources {
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
