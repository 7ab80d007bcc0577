//! Batched sampling (`golden::methods::Options::lanes`, eight rays at a
//! time with a branch-free opacity correction: plain, with substeps or
//! pre-integrated)
//! against the one-ray path:
//! every slice-order method's baseplane, image and sample counts are bit
//! for bit the same, back to front and front to back, with and without
//! skipping, termination and clip planes, on random sparse volumes,
//! tables and views (proptest), on 16-bit data and on brainsmall.
//!
//! `cargo test --release -p golden --test it -- lanes`

use glam::DVec3;
use golden::camera::Camera;
use golden::clip::ClipPlane;
use golden::methods::{Method, Options};
use golden::preint::Colouring;
use golden::render::{render, PrepareOptions, Prepared, RenderOptions, Technique};
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::{Volume, VoxelType, DEFAULT_MEMORY_LIMIT};
use proptest::prelude::*;

use crate::scenes::{eye_and_look, sparse, table};

fn bits(v: &[[f32; 4]]) -> Vec<[u32; 4]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

/// Renders `m` both ways and fails on the first word that differs.
fn same_both_ways(
    prep: &Prepared,
    lut: &Lut,
    m: Method,
    slice: Options,
) -> Result<u64, TestCaseError> {
    let frame = |lanes: bool| {
        let opts = RenderOptions {
            slice: Options { lanes, ..slice },
            ..RenderOptions::default()
        };
        render(prep, lut, Technique::Slice(m), &opts).expect("render")
    };
    let (fast, slow) = (frame(true), frame(false));
    let (f, s) = (fast.slice.expect("slice"), slow.slice.expect("slice"));
    let (fb, sb) = (bits(&f.baseplane.data), bits(&s.baseplane.data));
    let first = fb.iter().zip(&sb).position(|(a, b)| a != b);
    prop_assert!(
        first.is_none() && fb.len() == sb.len(),
        "{} baseplane differs at {:?}: {:?}",
        m.name(),
        first,
        first.map(|i| (f.baseplane.data[i], s.baseplane.data[i]))
    );
    prop_assert_eq!(bits(&fast.image.data), bits(&slow.image.data));
    prop_assert_eq!(&f.stats.samples_per_slice, &s.stats.samples_per_slice);
    prop_assert_eq!(f.stats.beams_skipped, s.stats.beams_skipped);
    Ok(f.stats.samples_total)
}

fn lut(threshold: f64) -> Lut {
    table(&[
        (0.0, [0.0; 4]),
        (threshold, [0.2, 0.3, 0.9, 0.0]),
        (threshold + 30.0, [1.0, 0.6, 0.2, 0.3]),
        (threshold + 60.0, [0.9, 0.9, 0.4, 0.8]),
        (255.0, [1.0, 1.0, 1.0, 1.0]),
    ])
}

#[allow(clippy::too_many_arguments)]
fn check(
    vol: &Volume,
    threshold: f64,
    (side, dist, look, fov): (usize, f64, [f64; 2], f64),
    size: (u32, u32),
    block: usize,
    terminate: f32,
    skips: Skips,
    clip: Option<([f64; 3], f64)>,
) -> Result<u64, TestCaseError> {
    let lut = lut(threshold);
    let (eye, at) = eye_and_look(vol.dims(), side, dist, look);
    let f = (at - eye).normalize();
    let up = if f.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    let cam = Camera::new(eye, at, up, fov, size.0, size.1).expect("camera");
    let mut opts = PrepareOptions {
        block,
        ..PrepareOptions::default()
    };
    if let Some((n, d)) = clip {
        opts.clip = vec![ClipPlane::new(DVec3::from_array(n), d).expect("plane")];
    }
    let prep =
        Prepared::with(vol, &cam, &opts).map_err(|e| TestCaseError::reject(e.to_string()))?;
    let mut samples = 0;
    for m in Method::ALL {
        for (preintegrate, pre_colouring, substeps) in [
            (false, Colouring::Fast, 1),
            (true, Colouring::Fast, 1),
            (true, Colouring::Attenuated, 1),
            (false, Colouring::Fast, 2),
            (false, Colouring::Fast, 3),
        ] {
            let slice = Options {
                terminate,
                skips,
                preintegrate,
                pre_colouring,
                substeps,
                ..Options::default()
            };
            samples += same_both_ways(&prep, &lut, m, slice)?;
        }
    }
    Ok(samples)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    /// Batches of rays give the one-ray path's bits for every method,
    /// view, table, skipping choice, threshold and clip plane.
    #[test]
    fn lanes_are_bit_identical_to_one_ray_at_a_time(
        dims in prop::array::uniform3(6usize..30),
        blobs in 1usize..6,
        seed in any::<u64>(),
        threshold in 10.0..120.0f64,
        side in 0usize..6,
        dist in prop_oneof![0.3..4.0f64, 4.0..60.0],
        look in prop::array::uniform2(-0.6..0.6f64),
        fov in prop_oneof![10.0..40.0f64, 40.0..150.0],
        block in prop::sample::select(vec![2usize, 4, 8]),
        terminate in prop_oneof![Just(1.0f32), 0.3..0.99f32],
        skip in any::<bool>(),
        clip in prop::option::of((prop::array::uniform3(-1.0..1.0f64), -20.0..20.0f64)),
    ) {
        let clip = clip.filter(|(n, _)| n.iter().any(|v| v.abs() > 0.05));
        let skips = if skip { Skips::default() } else { Skips::NONE };
        let vol = sparse(dims, blobs, seed);
        check(&vol, threshold, (side, dist, look, fov), (37, 29), block, terminate, skips, clip)?;
    }
}

/// A 16-bit volume (the other plane type) and brainsmall, where rows hold
/// long runs of every length modulo the batch.
#[test]
fn lanes_on_sixteen_bit_data_and_brainsmall() -> Result<(), TestCaseError> {
    // 16-bit words holding 8-bit-scale values, so the table's ramps are
    // crossed as in the 8-bit cases.
    let vol = crate::scenes::volume([40, 33, 27], VoxelType::U16, |x, y, z| {
        (crate::scenes::voxel_hash(7, x / 3, y / 3, z / 3) % 240) as u16
    });
    let taken = check(
        &vol,
        60.0,
        (0, 20.0, [0.1, -0.2], 70.0),
        (64, 48),
        4,
        0.95,
        Skips::default(),
        None,
    )?;
    assert!(taken > 10_000, "{taken} samples");
    let Some(path) = crate::scenes::brainsmall() else {
        println!("skipped: brainsmall.den not found");
        return Ok(());
    };
    let vol = golden::load::load_den(&path, DEFAULT_MEMORY_LIMIT).expect("brainsmall");
    let taken = check(
        &vol,
        30.0,
        (0, 40.0, [0.0, 0.0], 90.0),
        (96, 96),
        8,
        0.99,
        Skips::default(),
        None,
    )?;
    assert!(taken > 50_000, "{taken} samples");
    Ok(())
}
