//! The PE's volume-of-interest stage, bit for bit: the fixed-point twin of
//! [`golden::voi::ViewVoi::factor`] for a [`golden::voi::Voi`], applied
//! where golden applies it (after classification, before shading and the
//! opacity correction, see [`golden::sampling`]).
//!
//! **Hardware.** The PE knows its sample's position: `x` it computes, `y`
//! the row broadcasts, `z` is the slice. The host broadcasts, per frame,
//! the region's centre in view voxels ([`PipelineConfig::position`]), the
//! per-axis scale `s_axis / R` ([`PipelineConfig::voi_axis`], `R` the ramp
//! width, or 1 without a ramp), the box's half extents or the sphere's
//! radius in those units ([`PipelineConfig::voi_dist`]) and the gain
//! `S - 1` ([`PipelineConfig::voi_gain`]). Per sample:
//!
//! 1. `q = |p - c| k` per axis: an exact subtract and absolute value, a
//!    multiplier, assigned into `voi_dist`;
//! 2. *box*: `e = q - h` per axis into `voi_dist`; *sphere*: `|q|^2` exact;
//! 3. *without a ramp* (a step), a comparator: every `e <= 0`, or
//!    `|q|^2 <= r^2` (exact squares), gives `w = 1`, else 0;
//!    *with a ramp*, the signed distance `d` into `voi_dist`: the box's
//!    `sqrt(sum max(e, 0)^2)` outside (the array's exact integer square
//!    root, [`crate::datapath::isqrt_into`], truncated) or `max e` inside;
//!    the sphere's `sqrt(|q|^2) - r`; then `w = clamp(1/2 - d, 0, 1)` (two
//!    comparators) into [`PipelineConfig::voi_weight`];
//! 4. `w = 1 - w` with `outside` (exact);
//! 5. `f = 1 + (S - 1) w`, a multiply-add into
//!    [`PipelineConfig::voi_factor`];
//! 6. `a' = a f` into [`PipelineConfig::alpha`] (saturating at its top, as
//!    golden's opacity correction clamps at 1).
//!
//! A factor of exactly 1 (`w = 0`, or `S = 1`) leaves the opacity's bits
//! unchanged, and a zero opacity stays zero, so the occupancy memory stays
//! exact: no block the table leaves empty becomes visible
//! ([`crate::skip`] needs no change).
//!
//! Steps 1 to 5 depend only on the position, which is known when the
//! sample issues: they run beside the interpolation and classification;
//! only the multiply of step 6 follows the classified opacity
//! ([`crate::cost`] schedules it).

use golden::geometry::View;
use golden::voi::{Shape, ViewVoi, Voi};

use crate::config::PipelineConfig;
use crate::datapath::{isqrt_into, FrameUnit, Loaded, UnitFrame};
use crate::fixed::{Fx, FxError, QuantStats, Wide};
use crate::hw::compose::FrameUnits;

/// Why a frame's volume of interest cannot be loaded.
#[derive(Debug, thiserror::Error)]
pub enum VoiError {
    /// The VOI itself is invalid, or a constant does not fit its format.
    #[error("{0}")]
    Unsupported(String),
    /// A fixed-point error.
    #[error("{0}")]
    Fixed(#[from] FxError),
}

/// What the stage did for one sample, for waveforms and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct VoiTrace {
    /// The weight, raw `voi_weight` (after `1 - w` outside).
    pub weight: i64,
    /// The factor, raw `voi_factor`.
    pub factor: i64,
}

/// The stage's per-frame constants, loaded by the host.
#[derive(Debug, Clone)]
pub struct VoiUnit {
    /// Centre in view voxels, `position` words.
    centre: [Fx; 3],
    /// `s_axis / R`, `voi_axis` words.
    axis: [Fx; 3],
    /// Box half extents in ramp units, `voi_dist` words (zero for a sphere).
    half: [Fx; 3],
    /// Sphere radius in ramp units, a `voi_dist` word.
    radius: Fx,
    sphere: bool,
    outside: bool,
    /// No ramp: the comparator alone.
    step: bool,
    /// `S - 1`, a `voi_gain` word.
    gain: Fx,
}

