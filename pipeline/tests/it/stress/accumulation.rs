//! Long accumulation: 1024 slices and more against the closed form
//! `1 - (1 - a)^n`, and the pipeline's saturating accumulators on it.

use glam::DVec3;
use golden::camera::Camera;
use golden::methods::{self, Method, Options};
use golden::render::Prepared;
use golden::tf::{Lut, TransferFunction};
use golden::volume::{Volume, VoxelType};
use pipeline::config::PipelineConfig;
use pipeline::datapath::{Acc, Datapath};
use pipeline::fixed::{QuantStats, Wide};
use pipeline::tables::Tables;

use super::{assert_words_in_format, bad_value, pipeline_vs_golden};
use crate::scenes::{tf, volume};

/// Unit roundoff of `f32` (round to nearest): `2^-24`.
const U: f64 = 1.0 / 16_777_216.0;

/// A thin uniform column `8 x 8 x n` of value 200, seen from
/// `(4, 4, -d)` along +z through a 9x9, 1-degree camera whose centre pixel
/// looks exactly along +z. Ray `m = 4` on both axes sits at `(4, 4)` on
/// every slice (its slope `phi + m - eye` is 0 for every method's grid,
/// whose offsets `phi` are 0 when there is one region), so its path length
/// is exactly 1 and it samples all `n` slices.
fn column(n: usize, d: f64) -> (Volume, Prepared) {
    let vol = volume([8, 8, n], VoxelType::U8, |_, _, _| 200);
    let eye = DVec3::new(4.0, 4.0, -d);
    let cam = Camera::new(
        eye,
        DVec3::new(4.0, 4.0, n as f64 * 0.5),
        DVec3::Y,
        1.0,
        9,
        9,
    )
    .unwrap();
    let prep = Prepared::new(&vol, &cam).unwrap();
    (vol, prep)
}

/// A constant transfer function (one control point): colour
/// `(1, 1/2, 1/4)`, powers of two so that premultiplied colour is exactly
/// `c A` in `f32` (scaling by a power of two commutes with rounding), and
/// opacity `a` per unit length.
fn constant_tf(a: f64) -> TransferFunction {
    tf(&[(0.0, [1.0, 0.5, 0.25, a])])
}

const COLOUR: [f32; 3] = [1.0, 0.5, 0.25];

/// `1 - (1 - a)^n` in `f64`, without cancellation for small `a`.
fn closed_form(a: f64, n: f64) -> f64 {
    -(n * (-a).ln_1p()).exp_m1()
}

/// Worst-case error of `n` f32 compositing steps of opacity `a`, either
/// order. One step `A' = a + (1 - a) A` (or `A' = A + (1 - A) a`) rounds
/// three times (`1 - a`, the product, the sum), each by at most `u` of a
/// value no larger than `A'`: `3 u A_k` at step `k`, which later steps
/// multiply by `(1 - a)^(n - k)`. The corrected opacity itself
/// (`-expm1(ds ln1p(-a))`, `ds = 1`) is off by at most 5 `u` relative
/// (two libm calls of at most one ulp, 2 `u` each, and a product), and
/// `A_n = 1 - (1 - a)^n` has relative sensitivity
/// `a n (1 - a)^(n-1) / A_n <= 1` to `a`, so that adds `5 u A_n`.
fn accumulation_tolerance(a: f64, n: usize) -> f64 {
    let s: f64 = (1..=n)
        .map(|k| closed_form(a, k as f64) * (1.0 - a).powi((n - k) as i32))
        .sum();
    U * (3.0 * s + 5.0 * closed_form(a, n as f64))
}

/// The baseplane index of the sample at view `(4, 4)`.
fn centre_sample(grid: &golden::geometry::BaseGrid) -> usize {
    let k: [usize; 2] = std::array::from_fn(|a| {
        let k = ((4.0 - grid.origin[a]) / grid.spacing).round();
        assert!(
            (grid.origin[a] + k * grid.spacing - 4.0).abs() < 1e-9,
            "no baseplane sample at 4 on axis {a}: {grid:?}"
        );
        k as usize
    });
    k[1] * grid.counts[0] + k[0]
}

