//! The volume as the slice-order methods see it: permuted into view space,
//! kept in the volume's own voxel type (read as `f32`) and padded with one voxel on every side that repeats
//! the edge voxel, so that interpolation anywhere in `[-1/2, N - 1/2)` needs
//! no bounds checks. Repeating the edge (rather than padding with zeros)
//! makes each voxel's value hold across its whole cell up to the volume's
//! faces, so a ray that crosses the half-voxel rim sees no ramp that is not
//! in the data; every method, the reference included, reads this stack.

use crate::error::{Error, Result};
use crate::geometry::AxisMap;
use crate::volume::{Volume, Voxels};

mod gather;
mod permute;
pub(crate) use gather::bilinear_x8;
use permute::{pad_in_place, permute_consuming, permute_into, Permute};

/// Memory the permuted stack may take (bytes).
pub const STACK_LIMIT: u64 = 8 << 30;

/// The voxels of a stack, in the volume's own type (a byte per voxel for
/// 8-bit data).
#[derive(Debug, Clone, PartialEq)]
enum StackData {
    U8(Vec<u8>),
    U16(Vec<u16>),
}

/// One padded slice of a [`SliceStack`], in the stack's voxel type.
#[derive(Debug, Clone, Copy)]
pub enum Plane<'a> {
    /// 8-bit scalars.
    U8(&'a [u8]),
    /// 16-bit scalars.
    U16(&'a [u16]),
}

impl Plane<'_> {
    /// The value at padded index `i`.
    #[inline]
    pub fn get(&self, i: usize) -> f32 {
        match self {
            Plane::U8(s) => s[i] as f32,
            Plane::U16(s) => s[i] as f32,
        }
    }

    /// `len` values from padded index `start`, as `f32`.
    pub fn values(&self, start: usize, len: usize) -> impl Iterator<Item = f32> + '_ {
        (start..start + len).map(move |i| self.get(i))
    }
}

/// A permuted, padded copy of the rendered part of a volume.
#[derive(Debug, Clone, PartialEq)]
pub struct SliceStack {
    /// View-space dimensions `[nx, ny, nz]` (without padding).
    pub dims: [usize; 3],
    /// Padded row length `nx + 2`.
    pub row: usize,
    /// Padded slice size `(nx + 2) (ny + 2)`.
    pub plane: usize,
    data: StackData,
}

/// Bilinear interpolation at padded index `i` of `s` (row length `row`),
/// weights `tx`, `ty`: the one formula every type shares, so a stack's
/// type changes no bit.
#[inline(always)]
fn lerp2<T: Copy + Into<f32>>(s: &[T], i: usize, row: usize, tx: f32, ty: f32) -> f32 {
    let (a, b) = (s[i].into(), s[i + 1].into());
    let (c, d) = (s[i + row].into(), s[i + row + 1].into());
    lerp2_values(a, b, c, d, tx, ty)
}

/// The bilinear formula on a cell's four values (`a`, `b` on the top row,
/// `c`, `d` below), shared with [`crate::gradients`].
#[inline(always)]
pub(crate) fn lerp2_values(a: f32, b: f32, c: f32, d: f32, tx: f32, ty: f32) -> f32 {
    let top = a + tx * (b - a);
    let bot = c + tx * (d - c);
    top + ty * (bot - top)
}

/// The bilinear sample at `(x[l], y)` of padded plane `p` (row length
/// `row`) for every lane: [`SliceStack::bilinear`]'s arithmetic.
#[inline(always)]
pub(crate) fn bilinear_lanes<T: Copy + Into<f32>, const L: usize>(
    p: &[T],
    row: usize,
    x: &[f32; L],
    y: f32,
) -> [f32; L] {
    // A loop, not `array::from_fn`: its closure was left out of line.
    let mut s = [0f32; L];
    for l in 0..L {
        let (i, tx, ty) = SliceStack::cell_of(row, x[l], y);
        s[l] = lerp2(p, i, row, tx, ty);
    }
    s
}

