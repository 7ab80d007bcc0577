//! Test scenes shared by every crate's integration tests: pseudo-random
//! and smooth volumes, transfer functions, eyes and up vectors, buffer
//! differences, and where the real MRI head lives. Golden types only, so
//! golden's own tests can include it (`#[path]` from `tests/support/`);
//! the pipeline's helpers are in `chip.rs`.
#![allow(dead_code)]

use glam::DVec3;
use golden::render::lut_for;
use golden::tf::{ControlPoint, Lut, TransferFunction};
use golden::volume::{Volume, VoxelType, DEFAULT_MEMORY_LIMIT};
use proptest::prelude::*;

/// A 64-bit mix (splitmix64's finaliser): deterministic pseudo-random bits.
/// (The skipping tests' volumes are drawn from it; [`splitmix64`] is the
/// full generator step the figure and stress tests draw theirs from.)
pub fn hash(mut x: u64) -> u64 {
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    x ^ (x >> 33)
}

/// One step of SplitMix64 (increment, then the finaliser).
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// [`splitmix64`] of a voxel's coordinates under `seed`.
pub fn voxel_hash(seed: u64, x: usize, y: usize, z: usize) -> u64 {
    splitmix64(seed ^ (x as u64 | (y as u64) << 20 | (z as u64) << 40))
}

/// A volume of `kind` voxels from `f(x, y, z)`.
pub fn volume(
    dims: [usize; 3],
    kind: VoxelType,
    f: impl Fn(usize, usize, usize) -> u16 + Sync,
) -> Volume {
    Volume::from_fn(dims, kind, DEFAULT_MEMORY_LIMIT, f).expect("volume")
}

/// An 8-bit [`volume`].
pub fn volume_u8(dims: [usize; 3], f: impl Fn(usize, usize, usize) -> u16 + Sync) -> Volume {
    volume(dims, VoxelType::U8, f)
}

/// A built-in scene (`checker:32`, `ml:24`, ...).
pub fn scene(spec: &str) -> Volume {
    spec.parse::<golden::scenes::Scene>()
        .expect("scene spec")
        .build(DEFAULT_MEMORY_LIMIT)
        .expect("scene builds")
}

/// A coordinate axis far from parallel to `f`, as an up vector.
pub fn up_for(f: DVec3) -> DVec3 {
    let f = f.normalize();
    [DVec3::Y, DVec3::Z, DVec3::X]
        .into_iter()
        .min_by(|a, b| a.dot(f).abs().total_cmp(&b.dot(f).abs()))
        .expect("three candidates")
}

/// The real MRI head the repository ships, `data/brainsmall.den` (see
/// data/README.md), found upwards from the including crate.
pub fn brainsmall() -> Option<std::path::PathBuf> {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .map(|d| d.join("data/brainsmall.den"))
        .find(|p| p.is_file())
}

/// brainsmall with the golden issue's camera (eye (64, 64, -64) to the
/// centre, 90 degrees, 256x256); `None`, after printing the skip line,
/// when the file is absent.
pub fn brainsmall_view() -> Option<(Volume, golden::camera::Camera)> {
    let Some(path) = brainsmall() else {
        eprintln!("skipped: data/brainsmall.den is absent");
        return None;
    };
    let vol = golden::load::load_den(&path, DEFAULT_MEMORY_LIMIT).expect("brainsmall loads");
    let c = DVec3::from_array(vol.center_world());
    let eye = DVec3::new(64.0, 64.0, -64.0);
    let cam = golden::camera::Camera::new(eye, c, DVec3::Y, 90.0, 256, 256).expect("camera");
    Some((vol, cam))
}

/// `vol` prepared for a `w x h` camera at `eye` looking at its centre
/// (`None` when the camera or the view is refused).
pub fn centred_view(
    vol: &Volume,
    eye: DVec3,
    up: DVec3,
    fov: f64,
    w: u32,
    h: u32,
) -> Option<golden::render::Prepared> {
    let c = DVec3::from_array(vol.center_world());
    let cam = golden::camera::Camera::new(eye, c, up, fov, w, h).ok()?;
    golden::render::Prepared::new(vol, &cam).ok()
}

