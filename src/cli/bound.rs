//! The derived error bound of one pipeline frame, reported beside its
//! measured difference from the golden method it mirrors: the stats'
//! `bound` and the summary line say whether the difference stayed within
//! what the widths guarantee, or why no bound is derived for the frame.
//!
//! The bound is [`pipeline::bound`]'s, measured on the frame's own data,
//! table and view. It is derived for frames whose path lengths fit the
//! `path` format: a steeper view (a wide field of view with the eye close
//! to a face) saturates `ds` and so under-corrects the opacity of its
//! steepest rays, a difference no width of the other formats covers. Such
//! a frame gets no bound, a one-line warning, and the `path` format that
//! would hold it. So does a frame in which any format overflowed beyond a
//! designed clamp ([`pipeline::bound::range_violations`]): `why_none`
//! names each such format with its overflow count.

use serde_json::{json, Value};

use golden::geometry::View;
use golden::preint::PreTable;
use golden::render::Prepared;
use golden::shading::Shade;
use golden::tf::Lut;
use golden::voi::Voi;
use pipeline::bound::{self, BoundInputs, PreintInputs, ShadeInputs, VoiInputs};
use pipeline::config::{Order, PipelineConfig};
use pipeline::fixed::{Format, QuantStats};

/// A frame's derived bound against its measured difference.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameBound {
    /// The golden method the bound is against (`er` or `er-ftb`).
    pub against: &'static str,
    /// The per-channel bound on the final image, in `[0, 1]` units; `None`
    /// when none is derived for this frame (see `why`).
    pub value: Option<f64>,
    /// The largest per-channel difference of the final images (RGBA, in
    /// `[0, 1]` units, before rounding to 8 bits).
    pub measured: f64,
    /// The largest path length per slice step of the view, in voxels.
    pub ds_max: f64,
    /// The largest value the configured `path` format holds.
    pub path_max: f64,
    /// The narrowest `path` format with the configured fraction bits that
    /// holds `ds_max`, when the configured one does not.
    pub path_needed: Option<Format>,
    /// Why no bound is derived, when `value` is `None`.
    pub why: Option<String>,
    /// The formats whose overflows are range violations rather than
    /// designed clamps ([`pipeline::config::FormatId::clamps`]), with
    /// their overflow counts: no bound covers them.
    pub harmful: Vec<(&'static str, u64)>,
}

impl FrameBound {
    /// Whether the measured difference stayed within the bound (`None`
    /// when no bound is derived).
    pub fn held(&self) -> Option<bool> {
        self.value.map(|b| self.measured <= b)
    }

    /// The stats' `bound` object.
    pub fn json(&self) -> Value {
        json!({
            "against": self.against,
            "value": self.value,
            "value_255": self.value.map(|b| b * 255.0),
            "measured": self.measured,
            "measured_255": self.measured * 255.0,
            "held": self.held(),
            "why_none": self.why,
            "ds_max": self.ds_max,
            "path_max": self.path_max,
            "path_saturates": self.path_needed.is_some(),
            "path_needed": self.path_needed.map(|f| f.to_string()),
            "harmful_overflows": self
                .harmful
                .iter()
                .map(|&(name, n)| (name.to_string(), json!(n)))
                .collect::<serde_json::Map<String, Value>>(),
        })
    }

    /// The summary line's clause, e.g. `bound 3.1 /255, held`.
    pub fn summary(&self) -> String {
        match (self.value, self.held()) {
            (Some(b), Some(true)) => format!("bound {:.2} /255, held", b * 255.0),
            (Some(b), _) => format!("bound {:.2} /255, EXCEEDED", b * 255.0),
            (None, _) => format!("no bound: {}", self.why.as_deref().unwrap_or("not derived")),
        }
    }

    /// A one-line warning when the view's path lengths saturate the
    /// `path` format, naming the format that would hold them.
    pub fn warning(&self) -> Option<String> {
        let need = self.path_needed?;
        Some(format!(
            "warning: this view's path length per slice step reaches {} voxels, beyond the \
             `path` format's {}: the steepest rays' opacity correction saturates; \
             `path = {{ bits = {}, frac = {}, signed = false, quant = \"{}\", overflow = \"{}\" }}` \
             in --config holds it",
            sig3(self.ds_max),
            sig3(self.path_max),
            need.bits(),
            need.frac(),
            need.quant().name(),
            need.overflow().name(),
        ))
    }
}

/// `x` to three significant digits, without an exponent for the
/// magnitudes a path length takes.
fn sig3(x: f64) -> String {
    let digits = if x.abs() < 1e-300 {
        0
    } else {
        (2 - x.abs().log10().floor() as i32).max(0) as usize
    };
    format!("{x:.digits$}")
}

/// What the frame ran with, beyond the configuration and the table.
#[derive(Debug, Clone, Copy)]
pub struct FrameOptions<'a> {
    /// Shading, when on.
    pub shade: Option<&'a Shade>,
    /// The volume of interest, when on.
    pub voi: Option<&'a Voi>,
    /// Golden's pre-integrated table, for a pre-integrated frame.
    pub preint: Option<&'a PreTable>,
}

pub use pipeline::bound::path_holding;

