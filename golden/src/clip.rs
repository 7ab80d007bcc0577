//! User clip planes. A plane `(nx, ny, nz, d)` in world units keeps the
//! points `p` with `n . p + d >= 0` (OpenGL's plane equation); up to
//! [`MAX_PLANES`] planes cut the volume to their intersection. Every
//! method tests its own sample positions against the planes, so a sample
//! beyond a plane is never taken and the cut is as sharp as the sampling:
//! the slice-order methods test each ray's crossing of each slice (as a
//! run of rays per row, see [`crate::skip`]), the reference each step.

use std::str::FromStr;

use glam::DVec3;

use crate::error::{input, Error, Result};
use crate::geometry::AxisMap;

/// Most clip planes a view may have.
pub const MAX_PLANES: usize = 6;

/// A clip plane in world units: keeps `normal . p + d >= 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClipPlane {
    /// Plane normal (any non-zero length), pointing into the kept side.
    pub normal: DVec3,
    /// Offset.
    pub d: f64,
}

impl ClipPlane {
    /// A plane, refused when not finite or when the normal is zero.
    pub fn new(normal: DVec3, d: f64) -> Result<ClipPlane> {
        if !(normal.is_finite() && d.is_finite()) {
            return Err(input(format!(
                "clip plane {},{},{},{d} must be finite",
                normal.x, normal.y, normal.z
            )));
        }
        if normal.length_squared() == 0.0 {
            return Err(input("clip plane normal must not be zero"));
        }
        Ok(ClipPlane { normal, d })
    }
}

impl FromStr for ClipPlane {
    type Err = Error;
    /// Parses `nx,ny,nz,d`.
    fn from_str(s: &str) -> Result<ClipPlane> {
        let bad = || {
            input(format!(
                "clip plane '{s}' must be nx,ny,nz,d (four numbers)"
            ))
        };
        let v: Vec<f64> = s
            .split(',')
            .map(|t| t.trim().parse::<f64>().map_err(|_| bad()))
            .collect::<Result<_>>()?;
        if v.len() != 4 {
            return Err(bad());
        }
        ClipPlane::new(DVec3::new(v[0], v[1], v[2]), v[3])
    }
}

/// Refuses more than [`MAX_PLANES`] planes.
pub fn check_planes(planes: &[ClipPlane]) -> Result<()> {
    if planes.len() > MAX_PLANES {
        return Err(input(format!(
            "{} clip planes given; at most {MAX_PLANES} are supported",
            planes.len()
        )));
    }
    Ok(())
}

/// The clip planes in one view's space (voxel units of the permuted,
/// near-clipped stack): keeps `n . v + d >= 0`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ViewClip {
    planes: Vec<(DVec3, f64)>,
}

impl ViewClip {
    /// Moves world planes into the view space of `axes`; `spacing` is the
    /// volume's world units per index step.
    pub fn new(planes: &[ClipPlane], axes: &AxisMap, spacing: [f64; 3]) -> ViewClip {
        // World = S (A v + c): n . world + d = (A^T S n) . v + (n . S c + d).
        let world = |i: DVec3| DVec3::from_array(std::array::from_fn(|k| i[k] * spacing[k]));
        let c = world(axes.to_index(DVec3::ZERO));
        let cols = [DVec3::X, DVec3::Y, DVec3::Z].map(|e| world(axes.to_index(e)) - c);
        let planes = planes
            .iter()
            .map(|p| {
                let n = DVec3::new(
                    p.normal.dot(cols[0]),
                    p.normal.dot(cols[1]),
                    p.normal.dot(cols[2]),
                );
                (n, p.normal.dot(c) + p.d)
            })
            .collect();
        ViewClip { planes }
    }

    /// True when no plane is set.
    pub fn is_empty(&self) -> bool {
        self.planes.is_empty()
    }

    /// True when view-space point `(x, y, z)` is kept by every plane.
    #[inline]
    pub fn keeps(&self, x: f64, y: f64, z: f64) -> bool {
        self.planes
            .iter()
            .all(|(n, d)| n.x * x + n.y * y + n.z * z + d >= 0.0)
    }

    /// True when some plane cuts away the whole rectangle `[x0, x1] x
    /// [y0, y1]` of slice `z` (all four corners beyond it).
    pub fn drops_rect(&self, [x0, x1]: [f64; 2], [y0, y1]: [f64; 2], z: f64) -> bool {
        self.planes.iter().any(|(n, d)| {
            [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]
                .iter()
                .all(|&(x, y)| n.x * x + n.y * y + n.z * z + d < 0.0)
        })
    }

    /// Narrows the rays `lo..=hi` at `x = a + m t` (`t > 0`) on row `y` of
    /// slice `z` to those [`ViewClip::keeps`] keeps (an interval, since
    /// the kept set is convex); `lo > hi` when none is.
    pub fn narrow(
        &self,
        a: f64,
        t: f64,
        y: f64,
        z: f64,
        (mut lo, mut hi): (i64, i64),
    ) -> (i64, i64) {
        let keeps = |m: i64| self.keeps(a + m as f64 * t, y, z);
        for (n, d) in &self.planes {
            if lo > hi {
                break;
            }
            let c = n.y * y + n.z * z + d;
            if n.x == 0.0 {
                if c < 0.0 {
                    return (0, -1);
                }
                continue;
            }
            // n.x (a + m t) + c >= 0 at m = (-c / n.x - a) / t; the
            // estimate is then settled with the exact test of every plane.
            let m = ((-c / n.x - a) / t).clamp(-(1i64 << 52) as f64, (1i64 << 52) as f64);
            if n.x > 0.0 {
                lo = lo.max(m.floor() as i64 - 1);
            } else {
                hi = hi.min(m.ceil() as i64 + 1);
            }
        }
        while lo <= hi && !keeps(lo) {
            lo += 1;
        }
        while hi >= lo && !keeps(hi) {
            hi -= 1;
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `narrow` keeps exactly the rays `keeps` keeps, for planes at every
    /// orientation (including ones parallel to the row) and rays either
    /// side of them.
    #[test]
    fn narrow_matches_the_per_ray_test() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for case in 0..2000 {
            let n = |r: f64| if case % 7 == 0 { 0.0 } else { r };
            let planes: Vec<(DVec3, f64)> = (0..1 + case % 3)
                .map(|_| (DVec3::new(n(rnd()), rnd(), rnd()), rnd() * 40.0))
                .collect();
            let clip = ViewClip { planes };
            let (a, t) = (rnd() * 10.0, 0.25 + rnd().abs());
            let (y, z) = (rnd() * 30.0, rnd().abs() * 30.0);
            let range = (-40, 60);
            let (lo, hi) = clip.narrow(a, t, y, z, range);
            let want: Vec<i64> = (range.0..=range.1)
                .filter(|&m| clip.keeps(a + m as f64 * t, y, z))
                .collect();
            let got: Vec<i64> = (lo..=hi).collect();
            assert_eq!(got, want, "case {case}");
        }
    }
}
