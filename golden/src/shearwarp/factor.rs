//! The perspective shear-warp factorisation in ercube's view space
//! (Lacroute; Schulze, Niemeier and Lang, section 2.3), built on
//! [`crate::geometry::View`]: the principal axis, its permutation and the
//! near clip are the view's, so shear-warp sees the slices every other
//! method sees.
//!
//! **Shear.** In view space the eye is at `(e_x, e_y, -D)` and slice `z`
//! at view `z`. Projecting slice `z` from the eye onto the plane of slice 0
//! scales it about the eye's foot by `s(z) = D / (z + D)`:
//! `x' = e_x + (x - e_x) s(z)` (likewise `y`). In homogeneous form this is
//! the paper's `M^sd` times `D`: `(x' w, y' w, w) = [[D, 0, e_x, 0],
//! [0, D, e_y, 0], [0, 0, 1, D]] (x, y, z, 1)`. The intermediate image lies
//! on that plane with `S` ([`Factor::scale`], `--intermediate-scale`)
//! pixels per voxel, pixel `k` centred at `(k + 1/2) / S - 1/2`: the
//! pixels tile the voxel cells (`S` to a cell at `S >= 1`, one to `1/S`
//! cells below), so at `S = 1` slice 0's voxel centres are pixel centres
//! and at no scale does a pixel centre sit on a face of the volume,
//! which would widen the silhouette by a quarter voxel: `M^scale` and
//! `M^di` together.
//!
//! **Warp.** The final pixel `(p_x, p_y)` looks along `a + p_x b + p_y c`
//! ([`crate::camera::PixelRays`]), which meets the plane of slice 0 where
//! [`crate::warp::pixel_to_base`] says; with the intermediate image as its
//! [`BaseGrid`] that 3x3 map is the inverse warp `(M^iv)^-1`, so the warp
//! is the one the slice-order methods use, in one place. Because every
//! rendered slice lies in front of the eye along the principal axis
//! (`z > -D`), the line from the eye through an intermediate pixel is one
//! final pixel's ray: projecting before warping is exact (the paper's
//! section 2.4), which the tests check against an independent projection
//! of voxel centres.

use glam::{DMat3, DVec3};

use crate::error::{input, Error, Result};
use crate::geometry::{BaseGrid, View};
use crate::warp::pixel_to_base;

/// Accepted intermediate scales (pixels per voxel of slice 0): below 1/8
/// a pixel averages a 8x8 block of slice 0, above 8 the front slice is
/// magnified beyond any final image's need.
pub const SCALE_RANGE: (f64, f64) = (0.125, 8.0);

/// Largest intermediate image (pixels; 16 bytes each).
pub const MAX_INTERMEDIATE: u128 = 1 << 26;

/// Refuses an intermediate scale outside [`SCALE_RANGE`].
pub fn check_scale(scale: f64) -> Result<()> {
    let (lo, hi) = SCALE_RANGE;
    if !(scale.is_finite() && (lo..=hi).contains(&scale)) {
        return Err(input(format!(
            "intermediate scale {scale} must be a number from {lo} to {hi} (pixels per voxel of the front slice)"
        )));
    }
    Ok(())
}

/// Where the volume lies relative to the eye (the paper's section 3.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EyeCase {
    /// Entirely in front of the plane through the eye parallel to the
    /// image: the warp does the frustum clipping.
    Front,
    /// Entirely behind it: nothing is drawn, nothing composited.
    Behind,
    /// Partly in front and partly behind (the eye inside or beside the
    /// volume): slices nearer than the near plane along the principal
    /// axis are dropped ([`crate::geometry::View::new`]), the rest is
    /// composited and the warp keeps what lies in front of the eye.
    Around,
}

impl EyeCase {
    /// Which case `view` is: the rendered box's corners against the plane
    /// through the eye spanned by the image's axes (the rays of every
    /// pixel, of any image, point into its positive side).
    pub fn of(view: &View) -> EyeCase {
        let r = &view.rays;
        let mut n = r.b.cross(r.c);
        if n.dot(r.a) < 0.0 {
            n = -n;
        }
        let [nx, ny, nz] = view.dims;
        let (mut front, mut behind) = (false, false);
        for k in 0..8 {
            let x = if k & 1 == 0 { -0.5 } else { nx as f64 - 0.5 };
            let y = if k & 2 == 0 { -0.5 } else { ny as f64 - 0.5 };
            let z = if k & 4 == 0 { -0.5 } else { nz as f64 - 0.5 };
            let s = (DVec3::new(x, y, z) - view.eye).dot(n);
            front |= s > 0.0;
            behind |= s <= 0.0;
        }
        match (front, behind) {
            (true, false) => EyeCase::Front,
            (false, _) => EyeCase::Behind,
            (true, true) => EyeCase::Around,
        }
    }

    /// Name in the stats JSON.
    pub fn name(self) -> &'static str {
        match self {
            EyeCase::Front => "front",
            EyeCase::Behind => "behind",
            EyeCase::Around => "around",
        }
    }
}

/// The factorisation of one view: shear per slice, the intermediate image
/// and the warp.
#[derive(Debug, Clone, PartialEq)]
pub struct Factor {
    /// Eye in view space.
    pub eye: DVec3,
    /// Eye distance to slice 0.
    pub d: f64,
    /// Intermediate pixels per voxel on the plane of slice 0.
    pub scale: f64,
    /// Global index of intermediate pixel `(0, 0)` (pixel `k` of the
    /// whole plane is centred at `(k + 1/2) / scale - 1/2`).
    pub first: [i64; 2],
    /// The intermediate image as a grid on the plane of slice 0.
    pub grid: BaseGrid,
}

