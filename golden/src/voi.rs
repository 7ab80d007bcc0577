//! A volume of interest (Levoy's workstation, seed 001): a box or a sphere
//! in world units (voxel index times spacing, as `--clip` and `--eye`)
//! inside which (or, with `outside`, outside which) every sample's opacity
//! is scaled by `scale`, with a linear transition `ramp` world units wide
//! centred on the boundary. `scale = 0` outside hides everything but the
//! region; `scale > 1` inside brings it out of a translucent context.
//!
//! The weight of a sample at signed distance `d` from the boundary
//! (negative inside) is `w = clamp(1/2 - d / ramp, 0, 1)` (a step at
//! `d <= 0` when `ramp = 0`), and its opacity is multiplied by
//! `1 + (scale - 1) w` (`1 - w` for `w` with `outside`). A factor of
//! exactly 1 leaves a sample's bits unchanged, so a VOI of scale 1 renders
//! as none. Skipping stays exact: a scaled zero opacity is still zero, so
//! no empty block becomes visible.

use std::str::FromStr;

use glam::DVec3;

use crate::error::{input, Error, Result};
use crate::geometry::View;

/// The region's shape, in world units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// The box between two corners.
    Box {
        /// Lowest corner.
        lo: [f64; 3],
        /// Highest corner.
        hi: [f64; 3],
    },
    /// A ball.
    Sphere {
        /// Centre.
        centre: [f64; 3],
        /// Radius.
        radius: f64,
    },
}

impl FromStr for Shape {
    type Err = Error;

    /// Parses `box:x0,y0,z0,x1,y1,z1` or `sphere:cx,cy,cz,r`.
    fn from_str(s: &str) -> Result<Shape> {
        let bad = || {
            input(format!(
                "volume of interest '{s}' must be box:x0,y0,z0,x1,y1,z1 or sphere:cx,cy,cz,r"
            ))
        };
        let (kind, rest) = s.split_once(':').ok_or_else(bad)?;
        let v: Vec<f64> = rest
            .split(',')
            .map(|t| t.trim().parse::<f64>().map_err(|_| bad()))
            .collect::<Result<_>>()?;
        if v.iter().any(|x| !x.is_finite()) {
            return Err(input(format!("volume of interest '{s}' must be finite")));
        }
        match (kind, &v[..]) {
            ("box", &[x0, y0, z0, x1, y1, z1]) => {
                let (lo, hi) = ([x0, y0, z0], [x1, y1, z1]);
                if (0..3).any(|k| lo[k] > hi[k]) {
                    return Err(input(format!(
                        "volume of interest '{s}': each low corner coordinate must not exceed the high one"
                    )));
                }
                Ok(Shape::Box { lo, hi })
            }
            ("sphere", &[cx, cy, cz, r]) => {
                if r <= 0.0 {
                    return Err(input(format!(
                        "volume of interest '{s}': the radius must be positive"
                    )));
                }
                Ok(Shape::Sphere {
                    centre: [cx, cy, cz],
                    radius: r,
                })
            }
            _ => Err(bad()),
        }
    }
}

/// A volume of interest: shape, opacity scale, side and ramp width.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Voi {
    /// The region.
    pub shape: Shape,
    /// Opacity factor inside (or outside) the region, `0..=100`.
    pub scale: f64,
    /// Scale outside the region instead of inside.
    pub outside: bool,
    /// Width of the transition in world units (0: a step).
    pub ramp: f64,
}

impl Voi {
    /// Refuses a scale outside `0..=100` or a negative ramp.
    pub fn validate(&self) -> Result<()> {
        if !(self.scale.is_finite() && (0.0..=100.0).contains(&self.scale)) {
            return Err(input(format!(
                "volume-of-interest scale {} must lie in [0, 100]",
                self.scale
            )));
        }
        if !(self.ramp.is_finite() && self.ramp >= 0.0) {
            return Err(input(format!(
                "volume-of-interest ramp {} must be a finite width >= 0",
                self.ramp
            )));
        }
        Ok(())
    }
}

