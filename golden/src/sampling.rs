//! One slice of one region: every ray of the region that crosses the slice
//! takes a bilinear sample there, classifies it post-interpolation, corrects
//! its opacity for the ray's step length and composites it.
//!
//! The pipeline's PEs mirror [`sample_slice`] sample for sample: the same
//! rays (from [`crate::geometry`]), positions, slopes and compositing order.

use rayon::prelude::*;

use crate::geometry::{inside, Affine, RayGrid, View};
use crate::merge::Rgba;
use crate::slices::SliceStack;
use crate::tf::{correct_opacity, Lut};

/// Compositing direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Order {
    /// `C = c' + (1 - a') C`, `A = a' + (1 - a') A`.
    BackToFront,
    /// `C += (1 - A) c'`, `A += (1 - A) a'`; rays at or above `terminate`
    /// opacity take no more samples (1.0 or more disables termination).
    FrontToBack {
        /// Early-termination opacity threshold.
        terminate: f32,
    },
}

/// The ray index ranges of `grid` that sample slice `z`, per axis, and the
/// rays' affine positions there.
pub fn slice_rays(view: &View, grid: &RayGrid, z: usize) -> ([Affine; 2], [(i64, i64); 2]) {
    let p: [Affine; 2] = std::array::from_fn(|k| grid.at(view.eye, view.d, z as f64, k));
    let r = std::array::from_fn(|k| {
        let (lo, hi) = inside(p[k], view.dims[k]);
        (lo.max(grid.lo[k]), hi.min(grid.hi[k]))
    });
    (p, r)
}

/// Samples slice `z` for every ray of `grid` in `buf` and composites in
/// `order`; returns the number of samples taken.
pub fn sample_slice(
    view: &View,
    stack: &SliceStack,
    lut: &Lut,
    grid: &RayGrid,
    buf: &mut [Rgba],
    z: usize,
    order: Order,
) -> u64 {
    let ([px, py], [(x0, x1), (y0, y1)]) = slice_rays(view, grid, z);
    if x0 > x1 || y0 > y1 {
        return 0;
    }
    let w = grid.counts()[0];
    let slice = stack.slice(z);
    let rows = (y0 - grid.lo[1]) as usize..(y1 - grid.lo[1] + 1) as usize;
    let inv = 1.0 / (grid.z_ref + view.d);
    let (sx, sy, sz) = (view.spacing[0], view.spacing[1], view.spacing[2]);
    buf[rows.start * w..rows.end * w]
        .par_chunks_mut(w)
        .enumerate()
        .map(|(r, row)| {
            let my = y0 + r as i64;
            let y = (py.a + my as f64 * py.t) as f32;
            let dy = ((grid.phi[1] + my as f64 - view.eye.y) * inv * sy).powi(2);
            let mut taken = 0u64;
            for mx in x0..=x1 {
                let ray = &mut row[(mx - grid.lo[0]) as usize];
                if let Order::FrontToBack { terminate } = order {
                    if ray[3] >= terminate {
                        continue;
                    }
                }
                taken += 1;
                let x = (px.a + mx as f64 * px.t) as f32;
                let s = stack.bilinear(slice, x, y);
                let c = lut.lookup(s);
                if c[3] <= 0.0 {
                    continue;
                }
                let dx = ((grid.phi[0] + mx as f64 - view.eye.x) * inv * sx).powi(2);
                let ds = (dx + dy + sz * sz).sqrt() as f32;
                let a = correct_opacity(c[3], ds);
                match order {
                    Order::BackToFront => {
                        let k = 1.0 - a;
                        ray[0] = a * c[0] + k * ray[0];
                        ray[1] = a * c[1] + k * ray[1];
                        ray[2] = a * c[2] + k * ray[2];
                        ray[3] = a + k * ray[3];
                    }
                    Order::FrontToBack { .. } => {
                        let k = (1.0 - ray[3]) * a;
                        ray[0] += k * c[0];
                        ray[1] += k * c[1];
                        ray[2] += k * c[2];
                        ray[3] += k;
                    }
                }
            }
            taken
        })
        .sum()
}
