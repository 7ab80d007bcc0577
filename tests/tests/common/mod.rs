//! Helpers shared by the skipping tests (golden and pipeline).
#![allow(dead_code)]

use golden::render::lut_for;
use golden::tf::{ControlPoint, Lut, TransferFunction};
use golden::volume::{Volume, VoxelType, DEFAULT_MEMORY_LIMIT};

/// A 64-bit mix (splitmix64's finaliser): deterministic pseudo-random bits.
pub fn hash(mut x: u64) -> u64 {
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    x ^ (x >> 33)
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

/// A transfer function from `(value, rgba)` control points.
pub fn tf(points: &[(f64, [f64; 4])]) -> TransferFunction {
    TransferFunction::new(
        points
            .iter()
            .map(|&(value, rgba)| ControlPoint { value, rgba })
            .collect(),
    )
    .expect("tf")
}

/// Golden's table of [`tf`] for 8-bit data.
pub fn table(points: &[(f64, [f64; 4])]) -> Lut {
    lut_for(VoxelType::U8, &tf(points))
}
