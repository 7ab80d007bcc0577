//! Opacity correction for a step of length `ds`: `a' = 1 - (1 - a)^ds`
//! for opacity `a` per unit length, the one transcendental every
//! composited sample pays.
//!
//! [`correct_opacity`] evaluates it inline in `f64` without libm: one
//! division and two short polynomials (no call, no table, no lookup that
//! depends on the ray), so the per-sample cost is a few dozen flops that
//! the compiler schedules with the rest of the sample. Both halves use the
//! same kind of reduction:
//!
//! - `ln(1 - a) = -2 atanh(s)` with `s = a / (2 - a)` for `a <= 1/4`, and
//!   `ln(1 - a) = e ln 2 + 2 atanh(s)` with `1 - a = m 2^e`,
//!   `m` in `[sqrt(1/2), sqrt 2)`, `s = (m - 1) / (m + 1)` above (the
//!   subtraction `1 - a` is exact in `f64` there); `|s| <= 0.1716`, and
//!   the odd series to `s^9` leaves out less than `2.1e-9` relative;
//! - `1 - e^y = -expm1(y)`: the Taylor series of `expm1` to degree 8 for
//!   `|y| <= ln 2 / 2` (remainder below `6e-10` relative), else
//!   `y = k ln 2 + r` and `1 - 2^k (1 + expm1(r))`.
//!
//! The degrees are the least that keep the `f64` value within a few
//! hundredths of an `f32` ulp, so [`correct_opacity`] rounds to one of the
//! two `f32` neighbours of the exact value (at most one ulp, `e = 2^-24`
//! below 1, off): inside the `4 e` the
//! pipeline's error bound (`pipeline::bound`) charges golden's opacity
//! correction, and closer to the exact value than the libm `f32` form
//! ([`correct_opacity_libm`], `log1pf` then `expm1f`, kept for comparison)
//! it replaces. `tests/it/opacity.rs` checks both against
//! [`correct_opacity_exact`] (`f64` libm) over a dense grid of `a` and `ds`.

/// `1 - (1 - a)^ds` for opacity `a` per unit length over a step of length
/// `ds >= 0`: 0 for `a <= 0`, 1 for `a >= 1`, else within one `f32` ulp
/// of the exact value (see the module notes).
#[inline(always)]
pub fn correct_opacity(a: f32, ds: f32) -> f32 {
    if a <= 0.0 {
        return 0.0;
    }
    if a >= 1.0 {
        return 1.0;
    }
    let y = f64::from(ds) * ln_one_minus(f64::from(a));
    neg_expm1(y) as f32
}

/// `ln(1 - a)` for `a` in `(0, 1)` (`a` an `f32` value).
#[inline(always)]
fn ln_one_minus(a: f64) -> f64 {
    const LN2: f64 = std::f64::consts::LN_2;
    if a <= 0.25 {
        let s = a / (2.0 - a);
        return -2.0 * atanh_series(s);
    }
    // 1 - a is exact: a has at most 24 significant bits at or above 2^-26.
    let u = 1.0 - a;
    let bits = u.to_bits();
    let mut e = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let mut m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    if m > std::f64::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    let s = (m - 1.0) / (m + 1.0);
    e as f64 * LN2 + 2.0 * atanh_series(s)
}

/// `atanh(s)` for `|s| <= 0.1716`: the odd series to `s^9` (the first
/// term left out, `s^11 / 11`, is below `2.1e-9` relative).
#[inline(always)]
fn atanh_series(s: f64) -> f64 {
    let z = s * s;
    let p = 1.0 / 9.0;
    let p = p * z + 1.0 / 7.0;
    let p = p * z + 1.0 / 5.0;
    let p = p * z + 1.0 / 3.0;
    s + s * z * p
}

/// `1 - e^y` for `y <= 0` (any finite value; large negative `y` gives 1).
#[inline(always)]
pub(crate) fn neg_expm1(y: f64) -> f64 {
    const LN2: f64 = std::f64::consts::LN_2;
    if y >= -0.5 * LN2 {
        return -expm1_series(y);
    }
    // e^y below 2^-1022 is 0 for the f32 result.
    let y = y.max(-700.0);
    // The nearest integer to y / ln 2 (y < 0), by truncation of a
    // positive value (no libm `round` on targets without SSE4.1).
    let k = -((0.5 - y / LN2) as i64);
    let r = y - k as f64 * LN2;
    let scale = f64::from_bits(((k + 1023) as u64) << 52);
    1.0 - scale * (1.0 + expm1_series(r))
}

/// `e^r - 1` for `|r| <= ln 2 / 2 (+ rounding)`: the Taylor series to
/// degree 8 (the remainder is below `6e-10` relative).
#[inline(always)]
fn expm1_series(r: f64) -> f64 {
    let mut p = 1.0 / 40_320.0; // 1/8!
    for f in [
        5_040.0, // 7!
        720.0, 120.0, 24.0, 6.0, 2.0,
    ] {
        p = p * r + 1.0 / f;
    }
    r + r * r * p
}

/// The libm `f32` form golden used before [`correct_opacity`]:
/// `-expm1f(ds log1pf(-a))`, for comparison and benchmarks.
#[inline]
pub fn correct_opacity_libm(a: f32, ds: f32) -> f32 {
    if a <= 0.0 {
        0.0
    } else if a >= 1.0 {
        1.0
    } else {
        -((ds * (-a).ln_1p()).exp_m1())
    }
}

/// The exact form in `f64` libm, rounded once to `f32`: what the
/// tolerance tests measure [`correct_opacity`] against.
pub fn correct_opacity_exact(a: f32, ds: f32) -> f32 {
    if a <= 0.0 {
        0.0
    } else if a >= 1.0 {
        1.0
    } else {
        (-(f64::from(ds) * (-f64::from(a)).ln_1p()).exp_m1()) as f32
    }
}
