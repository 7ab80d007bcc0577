//! Pre-integrated classification (`golden::preint`): the table's
//! diagonal is the post-classified sample, a segment's opacity is the
//! exact integral of the linear scalar's extinction (against a brute-force
//! fine march), transparent spans have exactly zero extinction, skipping
//! with it stays bit-identical for every method (u8 and u16 volumes), it
//! sees a thin layer that one post-classified sample per slice misses,
//! and the attenuated colouring follows the march's colour far closer than
//! the fast one.
//!
//! `cargo test --release -p golden --test it -- preint`

use glam::DVec3;
use golden::camera::{Camera, ImagePlane};
use golden::clip::ClipPlane;
use golden::methods::{self, Method, Options, Output};
use golden::metrics::compare;
use golden::opacity::correct_opacity;
use golden::preint::{segment_opacity, Colouring, PreTable};
use golden::render::{render, PrepareOptions, Prepared, RenderOptions, Technique};
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::{Volume, VoxelType, DEFAULT_MEMORY_LIMIT};
use proptest::prelude::*;

use crate::scenes::{eye_and_look, sparse, table};

fn ramp() -> Lut {
    table(&[
        (0.0, [0.0; 4]),
        (60.0, [0.2, 0.4, 0.9, 0.0]),
        (140.0, [1.0, 0.7, 0.2, 0.6]),
        (255.0, [1.0, 1.0, 1.0, 0.95]),
    ])
}

#[test]
fn preint_diagonal_is_the_post_classified_sample() {
    let lut = ramp();
    let pt = PreTable::new(&lut);
    assert_eq!(pt.bins, 256);
    for s in 0..=255u16 {
        let s = f32::from(s);
        let e = pt.lookup(s, s);
        let c = lut.lookup(s);
        for ds in [0.5f32, 1.0, 1.41] {
            let (a, want) = (segment_opacity(e[3], ds), correct_opacity(c[3], ds));
            assert!(
                (a - want).abs() <= 2e-6,
                "s {s} ds {ds}: {a} against {want}"
            );
        }
        if e[3] > 0.0 {
            for k in 0..3 {
                assert!((e[k] / e[3] - c[k]).abs() < 1e-5, "s {s} channel {k}");
            }
        }
    }
}

/// March a linear scalar from `sf` to `sb` over length `ds` in `n` fine
/// post-classified steps, front to back.
fn march(lut: &Lut, sf: f32, sb: f32, ds: f32, n: usize) -> [f64; 4] {
    let mut acc = [0f64; 4];
    for k in 0..n {
        let s = sf + (sb - sf) * (k as f32 + 0.5) / n as f32;
        let c = lut.lookup(s);
        let a = f64::from(correct_opacity(c[3], ds / n as f32));
        let w = (1.0 - acc[3]) * a;
        for ch in 0..3 {
            acc[ch] += w * f64::from(c[ch]);
        }
        acc[3] += w;
    }
    acc
}

#[test]
fn preint_opacity_is_the_integral_of_the_linear_segment() {
    let lut = ramp();
    let pt = PreTable::new(&lut);
    let mut worst = (0f64, 0f64);
    for (sf, sb) in [
        (0.0f32, 255.0f32),
        (255.0, 0.0),
        (50.0, 150.0),
        (100.0, 101.0),
        (139.0, 141.0),
        (30.0, 200.0),
        (200.0, 70.0),
    ] {
        for ds in [0.5f32, 1.0, 1.3] {
            let e = pt.lookup(sf, sb);
            let a = f64::from(segment_opacity(e[3], ds));
            let m = march(&lut, sf, sb, ds, 20_000);
            worst.0 = worst.0.max((a - m[3]).abs());
            // The colour ignores the order inside the segment: bounded by
            // the colour's spread times the opacity, small here.
            let c: Vec<f64> = (0..3)
                .map(|k| f64::from(e[k] / e[3].max(1e-30)) * a)
                .collect();
            for k in 0..3 {
                worst.1 = worst.1.max((c[k] - m[k]).abs());
            }
        }
    }
    println!(
        "worst opacity difference {:.2e}, colour {:.2e}",
        worst.0, worst.1
    );
    assert!(worst.0 < 1e-6, "opacity off by {}", worst.0);
    assert!(worst.1 < 0.05, "colour off by {}", worst.1);
    // A constant colour is exact.
    let mono = table(&[(0.0, [0.5, 0.5, 0.5, 0.0]), (255.0, [0.5, 0.5, 0.5, 0.9])]);
    let pt = PreTable::new(&mono);
    let e = pt.lookup(10.0, 240.0);
    let m = march(&mono, 10.0, 240.0, 1.0, 20_000);
    let a = f64::from(segment_opacity(e[3], 1.0));
    assert!((f64::from(e[0] / e[3]) * a - m[0]).abs() < 1e-4);
}

