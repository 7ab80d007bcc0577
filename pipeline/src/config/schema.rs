//! The machinery behind the field table: [`config_fields!`], which expands
//! the table in `fields.rs` into everything a field needs, and
//! [`FieldValue`], which says how each field type is read and written.

use super::error::{invalid, ConfigError};
use super::{Mapping, Migration, Order, RayBuffer};
use crate::fixed::{Format, FormatSpec, Overflow, Quant};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::fmt;

/// How a field type crosses the TOML/JSON boundary.
///
/// The `Raw` side is deliberately wider than the field (integers are `i64`,
/// formats are unchecked [`FormatSpec`]s) so that a bad value parses and
/// is then reported as written, naming the field, instead of surfacing as
/// a serde type error.
pub(super) trait FieldValue: Copy {
    /// The unvalidated form held by `RawConfig`.
    type Raw: Copy + fmt::Debug + Serialize + DeserializeOwned;

    /// Whether [`PipelineConfig::formats`](super::PipelineConfig::formats)
    /// lists fields of this type. A constant, because it sizes that array;
    /// [`as_format`](FieldValue::as_format) must agree with it.
    const IS_FORMAT: bool = false;

    /// The raw form, for writing.
    fn to_raw(self) -> Self::Raw;

    /// Converts a raw value read for `field`. `range` is what an integer's
    /// error message says the field accepts; other types ignore it.
    fn from_raw(field: &str, raw: Self::Raw, range: Option<Range>) -> Result<Self, ConfigError>;

    /// The right-hand side of `field = ...` in a TOML dump.
    fn toml_value(raw: Self::Raw) -> String;

    /// The value as a register format, for `Format` fields.
    fn as_format(self) -> Option<Format> {
        None
    }
}

/// The accepted range an integer field's error message names, `lo..=hi`.
///
/// Only named, not enforced, on conversion: conversion rejects just what
/// does not fit the field's type, and the field's check enforces the
/// range, so code-built and file-read configs fail alike.
#[derive(Debug, Clone, Copy)]
pub(super) struct Range {
    /// Smallest accepted value.
    pub lo: i64,
    /// Largest accepted value.
    pub hi: i64,
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}..={}", self.lo, self.hi)
    }
}

impl FieldValue for Format {
    type Raw = FormatSpec;
    const IS_FORMAT: bool = true;

    fn to_raw(self) -> FormatSpec {
        self.spec()
    }

    fn from_raw(field: &str, raw: FormatSpec, _: Option<Range>) -> Result<Format, ConfigError> {
        Format::try_from(raw).map_err(|e| invalid(field, e.describe(field)))
    }

    fn toml_value(raw: FormatSpec) -> String {
        raw.to_string()
    }

    fn as_format(self) -> Option<Format> {
        Some(self)
    }
}

/// Integer fields: `i64` on the wire, narrowed on conversion.
macro_rules! int_field_value {
    ($($t:ty),*) => {$(
        impl FieldValue for $t {
            type Raw = i64;

            fn to_raw(self) -> i64 {
                i64::from(self)
            }

            fn from_raw(field: &str, raw: i64, range: Option<Range>) -> Result<$t, ConfigError> {
                // Without a declared range the type's own is the honest one.
                let range = range.unwrap_or(Range {
                    lo: i64::from(<$t>::MIN),
                    hi: i64::from(<$t>::MAX),
                });
                <$t>::try_from(raw)
                    .map_err(|_| invalid(field, format!("{field} = {raw} is outside {range}")))
            }

            fn toml_value(raw: i64) -> String {
                raw.to_string()
            }
        }
    )*};
}

int_field_value!(u8, u16, u32);

impl FieldValue for f64 {
    type Raw = f64;

    fn to_raw(self) -> f64 {
        self
    }

    fn from_raw(_: &str, raw: f64, _: Option<Range>) -> Result<f64, ConfigError> {
        Ok(raw)
    }

    fn toml_value(raw: f64) -> String {
        // `{:?}` keeps the decimal point, so TOML reads a float back.
        format!("{raw:?}")
    }
}

impl FieldValue for Order {
    type Raw = Order;

    fn to_raw(self) -> Order {
        self
    }

    fn from_raw(_: &str, raw: Order, _: Option<Range>) -> Result<Order, ConfigError> {
        Ok(raw)
    }

    fn toml_value(raw: Order) -> String {
        format!("\"{}\"", raw.name())
    }
}

impl FieldValue for Mapping {
    type Raw = Mapping;

    fn to_raw(self) -> Mapping {
        self
    }

    fn from_raw(_: &str, raw: Mapping, _: Option<Range>) -> Result<Mapping, ConfigError> {
        Ok(raw)
    }

    fn toml_value(raw: Mapping) -> String {
        format!("\"{}\"", raw.name())
    }
}

impl FieldValue for bool {
    type Raw = bool;

    fn to_raw(self) -> bool {
        self
    }

    fn from_raw(_: &str, raw: bool, _: Option<Range>) -> Result<bool, ConfigError> {
        Ok(raw)
    }

