//! [`PipelineConfig::validate`] and the rules the field table names.
//!
//! A rule gets the whole config (for cross-field rules), the name of the
//! field it checks (the field an error blames) and the field's value. The
//! table runs them in its order, so a rule may rely on every earlier field
//! having passed its own.

use super::error::{invalid, ConfigError};
use super::{
    Order, PipelineConfig, MAX_EXP_TABLE_BITS, MAX_PES, MAX_TABLE_ENTRIES, MAX_VOXEL_BITS,
    MIN_LOG_TRANSMITTANCE_INT_BITS,
};
use crate::fixed::Format;

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
        fold_headroom(self)
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

/// The check of `gradient`. Its range against the voxel's is checked
/// only when a frame is shaded ([`PipelineConfig::check_shading`]), so
/// that a configuration that never shades need not widen it.
pub(super) fn gradient(_: &PipelineConfig, field: &str, g: Format) -> Result<(), ConfigError> {
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
pub(super) fn grad_scale(c: &PipelineConfig, field: &str, s: Format) -> Result<(), ConfigError> {
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
pub(super) fn grad_norm(c: &PipelineConfig, field: &str, n: Format) -> Result<(), ConfigError> {
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
pub(super) fn light(_: &PipelineConfig, field: &str, l: Format) -> Result<(), ConfigError> {
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
pub(super) fn shade_table_bits(c: &PipelineConfig, field: &str, b: u8) -> Result<(), ConfigError> {
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
pub(super) fn unsigned_frac(_: &PipelineConfig, field: &str, f: Format) -> Result<(), ConfigError> {
    if f.is_signed() || f.frac() == 0 {
        return Err(invalid(
            field,
            format!("{field} = {f}, but it needs an unsigned format with fraction bits"),
        ));
    }
    Ok(())
}

/// The check of `voi_dist`.
pub(super) fn voi_dist(_: &PipelineConfig, field: &str, d: Format) -> Result<(), ConfigError> {
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
pub(super) fn voi_weight(c: &PipelineConfig, field: &str, w: Format) -> Result<(), ConfigError> {
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
pub(super) fn voi_gain(_: &PipelineConfig, field: &str, g: Format) -> Result<(), ConfigError> {
    if !g.is_signed() || g.int_bits() < 2 || g.frac() == 0 {
        return Err(invalid(
            field,
            format!("voi_gain = {g}, but the gain scale - 1 needs a signed format with >= 2 integer bits and fraction bits"),
        ));
    }
    Ok(())
}

/// The check of `voi_factor`.
pub(super) fn voi_factor(c: &PipelineConfig, field: &str, f: Format) -> Result<(), ConfigError> {
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

/// The check of `pes`.
pub(super) fn datapath_latency(
    _: &PipelineConfig,
    field: &str,
    clocks: u16,
) -> Result<(), ConfigError> {
    if clocks > 256 {
        return Err(invalid(
            field,
            format!("datapath_latency = {clocks} is outside 0..=256"),
        ));
    }
    Ok(())
}

pub(super) fn pes(_: &PipelineConfig, field: &str, pes: u16) -> Result<(), ConfigError> {
    if pes == 0 || pes > MAX_PES {
        return Err(invalid(
            field,
            format!("pes = {pes} is outside 1..={MAX_PES}"),
        ));
    }
    Ok(())
}

/// The check of `occupancy_block`.
pub(super) fn occupancy_block(_: &PipelineConfig, field: &str, b: u16) -> Result<(), ConfigError> {
    if !(b.is_power_of_two() && (2..=64).contains(&b)) {
        return Err(invalid(
            field,
            format!("occupancy_block = {b} is not a power of two from 2 to 64"),
        ));
    }
    Ok(())
}

/// `cyclic_width` in `1..=256`.
pub(super) fn cyclic_width(_: &PipelineConfig, field: &str, w: u16) -> Result<(), ConfigError> {
    in_range(field, i64::from(w), 1, 256)
}

/// `link_lanes` in `1..=4`, and above 1 only with the overlapped
/// migration (the between-slices one clocks the array's single ray port).
pub(super) fn link_lanes(c: &PipelineConfig, field: &str, n: u16) -> Result<(), ConfigError> {
    in_range(field, i64::from(n), 1, 4)?;
    if n > 1 && c.migration != super::Migration::Overlapped {
        return Err(invalid(
            field,
            format!("{field} = {n} needs migration = \"overlapped\" (between slices a link carries one ray a cycle)"),
        ));
    }
    Ok(())
}

/// `ray_buffer_bandwidth` in `1..=4096`.
pub(super) fn ray_buffer_bandwidth(
    _: &PipelineConfig,
    field: &str,
    b: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(b), 1, 4096)
}

/// `ray_buffer_rows` in `2..=64`.
pub(super) fn ray_buffer_rows(_: &PipelineConfig, field: &str, r: u16) -> Result<(), ConfigError> {
    in_range(field, i64::from(r), 2, 64)
}

/// `host_bandwidth` in `1..=4096`.
pub(super) fn host_bandwidth(_: &PipelineConfig, field: &str, b: u16) -> Result<(), ConfigError> {
    in_range(field, i64::from(b), 1, 4096)
}

/// `ray_buffer_latency` in `0..=4096`.
pub(super) fn ray_buffer_latency(
    _: &PipelineConfig,
    field: &str,
    l: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(l), 0, 4096)
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
