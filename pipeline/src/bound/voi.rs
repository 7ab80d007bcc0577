//! The volume-of-interest terms of the derived bound (step 3v, after
//! classification and before shading, where [`crate::voi`] scales the
//! opacity): how far the pipeline's scaled opacity of one sample can be
//! from golden's ([`golden::voi::ViewVoi::factor`]), given the classified
//! difference `da` of step 3. Distances are in ramp units (`R` the ramp
//! width, or world units with no ramp); `k = s / R` per axis.
//!
//! 1. Distance: each position differs by at most `ex` (step 1 of the
//!    parent module) and the centre rounds (`r(position)`); the axis scale
//!    rounds (`r(voi_axis)`, times the largest `|p - c|`, `P`) and `q`
//!    rounds once: `dq = (ex + r(position)) k + P r(voi_axis) +
//!    r(voi_dist)`. The half extents (or radius) and `e` round once
//!    more each; the box's and the sphere's signed distances are
//!    1-Lipschitz in the vector of per-axis errors (`sqrt 3` of the
//!    largest), the square root truncates and the result rounds:
//!    `dd = sqrt 3 (dq + 2 r(voi_dist)) + q(voi_dist) + 2 r(voi_dist)`.
//! 2. Weight, with a ramp: the clamp is 1-Lipschitz, so `dw = min(1, dd +
//!    r(voi_weight))` (`1 - w` is exact). Without a ramp the weight is a
//!    step: it agrees with golden's except for samples within `dd` of the
//!    boundary, which may take the other factor. Those are counted on
//!    golden's ray layout ([`VoiInputs::measure`]): per region, the most
//!    such samples of one ray, `n_i`; each changes the corrected opacity by
//!    at most `min(1, ds_max |S - 1| a_max)` (`a_max` the table's largest
//!    opacity) and enters the bound like one more slice's opacity error.
//! 3. Factor `f = 1 + (S - 1) w`: `df = |S - 1| dw + r(voi_gain) +
//!    r(voi_factor)`.
//! 4. Opacity `a f` into `alpha`, saturating one LSB below 1 where golden's
//!    correction clamps at 1: `da' = max(1, S) da + a_max df + r(alpha) +
//!    q(alpha) + 4 e max(1, S)`.
//!
//! The colour of a sample is not scaled, so `dc` passes unchanged.

use golden::geometry::View;
use golden::methods::Method;
use golden::sampling::slice_rays;
use golden::tf::Lut;
use golden::voi::{ViewVoi, Voi};

use super::{position_error, r, BoundInputs};
use crate::config::PipelineConfig;

/// What the volume-of-interest terms need: the VOI, the table's largest
/// opacity, the geometry's reach and, without a ramp, the samples near
/// the boundary.
#[derive(Debug, Clone, PartialEq)]
pub struct VoiInputs {
    /// The volume of interest.
    pub voi: Voi,
    /// The table's largest opacity.
    pub a_max: f64,
    /// Per view axis, `s / R`.
    pub axis: [f64; 3],
    /// Per view axis, the largest `|p - c|` in voxels over the volume's
    /// sample positions (with a voxel of margin).
    pub reach: [f64; 3],
    /// Without a ramp, per region of golden's `er` layout, the most
    /// samples of one ray within [`VoiInputs::band`] of the boundary
    /// (zeros with a ramp).
    pub flips_er: Vec<usize>,
    /// The same on the `er-ftb` layout, region 0 in front.
    pub flips_ftb: Vec<usize>,
    /// The half-width of the band, `dd` (step 1).
    pub band: f64,
}