/// The derived bound of a frame of `prep` under `cfg` with table `lut` on
/// `data_bits`-bit data, against a measured difference `measured`; the
/// frame's quantisation counts `quant` say whether a format overflowed
/// beyond what the bound covers.
pub fn frame_bound(
    cfg: &PipelineConfig,
    prep: &Prepared,
    lut: &Lut,
    data_bits: u32,
    (opts, quant): (FrameOptions<'_>, &QuantStats),
    measured: f64,
) -> anyhow::Result<FrameBound> {
    let view = &prep.view;
    let d = BoundInputs::measure_stack(&prep.stack, lut, view, data_bits)?;
    let path_max = cfg.path.max_value().to_f64();
    let saturates = d.ds_max >= path_max;
    let mut out = FrameBound {
        against: crate::cli::chip::golden_method(cfg).name(),
        value: None,
        measured,
        ds_max: d.ds_max,
        path_max,
        path_needed: None,
        why: None,
        harmful: bound::range_violations(quant),
    };
    if saturates {
        out.path_needed = path_holding(cfg.path, d.ds_max);
    }
    if saturates || !out.harmful.is_empty() {
        let mut parts: Vec<String> = out
            .harmful
            .iter()
            .map(|(name, n)| format!("{name} overflowed {n} times"))
            .collect();
        if saturates {
            parts.push(format!(
                "path length {} saturates the path format (max {})",
                sig3(d.ds_max),
                sig3(path_max)
            ));
        }
        out.why = Some(parts.join("; "));
        return Ok(out);
    }
    if cfg.order == Order::FrontToBack && cfg.terminate < 1.0 {
        out.why = Some("derived without early ray termination (--terminate 1 judges it)".into());
        return Ok(out);
    }
    let b = derive(cfg, view, lut, &d, opts, &prep.stack)?;
    if b.is_finite() {
        out.value = Some(b);
    } else {
        out.why = Some(match opts.shade {
            Some(_) => "the shaded bound needs a normal fade (--normal-fade)".into(),
            None => "not finite for this frame's options".into(),
        });
    }
    Ok(out)
}

/// The bound function of the frame's order and options.
fn derive(
    cfg: &PipelineConfig,
    view: &View,
    lut: &Lut,
    d: &BoundInputs,
    opts: FrameOptions<'_>,
    stack: &golden::slices::SliceStack,
) -> anyhow::Result<f64> {
    let shade = opts
        .shade
        .map(|s| ShadeInputs::measure_stack(stack, view, s));
    let regions = bound::region_slices(view)?;
    let btf = cfg.order == Order::BackToFront;
    if let Some(pt) = opts.preint {
        let p = PreintInputs::measure(cfg, d, pt);
        return Ok(if btf {
            bound::preint_error_bound(cfg, d, &p)
        } else {
            bound::preint_ftb_error_bound(cfg, d, &p, &regions)
        });
    }
    if let Some(v) = opts.voi {
        let vi = VoiInputs::measure(cfg, d, view, lut, v)?;
        return Ok(if btf {
            bound::voi_error_bound(cfg, d, shade.as_ref(), &vi)
        } else {
            bound::voi_ftb_error_bound(cfg, d, &regions, shade.as_ref(), &vi)
        });
    }
    Ok(match (&shade, btf) {
        (Some(s), true) => bound::shaded_error_bound(cfg, d, s),
        (Some(s), false) => bound::shaded_ftb_error_bound(cfg, d, &regions, s),
        (None, true) => bound::error_bound(cfg, d),
        (None, false) => bound::ftb_error_bound(cfg, d, &regions),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use pipeline::fixed::{Overflow, Quant};

    #[test]
    fn the_path_that_holds_a_length_keeps_the_fraction_and_is_narrowest() {
        let path = Format::new(16, 13, false, Quant::Rnd, Overflow::Sat).unwrap();
        // ufixed<16,3> holds below 8: 16.2 needs 5 integer bits.
        let need = path_holding(path, 16.2).unwrap();
        assert_eq!((need.bits(), need.frac()), (18, 13));
        assert!(need.max_value().to_f64() > 16.2);
        // Exactly 8 is not held by 3 integer bits (max 8 - 2^-13).
        assert_eq!(path_holding(path, 8.0).unwrap().int_bits(), 4);
        assert_eq!(path_holding(path, 7.5).unwrap().int_bits(), 3);
    }

    #[test]
    fn short_numbers_keep_three_significant_digits() {
        assert_eq!(sig3(16.2345), "16.2");
        assert_eq!(sig3(7.9998779296875), "8.00");
        assert_eq!(sig3(123.4), "123");
        assert_eq!(sig3(1.5), "1.50");
    }

    #[test]
    fn held_compares_the_measured_difference_with_the_bound() {
        let mut b = FrameBound {
            against: "er",
            value: Some(0.01),
            measured: 0.005,
            ds_max: 1.5,
            path_max: 8.0,
            path_needed: None,
            why: None,
            harmful: Vec::new(),
        };
        assert_eq!(b.held(), Some(true));
        assert!(b.summary().ends_with("held"));
        b.measured = 0.02;
        assert_eq!(b.held(), Some(false));
        assert!(b.summary().contains("EXCEEDED"));
        b.value = None;
        assert_eq!(b.held(), None);
        assert_eq!(b.json()["held"], Value::Null);
    }
}
