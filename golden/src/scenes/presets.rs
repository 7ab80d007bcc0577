//! The named transfer-function presets that go with the synthetic scenes.

use super::{CHECKER_FLOOR, CHECKER_WALL};
use crate::error::{input, Result};
use crate::tf::{ControlPoint, TransferFunction};

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