impl Factor {
    /// The factorisation of `view` at intermediate scale `scale`. The
    /// intermediate image covers the projection of every rendered slice
    /// (slices 0 and `nz - 1` bound it: `s(z)` is monotonic); with `cull`
    /// it is cut to what the final image can read (its corner rays' feet
    /// on the plane, widened by the warp filter), which changes no pixel.
    pub fn new(view: &View, scale: f64, cull: bool) -> Result<Factor> {
        check_scale(scale)?;
        let (eye, d) = (view.eye, view.d);
        let nz = view.dims[2];
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for z in [0, nz.saturating_sub(1)] {
            let s = d / (z as f64 + d);
            for a in 0..2 {
                for x in [-0.5, view.dims[a] as f64 - 0.5] {
                    let p = eye[a] + (x - eye[a]) * s;
                    lo[a] = lo[a].min(p);
                    hi[a] = hi[a].max(p);
                }
            }
        }
        if cull {
            if let Some((vlo, vhi)) = visible_feet(view, scale) {
                for a in 0..2 {
                    lo[a] = lo[a].max(vlo[a]);
                    hi[a] = hi[a].min(vhi[a]);
                }
            }
        }
        // One pixel of margin beyond the last centre the slices reach.
        let global = |x: f64| (x + 0.5) * scale - 0.5;
        let first: [i64; 2] = std::array::from_fn(|a| global(lo[a]).floor() as i64 - 1);
        let last: [i64; 2] = std::array::from_fn(|a| global(hi[a]).ceil() as i64 + 1);
        let counts: [usize; 2] = std::array::from_fn(|a| (last[a] - first[a] + 1).max(0) as usize);
        let pixels = counts[0] as u128 * counts[1] as u128;
        if pixels > MAX_INTERMEDIATE {
            return Err(Error::TooLarge {
                what: format!(
                    "the {}x{} intermediate image (lower --intermediate-scale)",
                    counts[0], counts[1]
                ),
                bytes: pixels * 16,
                limit: (MAX_INTERMEDIATE * 16) as u64,
            });
        }
        let h = 1.0 / scale;
        Ok(Factor {
            eye,
            d,
            scale,
            first,
            grid: BaseGrid {
                origin: [
                    (first[0] as f64 + 0.5) * h - 0.5,
                    (first[1] as f64 + 0.5) * h - 0.5,
                ],
                spacing: h,
                counts,
            },
        })
    }

    /// `s(z)`: how much slice `z` shrinks on its way to the plane of slice 0.
    #[inline]
    pub fn slice_scale(&self, z: f64) -> f64 {
        self.d / (z + self.d)
    }

    /// Plane position (view `x` or `y` on slice 0's plane) of intermediate
    /// pixel `k` (local index) on axis `a`.
    #[inline]
    pub fn pixel_pos(&self, k: usize, a: usize) -> f64 {
        ((self.first[a] + k as i64) as f64 + 0.5) / self.scale - 0.5
    }

    /// Continuous intermediate pixel coordinate (local) of plane position
    /// `x` on axis `a`: the inverse of [`Factor::pixel_pos`].
    #[inline]
    pub fn plane_to_pixel(&self, x: f64, a: usize) -> f64 {
        (x + 0.5) * self.scale - 0.5 - self.first[a] as f64
    }

    /// The shear: intermediate-image coordinates (pixel centres at
    /// integers, local indices) of view-space point `p` (`p.z > -D`).
    pub fn shear(&self, p: DVec3) -> [f64; 2] {
        let s = self.slice_scale(p.z);
        std::array::from_fn(|a| self.plane_to_pixel(self.eye[a] + (p[a] - self.eye[a]) * s, a))
    }

    /// Final pixel `(p_x, p_y, 1)` to homogeneous intermediate coordinates:
    /// the inverse warp (`w <= 0`: the pixel's ray never meets the plane).
    pub fn pixel_to_intermediate(&self, view: &View) -> DMat3 {
        pixel_to_base(view, &self.grid)
    }

    /// The warp: continuous final-pixel position of intermediate point
    /// `(u, v)`, `None` when it lies behind the eye.
    pub fn warp(&self, view: &View, uv: [f64; 2]) -> Option<[f64; 2]> {
        let q = self.pixel_to_intermediate(view).inverse() * DVec3::new(uv[0], uv[1], 1.0);
        (q.z > 0.0).then(|| [q.x / q.z, q.y / q.z])
    }
}

/// The plane positions the final image can read: the feet of its corner
/// rays on slice 0's plane, widened by the warp filter's half-width
/// there; `None` when a corner ray does not reach the plane (the visible
/// part is then unbounded).
fn visible_feet(view: &View, scale: f64) -> Option<([f64; 2], [f64; 2])> {
    let h = 1.0 / scale;
    let unit = BaseGrid {
        origin: [0.0, 0.0],
        spacing: h,
        counts: [1, 1],
    };
    let m = pixel_to_base(view, &unit);
    let [w, hgt] = view.size.map(f64::from);
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for (px, py) in [(0.0, 0.0), (w, 0.0), (0.0, hgt), (w, hgt)] {
        let q = m * DVec3::new(px, py, 1.0);
        if q.z <= 0.0 {
            return None;
        }
        let uv = [q.x / q.z, q.y / q.z];
        let half = super::warp::half_width(&m, q) + 2.0;
        for a in 0..2 {
            lo[a] = lo[a].min((uv[a] - half) * h);
            hi[a] = hi[a].max((uv[a] + half) * h);
        }
    }
    Some((lo, hi))
}
