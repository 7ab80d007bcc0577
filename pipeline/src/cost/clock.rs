//! The clock a frame rate is quoted at, and where the figure comes from.
//!
//! `ercube cost`, `ercube explore` and `ercube render --method pipeline`
//! quote frames per second at one clock option, `--clock-mhz`, with the
//! same default ([`assumed_mhz`] of the family; `explore` and `render`
//! price on xc7) and the same label ([`ClockSource`]). `ercube synth`
//! measures a unit's or the PE sample stage's clock after place and route.
//! `ercube cost` quotes by default (`--clock auto`) the clock the PE
//! sample stage of its design measured where one was placed
//! ([`super::fmax::stages`]), else the one its paths are predicted to
//! reach ([`super::fmax`]) where the family has a delay model, else the
//! family's assumed clock, each labelled with where it comes from.

use serde::Serialize;

use super::Target;

/// Where a clock figure comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ClockSource {
    /// Place and route met it (nextpnr's achieved clock).
    Measured,
    /// Predicted from the schedule's unit depths.
    Predicted,
    /// A family default or `--clock-mhz`: no timing analysis behind it.
    Assumed,
}

impl ClockSource {
    /// The word reports print beside the clock.
    pub fn name(self) -> &'static str {
        match self {
            ClockSource::Measured => "measured",
            ClockSource::Predicted => "predicted",
            ClockSource::Assumed => "assumed",
        }
    }
}

/// The assumed clock of a family, MHz: a comfortable rate for a fully
/// pipelined DSP datapath on a mid speed grade, not a timing result.
pub fn assumed_mhz(t: Target) -> f64 {
    match t {
        Target::Xc7 => 200.0,
        Target::Ecp5 => 150.0,
        Target::Ice40 => 48.0,
    }
}

/// Checks a `--clock-mhz` value: above 0 and at most 2000 MHz.
pub fn check_mhz(mhz: f64) -> Result<f64, String> {
    if mhz.is_finite() && mhz > 0.0 && mhz <= 2000.0 {
        Ok(mhz)
    } else {
        Err(format!(
            "--clock-mhz {mhz} must be a clock above 0 and at most 2000 MHz"
        ))
    }
}

/// Frames per second of `cycles` per frame at `mhz` (0 for no cycles).
pub fn fps(cycles: u64, mhz: f64) -> f64 {
    if cycles == 0 {
        0.0
    } else {
        mhz * 1e6 / cycles as f64
    }
}

/// How every command prints a frame's rate: `N cycles/frame, F frames/s
/// at C MHz (assumed clock)`.
pub fn rate_line(cycles: u64, mhz: f64, source: ClockSource) -> String {
    format!(
        "{cycles} cycles/frame, {:.1} frames/s at {mhz} MHz ({} clock)",
        fps(cycles, mhz),
        source.name()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_and_checks() {
        assert_eq!(fps(200_000, 200.0), 1000.0);
        assert_eq!(fps(0, 200.0), 0.0);
        assert!(check_mhz(0.0).is_err() && check_mhz(f64::NAN).is_err());
        assert_eq!(
            rate_line(195_447, 200.0, ClockSource::Assumed),
            "195447 cycles/frame, 1023.3 frames/s at 200 MHz (assumed clock)"
        );
    }
}
