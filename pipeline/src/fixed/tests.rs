//! Tests of the fixed-point layer.
//!
//! Two independent oracles:
//! * the `fixed` crate, for what it implements: same-format add, sub, mul
//!   and shifts (truncate toward −∞, wrap or saturate), format-to-format
//!   conversion (truncate), float conversion (nearest, ties to even) and
//!   rounding to an integer (floor, nearest-away, nearest-even,
//!   toward-zero);
//! * a reference written here in `f64` arithmetic that is exact for the
//!   generated magnitudes (below 2^53), which implements every mode from its
//!   *meaning* (nearest with a tie rule, wrap as a Euclidean remainder)
//!   rather than from the carry formula used by the implementation.

use super::*;
use proptest::prelude::*;
use std::cmp::Ordering;

/// At least 1024 cases: every property here is cheap, and the rounding
/// corner cases (ties, carries out of the integer part) are a small
/// fraction of random inputs.
fn cfg() -> ProptestConfig {
    ProptestConfig {
        cases: ProptestConfig::default().cases.max(1024),
        ..ProptestConfig::default()
    }
}

fn quant_strategy() -> impl Strategy<Value = Quant> {
    prop::sample::select(Quant::ALL.to_vec())
}

fn overflow_strategy() -> impl Strategy<Value = Overflow> {
    prop::sample::select(Overflow::ALL.to_vec())
}

/// Formats up to 24 bits, so every value and every value scaled by up to
/// 2^28 is exact in f64.
fn small_format() -> impl Strategy<Value = Format> {
    (
        1u8..=24,
        any::<bool>(),
        quant_strategy(),
        overflow_strategy(),
    )
        .prop_flat_map(|(bits, signed, q, o)| {
            (0u8..=bits).prop_map(move |frac| {
                Format::new(bits, frac, signed, q, o).expect("valid by range")
            })
        })
}

// ---------------------------------------------------------------------
// Independent f64 reference of assignment.
// ---------------------------------------------------------------------

/// Reference assignment of the exact value `raw * 2^-wfrac` into `f`.
/// Returns (raw word, overflow, inexact). Valid while
/// `|raw| * 2^(f.frac - wfrac) < 2^53`.
fn reference_quantize(raw: i64, wfrac: i32, f: Format) -> (i64, bool, bool) {
    let x = raw as f64 * 2f64.powi(-wfrac);
    let scaled = x * 2f64.powi(i32::from(f.frac()));
    let fl = scaled.floor();
    let d = scaled - fl;
    let odd = fl.rem_euclid(2.0) == 1.0;
    let up = match f.quant() {
        Quant::Trn => false,
        Quant::TrnZero => x < 0.0 && d > 0.0,
        Quant::Rnd => d >= 0.5,
        Quant::RndZero => d > 0.5 || (d == 0.5 && x < 0.0),
        Quant::RndMinInf => d > 0.5,
        Quant::RndInf => d > 0.5 || (d == 0.5 && x > 0.0),
        Quant::RndConv => d > 0.5 || (d == 0.5 && odd),
    };
    let r = if up { fl + 1.0 } else { fl };
    let bits = i32::from(f.bits());
    let (mut lo, hi) = if f.is_signed() {
        (-(2f64.powi(bits - 1)), 2f64.powi(bits - 1) - 1.0)
    } else {
        (0.0, 2f64.powi(bits) - 1.0)
    };
    if f.overflow() == Overflow::SatSym && f.is_signed() {
        lo = -hi;
    }
    let overflow = r > hi || r < lo;
    let out = if !overflow {
        r
    } else {
        match f.overflow() {
            Overflow::Wrap => {
                let m = r.rem_euclid(2f64.powi(bits));
                if f.is_signed() && m >= 2f64.powi(bits - 1) {
                    m - 2f64.powi(bits)
                } else {
                    m
                }
            }
            Overflow::Sat | Overflow::SatSym => {
                if r > hi {
                    hi
                } else {
                    lo
                }
            }
            Overflow::SatZero => 0.0,
        }
    };
    (out as i64, overflow, d != 0.0)
}

/// Exact values `raw * 2^-wfrac` with |raw| < 2^24 and wfrac in -4..=40,
/// half of them built to be exact ties at a random number of dropped bits.
fn wide_and_format() -> impl Strategy<Value = (i64, i32, Format)> {
    let general = (-(1i64 << 24)..(1i64 << 24), -4i32..=40, small_format());
    let ties = (small_format(), 1i32..=16, -(1i64 << 7)..(1i64 << 7)).prop_map(|(f, k, m)| {
        // raw = m * 2^k + 2^(k-1): exactly half an LSB of `f` above m LSBs.
        let raw = m * (1i64 << k) + (1i64 << (k - 1));
        (raw, i32::from(f.frac()) + k, f)
    });
    prop_oneof![general, ties]
}

