//! The datapath's shared operators: the exact linear interpolation every
//! interpolating unit uses (in 64-bit words when the widths prove it
//! fits) and the exact integer square root of the path length and the
//! gradient norm, each assigned into a declared [`Format`].

use crate::config::Reg;
use crate::fixed::{Fx, FxError, QuantStats, Wide};

/// `a + w (b - a)`, exactly, assigned into register `out`.
#[inline(always)]
pub fn lerp(a: Fx, b: Fx, w: Fx, out: Reg, st: &mut QuantStats) -> Result<Fx, FxError> {
    if let Some(v) = lerp64(a, b, w) {
        return Ok(out.assign(v, st));
    }
    let d = b - a;
    let wd = Wide::from(w).checked_mul(d)?;
    Ok(out.assign(Wide::from(a).checked_add(wd)?, st))
}

/// [`lerp`]'s exact `a + w (b - a)` before assignment, in 64-bit words,
/// when the operands' widths prove every intermediate fits (`None`
/// otherwise, and the caller takes the 128-bit path). The same value and
/// fraction as the 128-bit path: exact integer arithmetic does not depend
/// on the word it runs in. With `a`, `b` aligned to their larger fraction
/// in `B` bits and `w` in `bw`: `|b - a| < 2^(B+1)`, the product below
/// `2^(B+bw+1)`, `a` shifted by `w`'s fraction below `2^(B+bw)`, so the
/// sum stays below `2^(B+bw+2)`.
#[inline(always)]
pub(super) fn lerp64(a: Fx, b: Fx, w: Fx) -> Option<Wide> {
    let (fa, fb, fw) = (a.format().frac(), b.format().frac(), w.format().frac());
    let f = fa.max(fb);
    let (sa, sb) = (f - fa, f - fb);
    // Widths and fractions are at most 63, so these sums fit u8.
    let bits = (a.format().bits() + sa).max(b.format().bits() + sb);
    if u32::from(bits) + u32::from(w.format().bits()) + 2 > 62 {
        return None;
    }
    let (x, y) = (a.raw() << sa, b.raw() << sb);
    let v = (x << fw) + w.raw() * (y - x);
    Some(Wide::new(i128::from(v), i32::from(f) + i32::from(fw)))
}

/// `sqrt(v)` truncated onto `f`'s grid: an exact integer square root of
/// the radicand aligned to `2 f.frac` fraction bits (the path length's and
/// the gradient norm's unit). `op` names it in an overflow error.
#[inline(always)]
pub fn isqrt_into(v: Wide, f: Reg, op: &'static str, st: &mut QuantStats) -> Result<Fx, FxError> {
    let pf = i32::from(f.frac());
    // sqrt(raw 2^-k) 2^pf = sqrt(raw 2^(2 pf - k)).
    let shift = 2 * pf - v.frac;
    // `Wide` shifts move the exponent, so align the raw word by hand.
    let radicand = if shift >= 0 {
        // Exact iff shifting back recovers the word.
        u32::try_from(shift)
            .ok()
            .filter(|&s| s < 127)
            .map(|s| (v.raw << s, s))
            .filter(|&(r, s)| r >> s == v.raw)
            .map(|(r, _)| r)
            .ok_or(FxError::WideOverflow { op })?
    } else {
        v.raw >> (-shift) as u32
    };
    let root = isqrt(radicand.max(0) as u128) as i128;
    Ok(f.assign(Wide::new(root, pf), st))
}

/// `floor(sqrt(v))`, exactly: a float estimate corrected by at most a few
/// steps when `v` fits 64 bits (the datapath's radicands), the integer
/// algorithm otherwise. The unit it models is the exact root either way.
#[inline]
pub(crate) fn isqrt(v: u128) -> u128 {
    let Ok(small) = u64::try_from(v) else {
        return v.isqrt();
    };
    // The estimate is within one or two of the root for any u64; the
    // loops make it exact (squares of roots below 2^32 + 2 fit u128).
    let mut r = u128::from((small as f64).sqrt() as u64);
    while r * r > v {
        r -= 1;
    }
    while (r + 1) * (r + 1) <= v {
        r += 1;
    }
    r
}

/// Integer and fraction of a non-negative or negative fixed value at a
/// given number of fraction bits: `(floor, fraction raw)`.
#[inline]
pub(crate) fn split(raw: i64, frac: u32) -> (i64, i64) {
    (raw >> frac, raw & ((1i64 << frac) - 1))
}
