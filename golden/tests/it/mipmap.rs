//! 3D mip-map ray casting (`golden::mipmap`, `golden::mipcast`): the
//! pyramid's box filter, level selection against footprints measured from
//! the pixel rays, coarse levels far and level 0 near, exact skipping,
//! determinism across thread counts, and the error against the reference
//! beside undersampling's.
//!
//! `cargo test --release -p golden --test it -- --nocapture mipmap` prints
//! the measured errors.

use glam::DVec3;
use golden::camera::{Camera, ImagePlane};
use golden::clip::ClipPlane;
use golden::methods::Method;
use golden::metrics::compare;
use golden::mipcast::{footprint_angle, level_at, voxel_size};
use golden::mipmap::{Classify, MipMap};
use golden::render::{lut_for, render, PrepareOptions, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;
use golden::volume::VoxelType;

use crate::scenes::{scene, sparse, table, volume_u8};

fn camera(eye: DVec3, look: DVec3, fov: f64, w: u32, h: u32) -> Camera {
    let f = (look - eye).normalize();
    let up = if f.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    Camera::new(eye, look, up, fov, w, h).expect("camera")
}

fn opts(classify: Classify, skip: bool) -> RenderOptions {
    let mut o = RenderOptions {
        mip_classify: classify,
        ..RenderOptions::default()
    };
    o.slice.skips.empty = skip;
    o
}

fn bits(v: &[[f32; 4]]) -> Vec<[u32; 4]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

#[test]
fn the_pyramid_of_a_constant_volume_is_that_constant_at_every_level() {
    let vol = volume_u8([13, 8, 5], |_, _, _| 100);
    let lut = table(&[(0.0, [0.0; 4]), (255.0, [1.0, 0.5, 0.25, 0.8])]);
    let cam = camera(
        DVec3::new(6.0, 4.0, -20.0),
        DVec3::new(6.0, 4.0, 2.0),
        40.0,
        8,
        8,
    );
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    for classify in [Classify::Pre, Classify::Post] {
        let m = MipMap::build(&prep.stack, &lut, classify).expect("pyramid");
        // 13 -> 7 -> 4 -> 2 -> 1 voxels along x.
        assert_eq!(m.levels.len(), 5, "{classify:?}");
        assert_eq!(m.levels[m.top()].dims, [1, 1, 1]);
        let want = m.levels[0].data[0];
        for (l, level) in m.levels.iter().enumerate() {
            assert!(
                level.data.iter().all(|v| *v == want),
                "{classify:?} level {l} is not exactly the constant"
            );
        }
    }
}

#[test]
fn the_filter_is_the_2x2x2_box_mean_with_replicated_odd_edges() {
    // A 3x2x2 level 0: the 2x2x2 block x in 0..2 and the odd column x = 2.
    let a = |x: usize, y: usize, z: usize| (1 + x + 3 * y + 6 * z) as f32;
    let mut base = Vec::new();
    for z in 0..2 {
        for y in 0..2 {
            for x in 0..3 {
                let v = a(x, y, z);
                base.push([v * 0.5, v * 0.25, v, v / 16.0]);
            }
        }
    }
    let m = MipMap::from_base([3, 2, 2], base, Classify::Pre).expect("pyramid");
    assert_eq!(m.levels[1].dims, [2, 1, 1]);
    let block: f32 = (0..8).map(|i| a(i & 1, (i >> 1) & 1, i >> 2)).sum::<f32>() / 8.0;
    // The odd column x = 2 repeats itself for the missing x = 3.
    let edge: f32 = (0..8).map(|i| a(2, (i >> 1) & 1, i >> 2)).sum::<f32>() / 8.0;
    assert_eq!(
        m.levels[1].data[0],
        [block * 0.5, block * 0.25, block, block / 16.0]
    );
    assert_eq!(
        m.levels[1].data[1],
        [edge * 0.5, edge * 0.25, edge, edge / 16.0]
    );
    // The top is the mean of those two (a 2x1x1 level: each counted four times).
    assert_eq!(m.levels[2].data[0][2], (block + edge) / 2.0);
    // Post-classified: channel 0 the mean, 1 and 2 the range of the base.
    let scalars: Vec<[f32; 4]> = (0..12)
        .map(|i| {
            let v = a(i % 3, (i / 3) % 2, i / 6);
            [v, v, v, 0.0]
        })
        .collect();
    let p = MipMap::from_base([3, 2, 2], scalars, Classify::Post).expect("pyramid");
    assert_eq!(p.levels[1].data[0], [block, a(0, 0, 0), a(1, 1, 1), 0.0]);
    assert_eq!(p.levels[2].data[0][1..3], [1.0, 12.0]);
}

/// The footprint `r * angle` agrees with the spacing of neighbouring pixel
/// rays measured at distance `r`, and the level is its `log2` in voxels.
#[test]
fn the_level_follows_the_footprint_measured_between_neighbouring_rays() {
    let vol = volume_u8([32, 32, 32], |_, _, _| 0)
        .with_spacing([1.0, 1.0, 2.0])
        .unwrap();
    for (fov, plane) in [(60.0, ImagePlane::Camera), (120.0, ImagePlane::Front)] {
        let mut cam = camera(
            DVec3::new(40.0, 10.0, -50.0),
            DVec3::new(15.5, 15.5, 31.0),
            fov,
            64,
            48,
        );
        cam.image_plane = plane;
        let prep = Prepared::new(&vol, &cam).expect("prepare");
        let view = &prep.view;
        let voxel = voxel_size(view);
        assert!((voxel - 2f64.cbrt()).abs() < 1e-12);
        let world = |v: DVec3| DVec3::from_array(std::array::from_fn(|k| v[k] * view.spacing[k]));
        let unit = |px: f64, py: f64| world(view.rays.dir(px, py)).normalize();
        for (px, py) in [(32.0, 24.0), (0.5, 0.5), (63.5, 10.5), (20.5, 47.5)] {
            let angle = footprint_angle(view, px, py);
            for r in [5.0, 50.0, 200.0, 2000.0] {
                // Points at distance r on this ray and on its neighbours.
                let p = unit(px, py) * r;
                let dx = (unit(px + 1e-3, py) * r - p).length() / 1e-3;
                let dy = (unit(px, py + 1e-3) * r - p).length() / 1e-3;
                let measured = (dx * dy).sqrt();
                let model = r * angle;
                assert!(
                    (model / measured - 1.0).abs() < 1e-3,
                    "fov {fov} pixel ({px}, {py}) r {r}: footprint {model} vs measured {measured}"
                );
                let l = level_at(r, angle, voxel, 5);
                let want = (measured / voxel).log2().clamp(0.0, 5.0);
                assert!((l - want).abs() < 2e-3, "level {l} vs {want}");
            }
        }
    }
}

/// Far away the samples come from coarse levels, near the eye from level 0.
#[test]
fn a_far_view_reads_coarse_levels_and_a_near_view_level_0() {
    let vol = scene("ml:64");
    let lut = lut_for(VoxelType::U8, &tf_preset("ml").expect("preset"));
    let c = DVec3::splat(31.5);
    let hist = |eye: DVec3, fov: f64| {
        let prep = Prepared::new(&vol, &camera(eye, c, fov, 64, 64)).expect("prepare");
        let f = render(&prep, &lut, Technique::MipMap, &RenderOptions::default()).unwrap();
        f.mip.expect("mip stats").level_histogram
    };
    // 64 pixels over 60 degrees at ~1000 voxels: a footprint of ~18 voxels.
    let far = hist(DVec3::new(31.5, 31.5, -1000.0), 60.0);
    let total: u64 = far.iter().sum();
    assert!(far[4] as f64 > 0.9 * total as f64, "far histogram {far:?}");
    assert_eq!(far[0] + far[1] + far[2], 0, "far histogram {far:?}");
    // Close in with a narrow view: every footprint under a voxel.
    let near = hist(DVec3::new(31.5, 31.5, -4.0), 20.0);
    assert!(
        near[0] > 0 && near[1..].iter().all(|&n| n == 0),
        "near {near:?}"
    );
}

/// Empty-space skipping through the pyramid's octree leaves every image
/// bit for bit unchanged: sparse volumes, both classifications, eyes
/// outside on several sides, inside the volume (near plane) and with a
/// clip plane, images on the camera and on the front face.
#[test]
fn skipping_through_the_octree_leaves_the_image_bit_identical() {
    let lut = table(&[
        (0.0, [0.0; 4]),
        (70.0, [0.0; 4]),
        (160.0, [1.0, 0.7, 0.3, 0.6]),
        (255.0, [0.2, 0.4, 1.0, 0.9]),
    ]);
    let views = [
        (
            DVec3::new(20.0, 15.0, -60.0),
            50.0,
            None,
            ImagePlane::Camera,
        ),
        (DVec3::new(90.0, -30.0, 20.0), 70.0, None, ImagePlane::Front),
        (
            DVec3::new(10.0, 200.0, 300.0),
            25.0,
            None,
            ImagePlane::Camera,
        ),
        (DVec3::new(17.0, 14.0, 12.0), 90.0, None, ImagePlane::Camera),
        (
            DVec3::new(-40.0, 20.0, -30.0),
            60.0,
            Some(ClipPlane::new(DVec3::new(1.0, 0.3, 0.2), -14.0).unwrap()),
            ImagePlane::Camera,
        ),
    ];
    let mut skipped = 0;
    for seed in 0..3 {
        let vol = sparse([36, 30, 26], 5, seed);
        let c = DVec3::new(17.5, 14.5, 12.5);
        for (eye, fov, clip, plane) in &views {
            let look = if (*eye - c).length() < 10.0 {
                c + DVec3::new(0.0, 0.0, 20.0)
            } else {
                c
            };
            let mut cam = camera(*eye, look, *fov, 40, 32);
            cam.image_plane = *plane;
            let po = PrepareOptions {
                clip: clip.iter().copied().collect(),
                ..PrepareOptions::default()
            };
            let prep = Prepared::with(&vol, &cam, &po).expect("prepare");
            for classify in [Classify::Pre, Classify::Post] {
                let on = render(&prep, &lut, Technique::MipMap, &opts(classify, true)).unwrap();
                let off = render(&prep, &lut, Technique::MipMap, &opts(classify, false)).unwrap();
                assert!(
                    bits(&on.image.data) == bits(&off.image.data),
                    "seed {seed} eye {eye} {classify:?}: skipping changed the image"
                );
                let (s_on, s_off) = (on.mip.unwrap(), off.mip.unwrap());
                assert_eq!(
                    s_on.samples_total + s_on.samples_skipped,
                    s_off.samples_total
                );
                skipped += s_on.samples_skipped;
            }
        }
    }
    assert!(skipped > 0, "the views must skip something");
}

#[test]
fn images_and_stats_are_identical_with_1_2_and_3_threads() {
    let vol = sparse([30, 26, 34], 6, 11);
    let lut = table(&[
        (0.0, [0.0; 4]),
        (80.0, [0.0; 4]),
        (255.0, [1.0, 0.6, 0.3, 0.5]),
    ]);
    let cam = camera(
        DVec3::new(40.0, -9.0, -25.0),
        DVec3::new(14.5, 12.5, 16.5),
        70.0,
        40,
        36,
    );
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                [Classify::Pre, Classify::Post].map(|c| {
                    let f = render(&prep, &lut, Technique::MipMap, &opts(c, true)).unwrap();
                    (bits(&f.image.data), f.mip)
                })
            })
    };
    let one = run(1);
    assert!(
        one[0].0.iter().any(|p| p[3] != 0),
        "the view shows something"
    );
    for threads in [2, 3] {
        assert!(run(threads) == one, "mipmap differs with {threads} threads");
    }
}

