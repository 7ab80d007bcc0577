//! Scalar volumes: dimensions, voxel spacing and voxels.
//!
//! Voxels are stored in their file's type (`u8` or `u16`, see [`Voxels`]):
//! a volume costs its file's voxel bytes, not twice or four times that. The
//! bit depth tells classification tables and the pipeline's voxel width the
//! scalar range. Voxel `(x, y, z)` sits at index-space position
//! `(x, y, z)` and at world position `(x, y, z) * spacing`; x varies fastest.

use crate::error::{input, Error, Result};
use crate::values::ValueSet;

/// Memory a single volume may take unless the caller says otherwise (4 GiB):
/// enough for 1024^3 u16 voxels twice over, far below the machine, and
/// checked before anything is allocated.
pub const DEFAULT_MEMORY_LIMIT: u64 = 4 << 30;

/// The voxel spacings accepted, in world units per voxel (both ends
/// included), from a file's header or `--spacing`: wide enough for
/// nanometre microscopy and kilometre-scale grids in millimetres, narrow
/// enough that eye distances and ray steps stay ordinary floats (a spacing
/// of 1e-150 would render a flat sheet, 1e150 an eye past any range).
pub const SPACING_RANGE: (f64, f64) = (1e-6, 1e6);

/// Largest edge length accepted for any axis; larger files are refused as
/// absurd rather than attempted.
pub const MAX_EDGE: usize = 8192;

/// Stored voxel type (what the file held, and how it is kept).
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

/// How a volume's voxel values relate to the values its file stored
/// (after any rescale the format defines, e.g. DICOM's slope and
/// intercept): file value = `base + step * voxel`. Loaders set it from the
/// mapping rule they applied; built volumes have [`Units::IDENTITY`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Units {
    /// The file value of voxel value 0.
    pub base: f64,
    /// File units per voxel step.
    pub step: f64,
}

impl Units {
    /// Voxel values are the file's.
    pub const IDENTITY: Units = Units {
        base: 0.0,
        step: 1.0,
    };

    /// Voxel values are the file's minus `base` (an integer offset).
    pub fn shifted(base: f64) -> Units {
        Units { base, step: 1.0 }
    }

    /// The file value of voxel value `v`.
    pub fn value(self, v: f64) -> f64 {
        self.base + self.step * v
    }
}

/// A window onto file values (`--window lo,hi`): file values `lo..=hi`
/// map linearly onto voxel values `0..=65535`, values outside clamp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// The file value that becomes voxel 0.
    pub lo: f64,
    /// The file value that becomes voxel 65535.
    pub hi: f64,
}

impl std::str::FromStr for Window {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Window, String> {
        let v: Vec<f64> = s
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| format!("window '{s}' is not two comma-separated numbers lo,hi"))?;
        match v[..] {
            [lo, hi] if lo.is_finite() && hi.is_finite() && lo < hi => Ok(Window { lo, hi }),
            [_, _] => Err(format!("window '{s}' needs finite lo < hi")),
            _ => Err(format!(
                "window '{s}' is not two comma-separated numbers lo,hi"
            )),
        }
    }
}

/// A voxel type a volume or a slice stack keeps its scalars in; every
/// method reads them as `f32` (exact for both integer types).
pub trait Voxel: Copy + Default + Send + Sync + Into<f32> + Into<f64> + 'static {
    /// The scalar as the classification tables index it.
    fn value(self) -> u16;
}

impl Voxel for u8 {
    #[inline]
    fn value(self) -> u16 {
        self as u16
    }
}

impl Voxel for u16 {
    #[inline]
    fn value(self) -> u16 {
        self
    }
}

/// A volume's voxels in its file's type, x fastest.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Voxels {
    /// 8-bit voxels, one byte each.
    U8(Vec<u8>),
    /// 16-bit voxels.
    U16(Vec<u16>),
}

impl Voxels {
    /// Voxel count.
    pub fn len(&self) -> usize {
        match self {
            Voxels::U8(v) => v.len(),
            Voxels::U16(v) => v.len(),
        }
    }
    /// Whether there are no voxels (never, for a built volume).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Bytes the voxels take.
    pub fn bytes(&self) -> usize {
        match self {
            Voxels::U8(v) => v.len(),
            Voxels::U16(v) => 2 * v.len(),
        }
    }
}

/// Calls `$body` with `$v` bound to the voxel slice of `$voxels` (a
/// [`Voxels`]), once per type: hot loops are compiled for `u8` and `u16`
/// rather than branching per voxel.
#[macro_export]
macro_rules! with_voxels {
    ($voxels:expr, $v:ident => $body:expr) => {
        match $voxels {
            $crate::volume::Voxels::U8(data) => {
                let $v: &[u8] = data;
                $body
            }
            $crate::volume::Voxels::U16(data) => {
                let $v: &[u16] = data;
                $body
            }
        }
    };
}