/// A small two-blob scene, its table at `entries` entries, and three
/// views: from the front, from a side and from close up (several
/// regions).
pub fn small_views(entries: usize) -> (Volume, Lut, Vec<golden::render::Prepared>) {
    let vol = blobs(
        [20, 18, 22],
        &[(0.4, 0.5, 0.5, 0.3, 220.0), (0.7, 0.4, 0.6, 0.2, 160.0)],
        10,
        7,
    );
    let tf = tf(&[(30.0, [1.0, 0.5, 0.2, 0.0]), (200.0, [0.9, 0.9, 1.0, 0.7])]);
    let lut = Lut::for_bits(&tf, entries, vol.kind().bits());
    let views = [(0, 30.0), (3, 8.0), (4, 2.0)]
        .into_iter()
        .filter_map(|(side, dist)| {
            let (eye, up) = eye_for(vol.dims(), side, dist, (0.3, 0.6));
            centred_view(&vol, eye, up, 50.0, 24, 20)
        })
        .collect();
    (vol, lut, views)
}

/// Air (values below 40) with `blobs` random balls of tissue (60..255)
/// and some noise: mostly empty, as real scans are.
pub fn sparse(dims: [usize; 3], blobs: usize, seed: u64) -> Volume {
    let centres: Vec<([f64; 3], f64)> = (0..blobs as u64)
        .map(|b| {
            let h = |k: u64| (hash(seed ^ (b * 7 + k)) % 10_000) as f64 / 10_000.0;
            (
                std::array::from_fn(|a| h(a as u64) * dims[a] as f64),
                1.0 + h(3) * dims.iter().copied().min().unwrap_or(1) as f64 / 3.0,
            )
        })
        .collect();
    Volume::from_fn(dims, VoxelType::U8, DEFAULT_MEMORY_LIMIT, |x, y, z| {
        let p = [x as f64, y as f64, z as f64];
        let noise = (hash(seed ^ ((z * dims[1] + y) * dims[0] + x) as u64) % 40) as u16;
        for (c, r) in &centres {
            let d2: f64 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum();
            if d2 <= r * r {
                return 60 + ((d2.sqrt() / r) * 190.0) as u16 + noise / 8;
            }
        }
        noise
    })
    .expect("volume")
}

/// A transfer function from `(value, rgba)` control points in any order.
pub fn tf(points: &[(f64, [f64; 4])]) -> TransferFunction {
    let mut pts: Vec<ControlPoint> = points
        .iter()
        .map(|&(value, rgba)| ControlPoint { value, rgba })
        .collect();
    pts.sort_by(|a, b| a.value.total_cmp(&b.value));
    TransferFunction::new(pts).expect("tf")
}

/// Gaussian blobs `(cx, cy, cz, r, amplitude)` (centres and radii as
/// fractions of the volume) plus hashed noise below `noise`: smooth data
/// with a controllable rough part.
pub fn blobs(
    dims: [usize; 3],
    blobs: &[(f64, f64, f64, f64, f64)],
    noise: u16,
    seed: u64,
) -> Volume {
    Volume::from_fn(dims, VoxelType::U8, DEFAULT_MEMORY_LIMIT, |x, y, z| {
        let p = [
            x as f64 / dims[0] as f64,
            y as f64 / dims[1] as f64,
            z as f64 / dims[2] as f64,
        ];
        let mut v = 0.0;
        for &(cx, cy, cz, r, a) in blobs {
            let d2 = (p[0] - cx).powi(2) + (p[1] - cy).powi(2) + (p[2] - cz).powi(2);
            v += a * (-d2 / (r * r)).exp();
        }
        let h =
            ((x as u64 * 73_856_093) ^ (y as u64 * 19_349_663) ^ (z as u64 * 83_492_791) ^ seed)
                .wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let n = if noise > 0 {
            (h >> 40) % u64::from(noise)
        } else {
            0
        };
        (v.clamp(0.0, 255.0) as u64 + n).min(255) as u16
    })
    .expect("volume")
}