/// RMSE against the reference, at 64x64 on the 64^3 scenes, of mipmap
/// (post- and pre-classified) and undersampling, near and far.
fn errors(spec: &str, preset: &str, dist: f64, fov: f64, px: u32) -> [f64; 3] {
    let vol = scene(spec);
    let lut = lut_for(VoxelType::U8, &tf_preset(preset).expect("preset"));
    let c = DVec3::splat(31.5);
    let cam = camera(DVec3::new(31.5, 31.5, -dist), c, fov, px, px);
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    let reference = render(&prep, &lut, Technique::Reference, &RenderOptions::default()).unwrap();
    let e = |t: Technique, o: RenderOptions| {
        compare(&render(&prep, &lut, t, &o).unwrap().image, &reference.image)
            .unwrap()
            .rmse
    };
    let r = [
        e(Technique::MipMap, opts(Classify::Post, true)),
        e(Technique::MipMap, opts(Classify::Pre, true)),
        e(Technique::Slice(Method::Under), RenderOptions::default()),
    ];
    eprintln!(
        "{spec} ({preset}) at {dist}, {fov} deg, {px}x{px}: mipmap post / pre / under rmse {r:.4?}"
    );
    r
}

/// The bounds are the measured errors with a margin (printed with
/// `--nocapture`; docs/golden.md). Near (32 voxels, 90 degrees), the
/// mip-map's level-0 samples at half a voxel beat undersampling's one
/// sample per slice on both scenes (post-classified: 0.015 / 0.019 on
/// Marschner-Lobb, 0.10 / 0.17 on the checkerboard). Far away (400
/// voxels) the expectation, below undersampling, is **not** what
/// was measured: both are within about 20% of each other (0.036 / 0.035,
/// 0.065 / 0.054; minified to 16x16, 0.106 / 0.109 and 0.27 / 0.22).
/// There one ray per pixel through an isotropic box of one pixel's
/// footprint is set against the reference's 4x4 rays under a tent two
/// pixels wide, and that 2D pixel filter, not 3D aliasing, dominates.
#[test]
fn error_against_the_reference_is_bounded_below_undersampling_near_and_close_to_it_far() {
    let mut got = Vec::new();
    for (spec, preset) in [("ml:64", "ml"), ("checker:64", "checker")] {
        got.push((spec, "near", errors(spec, preset, 32.0, 90.0, 64)));
        got.push((spec, "far", errors(spec, preset, 400.0, 60.0, 64)));
        got.push((spec, "minified", errors(spec, preset, 400.0, 10.0, 16)));
    }
    for (spec, what, e) in got {
        let (bound, vs_under) = match (spec, what) {
            ("ml:64", "near") => (0.02, 1.0),
            ("checker:64", "near") => (0.13, 1.0),
            ("ml:64", _) => (0.13, 1.3),
            _ => (0.33, 1.5),
        };
        assert!(e[0] < bound, "{spec} {what}: rmse {} over {bound}", e[0]);
        assert!(
            e[0] < vs_under * e[2],
            "{spec} {what}: mipmap {} vs under {} (allowed x{vs_under})",
            e[0],
            e[2]
        );
    }
}
