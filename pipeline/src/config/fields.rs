//! The field table: every field of [`PipelineConfig`], described once.
//!
//! Each entry gives the field's rustdoc, type, default, the range an
//! integer's conversion error names, the comment above its key in a TOML
//! dump, and the rule [`PipelineConfig::validate`] checks it with (in
//! `rules.rs`). [`config_fields!`] expands the table; the order of the
//! entries is the order of the struct, of a TOML dump, of serde's output,
//! of [`PipelineConfig::formats`] and of the checks.
//!
//! The entries are in four groups, one file each, gathered in this order:
//! `fields/datapath.rs` (the sample datapath's formats and tables),
//! `fields/array.rs` (the array and its frame), `fields/units.rs` (the
//! shading, volume-of-interest and pre-integration units) and
//! `fields/architecture.rs` (ownership, links, passes, the ray buffer,
//! the host link).

use super::rules;
use super::schema::{config_fields, default_format as fmt};
use super::{Mapping, Migration, Order, RayBuffer, MAX_EXP_TABLE_BITS, MAX_PES, MAX_TABLE_ENTRIES};
use crate::fixed::Format;
use crate::fixed::Overflow::Sat;
use crate::fixed::Quant::{Rnd, Trn};

mod architecture;
mod array;
mod datapath;
mod units;

use architecture::architecture_fields;
use array::array_fields;
use datapath::datapath_fields;
use units::unit_fields;

config_fields! {
    @gather []
    [datapath_fields, array_fields, unit_fields, architecture_fields]
    /// Widths of every datapath register of the PE array, and the array size.
    ///
    /// The defaults model a VolumePro-class datapath (12-bit voxels and
    /// opacities, 8 fraction bits of colour) with enough position range for
    /// 1024³ volumes; each field's documentation says why its default was
    /// chosen.
    ///
    /// # Opacity correction
    ///
    /// Classification opacities are for a unit sample spacing; a ray that
    /// crosses a slice step along a path of length `ds` voxels needs the
    /// corrected opacity `a' = 1 - (1 - a)^ds`. The opacity-correction unit
    /// computes it in the log domain, from four fields:
    ///
    /// 1. `L = -log2(1 - a)`, read from a table indexed by the alpha code
    ///    (`2^alpha.bits` entries), stored in [`log_transmittance`];
    /// 2. `p = L * ds`, with `ds` in the [`path`] format, assigned to
    ///    [`log_transmittance`];
    /// 3. `T = 2^-p = 2^-int(p) * 2^-frac(p)`: an exp table indexed by the top
    ///    [`exp_table_bits`] bits of `frac(p)`, linearly interpolated with the
    ///    remaining fraction bits (interpolation weight in the [`weight`]
    ///    format), entries and result in the [`opacity_corr`] format, then
    ///    shifted right by `int(p)`;
    /// 4. `a' = 1 - T` in [`opacity_corr`].
    ///
    /// [`log_transmittance`]: PipelineConfig::log_transmittance
    /// [`path`]: PipelineConfig::path
    /// [`exp_table_bits`]: PipelineConfig::exp_table_bits
    /// [`weight`]: PipelineConfig::weight
    /// [`opacity_corr`]: PipelineConfig::opacity_corr
    pub struct PipelineConfig;
}

#[cfg(test)]
mod tests;
