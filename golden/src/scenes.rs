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
use crate::tf::{ControlPoint, TransferFunction};
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

/// Names accepted by [`tf_preset`].
pub const PRESETS: &[&str] = &[
    "checker",
    "checker-mono",
    "ml",
    "sphere",
    "ribbon",
    "impulse",
    "grey-ramp",
    "brain",
    "brain-shaded",
];

/// A named transfer-function preset, written for 8-bit scalars (0..=255)
/// with `fit = [0, 255]`, so that on wider data it spans the data's range
/// ([`TransferFunction::fitted`]). Opacity is per unit length (per voxel at
/// unit spacing), as everywhere in [`crate::tf`].
///
/// - `checker`: air and everything below 40 transparent (so interpolation
///   near air stays clear), white with opacity 0.9 at the wall value
///   [`CHECKER_WALL`], blue (0.2, 0.3, 1.0) with opacity 0.9 at the floor
///   value [`CHECKER_FLOOR`] and above; in between the colour blends.
/// - `ml`: transparent below 100, orange and opacity 0.9 from 127 (the
///   function's 0.5 iso-level) up, lightening towards 255.
/// - `sphere`: pale blue, transparent below 32, opacity rising to 0.25 at
///   255 so the far side of the shell shows through the near one.
/// - `ribbon`: transparent below 40, dark red rising to opaque yellow
///   (opacity 0.95 from 160): the ribbon's colour changes inside one
///   voxel, where a step's own attenuation decides what shows.
/// - `impulse`: white, opacity rising linearly from 0 at 0 to 1 at 255.
/// - `grey-ramp`: colour `value / 255` grey; opacity 0 up to 30, rising
///   linearly to 1 at 150, then 1 (the classic `brainsmall` ramp).
/// - `brain`: for `brainsmall`: faint skin tones over 25..70, then bone and
///   bright tissue near-white and opaque from about 100.
/// - `brain-shaded`: `brain`'s table with a shading material (rendered
///   shaded unless `--no-shade`): translucent skin over an opaque, lit
///   surface.
///
/// An unknown name is an error listing the valid ones.
pub fn tf_preset(name: &str) -> Result<TransferFunction> {
    let white = [1.0, 1.0, 1.0];
    let blue = [0.2, 0.3, 1.0];
    let orange = [1.0, 0.55, 0.15];
    let pale = [0.6, 0.8, 1.0];
    let grey = |v: f64| [v / 255.0; 3];
    let points: Vec<(f64, [f64; 3], f64)> = match name {
        "checker" => vec![
            (0.0, white, 0.0),
            (40.0, white, 0.0),
            (CHECKER_WALL as f64, white, 0.9),
            (CHECKER_FLOOR as f64, blue, 0.9),
            (255.0, blue, 0.9),
        ],
        // One look for both materials, opacity rising monotonically to 0.9
        // at the wall value: no interpolated value between air and a floor
        // cube looks like another material, so the error figures measure
        // ray sampling, not a thin skin that one sample per slice cannot
        // resolve.
        "checker-mono" => vec![
            (0.0, white, 0.0),
            (CHECKER_WALL as f64, white, 0.9),
            (255.0, white, 0.9),
        ],
        "ml" => vec![
            (0.0, orange, 0.0),
            (100.0, orange, 0.0),
            (127.0, orange, 0.9),
            (160.0, [1.0, 0.7, 0.3], 0.9),
            (255.0, [1.0, 0.85, 0.6], 0.9),
        ],
        "sphere" => vec![
            (0.0, pale, 0.0),
            (32.0, pale, 0.0),
            (128.0, [0.75, 0.88, 1.0], 0.1),
            (255.0, [0.9, 0.95, 1.0], 0.25),
        ],
        "ribbon" => vec![
            (0.0, [0.5, 0.0, 0.1], 0.0),
            (40.0, [0.5, 0.0, 0.1], 0.0),
            (100.0, [0.9, 0.2, 0.1], 0.6),
            (160.0, [1.0, 0.9, 0.2], 0.95),
            (255.0, [1.0, 1.0, 0.6], 0.95),
        ],
        "impulse" => vec![(0.0, white, 0.0), (255.0, white, 1.0)],
        "grey-ramp" => vec![
            (0.0, grey(0.0), 0.0),
            (30.0, grey(30.0), 0.0),
            (150.0, grey(150.0), 1.0),
            (255.0, grey(255.0), 1.0),
        ],
        "brain" | "brain-shaded" => vec![
            (0.0, [0.9, 0.6, 0.5], 0.0),
            (25.0, [0.9, 0.6, 0.5], 0.0),
            (45.0, [0.95, 0.7, 0.6], 0.06),
            (70.0, [0.95, 0.75, 0.65], 0.08),
            (100.0, [1.0, 0.95, 0.88], 0.6),
            (130.0, [1.0, 1.0, 0.97], 0.9),
            (255.0, white, 0.9),
        ],
        _ => {
            return Err(input(format!(
                "unknown transfer-function preset '{name}': use {}",
                PRESETS.join(", ")
            )))
        }
    };
    let mut tf = TransferFunction::new(
        points
            .into_iter()
            .map(|(value, [r, g, b], a)| ControlPoint {
                value,
                rgba: [r, g, b, a],
            })
            .collect(),
    )?;
    // Written over 8-bit values: on wider data they span its range.
    tf.fit = Some([0.0, 255.0]);
    if name == "brain-shaded" {
        // Matte skin, a little shine on the brain.
        tf.material = Some(crate::shading::Material {
            ambient: 0.15,
            diffuse: 0.75,
            specular: 0.25,
            shininess: 20.0,
        });
    }
    Ok(tf)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::DEFAULT_MEMORY_LIMIT;

    fn build(spec: &str) -> Volume {
        spec.parse::<Scene>()
            .unwrap()
            .build(DEFAULT_MEMORY_LIMIT)
            .unwrap()
    }

    fn parse_err(spec: &str) -> String {
        let e = spec.parse::<Scene>().unwrap_err().to_string();
        assert!(!e.contains('\n'), "{e}");
        e
    }

    #[test]
    fn specs_parse_with_defaults_and_round_trip() {
        let cases = [
            ("checker", Scene::Checker { n: 256, cube: 5 }),
            ("checker:32", Scene::Checker { n: 32, cube: 5 }),
            ("checker:3", Scene::Checker { n: 3, cube: 3 }),
            ("Checker:32:4", Scene::Checker { n: 32, cube: 4 }),
            ("ml", Scene::MarschnerLobb { n: 64 }),
            ("marschner-lobb:41", Scene::MarschnerLobb { n: 41 }),
            ("sphere", Scene::Sphere { n: 64 }),
            ("impulse", Scene::Impulse { n: 16 }),
            ("impulse:1024", Scene::Impulse { n: 1024 }),
        ];
        for (spec, want) in cases {
            let got: Scene = spec.parse().unwrap();
            assert_eq!(got, want, "{spec}");
            assert_eq!(got.to_string().parse::<Scene>().unwrap(), got);
            assert_eq!(got.dims(), [got.size(); 3]);
        }
    }

    #[test]
    fn bad_specs_name_the_problem() {
        assert!(parse_err("checker:0").contains("size 0 is out of range 2..=2048"));
        assert!(parse_err("checker:2049").contains("size 2049 is out of range 2..=2048"));
        assert!(parse_err("checker:16:0").contains("cube size 0 is out of range 1..=16"));
        assert!(parse_err("checker:16:17").contains("cube size 17"));
        let e = parse_err("foo");
        assert!(
            e.contains("unknown scene 'foo'") && e.contains(USAGE),
            "{e}"
        );
        assert!(parse_err("ml:abc").contains("size 'abc' is not a whole number"));
        assert!(parse_err("ml:99999").contains("size 99999 is out of range"));
        assert!(parse_err("ml:-3").contains("'-3' is not a whole number"));
        assert!(parse_err("sphere:1").contains("size 1 is out of range"));
        assert!(parse_err("impulse:8:2").contains("too many fields"));
        assert!(parse_err("checker:8:2:1").contains("too many fields"));
        assert!(parse_err("").contains("unknown scene ''"));
        assert!(parse_err("checker::3").contains("'' is not a whole number"));
    }

    /// Reads the checker in its unmirrored frame (side wall at x = 0).
    fn g(v: &Volume, x: usize, y: usize, z: usize) -> u16 {
        v.get(v.dims()[0] - 1 - x, y, z)
    }

    #[test]
    fn checker_has_a_checkered_floor_and_walls() {
        let (n, c) = (32, 4);
        let v = build("checker:32:4");
        assert_eq!((v.dims(), v.kind()), ([n; 3], VoxelType::U8));
        let last = n - 1;
        // The closed corner cube is filled floor; its floor neighbours in x
        // and z are empty, the next ones filled again.
        assert_eq!(g(&v, 0, 0, last), CHECKER_FLOOR);
        assert_eq!(g(&v, c - 1, c - 1, last - (c - 1)), CHECKER_FLOOR);
        assert_eq!(g(&v, c, 0, last - c), CHECKER_FLOOR);
        assert_eq!(g(&v, 2 * c, 0, last - 2 * c), CHECKER_FLOOR);
        assert_eq!(g(&v, 2 * c + 1, 1, last - 2), CHECKER_FLOOR);
        assert_eq!(g(&v, 2 * c, c - 1, 5), CHECKER_FLOOR);
        assert_eq!(g(&v, 3 * c, c - 1, 5), 0);
        // Left wall (x < c) and rear wall (z > last - c) above the floor.
        assert_eq!(g(&v, 0, c, last - c), CHECKER_WALL);
        assert_eq!(g(&v, c - 1, 2 * c, last - 2 * c), CHECKER_WALL);
        assert_eq!(g(&v, 0, 2 * c, last - 3 * c), 0);
        assert_eq!(g(&v, c, c, last), CHECKER_WALL);
        assert_eq!(g(&v, 2 * c, c, last), 0);
        assert_eq!(g(&v, 3 * c, 5 * c, last - c + 1), CHECKER_WALL);
        // One cube thick: nothing in the room's interior.
        for z in 0..n - c {
            for y in c..n {
                for x in c..n {
                    assert_eq!(g(&v, x, y, z), 0, "({x}, {y}, {z})");
                }
            }
        }
        // Floor and walls are half filled: the pattern alternates.
        let count = |val| v.data().iter().filter(|&&x| x == val).count();
        let floor_cells = n * n * c;
        assert_eq!(count(CHECKER_FLOOR), floor_cells / 2);
        assert!(count(CHECKER_WALL) > 0);
        assert_eq!(v.value_range(), (0, CHECKER_FLOOR));
    }

    #[test]
    fn checker_with_partial_cubes_keeps_walls_one_cube_thick() {
        let v = build("checker:23:5");
        assert_eq!(g(&v, 0, 0, 22), CHECKER_FLOOR);
        assert_eq!(g(&v, 0, 7, 22 - 4), 0); // i + j + k = 0 + 1 + 0
        assert_eq!(g(&v, 0, 12, 22), CHECKER_WALL);
        for (x, y, z) in [(5, 5, 17), (22, 22, 0), (10, 10, 10)] {
            assert_eq!(g(&v, x, y, z), 0);
        }
        let whole = build("checker:2:2");
        assert!(whole.data().iter().all(|&x| x == CHECKER_FLOOR));
    }

    #[test]
    fn marschner_lobb_matches_the_formula() {
        // Closed forms: at (0, 0, z), rho_r = cos(12 pi) = 1.
        assert!((marschner_lobb(0.0, 0.0, 0.0) - 0.6).abs() < 1e-12);
        assert!((marschner_lobb(0.0, 0.0, 1.0) - 0.2).abs() < 1e-12);
        assert!((marschner_lobb(0.0, 0.0, -1.0) - 1.0).abs() < 1e-12);
        let v = build("ml:65");
        assert_eq!(v.dims(), [65; 3]);
        assert_eq!(v.get(32, 32, 32), 153);
        assert_eq!(v.get(32, 32, 64), 51);
        assert_eq!(v.get(32, 32, 0), 255);
        let (x, y, z) = (3, 50, 17);
        let p = |i: usize| -1.0 + 2.0 * i as f64 / 64.0;
        let r = (p(x).powi(2) + p(y).powi(2)).sqrt();
        let rho_r = (2.0 * PI * 6.0 * (PI * r / 2.0).cos()).cos();
        let want = (1.0 - (PI * p(z) / 2.0).sin() + 0.25 * (1.0 + rho_r)) / 2.5;
        assert_eq!(v.get(x, y, z), (want * 255.0).round() as u16);
    }

    #[test]
    fn sphere_is_a_smooth_shell() {
        let n = 64;
        let v = build("sphere:64");
        let c = 31.5;
        let (radius, half) = (0.4 * n as f64, 2.0);
        let mut full = 0;
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let d =
                        ((x as f64 - c).powi(2) + (y as f64 - c).powi(2) + (z as f64 - c).powi(2))
                            .sqrt();
                    let val = v.get(x, y, z);
                    if (d - radius).abs() <= half - 0.5 {
                        assert_eq!(val, 255);
                    } else if (d - radius).abs() >= half + 0.5 {
                        assert_eq!(val, 0);
                    }
                    full += (val == 255) as usize;
                }
            }
        }
        // Shell volume 4 pi R^2 (T - 1) for the fully covered part.
        let expect = 4.0 * PI * radius * radius * (2.0 * half - 1.0);
        assert!(
            (full as f64 / expect - 1.0).abs() < 0.1,
            "{full} vs {expect}"
        );
        let (lo, hi) = v.value_range();
        assert_eq!((lo, hi), (0, 255));
        assert!(
            v.data().iter().any(|&x| x > 0 && x < 255),
            "edges are smooth"
        );
        assert_eq!(v.get(0, 0, 0), 0);
        assert_eq!(v.get(32, 32, 32), 0);
    }

    #[test]
    fn impulse_is_one_voxel() {
        for spec in ["impulse:16", "impulse:7", "impulse:2"] {
            let v = build(spec);
            let n = v.dims()[0];
            assert_eq!(v.get(n / 2, n / 2, n / 2), 255);
            assert_eq!(v.data().iter().filter(|&&x| x != 0).count(), 1);
        }
    }

    #[test]
    fn build_respects_the_memory_limit() {
        let s = Scene::Sphere { n: 1024 };
        let e = s.build(1 << 20).unwrap_err().to_string();
        assert!(e.contains("over the memory limit"), "{e}");
        let bad = Scene::Checker { n: 8, cube: 0 };
        assert!(bad.build(DEFAULT_MEMORY_LIMIT).is_err());
    }

    #[test]
    fn presets_parse_validate_and_cover_their_scenes() {
        for &name in PRESETS {
            let tf = tf_preset(name).unwrap();
            let plain = TransferFunction::new(tf.points.clone()).unwrap();
            assert_eq!(plain.points, tf.points);
            assert_eq!(tf.material.is_some(), name == "brain-shaded", "{name}");
            let back = TransferFunction::from_toml_str(&tf.to_toml_string()).unwrap();
            assert_eq!(back, tf, "{name}");
        }
        let e = tf_preset("rainbow").unwrap_err().to_string();
        assert!(
            e.contains("'rainbow'") && e.contains(&PRESETS.join(", ")),
            "{e}"
        );
        for spec in ["checker", "ml", "sphere", "impulse"] {
            let scene: Scene = spec.parse().unwrap();
            assert_eq!(scene.preset(), tf_preset(spec).unwrap());
        }
        let checker = tf_preset("checker").unwrap();
        assert_eq!(checker.eval(0.0)[3], 0.0);
        assert_eq!(checker.eval(40.0)[3], 0.0);
        let close = |a: [f64; 4], b: [f64; 4]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12);
        assert!(close(
            checker.eval(CHECKER_WALL as f64),
            [1.0, 1.0, 1.0, 0.9]
        ));
        assert!(close(
            checker.eval(CHECKER_FLOOR as f64),
            [0.2, 0.3, 1.0, 0.9]
        ));
        let ramp = tf_preset("grey-ramp").unwrap();
        assert_eq!(ramp.eval(30.0)[3], 0.0);
        assert!((ramp.eval(90.0)[3] - 0.5).abs() < 1e-12);
        assert!((ramp.eval(90.0)[0] - 90.0 / 255.0).abs() < 1e-12);
        assert_eq!(ramp.eval(200.0)[3], 1.0);
        let ml = tf_preset("ml").unwrap();
        assert_eq!(ml.eval(99.0)[3], 0.0);
        assert!(ml.eval(140.0)[3] >= 0.9 - 1e-12);
        assert_eq!(tf_preset("impulse").unwrap().eval(255.0), [1.0; 4]);
    }
}
