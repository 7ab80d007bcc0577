use super::*;
use crate::datapath::Datapath;
use crate::fixed::{Format, Fx, Overflow, Quant, QuantStats};
use crate::preint::PreintUnit;
use crate::tables::Tables;

/// `PHI_MAX` bounds `(1 - e^-u - u e^-u) / u` (it is about 0.2984).
#[test]
fn phi_max_bounds_the_contribution_slope() {
    let mut m = 0f64;
    for k in 1..200_000 {
        let u = k as f64 * 1e-4;
        m = m.max((1.0 - (-u).exp() - u * (-u).exp()) / u);
    }
    assert!(m < PHI_MAX && m > 0.29, "{m}");
}

/// The largest observed step differences against the bound's, over a
/// configuration.
fn check_unit(cfg: PipelineConfig, seed: u64) -> (f64, f64) {
    let tf = golden::scenes::tf_preset("grey-ramp").unwrap();
    let bits = u32::from(cfg.voxel.bits());
    let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, bits);
    let pt = PreTable::new(&lut);
    let mut st = QuantStats::default();
    let unit = PreintUnit::new(&cfg, &pt, cfg.table_entries as usize, &mut st).unwrap();
    let dp = Datapath::new(cfg, Tables::new(&cfg, &lut).unwrap());
    // The same scalars on both sides: only the positions' own
    // roundings (step 1 with ds = 0).
    let df = PreintInputs::position_difference(&cfg, &pt, 0.0);
    let ds_max = 3.0;
    let d = BoundInputs {
        gradient: [0.0; 2],
        table_step: [0.0; 2],
        max_index: 0.0,
        max_coord: 0.0,
        ds_max,
        slices: 1,
        merges: 0,
        data_bits: bits,
    };
    let p = PreintInputs::with_df(&pt, df, ds_max);
    let t = StepTerms {
        d_len: 0.0,
        ..step_terms(&cfg, &d, &p)
    };
    let mut x = seed;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let (mut worst, mut ratio) = (0f64, 0f64);
    let table = words(&pt);
    let last = (pt.bins - 1) as f64;
    let sf = cfg.sample;
    let scalars = |raw: i64| Fx::from_raw(raw, sf).unwrap();
    let words =
        |next: &mut dyn FnMut() -> u64| -> i64 {
            let max = sf.max_raw() as u64 + 1;
            match next() % 4 {
                // Around the opaque edge and the ramp's foot, and anywhere.
                0 => ((150u64 << (sf.frac() + bits as u8 - 8)) + next() % (64 << sf.frac())
                    - (32 << sf.frac()))
                .min(max - 1) as i64,
                1 => ((30u64 << (sf.frac() + bits as u8 - 8)) + next() % (64 << sf.frac()))
                    .min(max - 1) as i64,
                _ => (next() % max) as i64,
            }
        };
    for _ in 0..8_000 {
        let (fr, br) = (words(&mut next), words(&mut next));
        let same = next() % 8 == 0;
        let (front, back) = (scalars(fr), scalars(if same { fr } else { br }));
        let pf = cfg.path;
        let lo = pf.from_f64(1.0).unwrap().value.raw();
        let hi = pf.from_f64(ds_max).unwrap().value.raw();
        let len = Fx::from_raw(lo + (next() % (hi - lo + 1) as u64) as i64, pf).unwrap();
        let half = next() % 4 == 0;
        // Pipeline.
        let e = unit.lookup(&cfg, front, back, &mut st).unwrap();
        let (pc, pa) = match PreintUnit::step(&dp, e, (len, half), &mut st).unwrap() {
            Some((rgb, a)) => (rgb.map(|c| c.to_f64()), a.to_f64()),
            None => ([0.0; 3], 0.0),
        };
        // Golden, from the same scalars in data units.
        let unit_scale = 2f64.powi(bits as i32 - i32::from(cfg.voxel.bits()));
        let (gs_f, gs_b) = (
            (front.to_f64() * unit_scale) as f32,
            (back.to_f64() * unit_scale) as f32,
        );
        let l = len.to_f64() as f32 * if half { 0.5 } else { 1.0 };
        let ge = pt.lookup(gs_f, gs_b);
        let ga = golden::preint::segment_opacity(ge[3], l);
        let gc = if ga > 0.0 {
            let inv = 1.0 / ge[3];
            [ge[0], ge[1], ge[2]].map(|v| f64::from((v * inv).min(1.0)))
        } else {
            [0.0; 3]
        };
        let ga = f64::from(ga);
        let lens = if half {
            [0.5, ds_max / 2.0]
        } else {
            [1.0, ds_max]
        };
        let ps = f64::from(pt.per_scalar());
        let cell =
            [gs_f, gs_b].map(|v| ((f64::from(v) * ps).clamp(0.0, last) as usize).min(pt.bins - 2));
        let w = window_of(&table, pt.bins, df, cell, lens);
        let b = preint_step_bound(&t, &w, ga);
        let da = (pa - ga).abs();
        assert!(
            da <= b.opacity,
            "opacity {pa} vs {ga}: {da} > {} ({fr}, {br}, len {len:?}, half {half})",
            b.opacity
        );
        for k in 0..3 {
            let dpk = (pa * pc[k] - ga * gc[k]).abs();
            assert!(
                dpk <= b.contribution,
                "contribution {k}: {dpk} > {} ({fr}, {br}, len {len:?}, half {half})",
                b.contribution
            );
            worst = worst.max(dpk).max(da);
            ratio = ratio.max(dpk / b.contribution).max(da / b.opacity);
        }
    }
    (worst, ratio)
}

