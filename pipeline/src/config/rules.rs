//! [`PipelineConfig::validate`] and the rules the field table names.
//!
//! A rule gets the whole config (for cross-field rules), the name of the
//! field it checks (the field an error blames) and the field's value. The
//! table runs them in its order, so a rule may rely on every earlier field
//! having passed its own.

use super::error::{invalid, ConfigError};
use super::{
    Order, PipelineConfig, MAX_EXP_TABLE_BITS, MAX_TABLE_ENTRIES, MAX_VOXEL_BITS,
    MIN_LOG_TRANSMITTANCE_INT_BITS,
};
use crate::fixed::Format;

mod array;
mod units;

pub(super) use array::*;
pub(super) use units::*;

#[cfg(test)]
mod tests;

impl PipelineConfig {
    /// Checks that the datapath can work: each field's signedness and
    /// integer/fraction split suits its role, and related fields agree.
    /// Returns the first problem found, as a one-line message naming the
    /// field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.check_fields()?;
        terminate(self)?;
        fold_headroom(self)?;
        pipelining(self)
    }
}

/// The check of `voxel`.
pub(super) fn voxel(_: &PipelineConfig, field: &str, v: Format) -> Result<(), ConfigError> {
    if v.is_signed() {
        return Err(invalid(
            field,
            "voxel.signed = true, but voxels are unsigned words".into(),
        ));
    }
    if v.frac() != 0 {
        return Err(invalid(
            field,
            format!(
                "voxel.frac = {}, but voxels are integers (frac = 0)",
                v.frac()
            ),
        ));
    }
    if v.bits() > MAX_VOXEL_BITS {
        return Err(invalid(
            field,
            format!(
                "voxel.bits = {} exceeds the {MAX_VOXEL_BITS}-bit volume word",
                v.bits()
            ),
        ));
    }
    Ok(())
}

/// The check of `position`.
pub(super) fn position(_: &PipelineConfig, field: &str, p: Format) -> Result<(), ConfigError> {
    if !p.is_signed() {
        return Err(invalid(
            field,
            "position.signed = false, but rays start outside the volume at negative coordinates"
                .into(),
        ));
    }
    if p.frac() == 0 {
        return Err(invalid(
            field,
            "position.frac = 0 leaves no fraction bits for interpolation weights".into(),
        ));
    }
    if p.int_bits() < 2 {
        return Err(invalid(
            field,
            format!(
                "position has {} integer bit(s) including the sign; at least 2 are needed to address a voxel",
                p.int_bits()
            ),
        ));
    }
    Ok(())
}

/// The check of `step`.
pub(super) fn step(_: &PipelineConfig, field: &str, s: Format) -> Result<(), ConfigError> {
    if s.is_signed() {
        return Err(invalid(field, "step.signed = true, but 0 < t <= 1".into()));
    }
    if s.int_bits() < 1 {
        return Err(invalid(
            field,
            format!(
                "step.frac = {} equals step.bits, so t = 1 is not representable",
                s.frac()
            ),
        ));
    }
    if s.frac() == 0 {
        return Err(invalid(
            field,
            "step.frac = 0 leaves only t = 1; fractional spacing needs fraction bits".into(),
        ));
    }
    Ok(())
}

/// The check of a `[0, 1]`-valued field: unsigned, some fraction bits, and
/// at most one integer bit (more would only waste width).
pub(super) fn fraction(_: &PipelineConfig, name: &str, f: Format) -> Result<(), ConfigError> {
    if f.is_signed() {
        return Err(invalid(
            name,
            format!("{name}.signed = true, but {name} lies in [0, 1]"),
        ));
    }
    if f.frac() == 0 {
        return Err(invalid(
            name,
            format!("{name}.frac = 0, but {name} is a fraction in [0, 1]"),
        ));
    }
    if f.int_bits() > 1 {
        return Err(invalid(
            name,
            format!(
                "{name} has {} integer bits; a value in [0, 1] needs at most 1",
                f.int_bits()
            ),
        ));
    }
    Ok(())
}

