//! The divider ([`super::Op::Div`]) as a pipelined restoring unit, bit for
//! bit the evaluator's: the numerator aligned to the quotient's grid (the
//! bits below it truncated), a first stage that compares the numerator's
//! bits above the quotient's width with the divisor (at or above it, or a
//! zero divisor, the quotient saturates to all ones), then one
//! compare-and-subtract of a `D + 1`-bit partial remainder per quotient
//! bit, most significant first, one bit per stage (`D` the divisor's
//! bits). The remainder stays below the divisor, so `D` bits hold it
//! between stages.

use super::pipeline_rtl::Reg;
use super::Word;
use crate::rtl::{range, Body, RtlError};

/// Emits `num / den` (words `wn`, `wd`, read in the unit's first stage)
/// onto `out`'s grid over `stages` stages (at least one per quotient bit
/// and the first; any more hold the result), wires and registers named
/// from `v`; returns the quotient's wire, in the last stage.
#[allow(clippy::too_many_arguments)]
pub(crate) fn div(
    b: &mut Body,
    regs: &mut Vec<Reg>,
    v: &str,
    (num, wn): (&str, Word),
    (den, wd): (&str, Word),
    out: Word,
    stages: u32,
) -> Result<String, RtlError> {
    let qb = out.bits;
    if wn.signed || wd.signed || out.signed || stages < qb + 1 {
        return Err(RtlError::Unsupported(format!(
            "a divider of {qb} bits in {stages} stages, signed operands or a signed quotient ({v})"
        )));
    }
    let db = wd.bits;
    // The numerator on the quotient's grid: `aw` bits.
    let s = out.frac + wd.frac - wn.frac;
    let a = format!("{v}_al");
    let aw = wn.bits as i32 + s;
    if aw <= 0 {
        b.line(&format!("wire {a} = 1'b0;"));
    } else if s >= 0 {
        let src = if s > 0 {
            format!("{{{num}, {s}'b0}}")
        } else {
            num.to_owned()
        };
        b.line(&format!("wire {} {a} = {src};", range(aw as u32)));
    } else {
        b.line(&format!(
            "wire {} {a} = {num}[{}:{}];",
            range(aw as u32),
            wn.bits - 1,
            -s
        ));
    }
    let aw = aw.max(1) as u32;
    // Saturation: the bits above the quotient's at or above the divisor.
    let sat = format!("{v}_sat0");
    let r0 = format!("{v}_r0");
    if aw > qb {
        let hi = format!("{v}_hi");
        b.line(&format!(
            "wire {} {hi} = {a}[{}:{qb}];",
            range(aw - qb),
            aw - 1
        ));
        b.line(&format!("wire {sat} = {hi} >= {den};"));
        let r = if aw - qb >= db {
            format!("{hi}[{}:0]", db - 1)
        } else {
            format!("{{{}'b0, {hi}}}", db - (aw - qb))
        };
        b.line(&format!("wire {} {r0} = {r};", range(db)));
    } else {
        b.line(&format!("wire {sat} = {den} == {db}'d0;"));
        b.line(&format!("wire {} {r0} = {db}'d0;", range(db)));
    }
    let lo = format!("{v}_l0");
    let l = if aw >= qb {
        format!("{a}[{}:0]", qb - 1)
    } else {
        format!("{{{}'b0, {a}}}", qb - aw)
    };
    b.line(&format!("wire {} {lo} = {l};", range(qb)));
    let next = |s: &str, j: u32| format!("{v}_{s}{j}");
    // The first stage's registers.
    regs.push(Reg::new(&next("r", 1), Word::unsigned(db, 0), &r0));
    regs.push(Reg::new(&next("l", 1), Word::unsigned(qb, 0), &lo));
    regs.push(Reg::new(&next("d", 1), Word::unsigned(db, 0), den));
    regs.push(Reg::new(&next("sat", 1), Word::unsigned(1, 0), &sat));
    b.line(&format!("wire {} {} = {qb}'d0;", range(qb), next("q", 1)));
    for j in 1..=qb {
        let k = qb - j;
        let (r, l, d, st, q) = (
            next("r", j),
            next("l", j),
            next("d", j),
            next("sat", j),
            next("q", j),
        );
        let (sh, ge, rn, qn) = (next("sh", j), next("ge", j), next("rn", j), next("qn", j));
        b.line(&format!("wire {} {sh} = {{{r}, {l}[{k}]}};", range(db + 1)));
        b.line(&format!("wire {ge} = {sh} >= {{1'b0, {d}}};"));
        b.line(&format!(
            "wire {} {rn} = {ge} ? {sh} - {{1'b0, {d}}} : {sh};",
            range(db + 1)
        ));
        if qb == 1 {
            b.line(&format!("wire {qn} = {ge};"));
        } else {
            b.line(&format!(
                "wire {} {qn} = {{{q}[{}:0], {ge}}};",
                range(qb),
                qb - 2
            ));
        }
        if j == qb {
            let y = format!("{v}_y");
            b.line(&format!(
                "wire {} {y} = {st} ? {{{qb}{{1'b1}}}} : {qn};",
                range(qb)
            ));
            let mut o = y;
            for h in 0..stages - qb - 1 {
                let name = format!("{v}_h{h}");
                regs.push(Reg::new(&name, out, &o));
                o = name;
            }
            return Ok(o);
        }
        regs.push(Reg::new(
            &next("r", j + 1),
            Word::unsigned(db, 0),
            &format!("{rn}[{}:0]", db - 1),
        ));
        regs.push(Reg::new(&next("l", j + 1), Word::unsigned(qb, 0), &l));
        regs.push(Reg::new(&next("d", j + 1), Word::unsigned(db, 0), &d));
        regs.push(Reg::new(&next("sat", j + 1), Word::unsigned(1, 0), &st));
        regs.push(Reg::new(&next("q", j + 1), Word::unsigned(qb, 0), &qn));
    }
    unreachable!("the loop returns at its last bit")
}
