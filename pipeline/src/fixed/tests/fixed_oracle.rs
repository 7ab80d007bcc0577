//! Properties checked against the `fixed` crate as oracle.

use super::*;

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