proptest! {
    #![proptest_config(cfg())]

    #[test]
    fn quantize_matches_f64_reference((raw, wfrac, f) in wide_and_format()) {
        let q = f.quantize(Wide::new(i128::from(raw), wfrac));
        let (want, overflow, inexact) = reference_quantize(raw, wfrac, f);
        prop_assert_eq!(q.value.raw(), want);
        prop_assert_eq!(q.value.format(), f);
        prop_assert_eq!(q.overflow, overflow);
        prop_assert_eq!(q.inexact, inexact);
    }

    #[test]
    fn from_f64_is_exact_quantize((raw, wfrac, f) in wide_and_format()) {
        // x is exactly raw * 2^-wfrac, so converting the float must agree
        // with assigning the exact intermediate.
        let x = raw as f64 * 2f64.powi(-wfrac);
        let from_float = f.from_f64(x).unwrap();
        prop_assert_eq!(from_float, f.quantize(Wide::new(i128::from(raw), wfrac)));
    }

    #[test]
    fn wide_from_f64_round_trips(x in any::<f64>().prop_filter("finite", |x| x.is_finite())) {
        let w = Wide::from_f64(x).unwrap();
        prop_assert_eq!(w.to_f64(), x);
    }

    #[test]
    fn fx_ops_match_f64(
        (fa, fb) in (small_format(), small_format()),
        a in any::<u64>(),
        b in any::<u64>(),
    ) {
        // With <= 24-bit operands every sum, difference and product is
        // exact in f64.
        let x = Fx::from_bits(a, fa);
        let y = Fx::from_bits(b, fb);
        prop_assert_eq!((x + y).to_f64(), x.to_f64() + y.to_f64());
        prop_assert_eq!((x - y).to_f64(), x.to_f64() - y.to_f64());
        prop_assert_eq!((x * y).to_f64(), x.to_f64() * y.to_f64());
        prop_assert_eq!((-x).to_f64(), -x.to_f64());
        prop_assert_eq!((x << 5).to_f64(), x.to_f64() * 32.0);
        prop_assert_eq!((x >> 7).to_f64(), x.to_f64() / 128.0);
        prop_assert_eq!(
            x.cmp_value(y),
            x.to_f64().partial_cmp(&y.to_f64()).unwrap()
        );
    }

    #[test]
    fn int_and_frac_parts_recompose(f in small_format(), a in any::<u64>()) {
        let x = Fx::from_bits(a, f);
        let recomposed = x.int_part() as f64 + x.frac_part() as f64 * f.lsb();
        prop_assert_eq!(recomposed, x.to_f64());
        prop_assert!(x.frac_part() < 1u64 << f.frac());
        prop_assert_eq!(x.int_part() as f64, x.to_f64().floor());
    }

    #[test]
    fn bits_round_trip(f in small_format(), a in any::<u64>()) {
        let x = Fx::from_bits(a, f);
        prop_assert!(x.raw() >= f.min_raw() && x.raw() <= f.max_raw());
        prop_assert_eq!(x.to_bits(), a & ((1u64 << f.bits()) - 1));
        prop_assert_eq!(Fx::from_bits(x.to_bits(), f), x);
        prop_assert_eq!(Fx::from_raw(x.raw(), f).unwrap(), x);
    }

    #[test]
    fn wide_cmp_matches_f64(
        a in -(1i64 << 40)..(1i64 << 40),
        fa in -60i32..60,
        b in -(1i64 << 40)..(1i64 << 40),
        fb in -60i32..60,
    ) {
        let x = Wide::new(i128::from(a), fa);
        let y = Wide::new(i128::from(b), fb);
        let want = x.to_f64().partial_cmp(&y.to_f64()).unwrap();
        prop_assert_eq!(x.cmp_value(y), want);
    }

    #[test]
    fn wide_checked_ops_match_f64(
        a in -(1i64 << 20)..(1i64 << 20),
        fa in -20i32..20,
        b in -(1i64 << 20)..(1i64 << 20),
        fb in -20i32..20,
    ) {
        // Products are below 2^40 and so exact in f64. Sums can need up to
        // 60 bits after alignment, so they are checked exactly by undoing
        // them instead.
        let x = Wide::new(i128::from(a), fa);
        let y = Wide::new(i128::from(b), fb);
        prop_assert_eq!(x.checked_mul(y).unwrap().to_f64(), x.to_f64() * y.to_f64());
        let s = x.checked_add(y).unwrap();
        let d = x.checked_sub(y).unwrap();
        // Exactness check via the inverse operation in i128.
        prop_assert_eq!(s.checked_sub(y).unwrap().cmp_value(x), Ordering::Equal);
        prop_assert_eq!(d.checked_add(y).unwrap().cmp_value(x), Ordering::Equal);
        prop_assert_eq!(x.checked_neg().unwrap().to_f64(), -x.to_f64());
        prop_assert_eq!(x.checked_shl(3).unwrap().to_f64(), x.to_f64() * 8.0);
        prop_assert_eq!(x.checked_shr(3).unwrap().to_f64(), x.to_f64() / 8.0);
    }

    #[test]
    fn pack_unpack_round_trip(f in small_format(), words in prop::collection::vec(any::<u64>(), 0..40)) {
        let values: Vec<Fx> = words.iter().map(|&w| Fx::from_bits(w, f)).collect();
        let packed = pack(f, &values).unwrap();
        let w = usize::from(f.bits());
        prop_assert_eq!(packed.len(), w * values.len());
        for (i, v) in values.iter().enumerate() {
            for j in 0..w {
                prop_assert_eq!(packed[i * w + j], (v.to_bits() >> j) & 1 == 1);
            }
        }
        // The storage words read as a little-endian memory word.
        for (n, bit) in packed.iter().by_vals().enumerate() {
            prop_assert_eq!((packed.as_raw_slice()[n / 64] >> (n % 64)) & 1 == 1, bit);
        }
        prop_assert_eq!(unpack(f, &packed).unwrap(), values);
    }
}