impl VoiInputs {
    /// Measures the facts of `voi` in `view` with table `lut`, for a
    /// pipeline of `cfg` on data of `d` (the band depends on both).
    pub fn measure(
        cfg: &PipelineConfig,
        d: &BoundInputs,
        view: &View,
        lut: &Lut,
        voi: &Voi,
    ) -> golden::Result<VoiInputs> {
        let v = ViewVoi::new(view, voi)?;
        let (centre, _, _, _) = v.region();
        let spacing = v.spacing().to_array();
        let (_, _, ramp) = v.weighting();
        let unit = if ramp > 0.0 { ramp } else { 1.0 };
        let axis = spacing.map(|s| s / unit);
        let c = centre.to_array();
        let reach: [f64; 3] = std::array::from_fn(|k| {
            let n = view.dims[k] as f64;
            // Samples lie within half a voxel outside the volume; one
            // voxel of margin covers them.
            (c[k] + 1.0).abs().max((n + 1.0 - c[k]).abs())
        });
        let a_max = lut.rgba.iter().map(|e| f64::from(e[3])).fold(0.0, f64::max);
        let mut inputs = VoiInputs {
            voi: *voi,
            a_max,
            axis,
            reach,
            flips_er: Vec::new(),
            flips_ftb: Vec::new(),
            band: 0.0,
        };
        inputs.band = inputs.distance_error(cfg, position_error(cfg, d));
        if ramp == 0.0 {
            inputs.flips_er = flips(view, &v, Method::Er, inputs.band)?;
            inputs.flips_ftb = flips(view, &v, Method::ErFtb, inputs.band)?;
        }
        Ok(inputs)
    }

    /// Step 1: `dd`, at position error `ex`.
    fn distance_error(&self, cfg: &PipelineConfig, ex: f64) -> f64 {
        let rd = r(cfg.voi_dist);
        let dq = (0..3)
            .map(|k| (ex + r(cfg.position)) * self.axis[k] + self.reach[k] * r(cfg.voi_axis) + rd)
            .fold(0.0, f64::max);
        3f64.sqrt() * (dq + 2.0 * rd) + cfg.voi_dist.lsb() + 2.0 * rd
    }

    /// Steps 2 to 4: the scaled opacity difference from the classified
    /// one, at position error `ex`.
    pub(super) fn alpha_term(&self, cfg: &PipelineConfig, ex: f64, da: f64) -> f64 {
        let e = 2f64.powi(-24);
        let s = self.voi.scale;
        let dw = if self.voi.ramp > 0.0 {
            (self.distance_error(cfg, ex) + r(cfg.voi_weight)).min(1.0)
        } else {
            0.0
        };
        let df = (s - 1.0).abs() * dw + r(cfg.voi_gain) + r(cfg.voi_factor);
        let fmax = s.max(1.0);
        fmax * da + self.a_max * df + r(cfg.alpha) + cfg.alpha.lsb() + 4.0 * e * fmax
    }

    /// Step 2 without a ramp: the corrected-opacity change of one sample
    /// that takes the other factor.
    pub(super) fn flip(&self, ds_max: f64) -> f64 {
        (ds_max * (self.voi.scale - 1.0).abs() * self.a_max).min(1.0)
    }
}

/// Per region of `method`'s layout of `view`, the most samples of one ray
/// whose golden distance to `v`'s boundary is at most `band`.
fn flips(view: &View, v: &ViewVoi, method: Method, band: f64) -> golden::Result<Vec<usize>> {
    let layout = method.layout(view)?;
    let mut out = Vec::with_capacity(layout.grids.len());
    for g in &layout.grids {
        if g.is_empty() {
            out.push(0);
            continue;
        }
        let [w, h] = g.counts();
        let mut count = vec![0usize; w * h];
        for z in g.slices.clone() {
            let ([px, py], [(xlo, xhi), (ylo, yhi)]) = slice_rays(view, g, z);
            for my in ylo..=yhi {
                let y = py.a + my as f64 * py.t;
                for mx in xlo..=xhi {
                    let x = px.a + mx as f64 * px.t;
                    let p = glam::DVec3::new(x, y, z as f64);
                    if v.distance(p).abs() <= band {
                        let i = (my - g.lo[1]) as usize * w + (mx - g.lo[0]) as usize;
                        count[i] += 1;
                    }
                }
            }
        }
        out.push(count.into_iter().max().unwrap_or(0));
    }
    Ok(out)
}
