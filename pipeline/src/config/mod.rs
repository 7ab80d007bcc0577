//! Run-time configuration of every datapath width of the PE array.
//!
//! A [`PipelineConfig`] is built in code (start from [`Default`]) or read
//! from TOML with [`PipelineConfig::from_toml_str`]; each datapath register
//! is a [`Format`] written as an inline table:
//!
//! ```toml
//! alpha = { bits = 12, frac = 12, signed = false, quant = "RND", overflow = "SAT" }
//! ```
//!
//! Keys left out of a TOML file keep their default, unknown keys are
//! errors, and every config is checked by [`PipelineConfig::validate`],
//! whose errors are one line naming the field, e.g.
//! `alpha.frac = 20 exceeds alpha.bits = 16`.
//! [`PipelineConfig::to_toml`] writes a complete, commented file that reads
//! back to the same config, so `ercube` can dump the defaults for editing.
//!
//! # Adding a field
//!
//! Every field is one entry of the table in `config/fields.rs` (its
//! entries in four groups, `config/fields/*.rs`, by what they configure): its
//! rustdoc (what it holds, and why its default), type, default, the
//! one-line comment written above its key in a TOML dump, for an integer
//! the range named when a TOML value does not fit its type, and the rule
//! that checks it. The
//! `config_fields!` macro (`config/schema.rs`) turns the table into the
//! struct field, the `Default`, the TOML key and comment, the serde shape
//! with both conversions, the [`PipelineConfig::formats`] entry of a
//! [`Format`] and the call of the rule, all in table order.
//!
//! So a new datapath width is one entry, plus its rule in
//! `config/rules.rs` unless an existing one fits (`fraction` does for any
//! unsigned `[0, 1]` value). A field of a type the table has not seen yet
//! also needs a `FieldValue` impl in `config/schema.rs`, saying how it is
//! read and written.
//!
//! The rest of the module: `rules.rs` holds [`PipelineConfig::validate`],
//! `text.rs` the TOML reading and writing, `derived.rs` the quantities the
//! datapath derives from a config, `error.rs` [`ConfigError`] and
//! `order.rs` [`Order`], `mapping.rs` [`Mapping`] and [`RayBuffer`],
//! `named.rs` [`FormatId`] and [`Reg`] (which format an assignment writes).
//!
//! [`Format`]: crate::fixed::Format

mod derived;
mod error;
mod fields;
mod mapping;
mod named;
mod order;
mod rules;
mod schema;
mod text;

pub use error::ConfigError;
pub use fields::PipelineConfig;
pub use mapping::{Mapping, Migration, RayBuffer};
pub use named::{FormatId, Reg};
pub use order::Order;

/// Largest supported PE count. The array is 1D and each PE owns a column of
/// the slice buffer; 256 covers one PE per voxel column of a 256-wide
/// volume and keeps PE indices in 8 bits.
pub const MAX_PES: u16 = 256;

/// Largest classification table. 2^16 entries index a full 16-bit sample;
/// anything larger cannot be addressed by the widest voxel.
pub const MAX_TABLE_ENTRIES: u32 = 1 << 16;

/// Largest exp table of the opacity-correction unit, in index bits:
/// 2^16 entries, the same bound as the classification table.
pub const MAX_EXP_TABLE_BITS: u8 = 16;

/// Fewest integer bits of `log_transmittance`: `-log2` transmittances up to
/// 16, i.e. transmittance down to 2^-16.
pub const MIN_LOG_TRANSMITTANCE_INT_BITS: u8 = 4;

/// Widest voxel: volumes are stored as 8- or 16-bit words.
pub const MAX_VOXEL_BITS: u8 = 16;

/// Helpers shared by the unit tests of the submodules.
// `terminate` is the only float field, and every validated config has a
// finite one (NaN is refused), so equality is an equivalence on them.
impl Eq for PipelineConfig {}

#[cfg(test)]
mod testing {
    use super::{ConfigError, PipelineConfig};

    /// A format as a TOML inline table, with `RND`/`SAT` modes.
    pub(super) fn spec(bits: i64, frac: i64, signed: bool) -> String {
        format!("{{ bits = {bits}, frac = {frac}, signed = {signed}, quant = \"RND\", overflow = \"SAT\" }}")
    }

    /// Parses `key = value` on top of the defaults and returns the error.
    pub(super) fn error_for(key: &str, value: &str) -> ConfigError {
        let text = format!("{key} = {value}\n");
        match PipelineConfig::from_toml_str(&text) {
            Ok(c) => panic!("{text} was accepted as {c:?}"),
            Err(e) => e,
        }
    }
}