// ---------------------------------------------------------------------
// The `fixed` crate as oracle.
// ---------------------------------------------------------------------

macro_rules! same_type_oracle {
    ($modname:ident, $F:ident, $Inner:ty, $U:ident, $bits:expr, $frac:expr, $signed:expr) => {
        mod $modname {
            use super::*;
            type F = ::fixed::$F<::fixed::types::extra::$U>;

            fn fmt(q: Quant, o: Overflow) -> Format {
                Format::new($bits, $frac, $signed, q, o).unwrap()
            }
            fn ours(x: F) -> Fx {
                // Sign-extends signed inner types; from_bits keeps the low bits.
                Fx::from_bits(x.to_bits() as u64, fmt(Quant::Trn, Overflow::Wrap))
            }
            fn inner(x: Fx) -> $Inner {
                // x.raw() is in range of the format, which is the inner type.
                x.raw() as $Inner
            }

            /// Reals around the format's range, plus exact half-LSB ties.
            fn reals() -> impl Strategy<Value = f64> {
                let range = 2f64.powi($bits - $frac + 2);
                let lsb = 2f64.powi(-$frac);
                prop_oneof![
                    (-range..range),
                    (-(1i64 << ($bits + 1))..(1i64 << ($bits + 1)))
                        .prop_map(move |k| (k as f64 + 0.5) * lsb),
                    (-1e30f64..1e30),
                ]
            }

            proptest! {
                #![proptest_config(cfg())]

                #[test]
                fn add_sub(a in any::<$Inner>(), b in any::<$Inner>()) {
                    let (x, y) = (F::from_bits(a), F::from_bits(b));
                    let wrap = fmt(Quant::Trn, Overflow::Wrap);
                    let sat = fmt(Quant::Trn, Overflow::Sat);
                    let q = wrap.quantize(ours(x) + ours(y));
                    prop_assert_eq!(inner(q.value), x.wrapping_add(y).to_bits());
                    prop_assert_eq!(q.overflow, x.overflowing_add(y).1);
                    prop_assert!(!q.inexact);
                    prop_assert_eq!(inner(sat.quantize(ours(x) + ours(y)).value), x.saturating_add(y).to_bits());
                    let q = wrap.quantize(ours(x) - ours(y));
                    prop_assert_eq!(inner(q.value), x.wrapping_sub(y).to_bits());
                    prop_assert_eq!(q.overflow, x.overflowing_sub(y).1);
                    prop_assert_eq!(inner(sat.quantize(ours(x) - ours(y)).value), x.saturating_sub(y).to_bits());
                }

                #[test]
                fn mul_truncates(a in any::<$Inner>(), b in any::<$Inner>()) {
                    // fixed's same-type multiply floors the exact product
                    // (an arithmetic right shift), i.e. TRN.
                    let (x, y) = (F::from_bits(a), F::from_bits(b));
                    let p = ours(x) * ours(y);
                    let q = fmt(Quant::Trn, Overflow::Wrap).quantize(p);
                    prop_assert_eq!(inner(q.value), x.wrapping_mul(y).to_bits());
                    prop_assert_eq!(q.overflow, x.overflowing_mul(y).1);
                    let s = fmt(Quant::Trn, Overflow::Sat).quantize(p);
                    prop_assert_eq!(inner(s.value), x.saturating_mul(y).to_bits());
                }

                #[test]
                fn shifts(a in any::<$Inner>(), n in 0u16..$bits) {
                    let x = F::from_bits(a);
                    let f = fmt(Quant::Trn, Overflow::Wrap);
                    prop_assert_eq!(inner(f.quantize(ours(x) << n).value), x.wrapping_shl(u32::from(n)).to_bits());
                    prop_assert_eq!(inner(f.quantize(ours(x) >> n).value), x.wrapping_shr(u32::from(n)).to_bits());
                }

                #[test]
                fn to_f64_and_cmp(a in any::<$Inner>(), b in any::<$Inner>()) {
                    let (x, y) = (F::from_bits(a), F::from_bits(b));
                    prop_assert_eq!(ours(x).to_f64(), x.to_num::<f64>());
                    prop_assert_eq!(ours(x).cmp_value(ours(y)), x.cmp(&y));
                }

                #[test]
                fn from_f64_rounds_ties_even(r in reals()) {
                    // fixed's float conversion is nearest, ties to even:
                    // RND_CONV, then wrap or saturate.
                    let q = fmt(Quant::RndConv, Overflow::Wrap).from_f64(r).unwrap();
                    prop_assert_eq!(inner(q.value), F::wrapping_from_num(r).to_bits());
                    prop_assert_eq!(q.overflow, F::overflowing_from_num(r).1);
                    let s = fmt(Quant::RndConv, Overflow::Sat).from_f64(r).unwrap();
                    prop_assert_eq!(inner(s.value), F::saturating_from_num(r).to_bits());
                }
            }
        }
    };
}

