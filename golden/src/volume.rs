//! Scalar volumes: dimensions, voxel spacing and voxels.
//!
//! Voxels are stored as `u16` whatever their file type, with the bit depth
//! kept beside them, so classification tables and the pipeline's voxel width
//! know the scalar range. Voxel `(x, y, z)` sits at index-space position
//! `(x, y, z)` and at world position `(x, y, z) * spacing`; x varies fastest.

use crate::error::{input, Error, Result};

/// Memory a single volume may take unless the caller says otherwise (4 GiB):
/// enough for 1024^3 u16 voxels twice over, far below the machine, and
/// checked before anything is allocated.
pub const DEFAULT_MEMORY_LIMIT: u64 = 4 << 30;

/// Largest edge length accepted for any axis; larger files are refused as
/// absurd rather than attempted.
pub const MAX_EDGE: usize = 8192;

/// Stored voxel type (what the file held; values are kept in `u16`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum VoxelType {
    /// 8-bit unsigned scalars, range 0..=255.
    U8,
    /// 16-bit unsigned scalars, range 0..=65535.
    U16,
}

impl VoxelType {
    /// The largest scalar this type holds.
    pub fn max_value(self) -> u16 {
        match self {
            VoxelType::U8 => u8::MAX as u16,
            VoxelType::U16 => u16::MAX,
        }
    }
    /// Bits per voxel.
    pub fn bits(self) -> u32 {
        match self {
            VoxelType::U8 => 8,
            VoxelType::U16 => 16,
        }
    }
}

/// A scalar volume on a regular grid.
#[derive(Debug, Clone)]
pub struct Volume {
    dims: [usize; 3],
    spacing: [f64; 3],
    kind: VoxelType,
    data: Vec<u16>,
}

/// Checks that `dims` are sane and that `bytes_per_voxel * voxel count` fits
/// under `limit`, before anything is allocated. Returns the voxel count.
pub fn check_dims(dims: [usize; 3], bytes_per_voxel: u64, limit: u64) -> Result<usize> {
    for (axis, &n) in ["x", "y", "z"].iter().zip(&dims) {
        if n == 0 {
            return Err(input(format!("volume dimension {axis} is zero")));
        }
        if n > MAX_EDGE {
            return Err(input(format!(
                "volume dimension {axis} = {n} is absurd (at most {MAX_EDGE})"
            )));
        }
    }
    let count = dims.iter().map(|&n| n as u128).product::<u128>();
    let bytes = count * bytes_per_voxel as u128;
    if bytes > limit as u128 {
        return Err(Error::TooLarge {
            what: format!("a {}x{}x{} volume", dims[0], dims[1], dims[2]),
            bytes,
            limit,
        });
    }
    Ok(count as usize)
}

impl Volume {
    /// Builds a volume from voxels in x-fastest order.
    pub fn new(dims: [usize; 3], kind: VoxelType, data: Vec<u16>) -> Result<Volume> {
        let count = check_dims(dims, 2, u64::MAX)?;
        if data.len() != count {
            return Err(input(format!(
                "volume data has {} voxels, dimensions {}x{}x{} need {count}",
                data.len(),
                dims[0],
                dims[1],
                dims[2]
            )));
        }
        if let Some(v) = data.iter().find(|&&v| v > kind.max_value()) {
            return Err(input(format!("voxel value {v} exceeds the {kind:?} range")));
        }
        Ok(Volume {
            dims,
            spacing: [1.0; 3],
            kind,
            data,
        })
    }

    /// Builds a volume by evaluating `f(x, y, z)` at every voxel.
    pub fn from_fn(
        dims: [usize; 3],
        kind: VoxelType,
        limit: u64,
        f: impl Fn(usize, usize, usize) -> u16 + Sync,
    ) -> Result<Volume> {
        use rayon::prelude::*;
        check_dims(dims, 2, limit)?;
        let [nx, ny, nz] = dims;
        let max = kind.max_value();
        let mut data = vec![0u16; nx * ny * nz];
        data.par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(z, slice)| {
                for y in 0..ny {
                    for x in 0..nx {
                        slice[y * nx + x] = f(x, y, z).min(max);
                    }
                }
            });
        Volume::new(dims, kind, data)
    }

    /// Sets the voxel spacing (world units per voxel step on each axis).
    pub fn with_spacing(mut self, spacing: [f64; 3]) -> Result<Volume> {
        if spacing.iter().any(|s| !s.is_finite() || *s <= 0.0) {
            return Err(input(format!(
                "voxel spacing {spacing:?} must be finite and positive"
            )));
        }
        self.spacing = spacing;
        Ok(self)
    }

    /// Voxel counts along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }
    /// World units per voxel step along x, y, z.
    pub fn spacing(&self) -> [f64; 3] {
        self.spacing
    }
    /// The stored voxel type.
    pub fn kind(&self) -> VoxelType {
        self.kind
    }
    /// All voxels, x fastest.
    pub fn data(&self) -> &[u16] {
        &self.data
    }
    /// The voxel at integer position `(x, y, z)`.
    pub fn get(&self, x: usize, y: usize, z: usize) -> u16 {
        self.data[(z * self.dims[1] + y) * self.dims[0] + x]
    }
    /// World position of the volume's centre (the default look-at point).
    pub fn center_world(&self) -> [f64; 3] {
        std::array::from_fn(|k| (self.dims[k] as f64 - 1.0) * 0.5 * self.spacing[k])
    }
    /// Smallest and largest voxel value.
    pub fn value_range(&self) -> (u16, u16) {
        let mut lo = u16::MAX;
        let mut hi = 0;
        for &v in &self.data {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_zero_absurd_and_oversized_dims() {
        assert!(check_dims([0, 4, 4], 1, DEFAULT_MEMORY_LIMIT).is_err());
        assert!(check_dims([4, MAX_EDGE + 1, 4], 1, DEFAULT_MEMORY_LIMIT).is_err());
        let err = check_dims([4096, 4096, 4096], 2, DEFAULT_MEMORY_LIMIT).unwrap_err();
        assert!(err.to_string().contains("over the limit"), "{err}");
        assert_eq!(check_dims([2, 3, 4], 1, 100).unwrap(), 24);
    }

    #[test]
    fn indexing_is_x_fastest() {
        let v = Volume::from_fn([3, 4, 5], VoxelType::U8, DEFAULT_MEMORY_LIMIT, |x, y, z| {
            (x + 10 * y + 100 * z) as u16 % 256
        })
        .unwrap();
        assert_eq!(v.get(2, 3, 0), 32);
        // Voxel (1, 2, 1) sits at 1 + 3 (2 + 4 * 1).
        let (x, y, z) = (1, 2, 1);
        assert_eq!(v.data()[x + 3 * (y + 4 * z)], (1 + 20 + 100) as u16);
        assert!(Volume::new([2, 2, 2], VoxelType::U8, vec![300; 8]).is_err());
        assert!(Volume::new([2, 2, 2], VoxelType::U8, vec![0; 7]).is_err());
    }
}
