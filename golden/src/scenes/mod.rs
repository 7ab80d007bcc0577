//! Synthetic test scenes, sized by the user, and the named transfer-function
//! presets that go with them.
//!
//! Every scene is an 8-bit ([`VoxelType::U8`]) cube of `N^3` voxels with
//! unit spacing, built in parallel by [`Volume::from_fn`]. The CLI syntax is
//! `checker[:N[:cube]]`, `ml[:N]`, `sphere[:N]` and `impulse[:N]`.

use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

use crate::error::{input, Error, Result};
use crate::tf::TransferFunction;
use crate::volume::{Volume, VoxelType};

/// Smallest scene edge accepted (one voxel has no interior to interpolate).
pub const MIN_SIZE: usize = 2;
/// Largest scene edge accepted: 2048^3 is 8 GiB of bytes, which the
/// command line builds only when its memory check finds room for the frame.
pub const MAX_SIZE: usize = 2048;

/// Scalar value of filled floor cubes in [`Scene::Checker`].
pub const CHECKER_FLOOR: u16 = 200;
/// Scalar value of filled wall cubes in [`Scene::Checker`]; distinct from
/// the floor so a transfer function can colour them differently.
pub const CHECKER_WALL: u16 = 100;

/// Marschner-Lobb frequency `f_M` (the standard test value).
pub const ML_FM: f64 = 6.0;
/// Marschner-Lobb modulation depth `alpha` (the standard test value).
pub const ML_ALPHA: f64 = 0.25;

const USAGE: &str = "use checker[:N[:cube]], ml[:N], sphere[:N], ribbon[:N] or impulse[:N]";

/// A synthetic volume; `n` is the edge length in voxels (the volume is `n^3`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scene {
    /// The ER-Perspective paper's checkerboard room (Kreeger et al.): a
    /// floor (low y) of blue cubes and a left (high x: on the image's left
    /// for an eye at z < 0 looking along +z with up +y, since the camera is
    /// right-handed) and a rear (high z) wall of white cubes, each one cube thick,
    /// made of `cube`^3-voxel cubes alternating filled/empty in a
    /// checkerboard. Filled floor voxels hold [`CHECKER_FLOOR`], filled wall
    /// voxels [`CHECKER_WALL`], air 0.
    ///
    /// The cube grid is anchored at the room's closed corner (x = n - 1,
    /// y = 0, z = n - 1), whose cube is filled, so the floor and both walls are
    /// exactly one cube thick and share one 3D parity (the pattern runs on
    /// without a seam where they meet; the floor runs under the walls).
    /// When `cube` does not divide `n`, the partial cubes fall on the open
    /// sides (high x, high y, low z).
    Checker {
        /// Edge length in voxels.
        n: usize,
        /// Edge length of one cube in voxels (1..=n).
        cube: usize,
    },
    /// The Marschner-Lobb test signal ([`marschner_lobb`]) sampled over
    /// `[-1, 1]^3` at `n^3` points (voxel 0 at -1, voxel n-1 at +1),
    /// scaled to 0..=255.
    MarschnerLobb {
        /// Edge length in voxels.
        n: usize,
    },
    /// A spherical shell about the volume centre: radius `0.4 n`, thickness
    /// `max(n / 16, 1)` voxels, value 255 inside, falling off linearly to 0
    /// over one voxel at both surfaces so the edges do not alias.
    Sphere {
        /// Edge length in voxels.
        n: usize,
    },
    /// A thin, folded shell like a cortical ribbon: the surface
    /// `r = 0.3 n (1 + 0.15 sin(5 theta) sin(4 phi))` about the centre, its
    /// cross-section a Gaussian of standard deviation `0.6` voxels and peak
    /// 220 in distance along the radius, so the scalar rises and falls
    /// within two voxels on every ray that crosses it (a high-frequency
    /// volume for pre-integration).
    Ribbon {
        /// Edge length in voxels.
        n: usize,
    },
    /// A single voxel of value 255 at `(n/2, n/2, n/2)`, all else 0: the
    /// impulse response of a renderer.
    Impulse {
        /// Edge length in voxels.
        n: usize,
    },
}

