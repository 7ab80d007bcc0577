//! Wild inputs: golden never produces NaN or infinity, whatever finite
//! volume, transfer function and view it is given.

use glam::DVec3;
use golden::camera::Camera;
use golden::methods::{Method, Options};
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::volume::{Volume, VoxelType};
use proptest::prelude::*;

use super::{bad_value, eye_at};
use crate::scenes::{splitmix64, tf, up_for, volume, voxel_hash};

/// A random case biased to edges.
#[derive(Clone)]
struct Wild {
    dims: [usize; 3],
    sixteen: bool,
    pattern: u8,
    seed: u64,
    spacing: [f64; 3],
    points: Vec<(f64, [f64; 4])>,
    side: usize,
    dist: f64,
    off: [f64; 2],
    fov: f64,
    size: [u32; 2],
    substeps: u32,
    terminate: f32,
}

/// Shrunk failures print what reproduces them.
impl std::fmt::Debug for Wild {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Wild")
            .field("dims", &self.dims)
            .field("sixteen", &self.sixteen)
            .field("pattern", &self.pattern)
            .field("seed", &self.seed)
            .field("spacing", &self.spacing)
            .field("points", &self.points)
            .field("side", &self.side)
            .field("dist", &self.dist)
            .field("off", &self.off)
            .field("fov", &self.fov)
            .field("size", &self.size)
            .field("substeps", &self.substeps)
            .field("terminate", &self.terminate)
            .finish()
    }
}

fn wild_volume(w: &Wild) -> Volume {
    let (kind, scale) = if w.sixteen {
        (VoxelType::U16, 257u64)
    } else {
        (VoxelType::U8, 1)
    };
    let edges = [0u64, 1, 254, 255];
    let pick = splitmix64(w.seed) as usize % 4;
    volume(w.dims, kind, |x, y, z| {
        let h = voxel_hash(w.seed, x, y, z);
        let v = match w.pattern {
            0 => edges[pick] * scale,
            1 => edges[(h % 4) as usize] * scale,
            2 => (h >> 8) % (255 * scale + 1),
            // A checkerboard of the extremes with random voxels in it.
            _ => {
                if h.is_multiple_of(5) {
                    (h >> 8) % (255 * scale + 1)
                } else {
                    edges[3 * ((x + y + z) % 2)] * scale
                }
            }
        };
        v as u16
    })
    .with_spacing(w.spacing)
    .unwrap()
}

fn wild() -> impl Strategy<Value = Wild> {
    let dim = || prop_oneof![4 => 4usize..=16, 1 => Just(1usize), 1 => 2usize..=3];
    let value = prop_oneof![
        Just(0.0),
        Just(1.0),
        Just(254.0),
        Just(255.0),
        0.0..=255.0f64
    ];
    let opacity = prop_oneof![
        Just(0.0),
        Just(1e-7),
        Just(1e-30),
        Just(1e-45),
        Just(1.0),
        0.0..=1.0f64
    ];
    let colour = || prop_oneof![Just(0.0), Just(1.0), 0.0..=1.0f64];
    let point = (value, [colour(), colour(), colour()], opacity)
        .prop_map(|(v, c, a)| (v, [c[0], c[1], c[2], a]));
    let spacing = prop_oneof![3 => Just([1.0; 3]), 1 => [0.25..4.0f64, 0.25..4.0, 0.25..4.0]];
    let dist = prop_oneof![
        Just(1e-2),
        Just(1e5),
        (-2.0..5.0f64).prop_map(|e| 10f64.powf(e))
    ];
    let fov = prop_oneof![Just(0.5), Just(179.5), 0.5..179.5f64];
    let volume = (
        [dim(), dim(), dim()],
        any::<bool>(),
        0u8..4,
        any::<u64>(),
        spacing,
    );
    let view = (
        0usize..6,
        dist,
        [-1.5..1.5f64, -1.5..1.5],
        fov,
        [1u32..=8, 1u32..=8],
        prop_oneof![3 => Just(1u32), 1 => Just(2), 1 => Just(8)],
        prop_oneof![Just(0.99f32), Just(1.0)],
    );
    (volume, prop::collection::vec(point, 1..5), view).prop_map(
        |(
            (dims, sixteen, pattern, seed, spacing),
            points,
            (side, dist, off, fov, size, substeps, terminate),
        )| Wild {
            dims,
            sixteen,
            pattern,
            seed,
            spacing,
            points,
            side,
            dist,
            off,
            fov,
            size,
            substeps,
            terminate,
        },
    )
}