#[test]
fn preint_transparent_spans_have_zero_extinction() {
    let lut = table(&[
        (0.0, [0.0; 4]),
        (100.0, [1.0, 1.0, 1.0, 0.0]),
        (110.0, [1.0, 1.0, 1.0, 0.8]),
        (120.0, [1.0, 1.0, 1.0, 0.0]),
    ]);
    let pt = PreTable::new(&lut);
    assert_eq!(pt.lookup(10.0, 90.0)[3], 0.0);
    assert_eq!(pt.lookup(130.0, 250.0)[3], 0.0);
    assert_eq!(pt.lookup(99.5, 0.0)[3], 0.0);
    // Both ends transparent, the layer between them seen.
    assert_eq!(lut.lookup(50.0)[3] + lut.lookup(200.0)[3], 0.0);
    assert!(segment_opacity(pt.lookup(50.0, 200.0)[3], 1.0) > 0.05);
}

fn pre_options(skips: Skips, pre_colouring: Colouring) -> Options {
    Options {
        terminate: 1.0,
        skips,
        preintegrate: true,
        pre_colouring,
        ..Options::default()
    }
}

fn bits(v: &[[f32; 4]]) -> Vec<[u32; 4]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

fn slice(m: Method, p: &Prepared, l: &Lut, skips: Skips, c: Colouring) -> Output {
    methods::render(m, p, l, &pre_options(skips, c)).expect("render")
}

