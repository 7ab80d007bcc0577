//! The clock a family reaches, predicted from the depth of a stage:
//! multiplier blocks, carry chains and LUT levels on its longest
//! register-to-register path, priced by a linear delay model per family
//! fitted to units placed and routed by `ercube synth`.
//!
//! A stage's path is read off its units ([`Unit`](crate::cost::units::Unit)): an adder, subtractor,
//! incrementer or comparator is a carry chain of its width entered through
//! a LUT; a multiplexer or reduction a LUT level; a saturation clamp a LUT
//! level and a wide-fanout net (its overflow select drives every output
//! bit); a multiplier a block followed by the partial-product adders the
//! blocks do not take in and a post-adder outside the block (as
//! [`super::units`] prices them); a square-root or divider stage a carry
//! chain of the remainder's width, a LUT (the operand's conditional
//! inversion) and a wide-fanout net (the remainder's sign selecting that
//! inversion for every bit of the next stage); a memory read a block RAM.
//! On iCE40 a path through an unregistered SB_MAC16 is cut at the block:
//! nextpnr-ice40 has no timing arcs through it and times the path to its
//! inputs and the path from its output separately (the scheduled PE
//! registers every product at its block, so it has no such path).
//!
//! The period is `max(base, base + carry bit x n + LUT level x l + fanout
//! net x f + block x m + registered block x k + block RAM x r)`, the
//! coefficients a least-squares fit of the relative error (`fmax::fit`) to the
//! calibration settings of [`MEASURED`] (every unit, single-clock ones
//! included); the holdout settings check it out of sample.
//!
//! [`pe_prediction`] applies the model to [`crate::hw::schedule`]'s
//! stages of the plain sample datapath: the arrival time of each node
//! within its stage, the slowest stage setting the clock.

use serde::Serialize;

use super::Target;

mod fit;
mod measured;
mod path;
mod pipelining;
mod predict;
pub mod routing;
pub mod stages;

pub use fit::{fit_rows, least_squares, FEATURES};
pub use measured::{Measured, Role, Setting, MEASURED};
pub use path::{module_paths, unit_path, Path};
pub use pipelining::{clock_schedule, schedule_for, ClockSchedule, Clocked};
use predict::node_path;
pub use predict::{
    address_path, issue_path, module_mhz, pe_prediction, predicted_clock, sample_stage_prediction,
    stage_prediction, tap_path, unit_prediction, unit_predictions, PePrediction, UnitPrediction,
};

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DelayModel {
    /// The family.
    pub target: Target,
    /// Clock-to-out, setup and the routing every path has.
    pub base_ns: f64,
    /// Per carry-chain bit.
    pub carry_bit_ns: f64,
    /// Per LUT level (with its routing).
    pub lut_ns: f64,
    /// Per wide-fanout net (a select driving a whole word).
    pub fanout_ns: f64,
    /// Per multiplier block passed through.
    pub block_ns: f64,
    /// Per multiplier block ending at its output register.
    pub block_reg_ns: f64,
    /// Per block-RAM read.
    pub bram_ns: f64,
}

impl DelayModel {
    /// The period of a path, ns.
    pub fn period_ns(&self, p: &Path) -> f64 {
        self.base_ns
            + self.carry_bit_ns * p.carry_bits
            + self.lut_ns * p.luts
            + self.fanout_ns * p.fanout
            + self.block_ns * p.blocks
            + self.block_reg_ns * p.blocks_reg
            + self.bram_ns * p.brams
    }

    /// The clock of a path, MHz.
    pub fn mhz(&self, p: &Path) -> f64 {
        1e3 / self.period_ns(p)
    }
}

impl DelayModel {
    /// The model of `t` from the fit's coefficients ([`FEATURES`] of them,
    /// in [`Path::features`]'s order).
    pub fn from_coefficients(target: Target, x: [f64; FEATURES]) -> DelayModel {
        DelayModel {
            target,
            base_ns: x[0],
            carry_bit_ns: x[1],
            lut_ns: x[2],
            fanout_ns: x[3],
            block_ns: x[4],
            block_reg_ns: x[5],
            bram_ns: x[6],
        }
    }
}

/// The delay model of `t` fitted to the calibration settings of
/// [`MEASURED`] (`None` for a family without an open place and route:
/// xc7), fitted once per process.
pub fn model(t: Target) -> Option<DelayModel> {
    static FITTED: std::sync::OnceLock<[Option<DelayModel>; 3]> = std::sync::OnceLock::new();
    let fits = FITTED.get_or_init(|| Target::ALL.map(|t| fit::fit(t, Role::Calibration)));
    Target::ALL
        .iter()
        .position(|&x| x == t)
        .and_then(|i| fits[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PipelineConfig;

    /// The fitted models against every measurement, calibration and
    /// holdout (`--nocapture` prints the table docs/cost.md shows).
    #[test]
    fn every_measured_unit_is_predicted_within_15_percent() {
        let mut worst: Vec<String> = Vec::new();
        for t in [Target::Ice40, Target::Ecp5] {
            eprintln!("{t:?}: {:?}", model(t).unwrap());
            for p in unit_predictions(t) {
                let m = p.measured;
                eprintln!(
                    "| {} | {} | {:?} | {:.1} | {:.1} | {:+.1}% | {:?}",
                    m.unit,
                    m.part,
                    m.setting,
                    m.mhz,
                    p.predicted_mhz,
                    100.0 * p.error(),
                    p.path
                );
                if p.error().abs() > 0.15 {
                    worst.push(format!(
                        "{} {} {:?}: {:+.1}%",
                        m.part,
                        m.unit,
                        m.setting,
                        100.0 * p.error()
                    ));
                }
            }
        }
        assert!(worst.is_empty(), "{worst:?}");
    }

    #[test]
    fn fitted_models_are_positive_and_xc7_has_none() {
        assert!(model(Target::Xc7).is_none());
        for t in [Target::Ice40, Target::Ecp5] {
            let m = model(t).expect("a model");
            assert!(m.base_ns > 0.0, "{m:?}");
            for c in [
                m.carry_bit_ns,
                m.lut_ns,
                m.block_ns,
                m.block_reg_ns,
                m.bram_ns,
            ] {
                assert!(c >= 0.0, "{m:?}");
            }
        }
    }

    /// The schedule's stages are one multiplier or one carry chain deep:
    /// the PE's predicted clock is above every measured unit's clock of
    /// more than one chain in series (bilinear, composite).
    #[test]
    fn the_pipelined_pe_is_faster_than_the_unpipelined_units() {
        let cfg = PipelineConfig::default();
        for t in [Target::Ice40, Target::Ecp5] {
            let pe = stage_prediction(&cfg, t).expect("prediction");
            for u in ["bilinear", "composite"] {
                let meas = MEASURED
                    .iter()
                    .find(|m| m.target == t && m.unit == u && m.setting == Setting::Default)
                    .unwrap();
                assert!(pe.mhz > meas.mhz, "{t:?} {u}: {pe:?}");
            }
        }
    }
}
