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

use wide::{f64x4, u64x4};

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

/// [`correct_opacity`] over `N` independent lanes (`N` a multiple of 4),
/// with the same bits in every lane: both halves of each of its branches
/// are computed and the wanted one selected, four lanes at a time in
/// `f64` vectors, so a batch of samples runs without a data-dependent
/// branch (a row's opacities cross `1/4` and `ln 2 / 2` unpredictably).
/// `golden::sampling` composites a row's rays through it.
#[inline(always)]
pub fn correct_opacity_lanes<const N: usize>(a: &[f32; N], ds: &[f32; N]) -> [f32; N] {
    const { assert!(N.is_multiple_of(4), "lanes come in fours") };
    let mut out = [0f32; N];
    for q in 0..N / 4 {
        let (mut av, mut dv) = ([0.5f64; 4], [0f64; 4]);
        let mut any = false;
        for l in 0..4 {
            let x = a[4 * q + l];
            // Out-of-range lanes run the arithmetic on a harmless value and
            // are replaced below (a NaN stays inside, as in the scalar form).
            if !(x <= 0.0 || x >= 1.0) {
                av[l] = f64::from(x);
                any = true;
            }
            dv[l] = f64::from(ds[4 * q + l]);
        }
        // Four transparent or opaque lanes (air, or a solid material's
        // inside) need no arithmetic: the selects below give 0 or 1.
        let v = if any {
            correct_x4(f64x4::new(av), f64x4::new(dv)).to_array()
        } else {
            [0.0; 4]
        };
        for l in 0..4 {
            let x = a[4 * q + l];
            out[4 * q + l] = if x <= 0.0 {
                0.0
            } else if x >= 1.0 {
                1.0
            } else {
                v[l] as f32
            };
        }
    }
    out
}

/// `1 - (1 - a)^ds` for four `a` in `(0, 1)`: [`correct_opacity`]'s
/// arithmetic, operation for operation, with its branches as selects and
/// its two integer conversions done in the floating-point unit (both are
/// small integers, exact either way).
#[inline(always)]
fn correct_x4(a: f64x4, ds: f64x4) -> f64x4 {
    neg_expm1_x4(ds * ln_one_minus_x4(a))
}

/// Adding then subtracting 2^52 rounds a value in [0, 2^51) to an
/// integer, which then sits in the low mantissa bits of the sum.
const MAGIC: f64 = 4_503_599_627_370_496.0;

/// [`ln_one_minus`] in four lanes, both reductions selected.
#[inline(always)]
fn ln_one_minus_x4(a: f64x4) -> f64x4 {
    const LN2: f64 = std::f64::consts::LN_2;
    let c = f64x4::splat;
    let (one, magic) = (c(1.0), c(MAGIC));
    let small = a.simd_le(c(0.25));
    let bits = (one - a).to_bits();
    let m = f64x4::from_bits(
        (bits & u64x4::splat(0x000f_ffff_ffff_ffff)) | u64x4::splat(0x3ff0_0000_0000_0000),
    );
    let wide = m.simd_gt(c(std::f64::consts::SQRT_2));
    // The biased exponent (below 2^11) as a float, plus one when `m` halves.
    let biased = f64x4::from_bits(magic.to_bits() | (bits >> 52)) - magic;
    let e = biased - c(1023.0) + wide.select(one, c(0.0));
    let m = wide.select(m * c(0.5), m);
    let num = small.select(a, m - one);
    let den = small.select(c(2.0) - a, m + one);
    let t = atanh_x4(num / den);
    small.select(c(-2.0) * t, e * c(LN2) + c(2.0) * t)
}

/// [`neg_expm1`] in four lanes, both reductions selected.
#[inline(always)]
fn neg_expm1_x4(y: f64x4) -> f64x4 {
    const LN2: f64 = std::f64::consts::LN_2;
    let c = f64x4::splat;
    let (one, magic) = (c(1.0), c(MAGIC));
    let near = y.simd_ge(c(-0.5 * LN2));
    let yc = y.max(c(-700.0));
    // The scalar form's `(0.5 - y / ln 2) as i64`, a truncation of a value
    // in [0.5, 1010.4]: round to an integer, then step down if it rose.
    let v = c(0.5) - yc / c(LN2);
    let rounded = (v + magic) - magic;
    let n = rounded.simd_gt(v).select(rounded - one, rounded);
    let r = near.select(y, yc + n * c(LN2));
    let p = expm1_x4(r);
    // 2^-n from n's bits in the sum (n <= 1010: the exponent stays positive).
    let n_bits = (n + magic).to_bits() - magic.to_bits();
    let scale = f64x4::from_bits((u64x4::splat(1023) - n_bits) << 52);
    near.select(-p, one - scale * (one + p))
}