/// The unit against golden's step, within the per-step bound:
/// defaults (4096 entries, 256 bins), 256 entries, a coarse datapath.
#[test]
fn unit_steps_within_the_per_step_bound() {
    let base = PipelineConfig::default();
    let u = |bits, frac, q| Format::new(bits, frac, false, q, Overflow::Sat).unwrap();
    let coarse = PipelineConfig {
        table_entries: 1024,
        weight: u(8, 8, Quant::Trn),
        preint_tau: u(16, 9, Quant::Rnd),
        preint_color: u(16, 9, Quant::Trn),
        log_transmittance: u(16, 11, Quant::Rnd),
        opacity_corr: u(12, 11, Quant::Rnd),
        color: u(8, 7, Quant::Rnd),
        ..base
    };
    let cases = [
        ("default", base),
        (
            "256 entries",
            PipelineConfig {
                table_entries: 256,
                ..base
            },
        ),
        ("coarse", coarse),
    ];
    for (n, (name, cfg)) in cases.into_iter().enumerate() {
        cfg.validate().unwrap();
        let (worst, ratio) = check_unit(cfg, 0x9e37_79b9_7f4a_7c15 ^ n as u64);
        eprintln!("{name}: largest step difference {worst:.3e}, at most {ratio:.3} of its bound");
    }
}

/// At the default widths on brainsmall's facts (the view of the
/// equivalence test: 128x128x84, 8-bit, grey-ramp, regions 64 and 20),
/// the bound is finite and below 1; its value is printed.
#[test]
fn bound_on_brainsmall_like_inputs() {
    let cfg = PipelineConfig::default();
    let d = BoundInputs {
        gradient: [147.0, 152.0],
        table_step: [0.000_245, 0.000_521],
        max_index: 191.0,
        max_coord: 128.0,
        ds_max: 1.741,
        slices: 84,
        merges: 1,
        data_bits: 8,
    };
    let tf = golden::scenes::tf_preset("grey-ramp").unwrap();
    let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, 8);
    let p = PreintInputs::measure(&cfg, &d, &PreTable::new(&lut));
    let btf = preint_error_bound(&cfg, &d, &p);
    let ftb = preint_ftb_error_bound(&cfg, &d, &p, &[64, 20]);
    let plain = super::super::error_bound(&cfg, &d);
    eprintln!(
        "brainsmall-like: preint {btf:.4} (ftb {ftb:.4}), post-classified {plain:.4}, df {:.4}",
        p.df
    );
    assert!(btf.is_finite() && btf < 1.0 && ftb < 2.0);
    assert!(btf > plain, "two scalars per step cost more than one");
    // Narrower weights loosen it.
    let coarse = PipelineConfig {
        weight: Format::new(10, 10, false, Quant::Trn, Overflow::Sat).unwrap(),
        ..cfg
    };
    let pc = PreintInputs::measure(&coarse, &d, &PreTable::new(&lut));
    assert!(preint_error_bound(&coarse, &d, &pc) > btf);
}