impl Scene {
    /// Voxel counts along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        [self.size(); 3]
    }

    /// The edge length `n`.
    pub fn size(&self) -> usize {
        match *self {
            Scene::Checker { n, .. }
            | Scene::MarschnerLobb { n }
            | Scene::Sphere { n }
            | Scene::Ribbon { n }
            | Scene::Impulse { n } => n,
        }
    }

    /// The scene's name in the CLI syntax, which is also the name of its
    /// transfer-function preset.
    pub fn name(&self) -> &'static str {
        match self {
            Scene::Checker { .. } => "checker",
            Scene::MarschnerLobb { .. } => "ml",
            Scene::Sphere { .. } => "sphere",
            Scene::Ribbon { .. } => "ribbon",
            Scene::Impulse { .. } => "impulse",
        }
    }

    /// The voxel type the scene is built in.
    pub fn voxel_type(&self) -> VoxelType {
        VoxelType::U8
    }

    /// Builds the volume, refusing (before allocating) one over `limit`
    /// bytes.
    pub fn build(&self, limit: u64) -> Result<Volume> {
        let dims = self.dims();
        match *self {
            Scene::Checker { n, cube } => {
                if !(1..=n).contains(&cube) {
                    return Err(input(format!(
                        "checker cube size {cube} is out of range 1..={n}"
                    )));
                }
                Volume::from_fn(dims, VoxelType::U8, limit, |x, y, z| {
                    // Mirrored in x: the side wall stands at high x, which a camera at
                    // z < 0 with up +y shows on the image's left, as in the paper.
                    checker_value(n, cube, n - 1 - x, y, z)
                })
            }
            Scene::MarschnerLobb { n } => {
                let coord = |i: usize| -1.0 + 2.0 * i as f64 / (n - 1).max(1) as f64;
                Volume::from_fn(dims, VoxelType::U8, limit, |x, y, z| {
                    (marschner_lobb(coord(x), coord(y), coord(z)) * 255.0).round() as u16
                })
            }
            Scene::Sphere { n } => {
                let c = (n as f64 - 1.0) / 2.0;
                let radius = 0.4 * n as f64;
                let half = (n as f64 / 16.0).max(1.0) / 2.0;
                Volume::from_fn(dims, VoxelType::U8, limit, |x, y, z| {
                    let d =
                        ((x as f64 - c).powi(2) + (y as f64 - c).powi(2) + (z as f64 - c).powi(2))
                            .sqrt();
                    // Coverage of a one-voxel box filter: 1 well inside the
                    // shell, 0.5 on its surfaces, 0 a half voxel outside.
                    let cover = (half - (d - radius).abs() + 0.5).clamp(0.0, 1.0);
                    (cover * 255.0).round() as u16
                })
            }
            Scene::Ribbon { n } => {
                let c = (n as f64 - 1.0) / 2.0;
                let r0 = 0.3 * n as f64;
                Volume::from_fn(dims, VoxelType::U8, limit, |x, y, z| {
                    let (dx, dy, dz) = (x as f64 - c, y as f64 - c, z as f64 - c);
                    let d = (dx * dx + dy * dy + dz * dz).sqrt();
                    let theta = (dz / d.max(1e-9)).clamp(-1.0, 1.0).acos();
                    let phi = dy.atan2(dx);
                    let r = r0 * (1.0 + 0.15 * (5.0 * theta).sin() * (4.0 * phi).sin());
                    let u = (d - r) / 0.6;
                    (220.0 * (-0.5 * u * u).exp()).round() as u16
                })
            }
            Scene::Impulse { n } => Volume::from_fn(dims, VoxelType::U8, limit, |x, y, z| {
                if (x, y, z) == (n / 2, n / 2, n / 2) {
                    255
                } else {
                    0
                }
            }),
        }
    }

    /// The transfer-function preset made for this scene (see [`tf_preset`]).
    pub fn preset(&self) -> TransferFunction {
        tf_preset(self.name()).expect("every scene name is a preset")
    }
}