/// [`lerp2`] on a plane of any type.
#[inline(always)]
fn lerp_plane(s: Plane, i: usize, row: usize, tx: f32, ty: f32) -> f32 {
    match s {
        Plane::U8(s) => lerp2(s, i, row, tx, ty),
        Plane::U16(s) => lerp2(s, i, row, tx, ty),
    }
}

/// Trilinear interpolation in `f64` at padded index `i` of `s`.
#[inline(always)]
fn lerp3<T: Copy + Into<f64>>(s: &[T], i: usize, r: usize, p: usize, t: [f64; 3]) -> f64 {
    lerp3_by(|o| s[i + o].into(), r, p, t)
}

/// The trilinear formula on the values `v(o)` at offsets `o` from a cell's
/// first corner (row length `r`, plane size `p`), shared with
/// [`crate::gradients`].
#[inline(always)]
pub(crate) fn lerp3_by(v: impl Fn(usize) -> f64, r: usize, p: usize, t: [f64; 3]) -> f64 {
    let lerp = |a: f64, b: f64, t: f64| a + t * (b - a);
    let [tx, ty, tz] = t;
    let s0 = lerp(lerp(v(0), v(1), tx), lerp(v(r), v(r + 1), tx), ty);
    let s1 = lerp(
        lerp(v(p), v(p + 1), tx),
        lerp(v(p + r), v(p + r + 1), tx),
        ty,
    );
    lerp(s0, s1, tz)
}

impl SliceStack {
    /// Bytes the stack of `volume` seen through `axes` takes (no allocation).
    pub fn bytes_for(volume_dims: [usize; 3], bytes_per_voxel: u64, axes: &AxisMap) -> u128 {
        let p = axes.perm;
        let dims = [
            volume_dims[p[0]],
            volume_dims[p[1]],
            volume_dims[p[2]] - axes.z_first,
        ];
        (dims[0] as u128 + 2)
            * (dims[1] as u128 + 2)
            * (dims[2] as u128 + 2)
            * bytes_per_voxel as u128
    }

    /// The layout of `volume`'s stack under `axes`, refused above
    /// [`STACK_LIMIT`].
    fn layout(volume: &Volume, axes: &AxisMap) -> Result<Permute> {
        let id = volume.dims();
        let p = axes.perm;
        let dims = [id[p[0]], id[p[1]], id[p[2]] - axes.z_first];
        let (row, plane) = (dims[0] + 2, (dims[0] + 2) * (dims[1] + 2));
        let bytes = SliceStack::bytes_for(id, volume.kind().bits() as u64 / 8, axes);
        if bytes > STACK_LIMIT as u128 {
            return Err(Error::TooLarge {
                what: "the permuted slice stack".into(),
                bytes,
                limit: STACK_LIMIT,
            });
        }
        let stride = [1isize, id[0] as isize, (id[0] * id[1]) as isize];
        let z0 = axes.to_index(glam::DVec3::ZERO)[p[2]] as isize;
        Ok(Permute {
            dims,
            row,
            plane,
            base0: z0 * stride[p[2]],
            sx: stride[p[0]],
            sy: stride[p[1]],
            sz: if axes.flip_z {
                -stride[p[2]]
            } else {
                stride[p[2]]
            },
        })
    }

    /// Permutes `volume` into the view space of `axes`.
    pub fn new(volume: &Volume, axes: &AxisMap) -> Result<SliceStack> {
        let g = SliceStack::layout(volume, axes)?;
        let Permute {
            dims, row, plane, ..
        } = g;
        let len = plane * (dims[2] + 2);
        let data = match volume.voxels() {
            Voxels::U8(src) => {
                let mut data = vec![0u8; len];
                permute_into(src, &mut data, &g);
                StackData::U8(data)
            }
            Voxels::U16(src) => {
                let mut data = vec![0u16; len];
                permute_into(src, &mut data, &g);
                StackData::U16(data)
            }
        };
        Ok(SliceStack {
            dims,
            row,
            plane,
            data,
        })
    }