/// The check of `sample`.
pub(super) fn sample(c: &PipelineConfig, field: &str, sm: Format) -> Result<(), ConfigError> {
    if sm.is_signed() {
        return Err(invalid(
            field,
            "sample.signed = true, but samples index the classification table".into(),
        ));
    }
    if sm.int_bits() < c.voxel.bits() {
        return Err(invalid(
            field,
            format!(
                "sample has {} integer bits, fewer than voxel.bits = {}",
                sm.int_bits(),
                c.voxel.bits()
            ),
        ));
    }
    Ok(())
}

/// The check of `table_entries`.
pub(super) fn table_entries(c: &PipelineConfig, field: &str, n: u32) -> Result<(), ConfigError> {
    if n < 2 || !n.is_power_of_two() || n > MAX_TABLE_ENTRIES {
        return Err(invalid(
            field,
            format!("table_entries = {n} is not a power of two in 2..={MAX_TABLE_ENTRIES}"),
        ));
    }
    if n.trailing_zeros() > u32::from(c.sample.bits()) {
        return Err(invalid(
            field,
            format!(
                "table_entries = {n} needs {} index bits, more than sample.bits = {}",
                n.trailing_zeros(),
                c.sample.bits()
            ),
        ));
    }
    Ok(())
}

/// The check of `path`.
pub(super) fn path(_: &PipelineConfig, field: &str, ds: Format) -> Result<(), ConfigError> {
    if ds.is_signed() {
        return Err(invalid(
            field,
            "path.signed = true, but path lengths are positive".into(),
        ));
    }
    if ds.int_bits() < 2 {
        return Err(invalid(
            field,
            format!(
                "path has {} integer bit(s); at least 2 are needed for ds in [1, 4)",
                ds.int_bits()
            ),
        ));
    }
    if ds.frac() == 0 {
        return Err(invalid(
            field,
            "path.frac = 0 leaves only integer path lengths; oblique rays need fraction bits"
                .into(),
        ));
    }
    Ok(())
}

/// The check of `log_transmittance`.
pub(super) fn log_transmittance(
    c: &PipelineConfig,
    field: &str,
    lt: Format,
) -> Result<(), ConfigError> {
    if lt.is_signed() {
        return Err(invalid(
            field,
            "log_transmittance.signed = true, but -log2 of a transmittance in (0, 1] is non-negative"
                .into(),
        ));
    }
    if lt.int_bits() < MIN_LOG_TRANSMITTANCE_INT_BITS {
        return Err(invalid(
            field,
            format!(
                "log_transmittance has {} integer bit(s); at least {MIN_LOG_TRANSMITTANCE_INT_BITS} are needed",
                lt.int_bits()
            ),
        ));
    }
    // -log2 of the smallest transmittance, 2^-alpha.frac, is alpha.frac:
    // it needs ceil(log2(alpha.frac + 1)) integer bits, its bit length.
    let alpha_frac = c.alpha.frac();
    let needed = u8::BITS - alpha_frac.leading_zeros();
    if u32::from(lt.int_bits()) < needed {
        return Err(invalid(
            field,
            format!(
                "log_transmittance has {} integer bits, but -log2 of the smallest transmittance 2^-{alpha_frac} (alpha.frac = {alpha_frac}) needs ceil(log2({})) = {needed}",
                lt.int_bits(),
                u32::from(alpha_frac) + 1
            ),
        ));
    }
    Ok(())
}