/// Rounding to an integer, for formats with at least one integer bit:
/// fixed's `floor`, `round`, `round_ties_even` and `round_to_zero` return an
/// integer-valued number in the same type, wrapped on overflow. That equals
/// our assignment into the integer format of the same integer width,
/// shifted back by `frac`.
macro_rules! round_oracle {
    ($modname:ident, $F:ident, $Inner:ty, $U:ident, $bits:expr, $frac:expr, $signed:expr) => {
        mod $modname {
            use super::*;
            type F = ::fixed::$F<::fixed::types::extra::$U>;

            fn to_int(x: F, q: Quant) -> Quantized {
                let src = Fx::from_bits(
                    x.to_bits() as u64,
                    Format::new($bits, $frac, $signed, q, Overflow::Wrap).unwrap(),
                );
                Format::new($bits - $frac, 0, $signed, q, Overflow::Wrap)
                    .unwrap()
                    .quantize(src.wide())
            }
            fn back(q: Quantized) -> $Inner {
                // The integer fits bits - frac bits, so shifting by frac fits
                // the inner type.
                (q.value.raw() << $frac) as $Inner
            }

            /// Half of the words are exact ties (fraction bits `100…0`),
            /// which random words of 12+ fraction bits almost never are.
            fn words() -> impl Strategy<Value = $Inner> {
                prop_oneof![
                    any::<$Inner>(),
                    any::<$Inner>().prop_map(|m| m.wrapping_shl($frac) | (1 << ($frac - 1))),
                ]
            }

            proptest! {
                #![proptest_config(cfg())]

                #[test]
                fn round_to_int(a in words()) {
                    let x = F::from_bits(a);
                    let (v, o) = x.overflowing_floor();
                    let q = to_int(x, Quant::Trn);
                    prop_assert_eq!((back(q), q.overflow), (v.to_bits(), o));
                    let (v, o) = x.overflowing_round();
                    let q = to_int(x, Quant::RndInf);
                    prop_assert_eq!((back(q), q.overflow), (v.to_bits(), o));
                    let (v, o) = x.overflowing_round_ties_even();
                    let q = to_int(x, Quant::RndConv);
                    prop_assert_eq!((back(q), q.overflow), (v.to_bits(), o));
                    let q = to_int(x, Quant::TrnZero);
                    prop_assert_eq!((back(q), q.overflow), (x.round_to_zero().to_bits(), false));
                }
            }
        }
    };
}

/// Conversion between formats: fixed truncates extra fraction bits toward
/// −∞ and then wraps or saturates, which is TRN with WRAP or SAT.
macro_rules! convert_oracle {
    ($modname:ident, $S:ident, $SInner:ty, $SU:ident, ($sb:expr, $sf:expr, $ss:expr),
     $D:ident, $DInner:ty, $DU:ident, ($db:expr, $df:expr, $ds:expr)) => {
        mod $modname {
            use super::*;
            type S = ::fixed::$S<::fixed::types::extra::$SU>;
            type D = ::fixed::$D<::fixed::types::extra::$DU>;

            proptest! {
                #![proptest_config(cfg())]

                #[test]
                fn convert(a in any::<$SInner>()) {
                    let x = S::from_bits(a);
                    let src = Fx::from_bits(a as u64, Format::new($sb, $sf, $ss, Quant::Trn, Overflow::Wrap).unwrap());
                    let wrap = Format::new($db, $df, $ds, Quant::Trn, Overflow::Wrap).unwrap();
                    let q = wrap.quantize(src.wide());
                    prop_assert_eq!(q.value.raw() as $DInner, D::wrapping_from_num(x).to_bits());
                    prop_assert_eq!(q.overflow, D::overflowing_from_num(x).1);
                    let s = wrap.with_overflow(Overflow::Sat).quantize(src.wide());
                    prop_assert_eq!(s.value.raw() as $DInner, D::saturating_from_num(x).to_bits());
                }
            }
        }
    };
}

same_type_oracle!(i8_f0, FixedI8, i8, U0, 8, 0, true);
same_type_oracle!(i8_f3, FixedI8, i8, U3, 8, 3, true);
same_type_oracle!(i8_f8, FixedI8, i8, U8, 8, 8, true);
same_type_oracle!(u8_f0, FixedU8, u8, U0, 8, 0, false);
same_type_oracle!(u8_f5, FixedU8, u8, U5, 8, 5, false);
same_type_oracle!(u8_f8, FixedU8, u8, U8, 8, 8, false);
same_type_oracle!(i16_f8, FixedI16, i16, U8, 16, 8, true);
same_type_oracle!(i16_f15, FixedI16, i16, U15, 16, 15, true);
same_type_oracle!(u16_f12, FixedU16, u16, U12, 16, 12, false);
same_type_oracle!(u16_f16, FixedU16, u16, U16, 16, 16, false);
same_type_oracle!(i32_f0, FixedI32, i32, U0, 32, 0, true);
same_type_oracle!(i32_f16, FixedI32, i32, U16, 32, 16, true);
same_type_oracle!(i32_f31, FixedI32, i32, U31, 32, 31, true);
same_type_oracle!(u32_f24, FixedU32, u32, U24, 32, 24, false);
same_type_oracle!(u32_f32, FixedU32, u32, U32, 32, 32, false);