/// `1 - e^(-ds tau)` over `N` lanes (`N` a multiple of 4): the
/// pre-integrated step's opacity, `crate::preint::segment_opacity`'s bits
/// in every lane, branch-free as [`correct_opacity_lanes`] (a quad of
/// empty steps skips the arithmetic).
#[inline(always)]
pub fn segment_opacity_lanes<const N: usize>(tau: &[f32; N], ds: &[f32; N]) -> [f32; N] {
    let mut out = [0f32; N];
    segment_quads(tau, ds, |i, _, a| out[i] = a as f32);
    out
}

/// [`crate::preint::segment_attenuation`] over `N` lanes (`N` a multiple
/// of 4): [`segment_opacity_lanes`]' opacities and the colour weights
/// `h`, the scalar form's bits in every lane (a quad of empty steps skips
/// the arithmetic).
#[inline(always)]
pub fn segment_attenuation_lanes<const N: usize>(
    tau: &[f32; N],
    ds: &[f32; N],
) -> ([f32; N], [f32; N]) {
    let (mut a, mut h) = ([0f32; N], [0f32; N]);
    segment_quads(tau, ds, |i, lambda, v| {
        a[i] = v as f32;
        h[i] = crate::preint::attenuation_weight(lambda, v) as f32;
    });
    (a, h)
}

/// [`crate::preint::segment_exact`] over `N` lanes (`N` a multiple of 4):
/// the same bits, lane by lane (lanes with `tau <= 0` give `(0, (0, 0))`).
#[inline]
pub fn segment_exact_lanes<const N: usize>(
    tau: &[f32; N],
    ds: &[f32; N],
) -> ([f32; N], [(usize, f32); N]) {
    let (mut a, mut at) = ([0f32; N], [(0usize, 0f32); N]);
    segment_quads(tau, ds, |i, lambda, v| {
        a[i] = v as f32;
        at[i] = crate::preint::layer_position(lambda / std::f64::consts::LN_2);
    });
    (a, at)
}

/// The shared core of the segment lanes: `1 - e^(-lambda)` in `f64`,
/// `lambda = ds tau`, four lanes at a time, handed to `each(lane, lambda,
/// opacity)` for every lane with `tau > 0` (the others are left to the
/// caller's zeros; a quad of them skips the arithmetic).
#[inline(always)]
fn segment_quads<const N: usize>(
    tau: &[f32; N],
    ds: &[f32; N],
    mut each: impl FnMut(usize, f64, f64),
) {
    const { assert!(N.is_multiple_of(4), "lanes come in fours") };
    for q in 0..N / 4 {
        let t = &tau[4 * q..4 * q + 4];
        if t.iter().all(|&t| t <= 0.0) {
            continue;
        }
        let mut y = [0f64; 4];
        for l in 0..4 {
            y[l] = -f64::from(ds[4 * q + l]) * f64::from(t[l]);
        }
        let v = neg_expm1_x4(f64x4::new(y)).to_array();
        for l in 0..4 {
            if t[l] > 0.0 {
                each(4 * q + l, -y[l], v[l]);
            }
        }
    }
}

/// [`atanh_series`] in four lanes.
#[inline(always)]
fn atanh_x4(s: f64x4) -> f64x4 {
    let c = f64x4::splat;
    let z = s * s;
    let p = c(1.0 / 9.0);
    let p = p * z + c(1.0 / 7.0);
    let p = p * z + c(1.0 / 5.0);
    let p = p * z + c(1.0 / 3.0);
    s + s * z * p
}

/// [`expm1_series`] in four lanes.
#[inline(always)]
fn expm1_x4(r: f64x4) -> f64x4 {
    let mut p = f64x4::splat(1.0 / 40_320.0);
    for f in [5_040.0, 720.0, 120.0, 24.0, 6.0, 2.0] {
        p = p * r + f64x4::splat(1.0 / f);
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
