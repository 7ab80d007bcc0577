//! The routing a whole sample stage adds along its own paths.
//!
//! The stage's control has two paths of its own ([`StagePath`]): the
//! issue's pick ([`super::issue_path`], from the row plan's head register
//! through the carry chain over the slots) and the tap address
//! ([`super::tap_path`], from the datapath's tap column through the
//! clamps and the local column into the slice buffer's read ports).
//! Placed among a whole stage's cells (thousands of LUTs, tens of block
//! RAMs spread over the part) each of their nets routes far longer than
//! in a unit placed alone, where the delay model's coefficients come from
//! (on the LFE5U-85F 12.8 of the tap address's 21.3 ns are routing). The
//! term is `hop_ns x LUT levels` of the path, added to its period, its
//! one coefficient per family a least-squares fit of the relative period
//! error to the calibration rows of `pipeline/data/measured/stages.csv`
//! (stages placed by `ercube synth --pe`, each with the path nextpnr
//! found critical); the holdout rows check it. A family without a placed
//! stage (iCE40: no iCE40UP5K holds one) has no term.

use super::Role;
use crate::config::PipelineConfig;
use crate::cost::inventory::Geometry;
use crate::cost::Target;

/// The measured stages, as stored (see the file's header).
const STAGES: &str = include_str!("../../../data/measured/stages.csv");

/// A path of the sample stage's own logic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum StagePath {
    /// The issue's pick ([`super::issue_path`]).
    Issue,
    /// The tap address ([`super::tap_path`]).
    Tap,
}

impl StagePath {
    /// Both paths.
    pub const ALL: [StagePath; 2] = [StagePath::Issue, StagePath::Tap];

    /// The path for `s` on `t` (`None` without a delay model).
    pub fn path(
        self,
        cfg: &PipelineConfig,
        s: &crate::hw::pe_sample_rtl::PeSampleShape,
        t: Target,
    ) -> Option<super::Path> {
        match self {
            StagePath::Issue => Some(super::issue_path(s)),
            StagePath::Tap => super::tap_path(cfg, s, t),
        }
    }

    /// What a report calls it.
    pub fn describe(self) -> &'static str {
        match self {
            StagePath::Issue => "the sample stage's issue (plan FIFO head to the pick's registers)",
            StagePath::Tap => {
                "the sample stage's tap address (the datapath's tap column to the slice buffer)"
            }
        }
    }

    /// The name in the measurement file.
    fn parse(s: &str) -> Option<StagePath> {
        match s {
            "issue" => Some(StagePath::Issue),
            "tap" => Some(StagePath::Tap),
            _ => None,
        }
    }
}

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
    /// The path nextpnr found critical.
    pub critical: StagePath,
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
                critical: StagePath::parse(f[6])?,
            })
        })
        .collect()
}

/// The placed stage of `cfg` for `geo` on `t`, if one was measured: the
/// same family, PEs and widths, and a cube of the same edge.
pub fn measured_stage(cfg: &PipelineConfig, geo: &Geometry, t: Target) -> Option<StageMeasured> {
    stages().into_iter().find(|s| {
        s.target == t && s.config() == *cfg && geo.dims == [s.dims; 3] && geo.pes == s.pes
    })
}

/// Path `k`'s period without the term (the delay model's, plus the whole
/// datapath's routing term) and its LUT levels, for `geo`.
fn unrouted(cfg: &PipelineConfig, geo: &Geometry, t: Target, k: StagePath) -> Option<(f64, f64)> {
    let model = super::model(t)?;
    let shape = crate::hw::pe_sample_rtl::PeSampleShape::new(cfg, geo).ok()?;
    let path = k.path(cfg, &shape, t)?;
    Some((
        model.period_ns(&path) + super::routing::routing_ns(cfg, t),
        path.luts,
    ))
}

/// The fitted coefficient of path `k` on `t`, ns per LUT level (`None`
/// without a calibration row where `k` was critical). Each path has its
/// own: a net into a block RAM's ports routes farther than one between
/// flip-flops, and the two paths differ in that.
pub fn hop_ns(t: Target, k: StagePath) -> Option<f64> {
    static ISSUE: std::sync::OnceLock<[Option<f64>; 3]> = std::sync::OnceLock::new();
    static TAP: std::sync::OnceLock<[Option<f64>; 3]> = std::sync::OnceLock::new();
    match k {
        StagePath::Issue => super::routing::per_family(&ISSUE, |t| fit(t, StagePath::Issue), t),
        StagePath::Tap => super::routing::per_family(&TAP, |t| fit(t, StagePath::Tap), t),
    }
}

/// The calibration rows of `t` where `k` was critical
/// ([`super::routing`]'s relative-error fit), `c` its LUT levels.
fn fit(t: Target, k: StagePath) -> Option<f64> {
    super::routing::one_coefficient(
        stages()
            .into_iter()
            .filter(|s| s.target == t && s.role == Role::Calibration && s.critical == k)
            .map(|s| {
                let (base, luts) = unrouted(&s.config(), &s.geometry(), t, k)?;
                Some((luts, 1e3 / s.mhz, base))
            }),
    )
}

/// The term for path `k` of `luts` LUT levels on `t`, ns (0 without a
/// fitted coefficient: no placed stage of the family had it critical).
pub fn stage_routing_ns(luts: f64, t: Target, k: StagePath) -> f64 {
    hop_ns(t, k).map_or(0.0, |h| h * luts)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every placed stage, calibration and holdout, within 15% of the
    /// prediction with the term, and each calibration row's critical path
    /// the one predicted (`--nocapture` prints the rows docs/cost.md
    /// shows).
    #[test]
    fn placed_stages_are_predicted_within_15_percent() {
        let rows = stages();
        for s in &rows {
            for k in StagePath::ALL {
                let (ns, luts) = unrouted(&s.config(), &s.geometry(), s.target, k).unwrap();
                eprintln!("{}^3 {k:?}: {ns:.2} ns unrouted, {luts} LUT levels", s.dims);
            }
        }
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
                hop_ns(s.target, s.critical).unwrap_or(0.0)
            );
            // A calibration row's path is the one its term was fitted on;
            // a held-out stage's clock is checked, its path only reported
            // (nextpnr's routing of one path moves with the placement).
            if s.role == Role::Calibration {
                assert_eq!(p.critical, s.critical.describe(), "{s:?}");
            } else {
                eprintln!("  predicted {}, placed {:?}", p.critical, s.critical);
            }
            assert!(err.abs() <= 0.15, "{s:?}: predicted {:.1}", p.mhz);
        }
        // Each path critical in a calibration row has its term, fitted
        // positive; a family with no placed stage has none.
        for s in rows.iter().filter(|s| s.role == Role::Calibration) {
            assert!(hop_ns(s.target, s.critical).unwrap() > 0.0, "{s:?}");
        }
        for k in StagePath::ALL {
            assert!(hop_ns(Target::Ice40, k).is_none());
        }
    }
}