round_oracle!(round_i8_f3, FixedI8, i8, U3, 8, 3, true);
round_oracle!(round_i8_f7, FixedI8, i8, U7, 8, 7, true);
round_oracle!(round_u8_f5, FixedU8, u8, U5, 8, 5, false);
round_oracle!(round_i16_f8, FixedI16, i16, U8, 16, 8, true);
round_oracle!(round_u16_f12, FixedU16, u16, U12, 16, 12, false);
round_oracle!(round_i32_f16, FixedI32, i32, U16, 32, 16, true);
round_oracle!(round_u32_f31, FixedU32, u32, U31, 32, 31, false);

// Narrower fraction and integer part.
convert_oracle!(
    cv_i32f16_i16f8,
    FixedI32,
    i32,
    U16,
    (32, 16, true),
    FixedI16,
    i16,
    U8,
    (16, 8, true)
);
// Wider fraction, narrower integer part.
convert_oracle!(
    cv_i16f8_i32f28,
    FixedI16,
    i16,
    U8,
    (16, 8, true),
    FixedI32,
    i32,
    U28,
    (32, 28, true)
);
// Unsigned to signed.
convert_oracle!(
    cv_u16f12_i8f4,
    FixedU16,
    u16,
    U12,
    (16, 12, false),
    FixedI8,
    i8,
    U4,
    (8, 4, true)
);
// Signed to unsigned: negative values underflow.
convert_oracle!(
    cv_i16f8_u8f4,
    FixedI16,
    i16,
    U8,
    (16, 8, true),
    FixedU8,
    u8,
    U4,
    (8, 4, false)
);
// Signed to unsigned, wider.
convert_oracle!(
    cv_i8f0_u32f16,
    FixedI8,
    i8,
    U0,
    (8, 0, true),
    FixedU32,
    u32,
    U16,
    (32, 16, false)
);
// All-fraction to all-fraction.
convert_oracle!(
    cv_i32f32_u16f16,
    FixedI32,
    i32,
    U32,
    (32, 32, true),
    FixedU16,
    u16,
    U16,
    (16, 16, false)
);

// ---------------------------------------------------------------------
// Unit tests of edges the generators do not reach.
// ---------------------------------------------------------------------

fn f(bits: u8, frac: u8, signed: bool, q: Quant, o: Overflow) -> Format {
    Format::new(bits, frac, signed, q, o).unwrap()
}

#[test]
fn format_validation() {
    assert_eq!(
        Format::signed(0, 0),
        Err(FormatError::BitsOutOfRange { bits: 0 })
    );
    assert_eq!(
        Format::signed(64, 0),
        Err(FormatError::BitsOutOfRange { bits: 64 })
    );
    assert_eq!(
        Format::unsigned(16, 20),
        Err(FormatError::FracExceedsBits { frac: 20, bits: 16 })
    );
    let spec = FormatSpec {
        bits: 8,
        frac: -1,
        signed: false,
        quant: Quant::Trn,
        overflow: Overflow::Wrap,
    };
    assert_eq!(
        Format::try_from(spec),
        Err(FormatError::FracNegative { frac: -1 })
    );
    assert_eq!(
        FormatError::FracExceedsBits { frac: 20, bits: 16 }.describe("alpha"),
        "alpha.frac = 20 exceeds alpha.bits = 16"
    );
    // One-bit signed holds {-1, 0}; 63-bit formats are the widest.
    let one = Format::signed(1, 0).unwrap();
    assert_eq!((one.min_raw(), one.max_raw()), (-1, 0));
    let u63 = Format::unsigned(63, 0).unwrap();
    assert_eq!(u63.max_raw(), i64::MAX);
    let i63 = Format::signed(63, 0).unwrap();
    assert_eq!((i63.min_raw(), i63.max_raw()), (-(1 << 62), (1 << 62) - 1));
}

