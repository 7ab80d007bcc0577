//! A row's plain samples (one substep, no pre-integration, shading or
//! volume of interest: the default frame) taken [`LANES`] rays at a time.
//!
//! [`RayRow::sample`] is a chain of dependent steps per ray (position,
//! bilinear tap, table lookup, opacity correction, compositing) whose
//! branches follow the data; a batch runs each step over all its lanes
//! before the next, with the opacity correction branch-free
//! ([`correct_opacity_lanes`]), so independent rays overlap instead of
//! waiting on one another's divisions and mispredicted branches. Every
//! lane computes exactly what [`RayRow::sample`] computes for its ray, in
//! the same order, so the bits do not change (`golden/tests/it/lanes.rs`
//! checks frames against the one-ray path).

use super::{composite_alpha, RayRow};
use crate::merge::Rgba;
use crate::opacity::correct_opacity_lanes;
use crate::slices::{lerp2_values, Plane, SliceStack};

/// Rays per batch.
pub(super) const LANES: usize = 8;

impl RayRow<'_> {
    /// True when this frame's samples take the plain path that
    /// [`RayRow::sample_lanes`] covers.
    pub(super) fn plain(&self) -> bool {
        let p = self.pass;
        p.lanes && p.substeps == 1 && p.preint.is_none() && p.shader.is_none() && p.voi.is_none()
    }

    /// [`RayRow::sample`] for the rays at row offsets `idx` (one to
    /// [`LANES`] distinct offsets), composited into `row`.
    #[inline(always)]
    pub(super) fn sample_lanes(&self, row: &mut [Rgba], idx: &[usize]) {
        let n = idx.len();
        debug_assert!((1..=LANES).contains(&n));
        // Spare lanes repeat the last ray; only the first `n` are stored.
        let mut at = [idx[n - 1]; LANES];
        at[..n].copy_from_slice(idx);
        let mut x = [0f32; LANES];
        let mut ds = [0f32; LANES];
        for l in 0..LANES {
            let mx = self.grid.lo[0] + at[l] as i64;
            x[l] = (self.px.a + mx as f64 * self.px.t) as f32;
            ds[l] = self.ds[at[l]];
        }
        let s = match self.data {
            Plane::U8(p) => taps(p, self.pass.stack.row, &x, self.y),
            Plane::U16(p) => taps(p, self.pass.stack.row, &x, self.y),
        };
        let lut = self.pass.lut;
        let mut c = [[0f32; 4]; LANES];
        let mut alpha = [0f32; LANES];
        for l in 0..LANES {
            c[l] = lut.lookup(s[l]);
            alpha[l] = c[l][3];
        }
        let a = correct_opacity_lanes(&alpha, &ds);
        // The one-ray path composites only opacities above zero. Here a
        // transparent lane composites `a = 0`, which leaves every channel's
        // bits as they were: `0 c + 1 C = C` back to front, `C + 0 c = C`
        // front to back, for the non-negative finite values a ray holds.
        for l in 0..n {
            composite_alpha(&mut row[at[l]], c[l], a[l], self.pass.order);
        }
    }
}

/// The bilinear sample at `(x[l], y)` of padded plane `p` (row length
/// `row`) for every lane: [`SliceStack::bilinear`]'s arithmetic.
#[inline(always)]
fn taps<T: Copy + Into<f32>>(p: &[T], row: usize, x: &[f32; LANES], y: f32) -> [f32; LANES] {
    let mut s = [0f32; LANES];
    for l in 0..LANES {
        let (i, tx, ty) = SliceStack::cell_of(row, x[l], y);
        let (a, b) = (p[i].into(), p[i + 1].into());
        let (c, d) = (p[i + row].into(), p[i + row + 1].into());
        s[l] = lerp2_values(a, b, c, d, tx, ty);
    }
    s
}