/// Golden, every slice-order method, 1024 (and, ignored, up to 8192)
/// slices of constant opacity: the centre ray's opacity matches
/// `1 - (1 - a)^n` within the f32 bound of `accumulation_tolerance`, its
/// colour is exactly `c A`, and the centre pixel of the final image (a
/// convex combination of equal samples) matches within that bound plus
/// 20 `u`: the warp's normalised weights sum to `1 +- 5 u` (2 `u` per
/// axis for the normalisation, `u` for their product) and summing at most
/// 16 taps adds 15 `u`.
fn long_accumulation_golden(n: usize) {
    let (_, prep) = column(n, 1e4);
    assert_eq!(prep.view.d, 1e4);
    assert_eq!(prep.view.regions().count(), 1, "D = 1e4: one region");
    let no_termination = Options {
        terminate: 1.0,
        substeps: 1,
        ..Options::default()
    };
    for a in [1e-4, 0.02, 0.999, 1.0 - 1e-6] {
        // The model sees the f32 table entry, so the closed form uses it.
        let a32 = f64::from(a as f32);
        let lut = Lut::for_bits(&constant_tf(a), 256, 8);
        assert!(lut.rgba.iter().all(|e| f64::from(e[3]) == a32));
        let want = closed_form(a32, n as f64);
        let tol = accumulation_tolerance(a32, n);
        for m in Method::ALL {
            let out = methods::render(m, &prep, &lut, &no_termination).unwrap();
            let base = &out.baseplane;
            let got = base.data[centre_sample(&base.grid)];
            assert!(got.iter().all(|v| v.is_finite()));
            let err = (f64::from(got[3]) - want).abs();
            eprintln!(
                "n {n} a {a:e} {:>6}: A = {:.9} closed form {want:.9} error {err:.2e} \
                 (relative {:.2e}), tolerance {tol:.2e}",
                m.name(),
                got[3],
                err / want
            );
            assert!(
                err <= tol,
                "{} n {n} a {a}: opacity {} vs closed form {want}, error {err:e} > {tol:e}",
                m.name(),
                got[3]
            );
            for c in 0..3 {
                assert_eq!(
                    got[c],
                    COLOUR[c] * got[3],
                    "{} a {a}: channel {c} is not c A",
                    m.name()
                );
            }
            let img = golden::warp::warp(&prep.view, base);
            assert!(bad_value(&img.data).is_none());
            let px = img.get(4, 4)[3];
            let err_img = (f64::from(px) - want).abs();
            assert!(
                err_img <= tol + 20.0 * U * want,
                "{} a {a}: centre pixel {px} vs {want}, error {err_img:e}",
                m.name()
            );
        }
    }
}

#[test]
fn long_accumulation_golden_matches_the_closed_form() {
    long_accumulation_golden(1024);
}

/// The longest stacks the volume allows (MAX_EDGE = 8192):
/// `cargo test --release -p pipeline --test it -- --ignored stress`.
#[test]
#[ignore = "heavy: 4096 and 8192 slices"]
fn long_accumulation_golden_matches_the_closed_form_deep() {
    long_accumulation_golden(4096);
    long_accumulation_golden(8192);
}