#[test]
fn format_display_and_serde() {
    let a = f(12, 12, false, Quant::Rnd, Overflow::Sat);
    assert_eq!(a.to_string(), "ufixed<12,0,RND,SAT>");
    let p = f(28, 16, true, Quant::RndConv, Overflow::Wrap);
    assert_eq!(p.to_string(), "fixed<28,12,RND_CONV,WRAP>");
    let text = a.spec().to_string();
    assert_eq!(
        text,
        r#"{ bits = 12, frac = 12, signed = false, quant = "RND", overflow = "SAT" }"#
    );
    #[derive(serde::Deserialize, serde::Serialize, PartialEq, Debug)]
    struct Holder {
        x: Format,
    }
    let parsed: Holder = toml::from_str(&format!("x = {text}")).unwrap();
    assert_eq!(parsed.x, a);
    // Modes default to ap_fixed's TRN and WRAP.
    let parsed: Holder = toml::from_str("x = { bits = 8, frac = 2, signed = true }").unwrap();
    assert_eq!(parsed.x, Format::signed(8, 2).unwrap());
    // Invalid parameters and unknown keys are rejected.
    assert!(toml::from_str::<Holder>("x = { bits = 8, frac = 9, signed = true }").is_err());
    assert!(
        toml::from_str::<Holder>("x = { bits = 8, frac = 2, signed = true, round = \"RND\" }")
            .is_err()
    );
    assert!(toml::from_str::<Holder>(
        "x = { bits = 8, frac = 2, signed = true, quant = \"ROUND\" }"
    )
    .is_err());
    let json = serde_json::to_string(&Holder { x: p }).unwrap();
    assert_eq!(serde_json::from_str::<Holder>(&json).unwrap().x, p);
}

#[test]
fn rounding_modes_on_ties_and_near_ties() {
    // Signed 8.0 target; sources in quarters (frac 2).
    let cases: [(f64, [i64; 7]); 6] = [
        // value   TRN TRN_ZERO RND RND_ZERO RND_MIN_INF RND_INF RND_CONV
        (2.5, [2, 2, 3, 2, 2, 3, 2]),
        (3.5, [3, 3, 4, 3, 3, 4, 4]),
        (-2.5, [-3, -2, -2, -2, -3, -3, -2]),
        (-3.5, [-4, -3, -3, -3, -4, -4, -4]),
        (2.75, [2, 2, 3, 3, 3, 3, 3]),
        (-2.25, [-3, -2, -2, -2, -2, -2, -2]),
    ];
    for (x, want) in cases {
        for (q, &w) in Quant::ALL.iter().zip(want.iter()) {
            let got = f(8, 0, true, *q, Overflow::Wrap).from_f64(x).unwrap();
            assert_eq!(got.value.raw(), w, "{x} with {}", q.name());
            assert!(got.inexact);
        }
    }
}

#[test]
fn round_up_carry_overflows() {
    // 127.5 rounds to 128, which does not fit fixed<8,8>: the overflow is
    // detected after rounding, as in ap_fixed.
    let x = Wide::new(255, 1);
    let sat = f(8, 0, true, Quant::Rnd, Overflow::Sat).quantize(x);
    assert_eq!((sat.value.raw(), sat.overflow), (127, true));
    let wrap = f(8, 0, true, Quant::Rnd, Overflow::Wrap).quantize(x);
    assert_eq!((wrap.value.raw(), wrap.overflow), (-128, true));
    let zero = f(8, 0, true, Quant::Rnd, Overflow::SatZero).quantize(x);
    assert_eq!((zero.value.raw(), zero.overflow), (0, true));
    let trn = f(8, 0, true, Quant::Trn, Overflow::Sat).quantize(x);
    assert_eq!((trn.value.raw(), trn.overflow), (127, false));
}

#[test]
fn sat_sym_excludes_most_negative_code() {
    let s = f(8, 0, true, Quant::Trn, Overflow::SatSym);
    let q = s.from_int(-128);
    assert_eq!((q.value.raw(), q.overflow), (-127, true));
    let q = s.from_int(-1000);
    assert_eq!((q.value.raw(), q.overflow), (-127, true));
    let q = s.from_int(1000);
    assert_eq!((q.value.raw(), q.overflow), (127, true));
    let q = s.from_int(-127);
    assert_eq!((q.value.raw(), q.overflow), (-127, false));
    // Unsigned: same as SAT.
    let u = f(8, 0, false, Quant::Trn, Overflow::SatSym);
    assert_eq!(u.from_int(-5).value.raw(), 0);
    assert_eq!(u.from_int(300).value.raw(), 255);
}

#[test]
fn extreme_shifts_in_quantize() {
    let i8f0 = |q| f(8, 0, true, q, Overflow::Wrap);
    // -2^127 * 2^-128 = -1/2 exactly: a tie through the k = 128 path.
    let half = Wide::new(i128::MIN, 128);
    let want = [-1, 0, 0, 0, -1, -1, 0];
    for (q, w) in Quant::ALL.iter().zip(want) {
        assert_eq!(i8f0(*q).quantize(half).value.raw(), w, "{}", q.name());
    }
    // A tiny negative value far below the LSB: floor is -1, nearest is 0.
    let tiny = Wide::new(-1, 1000);
    let want = [-1, 0, 0, 0, 0, 0, 0];
    for (q, w) in Quant::ALL.iter().zip(want) {
        let got = i8f0(*q).quantize(tiny);
        assert_eq!(got.value.raw(), w, "{}", q.name());
        assert!(got.inexact && !got.overflow);
    }
    // 2^200 does not fit i128 once aligned: it overflows, saturates to max,
    // and wraps to 0 because its low bits are 0.
    let huge = Wide::new(1, -200);
    let sat = f(16, 4, true, Quant::Trn, Overflow::Sat).quantize(huge);
    assert_eq!((sat.value.raw(), sat.overflow), (i64::from(i16::MAX), true));
    let wrap = f(16, 4, true, Quant::Trn, Overflow::Wrap).quantize(huge);
    assert_eq!((wrap.value.raw(), wrap.overflow), (0, true));
    let neg = f(16, 4, false, Quant::Trn, Overflow::Sat).quantize(Wide::new(-3, -100));
    assert_eq!((neg.value.raw(), neg.overflow), (0, true));
    // 3 * 2^62 in a signed 63-bit register: fits i128, wraps exactly.
    let w = f(63, 0, true, Quant::Trn, Overflow::Wrap).quantize(Wide::new(3, -62));
    assert_eq!((w.value.raw(), w.overflow), (-(1 << 62), true));
}