    /// [`SliceStack::new`], taking the volume's voxels: when the view's
    /// slices are the volume's own z slices in either direction (principal
    /// axis +z or -z, no near clip) the stack is laid out in the volume's
    /// own buffer; in a side view (principal axis x or y) the volume's
    /// buffer is given back slab by slab as the stack fills
    /// (`permute_consuming`), so the frame never holds the voxels twice.
    /// With principal axis z and a near clip, the volume is freed once the
    /// stack is copied out of it.
    pub fn from_volume(volume: Volume, axes: &AxisMap) -> Result<SliceStack> {
        if axes.perm[2] != 2 {
            let g = SliceStack::layout(&volume, axes)?;
            let (id, along_x) = (volume.dims(), axes.perm[0] == 2);
            let data = match volume.into_voxels() {
                Voxels::U8(v) => StackData::U8(permute_consuming(v, id, &g, along_x)),
                Voxels::U16(v) => StackData::U16(permute_consuming(v, id, &g, along_x)),
            };
            return Ok(SliceStack {
                dims: g.dims,
                row: g.row,
                plane: g.plane,
                data,
            });
        }
        if axes.perm != [0, 1, 2] || axes.z_first != 0 {
            return SliceStack::new(&volume, axes);
        }
        let dims = volume.dims();
        let bytes = SliceStack::bytes_for(dims, volume.kind().bits() as u64 / 8, axes);
        if bytes > STACK_LIMIT as u128 {
            return Err(Error::TooLarge {
                what: "the permuted slice stack".into(),
                bytes,
                limit: STACK_LIMIT,
            });
        }
        let (row, plane) = (dims[0] + 2, (dims[0] + 2) * (dims[1] + 2));
        let data = match volume.into_voxels() {
            Voxels::U8(v) => StackData::U8(pad_in_place(v, dims, axes.flip_z)),
            Voxels::U16(v) => StackData::U16(pad_in_place(v, dims, axes.flip_z)),
        };
        Ok(SliceStack {
            dims,
            row,
            plane,
            data,
        })
    }

    /// The value at padded index `i`.
    #[inline]
    pub(crate) fn value(&self, i: usize) -> f32 {
        match &self.data {
            StackData::U8(d) => d[i] as f32,
            StackData::U16(d) => d[i] as f32,
        }
    }

    /// Bytes the stack's voxels take.
    pub fn bytes(&self) -> usize {
        match &self.data {
            StackData::U8(d) => d.len(),
            StackData::U16(d) => 2 * d.len(),
        }
    }

