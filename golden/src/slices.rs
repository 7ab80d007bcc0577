//! The volume as the slice-order methods see it: permuted into view space,
//! converted to `f32` and padded with one voxel on every side that repeats
//! the edge voxel, so that interpolation anywhere in `[-1/2, N - 1/2)` needs
//! no bounds checks. Repeating the edge (rather than padding with zeros)
//! makes each voxel's value hold across its whole cell up to the volume's
//! faces, so a ray that crosses the half-voxel rim sees no ramp that is not
//! in the data; every method, the reference included, reads this stack.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geometry::AxisMap;
use crate::volume::Volume;

/// Memory the permuted stack may take (bytes).
pub const STACK_LIMIT: u64 = 8 << 30;

/// A permuted, padded copy of the rendered part of a volume.
#[derive(Debug, Clone)]
pub struct SliceStack {
    /// View-space dimensions `[nx, ny, nz]` (without padding).
    pub dims: [usize; 3],
    /// Padded row length `nx + 2`.
    pub row: usize,
    /// Padded slice size `(nx + 2) (ny + 2)`.
    pub plane: usize,
    data: Vec<f32>,
}

impl SliceStack {
    /// Permutes `volume` into the view space of `axes`.
    pub fn new(volume: &Volume, axes: &AxisMap) -> Result<SliceStack> {
        let id = volume.dims();
        let p = axes.perm;
        let dims = [id[p[0]], id[p[1]], id[p[2]] - axes.z_first];
        let (row, plane) = (dims[0] + 2, (dims[0] + 2) * (dims[1] + 2));
        let bytes = plane as u128 * (dims[2] as u128 + 2) * 4;
        if bytes > STACK_LIMIT as u128 {
            return Err(Error::TooLarge {
                what: "the permuted slice stack".into(),
                bytes,
                limit: STACK_LIMIT,
            });
        }
        let stride = [1isize, id[0] as isize, (id[0] * id[1]) as isize];
        let (sx, sy) = (stride[p[0]], stride[p[1]]);
        let z0 = axes.to_index(glam::DVec3::ZERO)[p[2]] as isize;
        let sz = if axes.flip_z {
            -stride[p[2]]
        } else {
            stride[p[2]]
        };
        let src = volume.data();
        let mut data = vec![0f32; plane * (dims[2] + 2)];
        data.par_chunks_mut(plane)
            .enumerate()
            .skip(1)
            .take(dims[2])
            .for_each(|(zp, out)| {
                // Index offset of view voxel (0, 0, zp - 1).
                let base = z0 * stride[p[2]] + (zp as isize - 1) * sz;
                for y in 0..dims[1] {
                    let line = base + y as isize * sy;
                    let dst = &mut out[(y + 1) * row + 1..(y + 1) * row + 1 + dims[0]];
                    for (x, d) in dst.iter_mut().enumerate() {
                        *d = src[(line + x as isize * sx) as usize] as f32;
                    }
                    out[(y + 1) * row] = out[(y + 1) * row + 1];
                    out[(y + 1) * row + dims[0] + 1] = out[(y + 1) * row + dims[0]];
                }
                out.copy_within(row..2 * row, 0);
                out.copy_within(dims[1] * row..(dims[1] + 1) * row, (dims[1] + 1) * row);
            });
        data.copy_within(plane..2 * plane, 0);
        let last = dims[2] * plane;
        data.copy_within(last..last + plane, last + plane);
        Ok(SliceStack {
            dims,
            row,
            plane,
            data,
        })
    }

