//! The routing a whole sample stage adds along its issue path.
//!
//! The issue path ([`super::issue_path`]) runs from the row plan's block
//! RAM through a dozen LUT levels and four carry chains into the
//! compositing buffer's address: placed among a whole stage's cells
//! (thousands of LUTs, tens of block RAMs spread over the part) each of
//! its nets routes far longer than in a unit placed alone, where the delay
//! model's coefficients come from (on the LFE5U-85F, 15.4 to 19.9 ns of
//! the path's 28.5 to 32.6 ns are routing, about a nanosecond a hop). The
//! term is `hop_ns x LUT levels` of the path, added to its period, its
//! one coefficient per family a least-squares fit of the relative period
//! error to the calibration rows of `pipeline/data/measured/stages.csv`
//! (stages placed by `ercube synth --pe`); the holdout rows check it. A
//! family without a placed stage (iCE40: no iCE40UP5K holds one) has no
//! term.

use super::Role;
use crate::config::PipelineConfig;
use crate::cost::inventory::Geometry;
use crate::cost::Target;

/// The measured stages, as stored (see the file's header).
const STAGES: &str = include_str!("../../../data/measured/stages.csv");

/// One placed sample stage.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StageMeasured {
    /// The family.
    pub target: Target,
    /// The part placed on.
    pub part: String,
    /// The view-space volume's edge (`dims^3`).
    pub dims: usize,
    /// PEs the stage is declared for.
    pub pes: u16,
    /// Fitted to, or held out.
    pub role: Role,
    /// nextpnr's achieved clock, MHz.
    pub mhz: f64,
}

impl StageMeasured {
    /// The configuration it was placed at: the default widths over its PEs.
    pub fn config(&self) -> PipelineConfig {
        PipelineConfig {
            pes: self.pes,
            ..PipelineConfig::default()
        }
    }

    /// The geometry its memories were declared for.
    pub fn geometry(&self) -> Geometry {
        Geometry::new([self.dims; 3], self.pes)
    }
}

/// The rows of `pipeline/data/measured/stages.csv`.
pub fn stages() -> Vec<StageMeasured> {
    super::routing::csv_rows(STAGES)
        .filter_map(|f| {
            let target = Target::ALL.into_iter().find(|t| t.name() == f[0])?;
            Some(StageMeasured {
                target,
                part: f[1].to_owned(),
                dims: f[2].parse().ok()?,
                pes: f[3].parse().ok()?,
                role: super::routing::role(f[4]),
                mhz: f[5].parse().ok()?,
            })
        })
        .collect()
}

/// The issue path's period without the term (the delay model's, plus
/// the whole datapath's routing term) and its LUT levels, for `geo`.
fn unrouted(cfg: &PipelineConfig, geo: &Geometry, t: Target) -> Option<(f64, f64)> {
    let model = super::model(t)?;
    let shape = crate::hw::pe_sample_rtl::PeSampleShape::new(cfg, geo).ok()?;
    let path = super::issue_path(&shape);
    Some((
        model.period_ns(&path) + super::routing::routing_ns(cfg, t),
        path.luts,
    ))
}

/// The fitted coefficient of `t`, ns per LUT level of the issue path
/// (`None` without a calibration row).
pub fn hop_ns(t: Target) -> Option<f64> {
    static FITTED: std::sync::OnceLock<[Option<f64>; 3]> = std::sync::OnceLock::new();
    super::routing::per_family(&FITTED, fit, t)
}

/// The calibration rows of `t` ([`super::routing`]'s relative-error fit),
/// `c` the issue path's LUT levels.
fn fit(t: Target) -> Option<f64> {
    super::routing::one_coefficient(
        stages()
            .into_iter()
            .filter(|s| s.target == t && s.role == Role::Calibration)
            .map(|s| {
                let (base, luts) = unrouted(&s.config(), &s.geometry(), t)?;
                Some((luts, 1e3 / s.mhz, base))
            }),
    )
}

/// The term for an issue path of `luts` LUT levels on `t`, ns (0 for a
/// family without one).
pub fn issue_routing_ns(luts: f64, t: Target) -> f64 {
    hop_ns(t).map_or(0.0, |h| h * luts)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every placed stage, calibration and holdout, within 15% of the
    /// prediction with the term (`--nocapture` prints the rows
    /// docs/cost.md shows).
    #[test]
    fn placed_stages_are_predicted_within_15_percent() {
        let rows = stages();
        assert!(rows.iter().any(|s| s.role == Role::Holdout), "{rows:?}");
        for s in &rows {
            let p = super::super::sample_stage_prediction(&s.config(), &s.geometry(), s.target)
                .expect("a prediction");
            let err = (p.mhz - s.mhz) / s.mhz;
            eprintln!(
                "| {} | {}^3, {} PEs | {:?} | {:.1} | {:.1} ({:+.1}%) | {:.2} ns a level |",
                s.part,
                s.dims,
                s.pes,
                s.role,
                s.mhz,
                p.mhz,
                100.0 * err,
                hop_ns(s.target).unwrap_or(0.0)
            );
            assert!(p.critical.contains("issue"), "{p:?}");
            assert!(err.abs() <= 0.15, "{s:?}: predicted {:.1}", p.mhz);
        }
        assert!(hop_ns(Target::Ecp5).unwrap() > 0.0);
        assert!(hop_ns(Target::Ice40).is_none());
    }
}