/// A volume of interest in a view's index space.
#[derive(Debug, Clone)]
pub struct ViewVoi {
    /// Box centre and half extents, or sphere centre (half extents 0).
    centre: DVec3,
    half: DVec3,
    radius: f64,
    sphere: bool,
    spacing: DVec3,
    scale: f64,
    outside: bool,
    ramp: f64,
}

impl ViewVoi {
    /// `voi` in `view`'s space.
    pub fn new(view: &View, voi: &Voi) -> Result<ViewVoi> {
        voi.validate()?;
        let axes = &view.axes;
        // World to index: divide by the world spacing, index-space order.
        let world_spacing = {
            let mut s = [0.0; 3];
            for (k, &p) in axes.perm.iter().enumerate() {
                s[p] = view.spacing[k];
            }
            DVec3::from_array(s)
        };
        let to_view = |w: [f64; 3]| axes.to_view(DVec3::from_array(w) / world_spacing);
        let (centre, half, radius, sphere) = match voi.shape {
            Shape::Box { lo, hi } => {
                let (a, b) = (to_view(lo), to_view(hi));
                ((a + b) / 2.0, (a - b).abs() / 2.0, 0.0, false)
            }
            Shape::Sphere { centre, radius } => (to_view(centre), DVec3::ZERO, radius, true),
        };
        Ok(ViewVoi {
            centre,
            half,
            radius,
            sphere,
            spacing: DVec3::from_array(view.spacing),
            scale: voi.scale,
            outside: voi.outside,
            ramp: voi.ramp,
        })
    }

    /// The region in the view's index space, for a fixed-point twin:
    /// centre, box half extents (zero for a sphere), the sphere's radius in
    /// world units (zero for a box) and whether it is a sphere.
    pub fn region(&self) -> (DVec3, DVec3, f64, bool) {
        (self.centre, self.half, self.radius, self.sphere)
    }

    /// The view's voxel spacing per view axis (index to world units).
    pub fn spacing(&self) -> DVec3 {
        self.spacing
    }

    /// Opacity scale, whether it applies outside, and the ramp width.
    pub fn weighting(&self) -> (f64, bool, f64) {
        (self.scale, self.outside, self.ramp)
    }

    /// Signed distance in world units from view point `p` to the region's
    /// boundary, negative inside.
    pub fn distance(&self, p: DVec3) -> f64 {
        let q = (p - self.centre) * self.spacing;
        if self.sphere {
            return q.length() - self.radius;
        }
        let d = q.abs() - self.half * self.spacing;
        d.max(DVec3::ZERO).length() + d.max_element().min(0.0)
    }

    /// The opacity factor at view point `p`.
    #[inline]
    pub fn factor(&self, p: DVec3) -> f64 {
        let d = self.distance(p);
        let mut w = if self.ramp > 0.0 {
            (0.5 - d / self.ramp).clamp(0.0, 1.0)
        } else if d <= 0.0 {
            1.0
        } else {
            0.0
        };
        if self.outside {
            w = 1.0 - w;
        }
        1.0 + (self.scale - 1.0) * w
    }

    /// [`ViewVoi::factor`] for the slice-order methods' `f32` samples.
    #[inline]
    pub fn factor_f32(&self, x: f32, y: f32, z: f32) -> f32 {
        self.factor(DVec3::new(x.into(), y.into(), z.into())) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_parse_and_refuse() {
        assert_eq!(
            "box:1,2,3,4,5,6".parse::<Shape>().unwrap(),
            Shape::Box {
                lo: [1.0, 2.0, 3.0],
                hi: [4.0, 5.0, 6.0]
            }
        );
        assert!(matches!(
            "sphere:1,2,3,4".parse::<Shape>().unwrap(),
            Shape::Sphere { radius, .. } if radius == 4.0
        ));
        for bad in [
            "box:1,2,3",
            "cube:1,2,3,4,5,6",
            "sphere:1,2,3,0",
            "box:4,0,0,1,1,1",
            "sphere:a,b,c,d",
            "box",
        ] {
            let e = bad.parse::<Shape>().unwrap_err().to_string();
            assert!(e.contains("volume of interest"), "{bad}: {e}");
        }
    }
}