/// A scalar volume on a regular grid.
#[derive(Debug, Clone)]
pub struct Volume {
    dims: [usize; 3],
    spacing: [f64; 3],
    kind: VoxelType,
    data: Voxels,
    units: Units,
    /// The values the voxels hold, found the first time they are asked
    /// for ([`Volume::values`]); the voxels never change after the volume
    /// is built, so neither does the set.
    values: std::sync::OnceLock<std::sync::Arc<ValueSet>>,
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
    /// Builds a volume from voxels in x-fastest order, given as `u16`
    /// values and kept as `kind` (an 8-bit volume is narrowed to bytes).
    pub fn new(dims: [usize; 3], kind: VoxelType, data: Vec<u16>) -> Result<Volume> {
        check_count(dims, data.len())?;
        if let Some(v) = data.iter().find(|&&v| v > kind.max_value()) {
            return Err(input(format!("voxel value {v} exceeds the {kind:?} range")));
        }
        let data = match kind {
            VoxelType::U8 => Voxels::U8(data.into_iter().map(|v| v as u8).collect()),
            VoxelType::U16 => Voxels::U16(data),
        };
        Volume::from_voxels(dims, data)
    }

    /// Builds a volume from voxels already in their type (no copy).
    pub fn from_voxels(dims: [usize; 3], data: Voxels) -> Result<Volume> {
        check_count(dims, data.len())?;
        let kind = match data {
            Voxels::U8(_) => VoxelType::U8,
            Voxels::U16(_) => VoxelType::U16,
        };
        Ok(Volume {
            dims,
            spacing: [1.0; 3],
            kind,
            data,
            units: Units::IDENTITY,
            values: std::sync::OnceLock::new(),
        })
    }

    /// Builds a volume by evaluating `f(x, y, z)` at every voxel.
    pub fn from_fn(
        dims: [usize; 3],
        kind: VoxelType,
        limit: u64,
        f: impl Fn(usize, usize, usize) -> u16 + Sync,
    ) -> Result<Volume> {
        let bytes = kind.bits() as u64 / 8;
        check_dims(dims, bytes, limit)?;
        let max = kind.max_value();
        let data = match kind {
            VoxelType::U8 => Voxels::U8(fill(dims, |x, y, z| f(x, y, z).min(max) as u8)),
            VoxelType::U16 => Voxels::U16(fill(dims, |x, y, z| f(x, y, z).min(max))),
        };
        Volume::from_voxels(dims, data)
    }

    /// Sets the voxel spacing (world units per voxel step on each axis),
    /// each within [`SPACING_RANGE`].
    pub fn with_spacing(mut self, spacing: [f64; 3]) -> Result<Volume> {
        let (lo, hi) = SPACING_RANGE;
        if !spacing.iter().all(|s| (lo..=hi).contains(s)) {
            return Err(input(format!(
                "voxel spacing {spacing:?} must be numbers from {lo:e} to {hi:e}"
            )));
        }
        self.spacing = spacing;
        Ok(self)
    }

    /// Records how the voxel values relate to the file's (see [`Units`]).
    pub fn with_units(mut self, units: Units) -> Volume {
        self.units = units;
        self
    }

    /// How the voxel values relate to the file's.
    pub fn units(&self) -> Units {
        self.units
    }

