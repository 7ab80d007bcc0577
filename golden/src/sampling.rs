//! One slice of one region: every ray of the region that crosses the slice
//! samples the volume there, classifies the sample post-interpolation,
//! corrects its opacity for the ray's step length and composites it.
//!
//! With one substep (the paper's scheme) a ray takes one bilinear sample
//! where it crosses slice `z`. With `k > 1` substeps it takes `k` samples
//! spread evenly over the slice's thickness, at `z + (j + 1/2)/k - 1/2`
//! along the ray, each trilinear between the two nearest slices, and each
//! with `1/k` of the step's path length. Sampling only at integer `z`
//! misses the soft half of every boundary layer that trilinear
//! reconstruction puts between slices (a hard-edged cube's face is seen as
//! a step at the half-way plane); two substeps remove most of that bias.
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

/// Largest number of substeps per slice.
pub const MAX_SUBSTEPS: u32 = 8;

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

/// Samples slice `z` for every ray of `grid` in `buf` with `substeps`
/// samples per crossing and composites in `order`; returns the number of
/// ray crossings sampled.
#[allow(clippy::too_many_arguments)]
pub fn sample_slice(
    view: &View,
    stack: &SliceStack,
    lut: &Lut,
    grid: &RayGrid,
    buf: &mut [Rgba],
    z: usize,
    order: Order,
    substeps: u32,
) -> u64 {
    let ([px, py], [(x0, x1), (y0, y1)]) = slice_rays(view, grid, z);
    if x0 > x1 || y0 > y1 {
        return 0;
    }
    let w = grid.counts()[0];
    let slice = stack.slice(z);
    let rows = (y0 - grid.lo[1]) as usize..(y1 - grid.lo[1] + 1) as usize;
    let inv = 1.0 / (grid.z_ref + view.d);
    let [sx, sy, sz] = view.spacing.map(|s| s as f32);
    buf[rows.start * w..rows.end * w]
        .par_chunks_mut(w)
        .enumerate()
        .map(|(r, row)| {
            let my = y0 + r as i64;
            let y = (py.a + my as f64 * py.t) as f32;
            let slope_y = ((grid.phi[1] + my as f64 - view.eye.y) * inv) as f32;
            let dy = (slope_y * sy).powi(2) + sz * sz;
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
                let slope_x = ((grid.phi[0] + mx as f64 - view.eye.x) * inv) as f32;
                // Path length per slice step, needed only for visible samples.
                let ds = || ((slope_x * sx).powi(2) + dy).sqrt();
                if substeps == 1 {
                    let c = lut.lookup(stack.bilinear(slice, x, y));
                    if c[3] > 0.0 {
                        composite(ray, c, ds(), order);
                    }
                    continue;
                }
                for j in 0..substeps {
                    // Back-to-front walks the substeps from the rear.
                    let j = match order {
                        Order::BackToFront => substeps - 1 - j,
                        Order::FrontToBack { .. } => j,
                    };
                    let o = (j as f32 + 0.5) / substeps as f32 - 0.5;
                    let s = stack.trilinear_f32(x + o * slope_x, y + o * slope_y, z as f32 + o);
                    let c = lut.lookup(s);
                    if c[3] > 0.0 {
                        composite(ray, c, ds() / substeps as f32, order);
                    }
                }
            }
            taken
        })
        .sum()
}

/// Composites one classified sample `c` over a path of length `ds`.
#[inline]
fn composite(ray: &mut Rgba, c: [f32; 4], ds: f32, order: Order) {
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