fn image(p: &Prepared, l: &Lut, m: Method, skips: Skips, c: Colouring) -> Vec<[u32; 4]> {
    let opts = RenderOptions {
        slice: pre_options(skips, c),
        ..RenderOptions::default()
    };
    bits(
        &render(p, l, Technique::Slice(m), &opts)
            .expect("render")
            .image
            .data,
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    /// Empty-space skipping and culling with pre-integration never change
    /// a bit of any method's baseplane or image, for 8-bit volumes (table
    /// bins are entries) and 16-bit ones (coarser bins, widened occupancy),
    /// with either colouring.
    #[test]
    fn preint_skipping_is_bit_identical(
        dims in prop::array::uniform3(6usize..24),
        blobs in 1usize..5,
        seed in any::<u64>(),
        threshold in 20.0..120.0f64,
        side in 0usize..6,
        dist in prop_oneof![0.3..4.0f64, 4.0..60.0],
        look in prop::array::uniform2(-0.6..0.6f64),
        fov in prop_oneof![10.0..40.0f64, 40.0..150.0],
        block in prop::sample::select(vec![2usize, 4, 8]),
        wide in any::<bool>(),
        attenuated in any::<bool>(),
        clip in prop::option::of((prop::array::uniform3(-1.0..1.0f64), -20.0..20.0f64)),
    ) {
        let c = if attenuated { Colouring::Attenuated } else { Colouring::Fast };
        let vol8 = sparse(dims, blobs, seed);
        let (vol, lut) = if wide {
            let v = Volume::from_fn(dims, VoxelType::U16, DEFAULT_MEMORY_LIMIT, |x, y, z| {
                vol8.get(x, y, z) * 256
            })
            .expect("volume");
            let tf = crate::scenes::tf(&[
                (0.0, [0.0; 4]),
                (threshold * 256.0, [0.2, 0.3, 0.9, 0.0]),
                ((threshold + 40.0) * 256.0, [1.0, 0.6, 0.2, 0.5]),
                (65535.0, [1.0, 1.0, 1.0, 0.9]),
            ]);
            (v, golden::render::lut_for(VoxelType::U16, &tf))
        } else {
            let lut = table(&[
                (0.0, [0.0; 4]),
                (threshold, [0.2, 0.3, 0.9, 0.0]),
                (threshold + 40.0, [1.0, 0.6, 0.2, 0.5]),
                (255.0, [1.0, 1.0, 1.0, 0.9]),
            ]);
            (vol8, lut)
        };
        let (eye, at) = eye_and_look(dims, side, dist, look);
        let f = (at - eye).normalize();
        let up = if f.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
        let cam = Camera::new(eye, at, up, fov, 36, 30).expect("camera");
        let mut opts = PrepareOptions { block, ..PrepareOptions::default() };
        if let Some((n, d)) = clip.filter(|(n, _)| n.iter().any(|v| v.abs() > 0.05)) {
            opts.clip = vec![ClipPlane::new(DVec3::from_array(n), d).expect("plane")];
        }
        let prep = Prepared::with(&vol, &cam, &opts)
            .map_err(|e| TestCaseError::reject(e.to_string()))?;
        for m in Method::ALL {
            let off = slice(m, &prep, &lut, Skips::NONE, c);
            let on = slice(m, &prep, &lut, Skips::EMPTY, c);
            prop_assert_eq!(bits(&on.baseplane.data), bits(&off.baseplane.data),
                "{} baseplane changed by empty-space skipping", m.name());
            prop_assert!(on.stats.samples_total <= off.stats.samples_total);
            prop_assert_eq!(image(&prep, &lut, m, Skips::default(), c), image(&prep, &lut, m, Skips::NONE, c),
                "{} image changed by skipping", m.name());
        }
    }
}

/// A hard step from air (0) to floor (200) between two slices, with only
/// the values around 100 visible: the reference sees the thin skin where
/// interpolation passes through 100; one post-classified sample per slice
/// sees nothing of it, pre-integration sees it.
#[test]
fn preint_sees_the_thin_layer_post_classification_misses() {
    let n = 24;
    let vol = Volume::from_fn([n, n, n], VoxelType::U8, DEFAULT_MEMORY_LIMIT, |_, _, z| {
        if z >= 12 {
            200
        } else {
            0
        }
    })
    .expect("volume");
    let lut = table(&[
        (0.0, [0.0; 4]),
        (90.0, [1.0, 0.8, 0.6, 0.0]),
        (100.0, [1.0, 0.8, 0.6, 0.9]),
        (110.0, [1.0, 0.8, 0.6, 0.0]),
        (255.0, [1.0, 0.8, 0.6, 0.0]),
    ]);
    let c = (n as f64 - 1.0) / 2.0;
    let mut cam = Camera::new(
        DVec3::new(c, c, -30.0),
        DVec3::new(c, c, c),
        DVec3::Y,
        40.0,
        32,
        32,
    )
    .expect("camera");
    cam.image_plane = ImagePlane::Camera;
    let prep = Prepared::new(&vol, &cam).expect("view");
    // The reference's default step (a quarter voxel) point-samples a skin
    // a tenth of a voxel thick; a fine step integrates it.
    let mut fine = RenderOptions::default();
    fine.reference.step = 0.01;
    let reference = render(&prep, &lut, Technique::Reference, &fine)
        .expect("reference")
        .image;
    for m in [Method::Er, Method::ErFtb, Method::Over] {
        let mut opts = RenderOptions::default();
        let plain = render(&prep, &lut, Technique::Slice(m), &opts)
            .expect("plain")
            .image;
        opts.slice.preintegrate = true;
        let pre = render(&prep, &lut, Technique::Slice(m), &opts)
            .expect("pre")
            .image;
        let ep = compare(&plain, &reference).expect("sizes");
        let eq = compare(&pre, &reference).expect("sizes");
        println!(
            "{}: rmse plain {:.4}, pre-integrated {:.4}",
            m.name(),
            ep.rmse,
            eq.rmse
        );
        assert!(
            eq.rmse * 4.0 < ep.rmse,
            "{}: {} against {}",
            m.name(),
            eq.rmse,
            ep.rmse
        );
    }
}

#[test]
fn preint_refuses_substeps() {
    let o = Options {
        preintegrate: true,
        substeps: 2,
        ..Options::default()
    };
    let e = o.validate().unwrap_err().to_string();
    assert!(e.contains("--substeps") && !e.contains('\n'), "{e}");
}

#[test]
fn below_clear_below_every_step_is_transparent() {
    // An 8-bit table (bins are entries) and a 16-bit one (coarser bins).
    let wide = crate::scenes::tf(&[
        (0.0, [0.0; 4]),
        (60.0 * 256.0, [0.2, 0.4, 0.9, 0.0]),
        (140.0 * 256.0, [1.0, 0.7, 0.2, 0.6]),
        (65535.0, [1.0, 1.0, 1.0, 0.95]),
    ]);
    for lut in [ramp(), golden::render::lut_for(VoxelType::U16, &wide)] {
        let pt = PreTable::new(&lut);
        let clear = pt.clear_below();
        assert!(clear.is_finite() && clear > 0.0, "{clear}");
        let ps = pt.per_scalar();
        let mut f = 0.0f32;
        while f < clear {
            let mut b = 0.0f32;
            while b < clear {
                assert_eq!(pt.lookup(f / ps, b / ps)[3], 0.0, "at ({f}, {b})");
                b += 0.125;
            }
            f += 0.125;
        }
        // Half a bin past the bound, either end reaches a visible bin.
        assert!(pt.lookup((clear + 0.5) / ps, 0.0)[3] > 0.0);
        assert!(pt.lookup(0.0, (clear + 0.5) / ps)[3] > 0.0);
    }
    let visible_at_zero = table(&[(0.0, [1.0, 1.0, 1.0, 0.5]), (255.0, [1.0; 4])]);
    assert_eq!(
        PreTable::new(&visible_at_zero).clear_below(),
        f32::NEG_INFINITY
    );
    let clear_table = table(&[(0.0, [1.0, 1.0, 1.0, 0.0]), (255.0, [1.0, 1.0, 1.0, 0.0])]);
    assert_eq!(PreTable::new(&clear_table).clear_below(), f32::INFINITY);
}

/// The attenuated colouring against the fine march: on every segment of
/// a grid of front and back scalars and step lengths it is closer to the
/// self-attenuated integral than the fast colouring, by a wide margin
/// where the step is thick, and exact for a colour linear in the
/// extinction fraction (a constant extinction with a linear colour).
#[test]
fn preint_attenuated_colour_follows_the_attenuation_inside_the_step() {
    use golden::preint::segment_attenuation;
    let lut = ramp();
    let (fast, att) = (
        PreTable::new(&lut),
        PreTable::with_colouring(&lut, Colouring::Attenuated),
    );
    let (mut worst_fast, mut worst_att, mut sum_fast, mut sum_att) = (0f64, 0f64, 0f64, 0f64);
    for sf in (0..=255).step_by(15) {
        for sb in (0..=255).step_by(15) {
            for ds in [0.5f32, 1.0, 2.0, 4.0] {
                let (sf, sb) = (sf as f32, sb as f32);
                let m = march(&lut, sf, sb, ds, 4_000);
                let (e, k) = att.lookup_with_slope(sf, sb);
                if e[3] <= 0.0 {
                    continue;
                }
                let (a, h) = segment_attenuation(e[3], ds);
                assert_eq!(a.to_bits(), segment_opacity(e[3], ds).to_bits());
                let (cf, ca) = (
                    fast.step_colour(&fast.lookup(sf, sb), &[0.0; 4], 0.0),
                    att.step_colour(&e, &k, h),
                );
                for ch in 0..3 {
                    let df = (f64::from(cf[ch] * a) - m[ch]).abs();
                    let da = (f64::from(ca[ch] * a) - m[ch]).abs();
                    worst_fast = worst_fast.max(df);
                    worst_att = worst_att.max(da);
                    sum_fast += df;
                    sum_att += da;
                }
            }
        }
    }
    println!(
        "premultiplied colour against the march: fast worst {worst_fast:.2e} sum {sum_fast:.3}, attenuated worst {worst_att:.2e} sum {sum_att:.3}"
    );
    assert!(
        worst_att < worst_fast / 3.0,
        "{worst_att} against {worst_fast}"
    );
    assert!(sum_att < sum_fast / 5.0, "{sum_att} against {sum_fast}");
    // Constant opacity, colour linear in the scalar: the extinction
    // fraction is the scalar's, the colour linear in it, so exact.
    let lin = table(&[(0.0, [0.0, 0.2, 1.0, 0.5]), (255.0, [1.0, 0.6, 0.0, 0.5])]);
    let pt = PreTable::with_colouring(&lin, Colouring::Attenuated);
    for (sf, sb, ds) in [(10.0f32, 240.0f32, 3.0f32), (200.0, 20.0, 1.0)] {
        let (e, k) = pt.lookup_with_slope(sf, sb);
        let (a, h) = segment_attenuation(e[3], ds);
        let c = pt.step_colour(&e, &k, h);
        let m = march(&lin, sf, sb, ds, 20_000);
        for ch in 0..3 {
            let d = (f64::from(c[ch] * a) - m[ch]).abs();
            assert!(d < 2e-4, "{sf}..{sb} ds {ds} channel {ch}: off by {d}");
        }
    }
}