    fn toml_value(raw: bool) -> String {
        raw.to_string()
    }
}

impl FieldValue for Migration {
    type Raw = Migration;

    fn to_raw(self) -> Migration {
        self
    }

    fn from_raw(_: &str, raw: Migration, _: Option<Range>) -> Result<Migration, ConfigError> {
        Ok(raw)
    }

    fn toml_value(raw: Migration) -> String {
        format!("\"{}\"", raw.name())
    }
}

impl FieldValue for crate::cost::Target {
    type Raw = crate::cost::Target;

    fn to_raw(self) -> crate::cost::Target {
        self
    }

    fn from_raw(
        _: &str,
        raw: crate::cost::Target,
        _: Option<Range>,
    ) -> Result<crate::cost::Target, ConfigError> {
        Ok(raw)
    }

    fn toml_value(raw: crate::cost::Target) -> String {
        format!("\"{}\"", raw.name())
    }
}

impl FieldValue for RayBuffer {
    type Raw = RayBuffer;

    fn to_raw(self) -> RayBuffer {
        self
    }

    fn from_raw(_: &str, raw: RayBuffer, _: Option<Range>) -> Result<RayBuffer, ConfigError> {
        Ok(raw)
    }

    fn toml_value(raw: RayBuffer) -> String {
        format!("\"{}\"", raw.name())
    }
}