/// The frame's volume of interest ([`crate::datapath::FrameUnit`]): the
/// stage's constants for the frame's view.
impl FrameUnit for Voi {
    fn load(&self, f: &UnitFrame, units: &mut FrameUnits, st: &mut QuantStats) -> Loaded {
        let unit = VoiUnit::new(&f.dp.cfg, self, f.view, st).map_err(crate::RunError::Voi)?;
        units.voi = Some(unit);
        Ok(())
    }
}

impl VoiUnit {
    /// The stage's constants for `voi` in `view`.
    pub fn new(
        cfg: &PipelineConfig,
        voi: &Voi,
        view: &View,
        st: &mut QuantStats,
    ) -> Result<VoiUnit, VoiError> {
        let v = ViewVoi::new(view, voi).map_err(|e| VoiError::Unsupported(e.to_string()))?;
        let (centre, half, radius, sphere) = v.region();
        let spacing = v.spacing();
        let (scale, outside, ramp) = v.weighting();
        let unit = if ramp > 0.0 { ramp } else { 1.0 };
        // A constant that does not fit its format would make every sample
        // wrong: refused, naming the field.
        let mut q = |f: crate::config::Reg, x: f64, field: &str| -> Result<Fx, VoiError> {
            let r = f.from_f64(x)?;
            st.record_as(f.id, &r);
            if r.overflow {
                return Err(VoiError::Unsupported(format!(
                    "volume of interest: {x} does not fit {field} = {}; widen {field} (or the ramp)",
                    f.format
                )));
            }
            Ok(r.value)
        };
        let c = centre.to_array();
        let s = spacing.to_array();
        let h = half.to_array();
        let centre = [
            q(crate::reg!(cfg, position), c[0], "position")?,
            q(crate::reg!(cfg, position), c[1], "position")?,
            q(crate::reg!(cfg, position), c[2], "position")?,
        ];
        let axis = [
            q(crate::reg!(cfg, voi_axis), s[0] / unit, "voi_axis")?,
            q(crate::reg!(cfg, voi_axis), s[1] / unit, "voi_axis")?,
            q(crate::reg!(cfg, voi_axis), s[2] / unit, "voi_axis")?,
        ];
        let half = [
            q(crate::reg!(cfg, voi_dist), h[0] * s[0] / unit, "voi_dist")?,
            q(crate::reg!(cfg, voi_dist), h[1] * s[1] / unit, "voi_dist")?,
            q(crate::reg!(cfg, voi_dist), h[2] * s[2] / unit, "voi_dist")?,
        ];
        let radius = q(crate::reg!(cfg, voi_dist), radius / unit, "voi_dist")?;
        let gain = q(crate::reg!(cfg, voi_gain), scale - 1.0, "voi_gain")?;
        debug_assert_eq!(sphere, matches!(voi.shape, Shape::Sphere { .. }));
        Ok(VoiUnit {
            centre,
            axis,
            half,
            radius,
            sphere,
            outside,
            step: ramp == 0.0,
            gain,
        })
    }

