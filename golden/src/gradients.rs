//! The voxel gradients the shading interpolates ([`crate::shading`]):
//! central differences `(f(i + 1) - f(i - 1)) / (2 s)` along each view
//! axis at every padded position of a view's [`SliceStack`] (neighbours
//! beyond the padding are the padding's replicated edge), in the stack's
//! padded layout.
//!
//! The three components of a position are stored together: a shaded
//! sample reads all three at each of its four (or eight) taps, so one
//! cache line serves the three where three separate stacks took three.
//! Each component is interpolated with exactly the scalar's formula and
//! weights ([`SliceStack::bilinear`], [`SliceStack::trilinear_f32`],
//! [`SliceStack::trilinear`]).

use rayon::prelude::*;

use crate::geometry::View;
use crate::slices::SliceStack;

/// A view's voxel gradients.
#[derive(Debug, Clone)]
pub struct Gradients {
    dims: [usize; 3],
    row: usize,
    plane: usize,
    data: Vec<[f32; 3]>,
}

impl Gradients {
    /// The central-difference gradients of `stack`, scaled by `view`'s
    /// spacing (anisotropic volumes scale the gradient).
    pub fn new(view: &View, stack: &SliceStack) -> Gradients {
        let (row, plane) = (stack.row, stack.plane);
        let n = [row, stack.dims[1] + 2, stack.dims[2] + 2];
        let stride = [1, row, plane];
        let scale = view.spacing.map(|s| (0.5 / s) as f32);
        let mut data = vec![[0f32; 3]; plane * n[2]];
        data.par_chunks_mut(plane).enumerate().for_each(|(z, out)| {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    let at = [x, y, z];
                    let i = z * plane + y * row + x;
                    out[y * row + x] = [0, 1, 2].map(|axis| {
                        let (lo, hi) =
                            (at[axis].saturating_sub(1), (at[axis] + 1).min(n[axis] - 1));
                        let base = i - at[axis] * stride[axis];
                        (stack.value(base + hi * stride[axis])
                            - stack.value(base + lo * stride[axis]))
                            * scale[axis]
                    });
                }
            }
        });
        Gradients {
            dims: stack.dims,
            row,
            plane,
            data,
        }
    }

    /// The gradient at view `(x, y)` in slice `z`, bilinear like the
    /// scalar's sample there; `(x, y)` must lie in `[-1, nx) x [-1, ny)`.
    #[inline(always)]
    pub fn bilinear(&self, z: usize, x: f32, y: f32) -> [f32; 3] {
        let (i, tx, ty) = SliceStack::cell_of(self.row, x, y);
        self.lerp2(self.plane * (z + 1) + i, tx, ty)
    }

    /// The gradient at view `(x, y, z)`, trilinear in `f32` like the
    /// slice-order methods' sub-slice samples (positions beyond the volume
    /// read the nearest edge).
    #[inline(always)]
    pub fn trilinear_f32(&self, x: f32, y: f32, z: f32) -> [f32; 3] {
        let (z0, t, x, y) = SliceStack::clamp_f32_in(self.dims, x, y, z);
        let (i, tx, ty) = SliceStack::cell_of(self.row, x, y);
        let a = self.lerp2(self.plane * z0 + i, tx, ty);
        let b = self.lerp2(self.plane * (z0 + 1) + i, tx, ty);
        let lerp = |a: f32, b: f32| a + t * (b - a);
        [lerp(a[0], b[0]), lerp(a[1], b[1]), lerp(a[2], b[2])]
    }

    /// The gradient at view `(x, y, z)`, trilinear in `f64` (the
    /// reference's).
    #[inline]
    pub fn trilinear(&self, x: f64, y: f64, z: f64) -> [f64; 3] {
        let (i, t) = SliceStack::cell3_in(self.dims, self.row, self.plane, x, y, z);
        let (r, p) = (self.row, self.plane);
        [0, 1, 2].map(|k| crate::slices::lerp3_by(|o| f64::from(self.data[i + o][k]), r, p, t))
    }

    /// The gradient at padded position `(px, py)` of slice `z` (`px` in
    /// `0..nx + 2`, `py` in `0..ny + 2`).
    #[inline]
    pub fn at(&self, z: usize, px: usize, py: usize) -> [f32; 3] {
        self.data[self.plane * (z + 1) + py * self.row + px]
    }

    /// Bytes the gradients take.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.data[..])
    }

    /// [`crate::slices`]' bilinear formula on each component at padded
    /// index `i`.
    #[inline(always)]
    fn lerp2(&self, i: usize, tx: f32, ty: f32) -> [f32; 3] {
        let d = &self.data;
        let (a, b, c, e) = (d[i], d[i + 1], d[i + self.row], d[i + self.row + 1]);
        // Written out per component: an array `map` here does not inline.
        let f = |k: usize| crate::slices::lerp2_values(a[k], b[k], c[k], e[k], tx, ty);
        [f(0), f(1), f(2)]
    }
}