/// Expands the field table into the [`PipelineConfig`](super::PipelineConfig)
/// struct, its `Default`, the TOML comments (`FIELD_DOCS`), `formats()`,
/// the private serde shape `RawConfig` with both conversions, and
/// `check_fields()`, which runs each field's check in table order.
///
/// Each entry is
///
/// ```text
/// /// rustdoc of the field
/// pub name: Type {
///     default: expression,
///     range: lo..=hi,          // integers only, optional
///     toml: "one-line comment above the key in a dump",
///     check: rule_function,    // optional
/// },
/// ```
///
/// where `Type` implements [`FieldValue`] and `rule_function` has the
/// signature `fn(&PipelineConfig, &str, Type) -> Result<(), ConfigError>`
/// (the whole config for cross-field rules, the field's name, its value).
macro_rules! config_fields {
    // The table gathered from its groups (`fields/*.rs`): each group's
    // macro appends its entries to the list in brackets and hands it back
    // with the groups still to come; the last expands the whole table.
    (@gather [$($entries:tt)*] [$group:ident $(, $rest:ident)*] $($head:tt)*) => {
        $group! { @gather [$($entries)*] [$($rest),*] $($head)* }
    };
    (@gather [$($entries:tt)*] [] $(#[$struct_meta:meta])* pub struct PipelineConfig;) => {
        $crate::config::schema::config_fields! {
            $(#[$struct_meta])*
            pub struct PipelineConfig { $($entries)* }
        }
    };
    (
        $(#[$struct_meta:meta])*
        pub struct PipelineConfig {
            $(
                $(#[$field_meta:meta])*
                pub $field:ident : $ty:ty {
                    default: $default:expr,
                    $(range: $lo:literal ..= $hi:tt,)?
                    toml: $toml:literal,
                    $(check: $check:path,)?
                }
            ),* $(,)?
        }
    ) => {
        $(#[$struct_meta])*
        #[derive(Debug, Clone, Copy, PartialEq, ::serde::Serialize, ::serde::Deserialize)]
        #[serde(try_from = "RawConfig", into = "RawConfig")]
        pub struct PipelineConfig {
            $(
                $(#[$field_meta])*
                pub $field: $ty,
            )*
        }

        impl Default for PipelineConfig {
            fn default() -> Self {
                PipelineConfig {
                    $($field: $default,)*
                }
            }
        }

        /// How many fields the table has.
        pub(super) const FIELD_COUNT: usize = [$(stringify!($field)),*].len();

        /// How many fields are register formats.
        pub(super) const FORMAT_COUNT: usize =
            0 $(+ <$ty as $crate::config::schema::FieldValue>::IS_FORMAT as usize)*;

        /// One-line descriptions written above each key by
        /// [`PipelineConfig::to_toml`].
        pub(super) const FIELD_DOCS: [(&str, &str); FIELD_COUNT] =
            [$((stringify!($field), $toml)),*];

        /// Every field's name and whether it is a register format, in
        /// table order ([`super::FormatId`] numbers the formats by it).
        pub(super) const FIELD_KINDS: [(&str, bool); FIELD_COUNT] =
            [$((stringify!($field), <$ty as $crate::config::schema::FieldValue>::IS_FORMAT)),*];

        impl PipelineConfig {
            /// Every register format with its field name, in declaration order.
            pub fn formats(&self) -> [(&'static str, $crate::fixed::Format); FORMAT_COUNT] {
                use $crate::config::schema::FieldValue;
                let mut named = [$((stringify!($field), self.$field.as_format())),*]
                    .into_iter()
                    .filter_map(|(name, format)| Some((name, format?)));
                std::array::from_fn(|_| match named.next() {
                    Some(entry) => entry,
                    // FORMAT_COUNT counts exactly the entries that yield one.
                    None => unreachable!("FORMAT_COUNT disagrees with the field table"),
                })
            }

            /// Runs every field's check in table order, returning the first
            /// failure.
            pub(super) fn check_fields(&self) -> Result<(), $crate::config::ConfigError> {
                $($( $check(self, stringify!($field), self.$field)?; )?)*
                Ok(())
            }
        }

        /// The unvalidated TOML/JSON shape of [`PipelineConfig`]: each
        /// field in its `FieldValue::Raw` form, so out-of-range values are
        /// reported as written.
        #[derive(Debug, Clone, Copy, ::serde::Serialize, ::serde::Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub(super) struct RawConfig {
            $($field: <$ty as $crate::config::schema::FieldValue>::Raw,)*
        }

        impl RawConfig {
            /// The right-hand side of each key in a TOML dump, in table
            /// order (the order of [`FIELD_DOCS`]).
            pub(super) fn toml_values(&self) -> [String; FIELD_COUNT] {
                [$(<$ty as $crate::config::schema::FieldValue>::toml_value(self.$field)),*]
            }
        }

        impl Default for RawConfig {
            fn default() -> Self {
                PipelineConfig::default().into()
            }
        }

        impl From<PipelineConfig> for RawConfig {
            fn from(c: PipelineConfig) -> RawConfig {
                use $crate::config::schema::FieldValue;
                RawConfig {
                    $($field: c.$field.to_raw(),)*
                }
            }
        }

        impl TryFrom<RawConfig> for PipelineConfig {
            type Error = $crate::config::ConfigError;

            /// Converts field by field in table order (the first field that
            /// does not fit its type is the error), then validates.
            fn try_from(r: RawConfig) -> Result<PipelineConfig, $crate::config::ConfigError> {
                let config = PipelineConfig {
                    $($field: <$ty as $crate::config::schema::FieldValue>::from_raw(
                        stringify!($field),
                        r.$field,
                        $crate::config::schema::config_fields!(@range $($lo, $hi)?),
                    )?,)*
                };
                config.validate()?;
                Ok(config)
            }
        }
    };
    (@range) => {
        None
    };
    (@range $lo:literal, $hi:tt) => {
        Some($crate::config::schema::Range {
            lo: $lo,
            hi: i64::from($hi),
        })
    };
}

pub(super) use config_fields;

/// A default format of the field table. Only the table's literals reach
/// it.
pub(super) fn default_format(
    bits: u8,
    frac: u8,
    signed: bool,
    quant: Quant,
    overflow: Overflow,
) -> Format {
    match Format::new(bits, frac, signed, quant, overflow) {
        Ok(f) => f,
        // The defaults are literals inside the valid range; the test
        // `default_validates` builds every one of them.
        Err(e) => unreachable!("invalid default format: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use crate::config::testing::{error_for, spec};

    #[test]
    fn format_errors_name_the_field() {
        let e = error_for("alpha", &spec(16, 20, false));
        assert_eq!(e.field(), Some("alpha"));
        assert_eq!(e.to_string(), "alpha.frac = 20 exceeds alpha.bits = 16");
        let e = error_for("merge", &spec(0, 0, false));
        assert_eq!(e.to_string(), "merge.bits = 0 is outside 1..=63");
        let e = error_for("position", &spec(64, 16, true));
        assert_eq!(e.to_string(), "position.bits = 64 is outside 1..=63");
        let e = error_for("color", &spec(8, -1, false));
        assert_eq!(
            e.to_string(),
            "color.frac = -1 is negative; only 0 <= frac <= bits is supported"
        );
    }

    #[test]
    fn integer_errors_name_the_field() {
        assert_eq!(
            error_for("pes", "0").to_string(),
            "pes = 0 is outside 1..=256"
        );
        assert_eq!(
            error_for("pes", "257").to_string(),
            "pes = 257 is outside 1..=256"
        );
        assert_eq!(
            error_for("pes", "-3").to_string(),
            "pes = -3 is outside 1..=256"
        );
        assert_eq!(
            error_for("pes", "70000").to_string(),
            "pes = 70000 is outside 1..=256"
        );
        assert_eq!(
            error_for("table_entries", "1000").to_string(),
            "table_entries = 1000 is not a power of two in 2..=65536"
        );
        assert_eq!(
            error_for("table_entries", "-1").to_string(),
            "table_entries = -1 is outside 2..=65536"
        );
        for value in ["0", "17", "-1", "300"] {
            let e = error_for("exp_table_bits", value);
            assert_eq!(e.field(), Some("exp_table_bits"));
            assert_eq!(
                e.to_string(),
                format!("exp_table_bits = {value} is outside 1..=16")
            );
        }
        // The removed slope table is an unknown key now.
        let e = error_for("opacity_slope_bits", "6");
        assert!(
            e.to_string().contains("unknown field `opacity_slope_bits`"),
            "{e}"
        );
    }
}
