//! Properties checked against an independent `f64` reference of assignment.

use super::*;
use std::cmp::Ordering;

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