    /// The stage's constants from their words, for the description's
    /// checks (`crate::hw::units_tests`).
    #[cfg(test)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_words(
        centre: [Fx; 3],
        axis: [Fx; 3],
        half: [Fx; 3],
        radius: Fx,
        gain: Fx,
        (sphere, outside, step): (bool, bool, bool),
    ) -> VoiUnit {
        VoiUnit {
            centre,
            axis,
            half,
            radius,
            sphere,
            outside,
            step,
            gain,
        }
    }

    /// The stage's per-frame ports as its description names them
    /// ([`crate::hw::voi::voi`]: `centre.*`, `axis.*`, `half.*`,
    /// `radius`, `radius2`, `gain`, `sphere`, `step`, `outside`), raw
    /// words.
    pub fn port_words(&self) -> Vec<(String, i64)> {
        let mut v = Vec::new();
        for (k, a) in ["x", "y", "z"].iter().enumerate() {
            v.push((format!("centre.{a}"), self.centre[k].raw()));
            v.push((format!("axis.{a}"), self.axis[k].raw()));
            v.push((format!("half.{a}"), self.half[k].raw()));
        }
        let r = self.radius.raw();
        v.push(("radius".into(), r));
        v.push(("radius2".into(), r * r));
        v.push(("gain".into(), self.gain.raw()));
        for (n, b) in [
            ("sphere", self.sphere),
            ("step", self.step),
            ("outside", self.outside),
        ] {
            v.push((n.into(), i64::from(b)));
        }
        v
    }

    /// Steps 1 to 5: the opacity factor of a sample at view position
    /// `(x, y, z)` (`x`, `y` in `position`, `z` the slice).
    pub fn factor(
        &self,
        cfg: &PipelineConfig,
        (x, y, z): (Fx, Fx, usize),
        st: &mut QuantStats,
    ) -> Result<(Fx, VoiTrace), FxError> {
        let dist = crate::reg!(cfg, voi_dist);
        let pz = Wide::new(z as i128, 0);
        let p = [Wide::from(x), Wide::from(y), pz];
        let mut qk = [dist.zero(); 3];
        for k in 0..3 {
            let dlt = p[k].checked_sub(self.centre[k])?;
            let mag = if dlt.raw < 0 { dlt.checked_neg()? } else { dlt };
            qk[k] = dist.assign(mag.checked_mul(self.axis[k])?, st);
        }
        let one = Wide::new(1, 0);
        let wf = crate::reg!(cfg, voi_weight);
        let w = if self.sphere {
            let sq = (qk[0] * qk[0])
                .checked_add(qk[1] * qk[1])?
                .checked_add(qk[2] * qk[2])?;
            if self.step {
                let inside = sq.cmp_value(self.radius * self.radius).is_le();
                if inside {
                    wf.assign(one, st)
                } else {
                    wf.zero()
                }
            } else {
                let len = isqrt_into(sq, dist, "volume-of-interest distance", st)?;
                let d = dist.assign(len - self.radius, st);
                ramp_weight(wf, d, st)?
            }
        } else {
            let e: [Fx; 3] = std::array::from_fn(|k| dist.assign(qk[k] - self.half[k], st));
            let out = e.iter().any(|v| v.raw() > 0);
            if self.step {
                if out {
                    wf.zero()
                } else {
                    wf.assign(one, st)
                }
            } else if out {
                let mut sq = Wide::new(0, 0);
                for v in e.iter().filter(|v| v.raw() > 0) {
                    sq = sq.checked_add(*v * *v)?;
                }
                let d = isqrt_into(sq, dist, "volume-of-interest distance", st)?;
                ramp_weight(wf, d, st)?
            } else {
                let d = e
                    .into_iter()
                    .reduce(|a, b| if b.cmp_value(a).is_gt() { b } else { a })
                    .unwrap_or(dist.zero());
                ramp_weight(wf, d, st)?
            }
        };
        let w = if self.outside {
            wf.assign(one.checked_sub(w)?, st)
        } else {
            w
        };
        let f = crate::reg!(cfg, voi_factor).assign(one.checked_add(self.gain * w)?, st);
        Ok((
            f,
            VoiTrace {
                weight: w.raw(),
                factor: f.raw(),
            },
        ))
    }

    /// Step 6: opacity `a` scaled by factor `f`, into `alpha`.
    #[inline]
    pub fn scale(cfg: &PipelineConfig, a: Fx, f: Fx, st: &mut QuantStats) -> Fx {
        crate::reg!(cfg, alpha).assign(a * f, st)
    }
}

/// `clamp(1/2 - d, 0, 1)` into `wf` (the `1/2` is exact in `d`'s grid).
fn ramp_weight(wf: crate::config::Reg, d: Fx, st: &mut QuantStats) -> Result<Fx, FxError> {
    let v = Wide::new(1, 1).checked_sub(d)?;
    Ok(if v.raw <= 0 {
        wf.zero()
    } else if v.cmp_value(Wide::new(1, 0)).is_ge() {
        wf.assign(Wide::new(1, 0), st)
    } else {
        wf.assign(v, st)
    })
}
