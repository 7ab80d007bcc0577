//! The pinhole camera and its pixel rays.
//!
//! Conventions (the README and the tests state the same): forward
//! `f = normalize(look_at - eye)`, right `r = normalize(f x up)`, true up
//! `u = r x f`. Pixel `(i, j)` (column, row from the top) looks along
//! `f + sx r + sy u` with `sx = (2 (i + 0.5) / W - 1) tan(fov/2) W / H` and
//! `sy = (1 - 2 (j + 0.5) / H) tan(fov/2)`. All positions are world units:
//! voxel index times spacing (voxel units at unit spacing).

use glam::DVec3;

use crate::error::{input, Result};

/// Largest image edge accepted (pixels): keeps a typo from allocating
/// gigabytes.
pub const MAX_IMAGE_EDGE: u32 = 16384;

/// Where the final image lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ImagePlane {
    /// An ordinary perspective image perpendicular to the view direction.
    #[default]
    Camera,
    /// The paper's figures: the image plane is the volume's front face
    /// (the baseplane, perpendicular to the principal axis). Pixels are
    /// spaced `2 D tan(fov/2) / H` on it, centred where the line of sight
    /// meets it, with the camera's right and up projected onto it. When the
    /// line of sight is along the principal axis the two planes give the same
    /// image.
    Front,
}

/// A validated pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position (world units).
    pub eye: DVec3,
    /// The point the camera looks at.
    pub look_at: DVec3,
    /// Approximate up direction.
    pub up: DVec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_deg: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Which plane the final image lies on.
    pub image_plane: ImagePlane,
}

/// Pixel rays in affine form: the ray through continuous pixel position
/// `(px, py)` (pixel centres at `i + 0.5`) leaves `eye` along
/// `a + px b + py c` (world units, not normalised).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelRays {
    /// Ray origin.
    pub eye: DVec3,
    /// Direction at pixel position (0, 0), the image's top-left corner.
    pub a: DVec3,
    /// Change of direction per pixel to the right.
    pub b: DVec3,
    /// Change of direction per pixel downwards.
    pub c: DVec3,
}

impl PixelRays {
    /// Direction of the ray through continuous pixel position `(px, py)`.
    #[inline]
    pub fn dir(&self, px: f64, py: f64) -> DVec3 {
        self.a + px * self.b + py * self.c
    }

    /// Continuous pixel position where world point `p` projects, or `None`
    /// when it lies behind the eye. Solves `p - eye = s (a + px b + py c)`.
    pub fn project(&self, p: DVec3) -> Option<(f64, f64)> {
        let m = glam::DMat3::from_cols(self.b, self.c, self.a);
        let det = m.determinant();
        if det.abs() < 1e-300 {
            return None;
        }
        let q = m.inverse() * (p - self.eye);
        // q = (px s, py s, s) up to the scale s of the direction.
        if q.z <= 0.0 {
            return None;
        }
        Some((q.x / q.z, q.y / q.z))
    }
}

/// Largest coordinate magnitude accepted: far beyond any volume, small
/// enough that squared lengths stay finite.
pub const MAX_COORD: f64 = 1e9;

fn finite3(name: &str, v: DVec3) -> Result<()> {
    if !v.is_finite() {
        Err(input(format!("{name} {v} is not finite")))
    } else if v.abs().max_element() > MAX_COORD {
        Err(input(format!(
            "{name} {v} is absurdly far (coordinates up to {MAX_COORD:e})"
        )))
    } else {
        Ok(())
    }
}

impl Camera {
    /// Builds a camera, refusing values that cannot define a view.
    pub fn new(
        eye: DVec3,
        look_at: DVec3,
        up: DVec3,
        fov_deg: f64,
        width: u32,
        height: u32,
    ) -> Result<Camera> {
        finite3("eye", eye)?;
        finite3("look-at", look_at)?;
        finite3("up", up)?;
        if !(fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(input(format!(
                "field of view {fov_deg} degrees must lie strictly between 0 and 180"
            )));
        }
        for (name, n) in [("width", width), ("height", height)] {
            if n == 0 || n > MAX_IMAGE_EDGE {
                return Err(input(format!(
                    "image {name} {n} must be between 1 and {MAX_IMAGE_EDGE}"
                )));
            }
        }
        let f = look_at - eye;
        if f.length() < 1e-9 * (1.0 + eye.length()) {
            return Err(input("look-at point equals the eye"));
        }
        if up.length() == 0.0 {
            return Err(input("up vector is zero"));
        }
        let cross = f.normalize().cross(up.normalize());
        if cross.length() < 1e-9 {
            return Err(input("up vector is parallel to the view direction"));
        }
        Ok(Camera {
            eye,
            look_at,
            up,
            fov_deg,
            width,
            height,
            image_plane: ImagePlane::Camera,
        })
    }