    /// Padded slice `k` counting the padding (`0..nz + 2`).
    #[inline]
    fn padded(&self, k: usize) -> Plane<'_> {
        let r = k * self.plane..(k + 1) * self.plane;
        match &self.data {
            StackData::U8(d) => Plane::U8(&d[r]),
            StackData::U16(d) => Plane::U16(&d[r]),
        }
    }

    /// Padded slice `z` (view space, `0..nz`).
    #[inline]
    pub fn slice(&self, z: usize) -> Plane<'_> {
        self.padded(z + 1)
    }

    /// Bilinear interpolation in padded slice `s` at view `(x, y)`, which
    /// must lie in `[-1, nx) x [-1, ny)`.
    #[inline(always)]
    pub fn bilinear(&self, s: Plane, x: f32, y: f32) -> f32 {
        let (i, tx, ty) = self.cell(x, y);
        lerp_plane(s, i, self.row, tx, ty)
    }

    /// The padded index (in a plane of row length `row`) of the cell
    /// holding view `(x, y)` and the weights within it.
    #[inline(always)]
    pub(crate) fn cell_of(row: usize, x: f32, y: f32) -> (usize, f32, f32) {
        // Positions are at least -1, so truncation is the floor (and
        // avoids a libm call on targets without SSE4.1).
        // Through `u32`: the padded plane's rows are far below 2^32
        // samples, and `u32` converts to `f32` in one instruction.
        let (fx, fy) = (x + 1.0, y + 1.0);
        let (x0, y0) = (fx as u32, fy as u32);
        (
            y0 as usize * row + x0 as usize,
            fx - x0 as f32,
            fy - y0 as f32,
        )
    }

    #[inline(always)]
    fn cell(&self, x: f32, y: f32) -> (usize, f32, f32) {
        SliceStack::cell_of(self.row, x, y)
    }

    /// Trilinear interpolation as two bilinear ones, in `f32`: the slice-order
    /// methods' sub-slice samples. Positions beyond the volume read the
    /// nearest edge voxel.
    #[inline(always)]
    pub fn trilinear_f32(&self, x: f32, y: f32, z: f32) -> f32 {
        self.trilinear_lanes(&[x], y, z)[0]
    }

    /// [`SliceStack::trilinear_f32`] at `(x[l], y, z)` for every lane (its
    /// one-lane case is that function): the rays of one row share `y` and
    /// `z` at a substep, so their clamp and the two planes are found once.
    #[inline(always)]
    pub(crate) fn trilinear_lanes<const L: usize>(&self, x: &[f32; L], y: f32, z: f32) -> [f32; L] {
        let (z0, t, _, y) = SliceStack::clamp_f32_in(self.dims, 0.0, y, z);
        let mut x = *x;
        for v in &mut x {
            *v = SliceStack::clamp_f32_in(self.dims, *v, 0.0, 0.0).2;
        }
        let (front, back) = (z0 * self.plane, (z0 + 1) * self.plane);
        let (a, b) = match &self.data {
            StackData::U8(d) => (
                bilinear_lanes(&d[front..back], self.row, &x, y),
                bilinear_lanes(&d[back..back + self.plane], self.row, &x, y),
            ),
            StackData::U16(d) => (
                bilinear_lanes(&d[front..back], self.row, &x, y),
                bilinear_lanes(&d[back..back + self.plane], self.row, &x, y),
            ),
        };
        let mut s = a;
        for l in 0..L {
            s[l] += t * (b[l] - a[l]);
        }
        s
    }

    /// [`SliceStack::trilinear_f32`]'s clamped position in a stack of
    /// `dims`: the padded slice below, the weight between it and the next,
    /// and `x`, `y`.
    #[inline(always)]
    pub(crate) fn clamp_f32_in(dims: [usize; 3], x: f32, y: f32, z: f32) -> (usize, f32, f32, f32) {
        let x = x.clamp(-1.0, dims[0] as f32 - 1e-3);
        let y = y.clamp(-1.0, dims[1] as f32 - 1e-3);
        let fz = z.clamp(-1.0, dims[2] as f32 - 1e-3) + 1.0;
        // Through `u32`, as `cell_of`.
        let z0 = fz as u32;
        (z0 as usize, fz - z0 as f32, x, y)
    }

    /// Trilinear interpolation at view `(x, y, z)`, in `f64`; positions
    /// beyond the volume read the nearest edge voxel.
    #[inline]
    pub fn trilinear(&self, x: f64, y: f64, z: f64) -> f64 {
        let (i, t) = SliceStack::cell3_in(self.dims, self.row, self.plane, x, y, z);
        let (r, p) = (self.row, self.plane);
        match &self.data {
            StackData::U8(d) => lerp3(d, i, r, p, t),
            StackData::U16(d) => lerp3(d, i, r, p, t),
        }
    }

    /// [`SliceStack::trilinear`]'s cell in a stack of `dims` (padded row
    /// `row`, plane `plane`): its first corner's padded index and the
    /// weights.
    #[inline(always)]
    pub(crate) fn cell3_in(
        dims: [usize; 3],
        row: usize,
        plane: usize,
        x: f64,
        y: f64,
        z: f64,
    ) -> (usize, [f64; 3]) {
        // Beyond the padding the replicated edge holds, so clamping is exact.
        let lim = |v: f64, n: usize| v.clamp(-1.0, n as f64 - 1e-9) + 1.0;
        let (fx, fy, fz) = (lim(x, dims[0]), lim(y, dims[1]), lim(z, dims[2]));
        // Through `u32`, as `cell_of`.
        let (x0, y0, z0) = (fx as u32, fy as u32, fz as u32);
        let t = [fx - f64::from(x0), fy - f64::from(y0), fz - f64::from(z0)];
        let (x0, y0, z0) = (x0 as usize, y0 as usize, z0 as usize);
        (z0 * plane + y0 * row + x0, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::geometry::View;
    use crate::volume::{VoxelType, DEFAULT_MEMORY_LIMIT};
    use glam::DVec3;

    fn bytes_of(vol: &Volume) -> Volume {
        Volume::from_fn(
            vol.dims(),
            VoxelType::U8,
            DEFAULT_MEMORY_LIMIT,
            |x, y, z| vol.get(x, y, z) % 251,
        )
        .unwrap()
    }

    #[test]
    fn permutation_matches_axis_map_on_all_six_sides() {
        let vol = Volume::from_fn(
            [5, 6, 7],
            VoxelType::U16,
            DEFAULT_MEMORY_LIMIT,
            |x, y, z| (x + 10 * y + 100 * z) as u16,
        )
        .unwrap();
        let c = DVec3::new(2.0, 2.5, 3.0);
        for dir in [
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::NEG_Z,
        ] {
            let up = if dir.y.abs() > 0.5 {
                DVec3::Z
            } else {
                DVec3::Y
            };
            let cam = Camera::new(c - dir * 20.0, c, up, 60.0, 8, 8).unwrap();
            let view = View::new(vol.dims(), [1.0; 3], &cam, 1.0).unwrap();
            let stack = SliceStack::new(&vol, &view.axes).unwrap();
            assert_eq!(stack.dims, view.dims);
            // Taking the volume (in place along z) builds the same stack,
            // for bytes too.
            let taken = SliceStack::from_volume(vol.clone(), &view.axes).unwrap();
            assert!(taken == stack, "side {dir}: the taken stack differs");
            let bytes = Volume::from_fn(
                vol.dims(),
                VoxelType::U8,
                DEFAULT_MEMORY_LIMIT,
                |x, y, z| vol.get(x, y, z) % 251,
            )
            .unwrap();
            let want = SliceStack::new(&bytes, &view.axes).unwrap();
            let taken = SliceStack::from_volume(bytes, &view.axes).unwrap();
            assert!(taken == want, "side {dir}: the taken 8-bit stack differs");
            for z in 0..view.dims[2] {
                for y in 0..view.dims[1] {
                    for x in 0..view.dims[0] {
                        let i = view.axes.to_index(DVec3::new(x as f64, y as f64, z as f64));
                        let want = vol.get(i.x as usize, i.y as usize, i.z as usize) as f32;
                        let got = stack.bilinear(stack.slice(z), x as f32, y as f32);
                        assert_eq!(got, want, "side {dir} at {x},{y},{z}");
                    }
                }
            }
            // An eye inside the volume clips the near slices: the taken
            // stack still equals the copied one, both voxel types.
            let near = Camera::new(c - dir * 1.0, c + dir, up, 60.0, 8, 8).unwrap();
            let clipped = View::new(vol.dims(), [1.0; 3], &near, 1.0).unwrap();
            assert!(clipped.axes.z_first > 0, "side {dir}: no near clip");
            for v in [vol.clone(), bytes_of(&vol)] {
                let want = SliceStack::new(&v, &clipped.axes).unwrap();
                let taken = SliceStack::from_volume(v, &clipped.axes).unwrap();
                assert!(taken == want, "side {dir}: the clipped stack differs");
            }
            // The padding repeats the edge voxels.
            let n = view.dims;
            let edge = |x: usize, y: usize, z: usize| {
                let i = view.axes.to_index(DVec3::new(x as f64, y as f64, z as f64));
                vol.get(i.x as usize, i.y as usize, i.z as usize) as f64
            };
            assert_eq!(stack.trilinear(-1.0, 0.0, 0.0), edge(0, 0, 0));
            assert_eq!(stack.trilinear(-1.0, -1.0, -1.0), edge(0, 0, 0));
            let (lx, ly, lz) = (n[0] - 1, n[1] - 1, n[2] - 1);
            let far = |k: usize| n[k] as f64 - 0.25;
            assert_eq!(stack.trilinear(far(0), far(1), far(2)), edge(lx, ly, lz));
            assert_eq!(stack.trilinear(2.0, far(1), -1.0), edge(2, ly, 0));
        }
    }
}
