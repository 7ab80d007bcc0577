//! The rules of the units beside the plain sample: the gradient and
//! shading unit's formats (and the checks a shaded frame adds) and the
//! volume of interest's.

use super::fraction;
use crate::config::error::{invalid, ConfigError};
use crate::config::{PipelineConfig, MAX_EXP_TABLE_BITS};
use crate::fixed::Format;

/// The check of `gradient`. Its range against the voxel's is checked
/// only when a frame is shaded ([`PipelineConfig::check_shading`]), so
/// that a configuration that never shades need not widen it.
pub(in crate::config) fn gradient(
    _: &PipelineConfig,
    field: &str,
    g: Format,
) -> Result<(), ConfigError> {
    if !g.is_signed() || g.int_bits() < 2 {
        return Err(invalid(
            field,
            format!("gradient = {g}, but central differences need a signed format with >= 2 integer bits"),
        ));
    }
    Ok(())
}

impl PipelineConfig {
    /// The checks a shaded frame adds: `gradient` holds a full-range
    /// difference of two `voxel` words with its sign.
    pub fn check_shading(&self) -> Result<(), ConfigError> {
        let need = self.voxel.bits() + 1;
        if self.gradient.int_bits() < need {
            return Err(invalid(
                "gradient",
                format!(
                    "gradient has {} integer bits including the sign, fewer than voxel.bits + 1 = {need} (needed to shade)",
                    self.gradient.int_bits()
                ),
            ));
        }
        Ok(())
    }
}

/// The check of `grad_scale`.
pub(in crate::config) fn grad_scale(
    c: &PipelineConfig,
    field: &str,
    s: Format,
) -> Result<(), ConfigError> {
    unsigned_frac(c, field, s)?;
    if s.int_bits() < 1 {
        return Err(invalid(
            field,
            "grad_scale has no integer bit, so the scale 1 of an isotropic axis is not representable"
                .into(),
        ));
    }
    Ok(())
}

/// The check of `grad_norm`.
pub(in crate::config) fn grad_norm(
    c: &PipelineConfig,
    field: &str,
    n: Format,
) -> Result<(), ConfigError> {
    if n.is_signed() {
        return Err(invalid(
            field,
            "grad_norm.signed = true, but a magnitude is non-negative".into(),
        ));
    }
    if n.int_bits() < c.gradient.int_bits() {
        return Err(invalid(
            field,
            format!(
                "grad_norm has {} integer bits, fewer than gradient's {}",
                n.int_bits(),
                c.gradient.int_bits()
            ),
        ));
    }
    Ok(())
}

/// The check of `light`.
pub(in crate::config) fn light(
    _: &PipelineConfig,
    field: &str,
    l: Format,
) -> Result<(), ConfigError> {
    if !l.is_signed() || l.int_bits() < 2 || l.frac() == 0 {
        return Err(invalid(
            field,
            format!(
                "light = {l}, but unit vector components need a signed format with >= 2 integer bits and fraction bits"
            ),
        ));
    }
    Ok(())
}

/// The check of `shade_table_bits`.
pub(in crate::config) fn shade_table_bits(
    c: &PipelineConfig,
    field: &str,
    b: u8,
) -> Result<(), ConfigError> {
    if b == 0 || b > MAX_EXP_TABLE_BITS {
        return Err(invalid(
            field,
            format!("shade_table_bits = {b} is outside 1..={MAX_EXP_TABLE_BITS}"),
        ));
    }
    if b > c.normal_dot.frac() {
        return Err(invalid(
            field,
            format!(
                "shade_table_bits = {b} exceeds normal_dot.frac = {}: the table is indexed by fraction bits of |n.H|",
                c.normal_dot.frac()
            ),
        ));
    }
    Ok(())
}

/// The check of an unsigned field with fraction bits.
pub(in crate::config) fn unsigned_frac(
    _: &PipelineConfig,
    field: &str,
    f: Format,
) -> Result<(), ConfigError> {
    if f.is_signed() || f.frac() == 0 {
        return Err(invalid(
            field,
            format!("{field} = {f}, but it needs an unsigned format with fraction bits"),
        ));
    }
    Ok(())
}

/// The check of `voi_dist`.
pub(in crate::config) fn voi_dist(
    _: &PipelineConfig,
    field: &str,
    d: Format,
) -> Result<(), ConfigError> {
    if !d.is_signed() || d.int_bits() < 2 || d.frac() == 0 {
        return Err(invalid(
            field,
            format!("voi_dist = {d}, but signed distances need a signed format with >= 2 integer bits and fraction bits"),
        ));
    }
    Ok(())
}

/// The check of `voi_weight`: a fraction that holds 1 (the weight of a
/// sample deep inside).
pub(in crate::config) fn voi_weight(
    c: &PipelineConfig,
    field: &str,
    w: Format,
) -> Result<(), ConfigError> {
    fraction(c, field, w)?;
    if w.int_bits() < 1 {
        return Err(invalid(
            field,
            "voi_weight has no integer bit, so the weight 1 of a sample inside is not representable"
                .into(),
        ));
    }
    Ok(())
}

/// The check of `voi_gain`.
pub(in crate::config) fn voi_gain(
    _: &PipelineConfig,
    field: &str,
    g: Format,
) -> Result<(), ConfigError> {
    if !g.is_signed() || g.int_bits() < 2 || g.frac() == 0 {
        return Err(invalid(
            field,
            format!("voi_gain = {g}, but the gain scale - 1 needs a signed format with >= 2 integer bits and fraction bits"),
        ));
    }
    Ok(())
}

/// The check of `voi_factor`.
pub(in crate::config) fn voi_factor(
    c: &PipelineConfig,
    field: &str,
    f: Format,
) -> Result<(), ConfigError> {
    unsigned_frac(c, field, f)?;
    if f.int_bits() < 1 {
        return Err(invalid(
            field,
            "voi_factor has no integer bit, so the factor 1 that leaves an opacity unchanged is not representable"
                .into(),
        ));
    }
    Ok(())
}
