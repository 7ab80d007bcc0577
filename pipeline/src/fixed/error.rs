//! Error types of the fixed-point layer.

use super::format::{Format, MAX_BITS};
use thiserror::Error;

/// Why a set of format parameters does not describe a supported format.
///
/// Parameters are carried as `i64` so that a value read from a config file
/// (possibly negative or huge) is reported as written rather than as a
/// truncated integer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum FormatError {
    /// The width is zero, negative or above [`MAX_BITS`].
    #[error("bits = {bits} is outside 1..={max}", max = MAX_BITS)]
    BitsOutOfRange {
        /// The width as given.
        bits: i64,
    },
    /// A negative number of fraction bits (an `ap_fixed` with more integer
    /// bits than total bits), which this model does not support.
    #[error("frac = {frac} is negative; only 0 <= frac <= bits is supported")]
    FracNegative {
        /// The fraction count as given.
        frac: i64,
    },
    /// More fraction bits than total bits (a binary point left of the MSB),
    /// which this model does not support.
    #[error("frac = {frac} exceeds bits = {bits}")]
    FracExceedsBits {
        /// The fraction count as given.
        frac: i64,
        /// The width as given.
        bits: i64,
    },
}

impl FormatError {
    /// Renders the error with every parameter prefixed by `field.`, e.g.
    /// `alpha.frac = 20 exceeds alpha.bits = 16`, so a config error names
    /// the offending entry on one line.
    pub fn describe(&self, field: &str) -> String {
        match *self {
            FormatError::BitsOutOfRange { bits } => {
                format!("{field}.bits = {bits} is outside 1..={MAX_BITS}")
            }
            FormatError::FracNegative { frac } => {
                format!("{field}.frac = {frac} is negative; only 0 <= frac <= bits is supported")
            }
            FormatError::FracExceedsBits { frac, bits } => {
                format!("{field}.frac = {frac} exceeds {field}.bits = {bits}")
            }
        }
    }
}

/// Errors of fixed-point operations.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FxError {
    /// Invalid format parameters.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// A NaN or infinite real cannot be quantised: hardware has no encoding
    /// for it, and silently mapping it to a number would hide a bug upstream.
    #[error("cannot quantise non-finite value {value}")]
    NotFinite {
        /// The offending value.
        value: f64,
    },
    /// A raw word outside the range of its format.
    #[error("raw word {raw} does not fit {format}")]
    RawOutOfRange {
        /// The raw word as given.
        raw: i64,
        /// The format it was meant for.
        format: Format,
    },
    /// An exact intermediate of a [`Wide`](super::Wide) chain does not fit
    /// `i128` (or its fraction exponent does not fit `i32`).
    #[error("exact intermediate of {op} does not fit 128 bits")]
    WideOverflow {
        /// The operation that overflowed.
        op: &'static str,
    },
    /// A value of another layout was given where a packed layout was fixed.
    #[error("value of format {found} where {expected} was expected")]
    FormatMismatch {
        /// The layout of the packed array.
        expected: Format,
        /// The format of the offending value.
        found: Format,
    },
    /// A bit slice whose length is not a whole number of values.
    #[error("{len} bits is not a multiple of the {width}-bit value width")]
    PackLength {
        /// Length of the bit slice.
        len: usize,
        /// Width of one value.
        width: u8,
    },
}