/// The check of `exp_table_bits`.
pub(super) fn exp_table_bits(c: &PipelineConfig, field: &str, e: u8) -> Result<(), ConfigError> {
    if e == 0 || e > MAX_EXP_TABLE_BITS {
        return Err(invalid(
            field,
            format!("exp_table_bits = {e} is outside 1..={MAX_EXP_TABLE_BITS}"),
        ));
    }
    let lt = c.log_transmittance;
    if e > lt.frac() {
        return Err(invalid(
            field,
            format!(
                "exp_table_bits = {e} exceeds log_transmittance.frac = {}: the exp table is indexed by fraction bits of p",
                lt.frac()
            ),
        ));
    }
    Ok(())
}

/// The check of `accum_color`, against the colour it accumulates.
pub(super) fn accum_color(c: &PipelineConfig, name: &str, acc: Format) -> Result<(), ConfigError> {
    accumulator(name, acc, "color", c.color)
}

/// The check of `accum_alpha`, against the corrected opacity it
/// accumulates.
pub(super) fn accum_alpha(c: &PipelineConfig, name: &str, acc: Format) -> Result<(), ConfigError> {
    accumulator(name, acc, "opacity_corr", c.opacity_corr)
}

/// Checks a compositing accumulator against the input it accumulates.
fn accumulator(
    name: &str,
    acc: Format,
    input_name: &str,
    input: Format,
) -> Result<(), ConfigError> {
    if acc.is_signed() {
        return Err(invalid(
            name,
            format!("{name}.signed = true, but front-to-back compositing only adds"),
        ));
    }
    if acc.frac() < input.frac() {
        return Err(invalid(
            name,
            format!(
                "{name}.frac = {} is below {input_name}.frac = {}: faint contributions would round to zero",
                acc.frac(),
                input.frac()
            ),
        ));
    }
    Ok(())
}

/// The check of `merge`, against both accumulators it merges.
pub(super) fn merge(c: &PipelineConfig, field: &str, m: Format) -> Result<(), ConfigError> {
    if m.is_signed() {
        return Err(invalid(
            field,
            "merge.signed = true, but Bartlett weights and accumulators are non-negative".into(),
        ));
    }
    for (name, acc) in [
        ("accum_color", c.accum_color),
        ("accum_alpha", c.accum_alpha),
    ] {
        if m.frac() < acc.frac() {
            return Err(invalid(
                field,
                format!(
                    "merge.frac = {} is below {name}.frac = {}",
                    m.frac(),
                    acc.frac()
                ),
            ));
        }
        if m.int_bits() < acc.int_bits() {
            return Err(invalid(
                field,
                format!(
                    "merge has {} integer bits, fewer than {name}'s {}",
                    m.int_bits(),
                    acc.int_bits()
                ),
            ));
        }
    }
    Ok(())
}

/// `v` in `lo..=hi`, or the one-line error naming `field`.
fn in_range(field: &str, v: i64, lo: i64, hi: i64) -> Result<(), ConfigError> {
    if !(lo..=hi).contains(&v) {
        return Err(invalid(
            field,
            format!("{field} = {v} is outside {lo}..={hi}"),
        ));
    }
    Ok(())
}

/// The check of `terminate`, run by `validate` after the table's checks.
fn terminate(c: &PipelineConfig) -> Result<(), ConfigError> {
    let t = c.terminate;
    if !(t.is_finite() && t > 0.0 && t <= 1.0) {
        return Err(invalid(
            "terminate",
            format!("terminate = {t} is outside (0, 1] (1 disables early ray termination)"),
        ));
    }
    Ok(())
}

/// The front-to-back fold adds what a ray's children added behind it to
/// the ray's own state, which can pass 1 (by up to 7/16 per boundary where
/// neighbouring rays differ); the fold keeps its words in `merge`. Last, as
/// it depends on `order` and `merge` together.
fn fold_headroom(c: &PipelineConfig) -> Result<(), ConfigError> {
    if c.order == Order::FrontToBack && c.merge.int_bits() < 1 {
        return Err(invalid(
            "merge",
            "merge has 0 integer bits, but order = \"front-to-back\" folds results above 1 into it"
                .into(),
        ));
    }
    Ok(())
}