/// The pipeline on the same column at default widths. Its datapath is
/// replayed for the centre ray slice by slice (`Datapath` with the host's
/// slice constants, as a PE computes it), the replay is checked against
/// the frame's raw words, and along the ray every accumulator never
/// decreases (a wrap would drop it); near-1 opacities end exactly at the
/// accumulator's largest word (derived below), far from 0; every pixel
/// stays within `error_bound` of golden `er`. An eye 1 voxel away (ten
/// regions, nine merges) checks the bound with merges in the way.
#[test]
fn long_accumulation_pipeline_saturates_within_the_bound() {
    let cfg = PipelineConfig::default();
    for a in [1e-4, 0.02, 0.999, 1.0 - 1e-6, 1.0] {
        let t = constant_tf(a);
        let lut = Lut::for_bits(&t, cfg.table_entries as usize, 8);
        for d in [1e4, 1.0] {
            let (vol, prep) = column(1024, d);
            let (db, di, b, frame) = pipeline_vs_golden(&cfg, &vol, &lut, &prep);
            eprintln!(
                "a {a:e} D {d}: pipeline vs golden baseplane {db:.2e}, image {di:.2e}, \
                 bound {b:.2e}"
            );
            assert!(db <= b && di <= b, "a {a} D {d}: {db} / {di} > {b}");
            assert_words_in_format(&frame, &format!("a {a} D {d}"));
            let max = [
                cfg.accum_color.max_raw(),
                cfg.accum_color.max_raw(),
                cfg.accum_color.max_raw(),
                cfg.accum_alpha.max_raw(),
            ];
            if d != 1e4 {
                continue;
            }
            let plan = pipeline::host::plan(&cfg, &prep.view).unwrap();
            assert_eq!(plan.regions.len(), 1);
            let region = &plan.regions[0];
            assert_eq!(region.slices.len(), 1024);
            let dp = Datapath::new(cfg, Tables::new(&cfg, &lut).unwrap());
            let mut st = QuantStats::default();
            let word = pipeline::host::voxel_words(&cfg, &vol, &prep.view, &mut st)[0];
            let m = 4i64;
            let mut acc = Acc::default();
            let mut composited = 0;
            for s in &region.slices {
                assert!(s.range.iter().all(|&(lo, hi)| (lo..=hi).contains(&m)));
                let x = dp.position(s.a[0], s.t[0], m, &mut st).unwrap();
                let y = dp.position(s.a[1], s.t[1], m, &mut st).unwrap();
                let (_, wx) = dp.address(x, &mut st);
                let (_, wy) = dp.address(y, &mut st);
                let sample = dp.bilinear([[word; 2]; 2], wx, wy, &mut st).unwrap();
                let (rgb, alpha) = dp.classify(sample, &mut st).unwrap();
                if alpha.raw() == 0 {
                    continue;
                }
                let slope = |k: usize| {
                    let mt = Wide::new(i128::from(m), 0)
                        .checked_mul(region.slope_k[k])
                        .unwrap();
                    cfg.position.assign(
                        Wide::from(region.slope_b[k]).checked_add(mt).unwrap(),
                        &mut QuantStats::default(),
                    )
                };
                let ds = dp
                    .path(slope(0), slope(1), region.slope_z, &mut st)
                    .unwrap();
                assert_eq!(ds.to_f64(), 1.0, "the centre ray's path is exactly 1");
                let corr = dp.correct(alpha, ds, &mut st).unwrap();
                let before = acc;
                dp.composite_btf(&mut acc, rgb, corr, &mut st).unwrap();
                composited += 1;
                for c in 0..4 {
                    assert!(
                        acc.raw[c] >= before.raw[c],
                        "a {a}: channel {c} fell from {} to {} at slice {}",
                        before.raw[c],
                        acc.raw[c],
                        s.z
                    );
                }
            }
            let g = &region.grid;
            let idx = ((m - g.lo[1]) * (g.hi[0] - g.lo[0] + 1) + (m - g.lo[0])) as usize;
            assert_eq!(acc.raw, frame.raw[idx], "the replay is the PE's arithmetic");
            let opacity = acc.raw[3] as f64 * cfg.accum_alpha.lsb();
            eprintln!(
                "a {a:e}: alpha word {} of {}, {composited} slices composited, final words \
                 {:?} (max {}), opacity {opacity:.6} vs closed form {:.6}",
                dp.tables().alpha[0].raw(),
                cfg.alpha.max_raw(),
                acc.raw,
                max[3],
                closed_form(f64::from(a as f32), 1024.0)
            );
            if a >= 0.999 {
                // The alpha word is at least 4092/4096, so the correction
                // leaves transmittance T <= 2^-10 per slice (log table 10
                // or 12, ds = 1, exactly): after two slices the exact
                // update 1 - T + T A is within 2^-20 of 1, rounds to 1 and
                // saturates to the largest word, where it stays
                // (1 - T 2^-16 rounds up again). Full-opacity white
                // saturates the same way.
                assert_eq!(acc.raw[3], max[3], "a {a}: opacity not saturated");
                assert_eq!(acc.raw[0], max[0], "a {a}: white not saturated");
            }
        }
    }
}