/// The checkerboard room's voxel at `(x, y, z)`; see [`Scene::Checker`].
fn checker_value(n: usize, cube: usize, x: usize, y: usize, z: usize) -> u16 {
    let (i, j, k) = (x / cube, y / cube, (n - 1 - z) / cube);
    if (i + j + k) % 2 != 0 {
        0
    } else if j == 0 {
        CHECKER_FLOOR
    } else if i == 0 || k == 0 {
        CHECKER_WALL
    } else {
        0
    }
}

/// The Marschner-Lobb function at `(x, y, z)` in `[-1, 1]^3`, with
/// `f_M` = [`ML_FM`] and `alpha` = [`ML_ALPHA`]:
/// `(1 - sin(pi z / 2) + alpha (1 + rho_r(sqrt(x^2 + y^2)))) / (2 (1 + alpha))`
/// with `rho_r(r) = cos(2 pi f_M cos(pi r / 2))`. Its range is `[0, 1]`; it
/// is exposed so accuracy tests can compare against the continuous signal.
pub fn marschner_lobb(x: f64, y: f64, z: f64) -> f64 {
    let r = (x * x + y * y).sqrt();
    let rho_r = (2.0 * PI * ML_FM * (PI * r / 2.0).cos()).cos();
    (1.0 - (PI * z / 2.0).sin() + ML_ALPHA * (1.0 + rho_r)) / (2.0 * (1.0 + ML_ALPHA))
}

impl FromStr for Scene {
    type Err = Error;

    /// Parses `checker[:N[:cube]]` (default 256, cube 5), `ml[:N]` (default
    /// 64), `sphere[:N]` (default 64) or `impulse[:N]` (default 16); N in
    /// [`MIN_SIZE`]..=[`MAX_SIZE`], cube in 1..=N. Names are case-blind and
    /// `marschner-lobb` is accepted for `ml`.
    fn from_str(spec: &str) -> Result<Scene> {
        let mut fields = spec.split(':');
        let name = fields.next().unwrap_or_default().to_ascii_lowercase();
        let args: Vec<&str> = fields.collect();
        let (default_n, max_args) = match name.as_str() {
            "checker" => (256, 2),
            "ml" | "marschner-lobb" => (64, 1),
            "sphere" => (64, 1),
            "ribbon" => (64, 1),
            "impulse" => (16, 1),
            _ => return Err(input(format!("unknown scene '{spec}': {USAGE}"))),
        };
        if args.len() > max_args {
            return Err(input(format!(
                "scene '{spec}' has too many fields: {USAGE}"
            )));
        }
        let number = |what: &str, text: &str| -> Result<usize> {
            text.parse().map_err(|_| {
                input(format!(
                    "scene '{spec}': {what} '{text}' is not a whole number: {USAGE}"
                ))
            })
        };
        let n = match args.first() {
            Some(text) => number("size", text)?,
            None => default_n,
        };
        if !(MIN_SIZE..=MAX_SIZE).contains(&n) {
            return Err(input(format!(
                "scene '{spec}': size {n} is out of range {MIN_SIZE}..={MAX_SIZE}"
            )));
        }
        Ok(match name.as_str() {
            "checker" => {
                let cube = match args.get(1) {
                    Some(text) => number("cube size", text)?,
                    None => 5.min(n),
                };
                if !(1..=n).contains(&cube) {
                    return Err(input(format!(
                        "scene '{spec}': cube size {cube} is out of range 1..={n}"
                    )));
                }
                Scene::Checker { n, cube }
            }
            "sphere" => Scene::Sphere { n },
            "ribbon" => Scene::Ribbon { n },
            "impulse" => Scene::Impulse { n },
            _ => Scene::MarschnerLobb { n },
        })
    }
}

impl fmt::Display for Scene {
    /// The full CLI spelling, e.g. `checker:256:5`, which parses back to
    /// the same scene.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Scene::Checker { n, cube } => write!(f, "checker:{n}:{cube}"),
            other => write!(f, "{}:{}", other.name(), other.size()),
        }
    }
}

mod presets;
pub use presets::{tf_preset, PRESETS};

#[cfg(test)]
mod tests;
