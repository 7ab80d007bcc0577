//! Unit tests of edges the generators do not reach.

use super::*;
use crate::config::{FormatId, PipelineConfig};
use std::cmp::Ordering;

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
    let totals = |s: &QuantStats| (s.assignments, s.overflows, s.inexact);
    assert_eq!(totals(&stats), (4, 1, 1));
    // A bare format counts under `other`; a register under its field.
    let other = *stats.by_format.get(FormatId::OTHER);
    assert_eq!(
        (other.assignments, other.overflows, other.inexact),
        (4, 1, 1)
    );
    let mut total = stats;
    total.merge(&stats);
    assert_eq!(totals(&total), (8, 2, 2));
    assert_eq!(total.by_format.get(FormatId::OTHER).overflows, 2);
    assert_eq!(total.harmful_overflows(), 2);
    let cfg = PipelineConfig {
        accum_alpha: fmt,
        ..PipelineConfig::default()
    };
    let mut named = QuantStats::default();
    crate::reg!(cfg, accum_alpha).assign(Wide::new(100, 0), &mut named);
    let id = FormatId::named("accum_alpha");
    assert_eq!(named.by_format.get(id).overflows, 1);
    assert_eq!(named.by_format.get(FormatId::OTHER).assignments, 0);
    // The accumulator's saturation is a designed clamp.
    assert_eq!((named.overflows, named.harmful_overflows()), (1, 0));
    assert_eq!(named.times(3).by_format.get(id).overflows, 3);
    let mut full = QuantStats {
        assignments: u64::MAX,
        ..QuantStats::default()
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
