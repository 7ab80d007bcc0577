//! The routing a whole design adds to its slowest stage.
//!
//! The delay model's coefficients come from units placed alone in an
//! empty part; the same stage placed among a whole datapath's cells routes
//! longer (a slope square of the emitted datapath on an LFE5U-85F: 6.6
//! ns of routing against 4.1 ns for `mul_square` alone). The term is
//! `routing_ns_per_kcell x (estimated LUTs + flip-flops) / 1000`, added to
//! the slowest stage's period, its one coefficient per family a
//! least-squares fit of the relative period error to the calibration rows
//! of `pipeline/data/measured/designs.csv` (whole designs placed by
//! `ercube synth --datapath`); the holdout rows check it. A family without
//! a placed design (iCE40: no iCE40UP5K holds the datapath) has no term.

use super::{Role, Setting};
use crate::cost::Target;

/// The measured whole designs, as stored (see the file's header).
const DESIGNS: &str = include_str!("../../../data/measured/designs.csv");

/// One placed whole design.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DesignMeasured {
    /// The family.
    pub target: Target,
    /// The part placed on.
    pub part: String,
    /// The width setting.
    pub setting: Setting,
    /// Fitted to, or held out.
    pub role: Role,
    /// nextpnr's achieved clock, MHz.
    pub mhz: f64,
}

/// The data rows of a measurement file, split at commas (comment lines
/// and the header, which starts with `target,`, skipped).
pub(super) fn csv_rows(text: &str) -> impl Iterator<Item = Vec<&str>> {
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("target,") && !l.trim().is_empty())
        .map(|l| l.split(',').collect())
}

/// A row's role: `calibration`, or held out.
pub(super) fn role(field: &str) -> Role {
    if field == "calibration" {
        Role::Calibration
    } else {
        Role::Holdout
    }
}

/// The rows of `pipeline/data/measured/designs.csv`.
pub fn designs() -> Vec<DesignMeasured> {
    csv_rows(DESIGNS)
        .filter_map(|f| {
            let target = Target::ALL.into_iter().find(|t| t.name() == f[0])?;
            let setting = Setting::ALL.into_iter().find(|s| s.name() == f[2])?;
            Some(DesignMeasured {
                target,
                part: f[1].to_owned(),
                setting,
                role: role(f[3]),
                mhz: f[4].parse().ok()?,
            })
        })
        .collect()
}

/// The whole design's size the term scales with: the estimated LUTs and
/// flip-flops of the emitted datapath at `cfg`'s widths, thousands.
pub fn kcells(cfg: &crate::config::PipelineConfig, t: Target) -> f64 {
    let r = crate::synth::datapath_estimate(cfg, t);
    (r.lut + r.ff) as f64 / 1e3
}

/// The stage-only period of a design: its slowest scheduled stage, ns.
fn stage_ns(cfg: &crate::config::PipelineConfig, t: Target) -> Option<f64> {
    Some(1e3 / super::stage_prediction(cfg, t)?.mhz)
}

/// The fitted coefficient of `t`, ns per thousand cells (`None` without a
/// calibration row).
pub fn routing_ns_per_kcell(t: Target) -> Option<f64> {
    static FITTED: std::sync::OnceLock<[Option<f64>; 3]> = std::sync::OnceLock::new();
    per_family(&FITTED, fit, t)
}

/// `fit(t)`, fitted once per process for every family into `cell`.
pub(super) fn per_family(
    cell: &'static std::sync::OnceLock<[Option<f64>; 3]>,
    fit: fn(Target) -> Option<f64>,
    t: Target,
) -> Option<f64> {
    let fits = cell.get_or_init(|| Target::ALL.map(fit));
    Target::ALL
        .iter()
        .position(|&x| x == t)
        .and_then(|i| fits[i])
}

/// The one coefficient `rho` of a term `rho c` added to a period that
/// minimises the relative period error over `rows` of `(c, y, base)`, `y`
/// the measured period and `base` the period without the term: `rho =
/// sum(c (y - base) / y^2) / sum(c^2 / y^2)`, at least 0; `None` without
/// a row, or when a row could not be priced (`None` in `rows`).
pub(super) fn one_coefficient(rows: impl Iterator<Item = Option<(f64, f64, f64)>>) -> Option<f64> {
    let mut num = 0.0;
    let mut den = 0.0;
    for row in rows {
        let (c, y, base) = row?;
        num += c * (y - base) / (y * y);
        den += c * c / (y * y);
    }
    (den > 0.0).then(|| (num / den).max(0.0))
}

/// The calibration rows of `t`, `c` the design's thousands of cells.
fn fit(t: Target) -> Option<f64> {
    one_coefficient(
        designs()
            .into_iter()
            .filter(|d| d.target == t && d.role == Role::Calibration)
            .map(|d| {
                let cfg = d.setting.config();
                Some((kcells(&cfg, t), 1e3 / d.mhz, stage_ns(&cfg, t)?))
            }),
    )
}

/// The routing term of the whole datapath at `cfg`'s widths on `t`, ns
/// (0 for a family without one).
pub fn routing_ns(cfg: &crate::config::PipelineConfig, t: Target) -> f64 {
    routing_ns_per_kcell(t).map_or(0.0, |rho| rho * kcells(cfg, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every placed design, calibration and holdout, within 15% of the
    /// prediction with the routing term (`--nocapture` prints the rows
    /// docs/cost.md shows).
    #[test]
    fn placed_designs_are_predicted_within_15_percent() {
        let rows = designs();
        assert!(rows.iter().any(|d| d.role == Role::Holdout), "{rows:?}");
        for d in &rows {
            let cfg = d.setting.config();
            let p = super::super::pe_prediction(&cfg, d.target).unwrap();
            let err = (p.mhz - d.mhz) / d.mhz;
            eprintln!(
                "| {} | {} | {:?} | {:.1} | {:.1} | {:.1} ({:+.1}%) | {:.2} ns |",
                d.part,
                d.setting.name(),
                d.role,
                d.mhz,
                p.stage_mhz,
                p.mhz,
                100.0 * err,
                p.routing_ns
            );
            assert!(err.abs() <= 0.15, "{d:?}: predicted {:.1}", p.mhz);
        }
        assert!(routing_ns_per_kcell(Target::Ecp5).unwrap() > 0.0);
        assert!(routing_ns_per_kcell(Target::Ice40).is_none());
    }
}