#[test]
fn sixty_three_bit_operands_are_exact() {
    let u63 = Format::unsigned(63, 0).unwrap();
    let u63f63 = Format::unsigned(63, 63).unwrap();
    let i63 = Format::signed(63, 0).unwrap();
    let i63f63 = Format::signed(63, 63).unwrap();
    let umax = u63.max_value();
    let p = umax * umax;
    assert_eq!(p, Wide::new(i128::from(i64::MAX) * i128::from(i64::MAX), 0));
    let imin = i63.min_value();
    assert_eq!(imin * imin, Wide::new(1 << 124, 0));
    // Widest alignment: a 63-bit integer plus a 63-bit fraction.
    let s = umax + u63f63.max_value();
    assert_eq!(
        s,
        Wide::new((i128::from(i64::MAX) << 63) + i128::from(i64::MAX), 63)
    );
    let d = i63.min_value() - i63f63.max_value();
    assert_eq!(d, Wide::new(-(1i128 << 125) - ((1i128 << 62) - 1), 63));
    assert_eq!(-imin, Wide::new(1 << 62, 0));
}

#[test]
fn wide_overflow_is_reported() {
    let big = Wide::new(1 << 100, 0);
    assert_eq!(
        big.checked_mul(Wide::new(1 << 26, 0)),
        Ok(Wide::new(1 << 126, 0))
    );
    assert_eq!(
        big.checked_mul(Wide::new(1 << 30, 0)),
        Err(FxError::WideOverflow { op: "mul" })
    );
    assert_eq!(
        Wide::new(1, 0).checked_add(Wide::new(1, 127)),
        Err(FxError::WideOverflow { op: "add" })
    );
    assert_eq!(
        Wide::new(1, 0).checked_add(Wide::new(1, 100)),
        Ok(Wide::new((1 << 100) + 1, 100))
    );
    assert_eq!(
        Wide::new(i128::MAX, 0).checked_sub(Wide::new(-1, 0)),
        Err(FxError::WideOverflow { op: "sub" })
    );
    assert_eq!(
        Wide::new(i128::MIN, 0).checked_neg(),
        Err(FxError::WideOverflow { op: "neg" })
    );
    assert_eq!(
        Wide::new(1, i32::MAX).checked_shr(1),
        Err(FxError::WideOverflow { op: "shr" })
    );
    assert_eq!(
        Wide::new(1, i32::MIN).checked_shl(1),
        Err(FxError::WideOverflow { op: "shl" })
    );
    assert_eq!(
        Wide::new(1, 5).checked_mul(Wide::new(1, i32::MAX)),
        Err(FxError::WideOverflow { op: "mul" })
    );
    // Comparison never overflows, even when alignment would.
    assert_eq!(
        Wide::new(1, 0).cmp_value(Wide::new(i128::MAX, 200)),
        Ordering::Greater
    );
    assert_eq!(
        Wide::new(-1, 0).cmp_value(Wide::new(5, 200)),
        Ordering::Less
    );
    assert_eq!(
        Wide::new(5, 200).cmp_value(Wide::new(-1, 0)),
        Ordering::Greater
    );
    assert_eq!(
        Wide::new(3, -130).cmp_value(Wide::new(i128::MAX, 0)),
        Ordering::Greater
    );
    assert_eq!(Wide::new(2, 1).cmp_value(Wide::new(1, 0)), Ordering::Equal);
}

#[test]
fn from_f64_rejects_non_finite_and_handles_extremes() {
    let q8 = f(16, 8, true, Quant::RndConv, Overflow::Sat);
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(matches!(q8.from_f64(bad), Err(FxError::NotFinite { .. })));
    }
    assert_eq!(q8.from_f64(-0.0).unwrap().value, q8.zero());
    assert_eq!(q8.from_f64(f64::MAX).unwrap().value, q8.max_value());
    assert_eq!(q8.from_f64(f64::MIN).unwrap().value, q8.min_value());
    let sub = q8.from_f64(-f64::from_bits(1)).unwrap();
    assert_eq!((sub.value.raw(), sub.inexact), (0, true));
    let trn = q8
        .with_quant(Quant::Trn)
        .from_f64(-f64::from_bits(1))
        .unwrap();
    assert_eq!(trn.value.raw(), -1);
    assert_eq!(Wide::from_f64(0.75).unwrap().to_f64(), 0.75);
    assert_eq!(
        Wide::from_f64(f64::from_bits(1)).unwrap(),
        Wide::new(1, 1074)
    );
}