    /// The central difference along view axis `axis` divided by
    /// `2 spacing`, at every padded position (neighbours beyond the padding
    /// are the padding's replicated edge), in this stack's layout: the
    /// gradient component the shading interpolates like the scalar (see
    /// [`crate::shading`]).
    pub fn central_difference(&self, axis: usize, spacing: f64) -> SliceStack {
        let (row, plane) = (self.row, self.plane);
        let n = [row, self.dims[1] + 2, self.dims[2] + 2];
        let stride = [1, row, plane];
        let scale = (0.5 / spacing) as f32;
        let src = &self.data;
        let mut data = vec![0f32; src.len()];
        data.par_chunks_mut(plane).enumerate().for_each(|(z, out)| {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    let at = [x, y, z];
                    let i = z * plane + y * row + x;
                    let (lo, hi) = (at[axis].saturating_sub(1), (at[axis] + 1).min(n[axis] - 1));
                    let base = i - at[axis] * stride[axis];
                    out[y * row + x] =
                        (src[base + hi * stride[axis]] - src[base + lo * stride[axis]]) * scale;
                }
            }
        });
        SliceStack {
            dims: self.dims,
            row,
            plane,
            data,
        }
    }

    /// Padded slice `z` (view space, `0..nz`).
    #[inline]
    pub fn slice(&self, z: usize) -> &[f32] {
        &self.data[(z + 1) * self.plane..(z + 2) * self.plane]
    }

    /// Bilinear interpolation in padded slice `s` at view `(x, y)`, which
    /// must lie in `[-1, nx) x [-1, ny)`.
    #[inline]
    pub fn bilinear(&self, s: &[f32], x: f32, y: f32) -> f32 {
        // Positions are at least -1, so truncation is the floor (and
        // avoids a libm call on targets without SSE4.1).
        let (fx, fy) = (x + 1.0, y + 1.0);
        let (x0, y0) = (fx as usize, fy as usize);
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let i = y0 * self.row + x0;
        let (a, b) = (s[i], s[i + 1]);
        let (c, d) = (s[i + self.row], s[i + self.row + 1]);
        let top = a + tx * (b - a);
        let bot = c + tx * (d - c);
        top + ty * (bot - top)
    }

    /// Trilinear interpolation as two bilinear ones, in `f32`: the slice-order
    /// methods' sub-slice samples. Positions beyond the volume read the
    /// nearest edge voxel.
    #[inline]
    pub fn trilinear_f32(&self, x: f32, y: f32, z: f32) -> f32 {
        let x = x.clamp(-1.0, self.dims[0] as f32 - 1e-3);
        let y = y.clamp(-1.0, self.dims[1] as f32 - 1e-3);
        let fz = z.clamp(-1.0, self.dims[2] as f32 - 1e-3) + 1.0;
        let z0 = fz as usize;
        let t = fz - z0 as f32;
        let at = |k: usize| &self.data[k * self.plane..(k + 1) * self.plane];
        let a = self.bilinear(at(z0), x, y);
        let b = self.bilinear(at(z0 + 1), x, y);
        a + t * (b - a)
    }

    /// Trilinear interpolation at view `(x, y, z)`, in `f64`; positions
    /// beyond the volume read the nearest edge voxel.
    #[inline]
    pub fn trilinear(&self, x: f64, y: f64, z: f64) -> f64 {
        // Beyond the padding the replicated edge holds, so clamping is exact.
        let lim = |v: f64, n: usize| v.clamp(-1.0, n as f64 - 1e-9) + 1.0;
        let (fx, fy, fz) = (
            lim(x, self.dims[0]),
            lim(y, self.dims[1]),
            lim(z, self.dims[2]),
        );
        let (x0, y0, z0) = (fx as usize, fy as usize, fz as usize);
        let (tx, ty, tz) = (fx - x0 as f64, fy - y0 as f64, fz - z0 as f64);
        let i = z0 * self.plane + y0 * self.row + x0;
        let v = |o: usize| self.data[i + o] as f64;
        let lerp = |a: f64, b: f64, t: f64| a + t * (b - a);
        let (r, p) = (self.row, self.plane);
        let s0 = lerp(lerp(v(0), v(1), tx), lerp(v(r), v(r + 1), tx), ty);
        let s1 = lerp(
            lerp(v(p), v(p + 1), tx),
            lerp(v(p + r), v(p + r + 1), tx),
            ty,
        );
        lerp(s0, s1, tz)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::geometry::View;
    use crate::volume::{VoxelType, DEFAULT_MEMORY_LIMIT};
    use glam::DVec3;

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