    /// The volume seen through `w`: each voxel's file value `f`
    /// ([`Volume::units`]) becomes `round((clamp(f, lo, hi) - lo) * 65535
    /// / (hi - lo))`, a 16-bit volume whatever the input type, so a window
    /// narrower than the data spreads it over the whole table rather than
    /// squeezing it. Exact for integer data (step 1); float data was
    /// quantised to 65536 levels over its range on loading, and the window
    /// maps those levels.
    pub fn windowed(&self, w: Window) -> Volume {
        let scale = 65535.0 / (w.hi - w.lo);
        let u = self.units;
        let map = |v: u16| ((u.value(v as f64).clamp(w.lo, w.hi) - w.lo) * scale).round() as u16;
        let data = with_voxels!(&self.data, d => d.iter().map(|&v| map(v.value())).collect());
        Volume {
            dims: self.dims,
            spacing: self.spacing,
            kind: VoxelType::U16,
            data: Voxels::U16(data),
            units: Units {
                base: w.lo,
                step: 1.0 / scale,
            },
            values: std::sync::OnceLock::new(),
        }
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
    /// All voxels, x fastest, in their own type.
    pub fn voxels(&self) -> &Voxels {
        &self.data
    }
    /// The voxels, giving up the volume.
    pub fn into_voxels(self) -> Voxels {
        self.data
    }
    /// All voxels, x fastest, as `u16` values: borrowed for a 16-bit
    /// volume, a widened copy of an 8-bit one (for tests and small volumes;
    /// hot paths read [`Volume::voxels`]).
    pub fn data(&self) -> std::borrow::Cow<'_, [u16]> {
        match &self.data {
            Voxels::U8(d) => d.iter().map(|&v| v as u16).collect(),
            Voxels::U16(d) => std::borrow::Cow::Borrowed(d),
        }
    }
    /// The voxel at integer position `(x, y, z)`.
    pub fn get(&self, x: usize, y: usize, z: usize) -> u16 {
        let i = (z * self.dims[1] + y) * self.dims[0] + x;
        match &self.data {
            Voxels::U8(d) => d[i] as u16,
            Voxels::U16(d) => d[i],
        }
    }
    /// World position of the volume's centre (the default look-at point).
    pub fn center_world(&self) -> [f64; 3] {
        std::array::from_fn(|k| (self.dims[k] as f64 - 1.0) * 0.5 * self.spacing[k])
    }
    /// Smallest and largest voxel value ([`Volume::values`]' ends).
    pub fn value_range(&self) -> (u16, u16) {
        // A built volume has voxels, so the set is never empty.
        self.values().range().unwrap_or((u16::MAX, 0))
    }
    /// The values the voxels hold: read from the voxels on the first call
    /// and kept with the volume (its clones share it), so the value range
    /// and a transfer function's coverage cost one pass over the voxels a
    /// volume, not one a frame.
    pub fn values(&self) -> &ValueSet {
        self.values
            .get_or_init(|| std::sync::Arc::new(ValueSet::of(&self.data)))
    }
}

/// Checks that `count` voxels fill `dims`.
fn check_count(dims: [usize; 3], count: usize) -> Result<()> {
    let want = check_dims(dims, 1, u64::MAX)?;
    if count != want {
        return Err(input(format!(
            "volume data has {count} voxels, dimensions {}x{}x{} need {want}",
            dims[0], dims[1], dims[2]
        )));
    }
    Ok(())
}

/// Voxels `f(x, y, z)` of `dims`, x fastest, filled in parallel over z.
fn fill<T: Voxel>(dims: [usize; 3], f: impl Fn(usize, usize, usize) -> T + Sync) -> Vec<T> {
    use rayon::prelude::*;
    let [nx, ny, nz] = dims;
    let mut data = vec![T::default(); nx * ny * nz];
    data.par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(z, slice)| {
            for y in 0..ny {
                for x in 0..nx {
                    slice[y * nx + x] = f(x, y, z);
                }
            }
        });
    data
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_values_are_read_once_and_shared_by_clones() {
        let v = Volume::new([3, 2, 1], VoxelType::U16, vec![9, 4, 4, 300, 9, 7]).unwrap();
        assert_eq!(v.value_range(), (4, 300));
        assert_eq!(v.values().iter().collect::<Vec<_>>(), vec![4, 7, 9, 300]);
        // A clone made after the first call holds the same set, not a new one.
        let c = v.clone();
        assert!(std::ptr::eq(v.values(), c.values()));
        // A windowed volume holds other values, so it finds its own.
        let w = v.windowed(Window { lo: 4.0, hi: 9.0 });
        assert_eq!(w.value_range(), (0, 65535));
    }

    #[test]
    fn rejects_zero_absurd_and_oversized_dims() {
        assert!(check_dims([0, 4, 4], 1, DEFAULT_MEMORY_LIMIT).is_err());
        assert!(check_dims([4, MAX_EDGE + 1, 4], 1, DEFAULT_MEMORY_LIMIT).is_err());
        let err = check_dims([4096, 4096, 4096], 2, DEFAULT_MEMORY_LIMIT).unwrap_err();
        assert!(err.to_string().contains("over the memory limit"), "{err}");
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

    #[test]
    fn a_window_maps_file_values_onto_the_16_bit_range() {
        // CT-like: voxels are HU + 1024.
        let v = Volume::new([4, 1, 1], VoxelType::U16, vec![0, 1024, 1064, 4095])
            .unwrap()
            .with_units(Units::shifted(-1024.0));
        let w: Window = "-40,80".parse().unwrap();
        let out = v.windowed(w);
        assert_eq!(out.kind(), VoxelType::U16);
        // -1024 clamps to -40 (0); 0 HU is 40/120 of the way; 40 HU is 2/3.
        assert_eq!(out.data()[..], [0, 21845, 43690, 65535]);
        assert_eq!(out.units().value(21845.0).round(), 0.0);
        for bad in ["1", "2,1", "a,b", "0,inf", "1,2,3"] {
            let e = bad.parse::<Window>().unwrap_err();
            assert!(e.contains("window"), "{e}");
        }
    }
}
