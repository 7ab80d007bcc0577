//! The integer square root ([`super::Op::Isqrt`]) as a pipelined
//! non-restoring unit: one add-or-subtract of a `M + 2`-bit remainder per
//! result bit, one result bit per stage, `M` the format's magnitude bits.
//! Bit for bit [`crate::datapath::isqrt_into`]: the radicand aligned to
//! twice the format's fraction bits (the bits below truncated), a
//! negative radicand read as zero, the root assigned into the format (its
//! fraction is the format's, so only the overflow acts: a radicand of
//! `2^(2M)` or more saturates; a wrapping format is refused).
//!
//! Each stage `j` (result bit `i = M - 1 - j`) shifts the next two
//! radicand bits into the remainder `R` and adds `4Q + 3` if `R` is
//! negative, else subtracts `4Q + 1` (one adder: `R + {~Q, 11}` is
//! `R - {Q, 01}`); the new bit of `Q` is `R >= 0`.
//! The remainder is never restored, and `M + 2` bits hold it (its sign and
//! its magnitude below `2Q + 2`); the shifted bits it loses are copies of
//! its sign, so the sum modulo `2^(M+2)` is exact.

use super::pipeline_rtl::Reg;
use super::Word;
use crate::fixed::{Format, Overflow};
use crate::rtl::{range, Body, RtlError};

/// Emits the root of `x` (word `wx`, read in the unit's first stage) into
/// `f`, over `stages` stages (at least the format's magnitude bits; any
/// more hold the result), wires and registers named from `v`; returns the
/// result's wire, in the last stage.
pub(crate) fn isqrt(
    b: &mut Body,
    regs: &mut Vec<Reg>,
    v: &str,
    x: &str,
    wx: Word,
    f: Format,
    stages: u32,
) -> Result<String, RtlError> {
    let m = u32::from(f.bits()) - u32::from(f.is_signed());
    if m == 0 || stages < m {
        return Err(RtlError::Unsupported(format!(
            "an integer square root of {m} bits in {stages} stages ({v})"
        )));
    }
    let sat = match f.overflow() {
        Overflow::Sat | Overflow::SatSym => format!("{{{m}{{1'b1}}}}"),
        Overflow::SatZero => format!("{m}'d0"),
        Overflow::Wrap => {
            return Err(RtlError::Unsupported(format!(
                "a wrapping integer square root ({v})"
            )))
        }
    };
    // The radicand: the magnitude bits of `x` aligned to 2 pf fraction
    // bits (`dw` bits), then 2M bits of it and whether any above are set.
    let si = u32::from(wx.signed);
    let mb = i64::from(wx.bits - si);
    let shift = 2 * i64::from(f.frac()) - i64::from(wx.frac);
    let dw = mb + shift;
    let neg = if wx.signed {
        format!("{x}[{}]", wx.bits - 1)
    } else {
        "1'b0".to_owned()
    };
    let two_m = 2 * i64::from(m);
    let d0 = format!("{v}_d0");
    let o0 = format!("{v}_o0");
    if dw <= 0 {
        // Every bit of the radicand is below the root's grid.
        b.line(&format!("wire {} {d0} = {two_m}'d0;", range(2 * m)));
        b.line(&format!("wire {o0} = 1'b0;"));
    } else {
        let d = format!("{v}_rad");
        let src = if shift > 0 {
            format!("{{{x}[{}:0], {shift}'b0}}", mb - 1)
        } else {
            format!("{x}[{}:{}]", mb - 1, -shift)
        };
        b.line(&format!("wire {} {d} = {src};", range(dw as u32)));
        let low = if dw >= two_m {
            format!("{d}[{}:0]", two_m - 1)
        } else {
            format!("{{{}'b0, {d}}}", two_m - dw)
        };
        b.line(&format!(
            "wire {} {d0} = {neg} ? {two_m}'d0 : {low};",
            range(2 * m)
        ));
        let over = if dw > two_m {
            format!("~{neg} & (|{d}[{}:{two_m}])", dw - 1)
        } else {
            "1'b0".to_owned()
        };
        b.line(&format!("wire {o0} = {over};"));
    }
    let rw = m + 2;
    let (mut r, mut q, mut d, mut o) = (format!("{v}_r0"), format!("{v}_q0"), d0, o0);
    b.line(&format!("wire {} {r} = {rw}'d0;", range(rw)));
    b.line(&format!("wire {} {q} = {m}'d0;", range(m)));
    for j in 0..m {
        let i = m - 1 - j;
        let dbits = 2 * i + 2;
        let sh = format!("{v}_sh{j}");
        let rn = format!("{v}_rn{j}");
        let qn = format!("{v}_qn{j}");
        b.line(&format!(
            "wire {} {sh} = {{{r}[{}:0], {d}[{}:{}]}};",
            range(rw),
            rw - 3,
            dbits - 1,
            dbits - 2
        ));
        // `sh - {q, 01}` is `sh + {~q, 11}` modulo 2^rw: one adder whose
        // operand is `q` or its complement by the remainder's sign (yosys
        // builds an adder, a subtractor and a multiplexer from the
        // two-armed form, about three times the LUTs).
        b.line(&format!(
            "wire {} {rn} = {sh} + {{({r}[{}] ? {q} : ~{q}), 2'b11}};",
            range(rw),
            rw - 1
        ));
        let bit = format!("~{rn}[{}]", rw - 1);
        if m == 1 {
            b.line(&format!("wire {qn} = {bit};"));
        } else {
            b.line(&format!(
                "wire {} {qn} = {{{q}[{}:0], {bit}}};",
                range(m),
                m - 2
            ));
        }
        if j + 1 == m {
            let y = format!("{v}_y");
            let pad = u32::from(f.bits()) - m;
            let root = if pad > 0 {
                format!("{{{pad}'b0, {qn}}}")
            } else {
                qn.clone()
            };
            let sat = if pad > 0 {
                format!("{{{pad}'b0, {sat}}}")
            } else {
                sat.clone()
            };
            b.line(&format!(
                "wire {} {y} = {o} ? {sat} : {root};",
                range(u32::from(f.bits()))
            ));
            let mut out = y;
            // Stages past the last result bit hold the result.
            for k in 0..stages - m {
                let h = format!("{v}_h{k}");
                regs.push(Reg::new(&h, Word::from(f), &out));
                out = h;
            }
            return Ok(out);
        }
        // The stage's registers: remainder, root so far, radicand bits
        // still to come, overflow.
        let next = |s: &str| format!("{v}_{s}{}", j + 1);
        regs.push(Reg::new(&next("r"), Word::unsigned(rw, 0), &rn));
        regs.push(Reg::new(&next("q"), Word::unsigned(m, 0), &qn));
        regs.push(Reg::new(
            &next("d"),
            Word::unsigned(dbits - 2, 0),
            &format!("{d}[{}:0]", dbits - 3),
        ));
        regs.push(Reg::new(&next("o"), Word::unsigned(1, 0), &o));
        (r, q, d, o) = (next("r"), next("q"), next("d"), next("o"));
    }
    unreachable!("the loop returns at its last bit")
}
