//! Width monotonicity: the pipeline's error against golden as one width
//! at a time grows.

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use golden::tf::Lut;
use pipeline::config::PipelineConfig;
use pipeline::fixed::{Format, Overflow, Quant};

use super::{blob, pipeline_vs_golden, ramp};

/// Widths swept one at a time around the defaults.
#[derive(Debug, Clone, Copy)]
enum Sweep {
    Alpha,
    Accum,
    PositionFrac,
    Weight,
}

fn swept(which: Sweep, bits: u8) -> PipelineConfig {
    let u = |b: u8, f: u8, q| Format::new(b, f, false, q, Overflow::Sat).unwrap();
    let base = PipelineConfig::default();
    let cfg = match which {
        Sweep::Alpha => PipelineConfig {
            alpha: u(bits, bits, Quant::Rnd),
            ..base
        },
        // Both accumulators; the merge keeps 4 integer bits over them and
        // the corrected opacity may not have more fraction bits than its
        // accumulator (the config refuses it), so below 15 it narrows too.
        Sweep::Accum => PipelineConfig {
            accum_color: u(bits, bits, Quant::Rnd),
            accum_alpha: u(bits, bits, Quant::Rnd),
            merge: u(bits + 4, bits, Quant::Rnd),
            opacity_corr: if bits < base.opacity_corr.frac() {
                u(bits + 1, bits, Quant::Rnd)
            } else {
                base.opacity_corr
            },
            ..base
        },
        Sweep::PositionFrac => PipelineConfig {
            position: Format::new(12 + bits, bits, true, Quant::Rnd, Overflow::Sat).unwrap(),
            ..base
        },
        Sweep::Weight => PipelineConfig {
            weight: u(bits, bits, Quant::Trn),
            ..base
        },
    };
    cfg.validate()
        .unwrap_or_else(|e| panic!("{which:?} {bits}: {e}"));
    cfg
}

/// One width at a time on a small smooth scene: the pipeline's largest
/// image difference from golden `er` does not grow by more than noise when
/// two bits are added. Noise allowance: exactly one LSB of the final 8-bit
/// image, 1/255 (rounding can move an error by less than that either way,
/// anything beyond it would be visible).
#[test]
fn error_does_not_grow_with_width() {
    let vol = blob([24, 20, 28], 0);
    let c = DVec3::from_array(vol.center_world());
    let cam = Camera::new(DVec3::new(11.0, 9.0, -12.0), c, DVec3::Y, 50.0, 24, 20).unwrap();
    let prep = Prepared::new(&vol, &cam).unwrap();
    let sweeps = [
        (Sweep::Alpha, 8..=16),
        (Sweep::Accum, 10..=20),
        (Sweep::PositionFrac, 8..=20),
        (Sweep::Weight, 8..=14),
    ];
    let noise = 1.0 / 255.0;
    for (which, range) in sweeps {
        let curve: Vec<(u8, f64, f64)> = range
            .map(|bits| {
                let cfg = swept(which, bits);
                let lut = Lut::for_bits(&ramp(), cfg.table_entries as usize, 8);
                let (db, di, _, _) = pipeline_vs_golden(&cfg, &vol, &lut, &prep);
                (bits, di, db)
            })
            .collect();
        eprintln!("{which:?}: bits -> max image diff (baseplane diff), in 1/255");
        for &(b, di, db) in &curve {
            eprintln!("  {b:>2}: {:8.3} ({:8.3})", di * 255.0, db * 255.0);
        }
        for w in curve.windows(3) {
            let ((b0, e0, _), (b2, e2, _)) = (w[0], w[2]);
            assert!(
                e2 <= e0 + noise,
                "{which:?}: error grew from {e0:e} at {b0} bits to {e2:e} at {b2} bits"
            );
        }
    }
}
