//! Skipping with several substeps per slice crossing: empty-space runs
//! decided on each ray's segment between its first and last substep
//! (`golden::skip::SampleMask::substep_runs`) leave every method's
//! baseplane and image bit for bit what the unskipped substep path gives
//! (proptest over random sparse volumes, tables, views, block sizes,
//! 2 to 5 substeps and an optional clip plane), and they do skip.
//!
//! `cargo test --release -p golden --test it -- substeps`

use glam::DVec3;
use golden::camera::Camera;
use golden::clip::ClipPlane;
use golden::methods::{self, Method, Options, Output};
use golden::render::{render, PrepareOptions, Prepared, RenderOptions, Technique};
use golden::skip::Skips;
use golden::tf::Lut;
use proptest::prelude::*;

use crate::scenes::{eye_and_look, sparse, table};

fn options(substeps: u32, skips: Skips) -> Options {
    Options {
        terminate: 1.0,
        substeps,
        skips,
        ..Options::default()
    }
}

fn slice(m: Method, p: &Prepared, l: &Lut, substeps: u32, skips: Skips) -> Output {
    methods::render(m, p, l, &options(substeps, skips)).expect("render")
}

fn image_bits(p: &Prepared, l: &Lut, m: Method, substeps: u32, skips: Skips) -> Vec<[u32; 4]> {
    let opts = RenderOptions {
        slice: options(substeps, skips),
        ..RenderOptions::default()
    };
    let img = render(p, l, Technique::Slice(m), &opts).expect("render");
    img.image.data.iter().map(|p| p.map(f32::to_bits)).collect()
}

fn bits(v: &[[f32; 4]]) -> Vec<[u32; 4]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

/// The index of the first word where `a` and `b` differ (or where one
/// ends), so that a failure names a ray instead of printing two frames.
fn first_difference(a: &[[u32; 4]], b: &[[u32; 4]]) -> Option<usize> {
    a.iter()
        .zip(b)
        .position(|(x, y)| x != y)
        .or((a.len() != b.len()).then_some(a.len().min(b.len())))
}

fn lut(threshold: f64) -> Lut {
    table(&[
        (0.0, [0.0; 4]),
        (threshold, [0.2, 0.3, 0.9, 0.0]),
        (threshold + 40.0, [1.0, 0.6, 0.2, 0.5]),
        (255.0, [1.0, 1.0, 1.0, 0.9]),
    ])
}

#[allow(clippy::too_many_arguments)]
fn check(
    dims: [usize; 3],
    blobs: usize,
    seed: u64,
    threshold: f64,
    (side, dist, look, fov): (usize, f64, [f64; 2], f64),
    block: usize,
    substeps: u32,
    clip: Option<([f64; 3], f64)>,
) -> Result<(), TestCaseError> {
    let vol = sparse(dims, blobs, seed);
    let lut = lut(threshold);
    let (eye, at) = eye_and_look(dims, side, dist, look);
    let f = (at - eye).normalize();
    let up = if f.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    let cam = Camera::new(eye, at, up, fov, 36, 30).expect("camera");
    let mut opts = PrepareOptions {
        block,
        ..PrepareOptions::default()
    };
    if let Some((n, d)) = clip {
        opts.clip = vec![ClipPlane::new(DVec3::from_array(n), d).expect("plane")];
    }
    let prep =
        Prepared::with(&vol, &cam, &opts).map_err(|e| TestCaseError::reject(e.to_string()))?;
    for m in Method::ALL {
        let off = slice(m, &prep, &lut, substeps, Skips::NONE);
        let on = slice(m, &prep, &lut, substeps, Skips::EMPTY);
        let first = first_difference(&bits(&on.baseplane.data), &bits(&off.baseplane.data));
        prop_assert!(
            first.is_none(),
            "{} baseplane changed by empty-space skipping at {} substeps: {:?}",
            m.name(),
            substeps,
            first.map(|i| (i, on.baseplane.data[i], off.baseplane.data[i]))
        );
        prop_assert!(on.stats.samples_total <= off.stats.samples_total);
        let first = first_difference(
            &image_bits(&prep, &lut, m, substeps, Skips::default()),
            &image_bits(&prep, &lut, m, substeps, Skips::NONE),
        );
        prop_assert!(
            first.is_none(),
            "{} image changed by skipping at {} substeps: first at pixel {:?}",
            m.name(),
            substeps,
            first
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
    /// Empty-space skipping and culling with 2 to 5 substeps never change
    /// a bit of any method's baseplane or image.
    #[test]
    fn substep_skipping_is_bit_identical(
        dims in prop::array::uniform3(6usize..26),
        blobs in 1usize..5,
        seed in any::<u64>(),
        threshold in 20.0..120.0f64,
        side in 0usize..6,
        dist in prop_oneof![0.3..4.0f64, 4.0..60.0],
        look in prop::array::uniform2(-0.6..0.6f64),
        fov in prop_oneof![10.0..40.0f64, 40.0..150.0],
        block in prop::sample::select(vec![2usize, 4, 8]),
        substeps in 2u32..=5,
        clip in prop::option::of((prop::array::uniform3(-1.0..1.0f64), -20.0..20.0f64)),
    ) {
        let clip = clip.filter(|(n, _)| n.iter().any(|v| v.abs() > 0.05));
        check(dims, blobs, seed, threshold, (side, dist, look, fov), block, substeps, clip)?;
    }
}

/// The cases proptest found where skipping did change a baseplane: an eye
/// 0.3 voxels from a face with a narrow field of view.
#[test]
fn substep_skipping_near_the_eye() -> Result<(), TestCaseError> {
    check(
        [6, 11, 10],
        1,
        12957630168704801925,
        43.85,
        (5, 0.3, [0.0, 0.0], 10.0),
        2,
        3,
        None,
    )?;
    check(
        [16, 10, 11],
        2,
        13263165616351291641,
        81.30686029245028,
        (4, 0.3, [0.0, 0.0], 10.0),
        2,
        2,
        None,
    )
}

/// On a sparse volume with transparent air, two substeps with skipping
/// take a fraction of the unskipped samples (before, substep frames
/// skipped only whole slices), within a small factor of one substep's.
#[test]
fn substep_skipping_saves_samples() {
    let vol = sparse([48, 40, 44], 2, 7);
    let lut = table(&[
        (0.0, [0.0; 4]),
        (50.0, [1.0, 1.0, 1.0, 0.0]),
        (255.0, [1.0; 4]),
    ]);
    let cam = Camera::new(
        DVec3::new(23.5, 19.5, -30.0),
        DVec3::new(23.5, 19.5, 21.5),
        DVec3::Y,
        60.0,
        40,
        32,
    )
    .expect("camera");
    let prep = Prepared::new(&vol, &cam).expect("view");
    for m in [Method::Er, Method::ErFtb] {
        let off = slice(m, &prep, &lut, 2, Skips::NONE).stats.samples_total;
        let on = slice(m, &prep, &lut, 2, Skips::default())
            .stats
            .samples_total;
        let one = slice(m, &prep, &lut, 1, Skips::default())
            .stats
            .samples_total;
        println!(
            "{}: 2 substeps {off} -> {on} crossings (1 substep: {one})",
            m.name()
        );
        assert!(on * 2 < off, "{}: {off} -> {on}", m.name());
        assert!(on < 2 * one, "{}: {on} against {one}", m.name());
    }
}
