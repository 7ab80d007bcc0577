//! Calibration modules of the shading unit's iterative arithmetic
//! ([`crate::shading`]): the integer square root of `|g|^2` and the
//! truncating divider `|g . v| / |g|`, each pipelined one add/subtract
//! stage per result bit (non-restoring), as [`Unit::Sqrt`] and
//! [`Unit::Div`] price them.
//!
//! Non-restoring, because a stage is then one adder whose operand is
//! inverted by the sign of the previous remainder (one LUT per bit on
//! the carry chain), where a restoring stage needs the subtract and a
//! multiplexer. Both give the same result bits: the sign of the
//! non-restoring remainder is the sign of the restoring trial.

use super::{module, range, Body, CalibrationModule};
use crate::config::PipelineConfig;
use crate::cost::shading::{divider_units, norm_root, sqrt_units};
use crate::cost::shapes::Word;

/// Bits of a format.
fn bits(f: crate::fixed::Format) -> u32 {
    u32::from(f.bits())
}

/// `{k{1'b0}}, x`: `x` zero-extended by `k` bits (`x` alone for `k = 0`).
fn zext(x: &str, k: u32) -> String {
    if k == 0 {
        x.to_owned()
    } else {
        format!("{{{k}'b0, {x}}}")
    }
}

/// The gradient norm `|g| = isqrt(|g|^2)`: a `2 n`-bit radicand
/// (`n = norm_root`, the sum of squares aligned to `grad_norm`'s fraction
/// bits, as `crate::datapath::isqrt_into` aligns it) to an `n`-bit root in
/// `n` stages, output in `grad_norm`.
///
/// Stage `k` shifts two radicand bits into the remainder `R` (`n + 2`
/// bits, two's complement; the sum is exact modulo `2^(n + 2)` because
/// every true remainder fits) and adds `4 Q + 3` when `R < 0`, else
/// subtracts `4 Q + 1`, as `{Q or ~Q, 2'b11}` (`-(4 Q + 1) = ~(4 Q)`);
/// the root bit is the new remainder's sign inverted.
pub fn sqrt_norm(cfg: &PipelineConfig) -> CalibrationModule {
    let n = norm_root(cfg).max(1);
    let nb = bits(cfg.grad_norm);
    let rw = n + 2;
    let mut b = Body::new();
    let mut regs = Vec::new();
    // The previous stage's remainder, root and remaining radicand.
    let (mut r, mut q, mut x) = (None::<String>, None::<String>, "x".to_owned());
    let mut out = String::new();
    for k in 1..=n {
        let left = 2 * (n - k + 1);
        let s = format!("s_{k}");
        let low = format!("{x}[{}:{}]", left - 1, left - 2);
        match &r {
            Some(r) => b.line(&format!(
                "wire {} {s} = {{{r}[{}:0], {low}}};",
                range(rw),
                n - 1
            )),
            None => b.line(&format!("wire {} {s} = {};", range(rw), zext(&low, n))),
        }
        let qz = match &q {
            Some(q) => zext(q, n - (k - 1)),
            None => format!("{n}'b0"),
        };
        let op = match &r {
            Some(r) => format!("({r}[{}] ? {qz} : ~{qz})", rw - 1),
            None => format!("~{qz}"),
        };
        let a = format!("a_{k}");
        b.line(&format!("wire {} {a} = {s} + {{{op}, 2'b11}};", range(rw)));
        let qk = match &q {
            Some(q) => format!("{{{q}, ~{a}[{}]}}", rw - 1),
            None => format!("~{a}[{}]", rw - 1),
        };
        if k == n {
            out = if nb > n {
                format!("{{{}'b0, {qk}}}", nb - n)
            } else {
                qk
            };
            break;
        }
        let (rr, qr, xr) = (format!("r{k}"), format!("q{k}"), format!("x{k}"));
        regs.push((rr.clone(), rw, a));
        regs.push((qr.clone(), k, qk));
        regs.push((xr.clone(), left - 2, format!("{x}[{}:0]", left - 3)));
        r = Some(rr);
        q = Some(qr);
        x = xr;
    }
    let name = "ercube_sqrt_norm".to_owned();
    let verilog = module(
        &name,
        &format!(
            "gradient norm: isqrt of a {}b radicand -> {n}b root, {n} stages, into {nb}b",
            2 * n
        ),
        &[("x", Word::unsigned(2 * n, 0))],
        &regs,
        &[("y".into(), nb.max(n), out)],
        &b,
    );
    CalibrationModule {
        name,
        description: format!("isqrt {}b -> {n}b ({n} stages)", 2 * n),
        verilog,
        units: sqrt_units(cfg),
    }
}

/// Width of the divider's dividend `|g . v|`: three `gradient x light`
/// products of magnitude at most `2^(gb + lb - 2)` each.
pub fn dividend_bits(cfg: &PipelineConfig) -> u32 {
    bits(cfg.gradient) + bits(cfg.light)
}

