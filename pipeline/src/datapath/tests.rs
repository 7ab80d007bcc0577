use super::ops::lerp64;
use super::*;
use crate::fixed::Format;
use proptest::prelude::*;

fn fx(raw: i64, bits: u8, frac: u8, signed: bool) -> Fx {
    let f = if signed {
        Format::signed(bits, frac.min(bits))
    } else {
        Format::unsigned(bits, frac.min(bits))
    }
    .unwrap();
    let span = i128::from(f.max_raw()) - i128::from(f.min_raw()) + 1;
    let raw = i128::from(raw).rem_euclid(span) + i128::from(f.min_raw());
    Fx::from_raw(raw as i64, f).unwrap()
}

/// The listed classification gives, for every sample word, the words
/// and the quantisation counts of the unit's own arithmetic: 8- and
/// 12-bit voxels, tables with fewer and more entries than voxel codes
/// (the weight split both ways), several rounding modes. A sample
/// format wider than the list's limit classifies through the unit.
#[test]
fn listed_classes_are_the_unit_word_for_word() {
    use crate::fixed::{Overflow, Quant};
    let tf = golden::scenes::tf_preset("grey-ramp").unwrap();
    let base = PipelineConfig::default();
    let u = |bits, frac, q| Format::new(bits, frac, false, q, Overflow::Sat).unwrap();
    let cases = [
        base,
        PipelineConfig {
            voxel: u(12, 0, Quant::Trn),
            sample: u(16, 4, Quant::RndConv),
            ..base
        },
        PipelineConfig {
            table_entries: 64,
            color: u(9, 8, Quant::Rnd),
            ..base
        },
        PipelineConfig {
            table_entries: 1 << 12,
            voxel: u(8, 0, Quant::Trn),
            sample: u(13, 5, Quant::Trn),
            alpha: u(12, 12, Quant::RndInf),
            ..base
        },
    ];
    for (n, cfg) in cases.into_iter().enumerate() {
        let bits = u32::from(cfg.voxel.bits());
        let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, bits);
        let dp = Datapath::new(cfg, Tables::new(&cfg, &lut).unwrap());
        assert!(dp.classes.is_some(), "case {n} is listed");
        let mut lit = 0;
        for raw in 0..=cfg.sample.max_raw() {
            let s = Fx::from_raw(raw, cfg.sample).unwrap();
            let (mut a, mut b) = (QuantStats::default(), QuantStats::default());
            let listed = dp.classify(s, &mut a).unwrap();
            let unit = dp.classify_unit(s, &mut b).unwrap();
            assert_eq!(listed, unit, "case {n} word {raw}");
            assert_eq!(a, b, "case {n} word {raw}");
            lit += usize::from(unit.1.raw() > 0);
        }
        assert!(lit > 0, "case {n} classifies something visible");
    }
    let wide = PipelineConfig {
        sample: Format::new(Classes::MAX_BITS + 1, 4, false, Quant::Trn, Overflow::Sat).unwrap(),
        ..base
    };
    let lut = golden::tf::Lut::for_bits(&tf, wide.table_entries as usize, 8);
    assert!(Datapath::new(wide, Tables::new(&wide, &lut).unwrap())
        .classes
        .is_none());
}

proptest! {
    /// Where the 64-bit lerp runs, it gives the 128-bit expression's
    /// word and fraction.
    #[test]
    fn lerp64_is_the_wide_lerp(
        r in any::<[i64; 3]>(),
        bits in proptest::array::uniform3(1u8..=63),
        frac in proptest::array::uniform3(0u8..=63),
        signed in any::<[bool; 3]>(),
    ) {
        let v: Vec<Fx> = (0..3).map(|i| fx(r[i], bits[i], frac[i], signed[i])).collect();
        let (a, b, w) = (v[0], v[1], v[2]);
        if let Some(got) = lerp64(a, b, w) {
            let want = Wide::from(a).checked_add(Wide::from(w).checked_mul(b - a).unwrap());
            prop_assert_eq!(got, want.unwrap());
        }
    }
}

/// The default widths take the 64-bit path in every lerp of the
/// datapath (interpolation, classification, the exp table), so the
/// fast path is the one that runs.
#[test]
fn default_lerps_run_in_64_bits() {
    let c = PipelineConfig::default();
    let max = |f: Format| f.max_value();
    for (ab, w) in [
        (c.voxel, c.weight),
        (c.sample, c.weight),
        (c.color, c.weight),
        (c.alpha, c.weight),
        (c.opacity_corr, c.weight),
    ] {
        assert!(
            lerp64(max(ab), ab.min_value(), max(w)).is_some(),
            "{ab:?} {w:?}"
        );
    }
}
