//! The inline opacity correction against the exact form: over a dense
//! grid of opacities (every 2^-16 step of `[0, 1]`, the ends of the range
//! in every binade down to 2^-40, and table-like values) and path lengths
//! (substep fractions to long anisotropic steps), [`correct_opacity`]
//! stays within one `f32` ulp of `1` (`e = 2^-24`, below the `4 e` the
//! pipeline's bound charges golden's correction) of the `f64` exact
//! form, and within a few ulps relative for small opacities; the libm
//! `f32` form it replaced is measured the same way, for comparison.
//!
//! `cargo test --release -p golden --test it -- opacity`

use golden::opacity::{
    correct_opacity, correct_opacity_exact, correct_opacity_lanes, correct_opacity_libm,
    segment_opacity_lanes,
};
use golden::preint::segment_opacity;

const E: f64 = 1.0 / 16_777_216.0;

fn opacities() -> Vec<f32> {
    let mut a: Vec<f32> = (0..=65_536).map(|i| i as f32 / 65_536.0).collect();
    for b in 1..=40 {
        let lo = 2f32.powi(-b);
        for k in 0..64 {
            a.push(lo * (1.0 + k as f32 / 64.0));
            a.push(1.0 - lo * (1.0 + k as f32 / 128.0));
        }
    }
    // Largest value below 1 and smallest above 0.
    a.push(1.0 - f32::EPSILON / 2.0);
    a.push(f32::MIN_POSITIVE);
    a.push(1e-30);
    a
}

const PATHS: [f32; 11] = [
    0.0,
    0.125,
    0.25,
    1.0 / 3.0,
    0.5,
    0.7,
    1.0,
    1.2247,
    1.732,
    3.0,
    17.5,
];

fn worst(f: impl Fn(f32, f32) -> f32) -> (f64, f64) {
    let (mut abs, mut rel) = (0f64, 0f64);
    for &ds in &PATHS {
        for &a in &opacities() {
            let (got, want) = (f(a, ds) as f64, correct_opacity_exact(a, ds) as f64);
            assert!(
                got.is_finite() && (0.0..=1.0).contains(&got),
                "a {a} ds {ds}: {got}"
            );
            let d = (got - want).abs();
            abs = abs.max(d);
            if want > 1e-30 {
                rel = rel.max(d / want);
            }
        }
    }
    (abs, rel)
}

#[test]
fn opacity_correction_is_within_one_ulp_of_the_exact_form() {
    let (abs, rel) = worst(correct_opacity);
    println!(
        "inline: worst |d| {:.3} e, worst relative {rel:.3e}",
        abs / E
    );
    assert!(abs <= E, "inline correction off by {} e", abs / E);
    assert!(rel <= 4.0 * f32::EPSILON as f64, "relative {rel}");
    let (abs, rel) = worst(correct_opacity_libm);
    println!(
        "libm f32: worst |d| {:.3} e, worst relative {rel:.3e}",
        abs / E
    );
    assert!(abs <= 4.0 * E, "libm form off by {} e", abs / E);
}

#[test]
fn opacity_correction_edges() {
    for ds in PATHS {
        assert_eq!(correct_opacity(0.0, ds), 0.0);
        assert_eq!(correct_opacity(-0.5, ds), 0.0);
        assert_eq!(correct_opacity(1.0, ds), 1.0);
        assert_eq!(correct_opacity(1.5, ds), 1.0);
    }
    // A unit step returns the opacity itself.
    for a in [1e-6f32, 0.1, 0.25, 0.2500001, 0.5, 0.9, 0.999] {
        assert!(
            (correct_opacity(a, 1.0) - a).abs() <= f32::EPSILON * a.max(0.5),
            "{a}"
        );
    }
    // Monotone in the opacity for a fixed step.
    for ds in PATHS {
        let mut last = 0.0;
        for i in 0..=4096 {
            let v = correct_opacity(i as f32 / 4096.0, ds);
            assert!(v >= last, "ds {ds} at {i}");
            last = v;
        }
    }
}

/// The branch-free lanes give the scalar form's bits in every lane, for
/// every opacity of the grid (both reductions of both halves, their
/// boundaries at 1/4, sqrt 2 and ln 2 / 2, and the clamped ends: zero,
/// negative, one and above) and every path length, whatever the lane.
#[test]
fn opacity_lanes_equal_the_scalar_correction_bit_for_bit() {
    let mut a = opacities();
    a.extend([
        -0.0,
        -1.0,
        1.0,
        1.5,
        0.25,
        0.250_000_03,
        0.249_999_98,
        0.292_893_2,
        0.292_893_23,
    ]);
    let mut paths = PATHS.to_vec();
    paths.extend([0.999_999_94, 2.0, 1e-6, 40.0]);
    let mut checked = 0u64;
    for &ds in &paths {
        // Lanes of 8 with a path length per lane, the grid shifted by one
        // lane each round so every value meets every lane.
        for shift in 0..8 {
            for chunk in a[shift.min(a.len())..].chunks(8) {
                let mut lane_a = [0.5f32; 8];
                let mut lane_ds = [ds; 8];
                for (l, &v) in chunk.iter().enumerate() {
                    lane_a[l] = v;
                    lane_ds[l] = if l % 2 == 0 { ds } else { ds * 0.5 };
                }
                let got = correct_opacity_lanes(&lane_a, &lane_ds);
                for l in 0..chunk.len() {
                    let want = correct_opacity(lane_a[l], lane_ds[l]);
                    assert_eq!(
                        got[l].to_bits(),
                        want.to_bits(),
                        "a {} ds {}: lanes {} scalar {want}",
                        lane_a[l],
                        lane_ds[l],
                        got[l]
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 5_000_000, "{checked} lanes checked");
}

/// The pre-integrated step's lanes give `segment_opacity`'s bits: mean
/// extinctions from zero (and below) through the grid to far past the
/// point where `e^(-ds tau)` underflows, over every path length, with
/// empty and non-empty steps mixed in a quad.
#[test]
fn segment_lanes_equal_the_scalar_step_bit_for_bit() {
    let mut tau = opacities();
    tau.extend([-0.5, 2.0, 37.0, 700.0, 1e4, 1e30]);
    let mut checked = 0u64;
    for &ds in PATHS.iter().chain(&[0.999_999_94, 40.0]) {
        for chunk in tau.chunks(8) {
            let mut t = [0f32; 8];
            t[..chunk.len()].copy_from_slice(chunk);
            let d: [f32; 8] = std::array::from_fn(|l| ds * (1.0 + l as f32 / 7.0));
            let got = segment_opacity_lanes(&t, &d);
            for l in 0..chunk.len() {
                let want = segment_opacity(t[l], d[l]);
                assert_eq!(got[l].to_bits(), want.to_bits(), "tau {} ds {}", t[l], d[l]);
                checked += 1;
            }
        }
    }
    assert!(checked > 900_000, "{checked} lanes checked");
}