/// Oversampling's rays grow as `(N / D)^2` per slice; views whose layout
/// holds more than this many rays skip its render (its layout is still
/// built, and must be `Ok` or `TooLarge`), to keep 256 cases fast.
const OVER_RAYS_RENDERED: usize = 1 << 20;

fn run_wild(w: &Wild) -> Result<(), TestCaseError> {
    let vol = wild_volume(w);
    let scale = if w.sixteen { 257.0 } else { 1.0 };
    let points: Vec<(f64, [f64; 4])> = w.points.iter().map(|&(v, c)| (v * scale, c)).collect();
    let t = tf(&points);
    let lut = lut_for(vol.kind(), &t);
    let axis = w.side / 2;
    let mut eye = eye_at(
        w.dims,
        axis,
        w.side % 2 == 1,
        w.dist,
        w.off.map(|o| o * w.dims[axis].max(2) as f64),
    );
    for k in 0..3 {
        eye[k] *= w.spacing[k];
    }
    let centre = DVec3::from_array(vol.center_world());
    // Clear refusals (an unusable camera or view) are allowed outcomes.
    let Ok(cam) = Camera::new(
        eye,
        centre,
        up_for(centre - eye),
        w.fov,
        w.size[0],
        w.size[1],
    ) else {
        return Ok(());
    };
    let Ok(prep) = Prepared::new(&vol, &cam) else {
        return Ok(());
    };
    let opts = RenderOptions {
        slice: Options {
            terminate: w.terminate,
            substeps: w.substeps,
            ..Options::default()
        },
        ..RenderOptions::default()
    };
    let mut techs = vec![Technique::Reference];
    techs.extend(Method::ALL.map(Technique::Slice));
    for tech in techs {
        if tech == Technique::Slice(Method::Over) {
            match Method::Over.layout(&prep.view) {
                Ok(l) if l.grids[0].len() > OVER_RAYS_RENDERED => continue,
                Ok(_) => {}
                Err(golden::Error::TooLarge { .. }) => continue,
                Err(e) => prop_assert!(false, "over's layout failed oddly: {e}"),
            }
        }
        let frame = match render(&prep, &lut, tech, &opts) {
            Ok(f) => f,
            Err(_) => continue,
        };
        let check = |data: &[[f32; 4]], what: &str| -> Result<(), TestCaseError> {
            if let Some((i, p)) = bad_value(data) {
                prop_assert!(false, "{} {what} value {i} is {p:?}", tech.name());
            }
            Ok(())
        };
        check(&frame.image.data, "image")?;
        if let Some(out) = &frame.slice {
            prop_assert!(
                out.baseplane
                    .data
                    .iter()
                    .flatten()
                    .all(|v| v.is_finite() && *v >= 0.0),
                "{} baseplane not finite or negative",
                tech.name()
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any finite input gives a clear error or a finite image in [0, 1],
    /// for every golden technique.
    #[test]
    fn golden_never_produces_nan_or_infinity(w in wild()) {
        run_wild(&w)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4096))]

    /// The long run: `cargo test --release -p pipeline --test it -- --ignored stress`.
    #[test]
    #[ignore = "long run: 4096 cases"]
    fn golden_never_produces_nan_or_infinity_long_run(w in wild()) {
        run_wild(&w)?;
    }
}