/// The shading divider [`crate::shading::divide`]: `num` (`|g . v|`, raw at
/// `gradient.frac + light.frac` fraction bits) over `d` (`|g|`, raw
/// `grad_norm`) onto the `normal_dot` grid (`F` fraction bits), capped at
/// 1, in `F + 1` stages.
///
/// The dividend is aligned by wiring (the model's shift). Stage 0
/// subtracts `d` from the dividend's integer part `H`: a non-negative
/// result is a quotient of at least 1, which saturates to exactly 1.
/// Otherwise `H < d` and stages `1..=F` bring in the `F` fraction bits
/// one at a time, adding `d` after a negative remainder and subtracting
/// it after a non-negative one, in `nb + 1` bits (exact modulo `2^(nb +
/// 1)`: every true remainder lies in `[-d, d)`).
pub fn divider(cfg: &PipelineConfig) -> CalibrationModule {
    let nd = cfg.normal_dot;
    let f = u32::from(nd.frac());
    let ndb = bits(nd);
    let nb = bits(cfg.grad_norm);
    let w = dividend_bits(cfg);
    let fd = i32::from(cfg.gradient.frac()) + i32::from(cfg.light.frac());
    let shift = i32::from(nd.frac()) + i32::from(cfg.grad_norm.frac()) - fd;
    let ws = (w as i32 + shift).max(1) as u32;
    let mut b = Body::new();
    // The aligned dividend: `num << shift`, or its top bits.
    if shift >= 0 {
        b.line(&format!(
            "wire {} n = {};",
            range(ws),
            super::shl("num", shift)
        ));
    } else {
        b.line(&format!(
            "wire {} n = num[{}:{}];",
            range(ws),
            w - 1,
            -shift
        ));
    }
    // Stage 0: H - d, wide enough for both.
    let wh = ws.saturating_sub(f).max(1);
    let hi = if ws > f {
        format!("n[{}:{f}]", ws - 1)
    } else {
        "1'b0".to_owned()
    };
    let t = wh.max(nb) + 1;
    b.line(&format!(
        "wire {} t0 = {} - {};",
        range(t),
        zext(&hi, t - wh),
        zext("d", t - nb)
    ));
    let rw = nb + 1;
    let mut regs = vec![
        ("sat0".to_owned(), 1, format!("~t0[{}]", t - 1)),
        ("r0".to_owned(), rw, format!("t0[{}:0]", rw - 1)),
        ("d0".to_owned(), nb, "d".to_owned()),
    ];
    if f > 0 {
        regs.push(("l0".to_owned(), f, format!("n[{}:0]", f - 1)));
    }
    let mut q = None::<String>;
    for j in 1..=f {
        let (rp, dp, lp, sp) = (
            format!("r{}", j - 1),
            format!("d{}", j - 1),
            format!("l{}", j - 1),
            format!("sat{}", j - 1),
        );
        let left = f - j + 1;
        // {R, next bit, c} + {d or ~d, c}, shifted down: R 2 + bit - d
        // (c = 1, the two's-complement carry) or + d (c = 0) in one adder.
        let c = format!("~{rp}[{}]", rw - 1);
        let e = format!("e_{j}");
        b.line(&format!(
            "wire {} {e} = {{{rp}[{}:0], {lp}[{}], {c}}} + {{({rp}[{}] ? {{1'b0, {dp}}} : ~{{1'b0, {dp}}}), {c}}};",
            range(rw + 1),
            nb - 1,
            left - 1,
            rw - 1
        ));
        let a = format!("a_{j}");
        b.line(&format!("wire {} {a} = {e}[{}:1];", range(rw), rw));
        let qj = match &q {
            Some(q) => format!("{{{q}, ~{a}[{}]}}", rw - 1),
            None => format!("~{a}[{}]", rw - 1),
        };
        if j == f {
            q = Some(qj);
            break;
        }
        let (rr, dr, lr, sr, qr) = (
            format!("r{j}"),
            format!("d{j}"),
            format!("l{j}"),
            format!("sat{j}"),
            format!("q{j}"),
        );
        regs.push((rr, rw, a));
        regs.push((dr, nb, dp));
        if left > 1 {
            regs.push((lr, left - 1, format!("{lp}[{}:0]", left - 2)));
        }
        regs.push((sr, 1, sp));
        regs.push((qr.clone(), j, qj));
        q = Some(qr);
    }
    let sat = format!("sat{}", f.saturating_sub(1));
    // 1.0 when saturated, else the F quotient bits, in normal_dot.
    let one = if ndb > f + 1 {
        format!("{{{}'b0, 1'b1, {f}'b0}}", ndb - f - 1)
    } else if ndb == f + 1 {
        format!("{{1'b1, {f}'b0}}")
    } else {
        // No integer bit: 1 saturates to the largest code.
        format!("{{{ndb}{{1'b1}}}}")
    };
    let out = match q {
        Some(q) => format!("{sat} ? {one} : {}", zext(&q, ndb - f)),
        None => format!("{sat} ? {one} : {ndb}'b0"),
    };
    let name = "ercube_divider".to_owned();
    let verilog = module(
        &name,
        &format!(
            "shading divider: {w}b dividend / {nb}b divisor -> {ndb}b quotient capped at 1, {} stages",
            f + 1
        ),
        &[("num", Word::unsigned(w, 0)), ("d", Word::unsigned(nb, 0))],
        &regs,
        &[("y".into(), ndb, out)],
        &b,
    );
    CalibrationModule {
        name,
        description: format!("{w}b / {nb}b -> {ndb}b ({} stages)", f + 1),
        verilog,
        units: divider_units(cfg),
    }
}