#[test]
fn from_raw_checks_range() {
    let u = Format::unsigned(4, 2).unwrap();
    assert_eq!(Fx::from_raw(15, u).unwrap().to_f64(), 3.75);
    assert_eq!(
        Fx::from_raw(16, u),
        Err(FxError::RawOutOfRange { raw: 16, format: u })
    );
    assert!(Fx::from_raw(-1, u).is_err());
    let s = Format::signed(4, 2).unwrap();
    assert_eq!(Fx::from_bits(0b1111, s).raw(), -1);
    assert_eq!(Fx::from_raw(-8, s).unwrap().to_bits(), 0b1000);
    assert_eq!(Fx::from_raw(-3, s).unwrap().int_part(), -1);
    assert_eq!(Fx::from_raw(-3, s).unwrap().frac_part(), 1);
}

#[test]
fn stats_count_events() {
    let fmt = f(8, 4, false, Quant::Rnd, Overflow::Sat);
    let mut stats = QuantStats::default();
    let a = fmt.assign(Wide::new(3, 0), &mut stats); // exact
    let b = fmt.assign(Wide::new(1, 8), &mut stats); // 1/256: inexact
    let c = fmt.assign(Wide::new(100, 0), &mut stats); // overflow
    let d = fmt.assign(a * b, &mut stats); // 3 * 0 = 0: exact
    assert_eq!(a.to_f64(), 3.0);
    assert_eq!(b.to_f64(), 0.0);
    assert_eq!(c, fmt.max_value());
    assert!(d.is_zero());
    assert_eq!(
        stats,
        QuantStats {
            assignments: 4,
            overflows: 1,
            inexact: 1
        }
    );
    let mut total = stats;
    total.merge(&stats);
    assert_eq!(
        total,
        QuantStats {
            assignments: 8,
            overflows: 2,
            inexact: 2
        }
    );
    let mut full = QuantStats {
        assignments: u64::MAX,
        overflows: 0,
        inexact: 0,
    };
    full.merge(&stats);
    assert_eq!(full.assignments, u64::MAX);
}

#[test]
fn pack_layout_and_errors() {
    let s5 = Format::signed(5, 1).unwrap();
    let vals = [
        Fx::from_raw(1, s5).unwrap(),
        Fx::from_raw(-1, s5).unwrap(),
        Fx::from_raw(-16, s5).unwrap(),
    ];
    let bits = pack(s5, &vals).unwrap();
    // 00001 | 11111 | 10000, LSB-first.
    assert_eq!(bits.as_raw_slice(), &[0b10000_11111_00001u64]);
    assert_eq!(unpack(s5, &bits).unwrap(), vals);
    // Fields straddling the 64-bit storage boundary.
    let u7 = Format::unsigned(7, 0).unwrap();
    let many: Vec<Fx> = (0..20)
        .map(|i| Fx::from_raw(i * 6 + 1, u7).unwrap())
        .collect();
    let packed = pack(u7, &many).unwrap();
    assert_eq!(packed.len(), 140);
    assert_eq!(unpack(u7, &packed).unwrap(), many);
    // Value 9 (index 9, raw 55) occupies bits 63..70.
    let v9 = (packed.as_raw_slice()[0] >> 63) | ((packed.as_raw_slice()[1] & 0x3f) << 1);
    assert_eq!(v9, 55);
    // Modes may differ; layout may not.
    let modes = s5.with_quant(Quant::Rnd).with_overflow(Overflow::Sat);
    assert!(pack(modes, &vals).is_ok());
    assert!(matches!(
        pack(Format::signed(5, 2).unwrap(), &vals),
        Err(FxError::FormatMismatch { .. })
    ));
    assert_eq!(
        unpack(s5, &bits[..14]),
        Err(FxError::PackLength { len: 14, width: 5 })
    );
    assert!(pack(s5, &[]).unwrap().is_empty());
}

/// SAT_SYM's lower limit is `-max`: a rounded value at `min_raw` must be
/// flagged and clamped even when it drops fraction bits (the TRN/RND fast
/// path must not take it).
#[test]
fn sat_sym_clamps_min_raw_after_rounding() {
    for quant in [Quant::Trn, Quant::Rnd] {
        let f = Format::new(1, 0, true, quant, Overflow::SatSym).unwrap();
        // -1 exactly, carried with one fraction bit: raw -2 at frac 1.
        let q = f.quantize(Wide::new(-2, 1));
        assert_eq!(q.value.raw(), 0, "{quant:?}");
        assert!(q.overflow, "{quant:?}");
        let f = Format::new(8, 4, true, quant, Overflow::SatSym).unwrap();
        let q = f.quantize(Wide::new(-128 * 4, 6));
        assert_eq!(q.value.raw(), -127, "{quant:?}");
        assert!(q.overflow);
    }
}
