//! The views of `ercube peer --views`: the command's camera and views
//! derived from it, so that one run times and compares ercube and the
//! peer on views nobody tuned a method to (oblique, near, far), not only
//! the front one.

use anyhow::{bail, Result};
use glam::{DQuat, DVec3};
use golden::camera::Camera;

/// A view derived from the command's camera (eye `e`, looking at `c`,
/// distance `r = |e - c|`, up `u`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeerView {
    /// The command's own camera.
    Front,
    /// The eye turned 40 degrees about `u` and raised 25 degrees about
    /// the camera's right axis around `c`, at the same distance and field
    /// of view.
    Oblique,
    /// The eye moved along the view line to `0.55 r` from `c`, the same
    /// field of view (the volume fills more of the image, the rays
    /// diverge more).
    Near,
    /// The eye moved to `3 r` from `c` with the field of view narrowed so
    /// that the same extent fills the image (`tan(fov'/2) = tan(fov/2) /
    /// 3`): nearly parallel rays, the volume as large on the image.
    Far,
}

impl PeerView {
    /// Every view, in table order.
    pub const ALL: [PeerView; 4] = [
        PeerView::Front,
        PeerView::Oblique,
        PeerView::Near,
        PeerView::Far,
    ];

    /// The name on the command line, in tables and as the view's folder.
    pub fn name(self) -> &'static str {
        match self {
            PeerView::Front => "front",
            PeerView::Oblique => "oblique",
            PeerView::Near => "near",
            PeerView::Far => "far",
        }
    }

    /// This view of the command's camera `given`.
    pub fn camera(self, given: &Camera) -> Result<Camera> {
        let c = given.look_at;
        let d = given.eye - c;
        let r = d.length();
        let up = given.up.normalize();
        let mut cam = *given;
        match self {
            PeerView::Front => {}
            PeerView::Oblique => {
                let turned = DQuat::from_axis_angle(up, 40f64.to_radians()) * d;
                let right = turned.cross(up).normalize();
                let raised = DQuat::from_axis_angle(right, 25f64.to_radians()) * turned;
                cam.eye = c + raised;
            }
            PeerView::Near => cam.eye = c + d * 0.55,
            PeerView::Far => {
                cam.eye = c + d * 3.0;
                let half = (given.fov_deg.to_radians() / 2.0).tan() / 3.0;
                cam.fov_deg = 2.0 * half.atan().to_degrees();
            }
        }
        if !(r.is_finite() && r > 0.0) || cam.eye.distance(c) <= 0.0 {
            bail!("--views needs an eye apart from --look-at");
        }
        // Keep `up` off the new view direction (the oblique view turns it).
        if (cam.eye - c).normalize().cross(up).length() < 1e-3 {
            cam.up = pick_up(cam.eye - c);
        }
        Ok(cam)
    }
}

/// An axis far from `d` to use as up.
fn pick_up(d: DVec3) -> DVec3 {
    let d = d.normalize();
    [DVec3::Y, DVec3::Z, DVec3::X]
        .into_iter()
        .min_by(|a, b| a.dot(d).abs().total_cmp(&b.dot(d).abs()))
        .unwrap_or(DVec3::Y)
}

/// Parses `--views`: comma-separated names, or `all`.
pub fn parse_views(s: &str) -> Result<Vec<PeerView>> {
    let mut out = Vec::new();
    for tok in s.split(',').map(str::trim).filter(|t| !t.is_empty()) {
        if tok == "all" {
            for v in PeerView::ALL {
                if !out.contains(&v) {
                    out.push(v);
                }
            }
            continue;
        }
        let Some(v) = PeerView::ALL.into_iter().find(|v| v.name() == tok) else {
            bail!("unknown view '{tok}' in --views: use front, oblique, near, far or all");
        };
        if out.contains(&v) {
            bail!("view '{tok}' is listed twice in --views");
        }
        out.push(v);
    }
    if out.is_empty() {
        bail!("--views names no view");
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn given() -> Camera {
        Camera::new(
            DVec3::new(64.0, 64.0, -64.0),
            DVec3::new(64.0, 64.0, 42.0),
            DVec3::Y,
            90.0,
            32,
            32,
        )
        .unwrap()
    }

    #[test]
    fn views_keep_the_target_and_move_the_eye_as_documented() {
        let g = given();
        let r = g.eye.distance(g.look_at);
        let front = PeerView::Front.camera(&g).unwrap();
        assert_eq!(front.eye, g.eye);
        let ob = PeerView::Oblique.camera(&g).unwrap();
        assert!((ob.eye.distance(g.look_at) - r).abs() < 1e-9);
        let angle = (ob.eye - g.look_at)
            .angle_between(g.eye - g.look_at)
            .to_degrees();
        assert!(angle > 40.0 && angle < 65.0, "{angle}");
        let near = PeerView::Near.camera(&g).unwrap();
        assert!((near.eye.distance(g.look_at) - 0.55 * r).abs() < 1e-9);
        let far = PeerView::Far.camera(&g).unwrap();
        assert!((far.eye.distance(g.look_at) - 3.0 * r).abs() < 1e-9);
        let t = (far.fov_deg.to_radians() / 2.0).tan() * 3.0;
        assert!((t - (g.fov_deg.to_radians() / 2.0).tan()).abs() < 1e-12);
        for v in PeerView::ALL {
            assert_eq!(v.camera(&g).unwrap().look_at, g.look_at);
        }
    }

    #[test]
    fn view_lists() {
        assert_eq!(parse_views("all").unwrap(), PeerView::ALL.to_vec());
        assert_eq!(
            parse_views("near, front").unwrap(),
            vec![PeerView::Near, PeerView::Front]
        );
        assert!(parse_views("front,front").is_err());
        assert!(parse_views("side").is_err());
        assert!(parse_views("").is_err());
    }
}