    /// Forward, right and true-up unit vectors.
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let f = (self.look_at - self.eye).normalize();
        let r = f.cross(self.up).normalize();
        let u = r.cross(f);
        (f, r, u)
    }

    /// `tan(fov / 2)`.
    pub fn tan_half_fov(&self) -> f64 {
        (self.fov_deg.to_radians() * 0.5).tan()
    }

    /// The camera's pixel rays for the ordinary image plane.
    pub fn pixel_rays(&self) -> PixelRays {
        let (f, r, u) = self.basis();
        let t = self.tan_half_fov();
        let (w, h) = (self.width as f64, self.height as f64);
        // sx = (2 px / W - 1) t W / H, sy = (1 - 2 py / H) t.
        PixelRays {
            eye: self.eye,
            a: f - t * (w / h) * r + t * u,
            b: (2.0 * t / h) * r,
            c: (-2.0 * t / h) * u,
        }
    }

    /// Pixel rays whose image lies on the plane through `point` with unit
    /// normal `normal` (pointing away from the eye): the `Front` mode.
    /// Fails when the line of sight does not meet the plane in front.
    pub fn plane_rays(&self, point: DVec3, normal: DVec3) -> Result<PixelRays> {
        let (f, r, u) = self.basis();
        let dist = (point - self.eye).dot(normal);
        let fn_ = f.dot(normal);
        if dist <= 0.0 || fn_ <= 1e-9 {
            return Err(input(
                "the front image plane is not in front of the eye along the line of sight",
            ));
        }
        let centre = self.eye + f * (dist / fn_);
        let rp = r - normal * r.dot(normal);
        if rp.length() < 1e-9 {
            return Err(input(
                "the camera's right vector is perpendicular to the front plane",
            ));
        }
        let rp = rp.normalize();
        let mut up_p = normal.cross(rp);
        if up_p.dot(u) < 0.0 {
            up_p = -up_p;
        }
        let s = 2.0 * dist * self.tan_half_fov() / self.height as f64;
        let (w, h) = (self.width as f64, self.height as f64);
        let corner = centre - rp * (s * w * 0.5) + up_p * (s * h * 0.5);
        Ok(PixelRays {
            eye: self.eye,
            a: corner - self.eye,
            b: rp * s,
            c: -up_p * s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::new(
            DVec3::new(0.0, 0.0, -10.0),
            DVec3::ZERO,
            DVec3::Y,
            90.0,
            64,
            32,
        )
        .unwrap()
    }

    #[test]
    fn pixel_rays_follow_the_stated_formula() {
        let c = cam();
        let rays = c.pixel_rays();
        let (f, r, u) = c.basis();
        let t = c.tan_half_fov();
        for &(i, j) in &[(0u32, 0u32), (63, 31), (10, 20)] {
            let sx = (2.0 * (i as f64 + 0.5) / 64.0 - 1.0) * t * 2.0;
            let sy = (1.0 - 2.0 * (j as f64 + 0.5) / 32.0) * t;
            let want = f + sx * r + sy * u;
            let got = rays.dir(i as f64 + 0.5, j as f64 + 0.5);
            assert!((want - got).length() < 1e-12);
            let back = rays.project(c.eye + 3.0 * got).unwrap();
            assert!((back.0 - (i as f64 + 0.5)).abs() < 1e-9);
            assert!((back.1 - (j as f64 + 0.5)).abs() < 1e-9);
        }
        // Looking along +z with up +y, right is -x.
        assert!((r - DVec3::NEG_X).length() < 1e-12);
    }

    #[test]
    fn front_plane_equals_camera_when_looking_along_its_normal() {
        let c = cam();
        let a = c.pixel_rays();
        let b = c.plane_rays(DVec3::new(0.0, 0.0, 5.0), DVec3::Z).unwrap();
        for &(px, py) in &[(0.5, 0.5), (20.0, 7.25), (63.5, 31.5)] {
            let (da, db) = (a.dir(px, py).normalize(), b.dir(px, py).normalize());
            assert!((da - db).length() < 1e-12, "{da} {db}");
        }
    }

    #[test]
    fn rejects_bad_cameras() {
        let e = DVec3::new(0.0, 0.0, -10.0);
        assert!(Camera::new(e, DVec3::ZERO, DVec3::Y, 0.0, 8, 8).is_err());
        assert!(Camera::new(e, DVec3::ZERO, DVec3::Y, 180.0, 8, 8).is_err());
        assert!(Camera::new(e, DVec3::ZERO, DVec3::Y, f64::NAN, 8, 8).is_err());
        assert!(Camera::new(e, e, DVec3::Y, 60.0, 8, 8).is_err());
        assert!(Camera::new(e, DVec3::ZERO, DVec3::Z, 60.0, 8, 8).is_err());
        assert!(Camera::new(e, DVec3::ZERO, DVec3::Y, 60.0, 0, 8).is_err());
        assert!(Camera::new(e, DVec3::ZERO, DVec3::Y, 60.0, 8, 1 << 20).is_err());
        assert!(Camera::new(DVec3::NAN, DVec3::ZERO, DVec3::Y, 60.0, 8, 8).is_err());
    }
}