/// An eye outside face `side` (axis `side / 2`, low or high), `dist` from
/// it, offset across it by fractions `off` of the volume, and an up vector
/// not parallel to the view.
pub fn eye_for(dims: [usize; 3], side: usize, dist: f64, off: (f64, f64)) -> (DVec3, DVec3) {
    let axis = side / 2;
    let n = dims.map(|d| d as f64);
    let mut e = [0.0; 3];
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    e[a] = off.0 * n[a];
    e[b] = off.1 * n[b];
    e[axis] = if side.is_multiple_of(2) {
        -dist
    } else {
        n[axis] - 1.0 + dist
    };
    let up = if axis == 1 { DVec3::Z } else { DVec3::Y };
    (DVec3::from_array(e), up)
}

/// Golden's table of [`tf`] for 8-bit data.
pub fn table(points: &[(f64, [f64; 4])]) -> Lut {
    lut_for(VoxelType::U8, &tf(points))
}

/// An eye `dist` voxels outside face `side` of a `dims` volume, on the
/// line through its centre, looking at the centre moved across the face by
/// fractions `look` of the volume (narrow views then see only part of it).
pub fn eye_and_look(dims: [usize; 3], side: usize, dist: f64, look: [f64; 2]) -> (DVec3, DVec3) {
    let n = dims.map(|d| d as f64);
    let centre = DVec3::new(n[0] - 1.0, n[1] - 1.0, n[2] - 1.0) * 0.5;
    let axis = side / 2;
    let mut eye = centre;
    eye[axis] = if side.is_multiple_of(2) {
        -dist
    } else {
        n[axis] - 1.0 + dist
    };
    let mut at = centre;
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    at[a] += look[0] * n[a];
    at[b] += look[1] * n[b];
    (eye, at)
}

/// Random Gaussian blobs for [`blobs`]: one to three of them.
pub fn blob_strategy() -> impl Strategy<Value = Vec<(f64, f64, f64, f64, f64)>> {
    prop::collection::vec(
        (
            0.0..1.0f64,
            0.0..1.0f64,
            0.0..1.0f64,
            0.1..0.6f64,
            0.0..300.0f64,
        ),
        1..4,
    )
}

/// Random transfer-function control points for [`tf`]: two to five.
pub fn tf_points_strategy() -> impl Strategy<Value = Vec<(f64, [f64; 4])>> {
    prop::collection::vec(
        (
            0.0..255.0f64,
            [0.0..=1.0f64, 0.0..=1.0, 0.0..=1.0, 0.0..=1.0],
        ),
        2..6,
    )
}

/// Largest per-channel difference between two float RGBA buffers.
pub fn max_diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| (0..4).map(move |c| (f64::from(p[c]) - f64::from(q[c])).abs()))
        .fold(0.0, f64::max)
}

/// [`max_diff`] in `f32`: the same number an `f32` subtraction gives,
/// since both round the exact difference once.
pub fn max_diff_f32(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    max_diff(a, b) as f32
}

/// The paper's two views of the 128^3 checkerboard, image on the front
/// face: D = 32 at 127 degrees and D = 64 at 90, 128x128.
pub fn checker128_views() -> Vec<(f64, f64, golden::camera::Camera)> {
    [(32.0, 127.0), (64.0, 90.0)]
        .into_iter()
        .map(|(d, fov)| {
            let mut cam = golden::camera::Camera::new(
                DVec3::new(64.0, 64.0, -d),
                DVec3::splat(63.5),
                DVec3::Y,
                fov,
                128,
                128,
            )
            .expect("camera");
            cam.image_plane = golden::camera::ImagePlane::Front;
            (d, fov, cam)
        })
        .collect()
}
