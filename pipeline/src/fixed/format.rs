//! Fixed-point formats and their quantisation and overflow modes.

use super::error::FormatError;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Widest supported word. 63 rather than 64 so that any sum, difference or
/// product of two [`Fx`](super::Fx) values is exact in `i128` (see the
/// module documentation).
pub const MAX_BITS: u8 = 63;

/// Quantisation (rounding) mode, applied when fraction bits are dropped.
///
/// The names and definitions are those of `ap_fixed` (`AP_TRN`, ...) and
/// `ac_fixed`. With `q` the value truncated toward −∞ at the target LSB,
/// `qb` the most significant dropped bit, `r` the OR of the other dropped
/// bits and `neg` the sign of the source value, the result is `q + 1` when:
///
/// | mode | adds one when | meaning |
/// |------|---------------|---------|
/// | `TRN` | never | truncate toward −∞ (floor) |
/// | `TRN_ZERO` | `neg && (qb \|\| r)` | truncate toward zero |
/// | `RND` | `qb` | nearest, ties toward +∞ |
/// | `RND_ZERO` | `qb && (neg \|\| r)` | nearest, ties toward zero |
/// | `RND_MIN_INF` | `qb && r` | nearest, ties toward −∞ |
/// | `RND_INF` | `qb && (!neg \|\| r)` | nearest, ties away from zero |
/// | `RND_CONV` | `qb && (lsb(q) \|\| r)` | nearest, ties to even |
///
/// Note that `RND_ZERO` is round-to-*nearest* with ties toward zero; plain
/// rounding toward zero is `TRN_ZERO`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum Quant {
    /// Truncate toward −∞ (`AP_TRN`, the `ap_fixed` default): free in
    /// hardware, it just drops wires.
    #[default]
    #[serde(rename = "TRN")]
    Trn,
    /// Truncate toward zero (`AP_TRN_ZERO`).
    #[serde(rename = "TRN_ZERO")]
    TrnZero,
    /// Round to nearest, ties toward +∞ (`AP_RND`): one half-LSB adder.
    #[serde(rename = "RND")]
    Rnd,
    /// Round to nearest, ties toward zero (`AP_RND_ZERO`).
    #[serde(rename = "RND_ZERO")]
    RndZero,
    /// Round to nearest, ties toward −∞ (`AP_RND_MIN_INF`).
    #[serde(rename = "RND_MIN_INF")]
    RndMinInf,
    /// Round to nearest, ties away from zero (`AP_RND_INF`).
    #[serde(rename = "RND_INF")]
    RndInf,
    /// Round to nearest, ties to even (`AP_RND_CONV`, convergent): unbiased.
    #[serde(rename = "RND_CONV")]
    RndConv,
}

impl Quant {
    /// Every mode, for tests and tools that iterate over them.
    pub const ALL: [Quant; 7] = [
        Quant::Trn,
        Quant::TrnZero,
        Quant::Rnd,
        Quant::RndZero,
        Quant::RndMinInf,
        Quant::RndInf,
        Quant::RndConv,
    ];

    /// The `ap_fixed` spelling without the `AP_` prefix, as used in TOML.
    pub fn name(self) -> &'static str {
        match self {
            Quant::Trn => "TRN",
            Quant::TrnZero => "TRN_ZERO",
            Quant::Rnd => "RND",
            Quant::RndZero => "RND_ZERO",
            Quant::RndMinInf => "RND_MIN_INF",
            Quant::RndInf => "RND_INF",
            Quant::RndConv => "RND_CONV",
        }
    }
}

/// Overflow mode, applied after rounding when the value does not fit the
/// integer part.
///
/// | mode | result when above max | result when below min |
/// |------|-----------------------|-----------------------|
/// | `WRAP` | low `bits` bits, two's complement | same |
/// | `SAT` | max | min |
/// | `SAT_ZERO` | 0 | 0 |
/// | `SAT_SYM` | max | −max for signed formats, 0 for unsigned |
///
/// `SAT_SYM` follows `ap_fixed`: for a signed format the most negative code
/// is never produced, so an exact result equal to `min` also becomes `−max`
/// and counts as an overflow. `ap_fixed`'s `WRAP_SM` and the saturation-bit
/// count `N` are not modelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum Overflow {
    /// Keep the low bits (`AP_WRAP`, the `ap_fixed` default): free in
    /// hardware.
    #[default]
    #[serde(rename = "WRAP")]
    Wrap,
    /// Clamp to the nearest representable value (`AP_SAT`).
    #[serde(rename = "SAT")]
    Sat,
    /// Replace any out-of-range value by zero (`AP_SAT_ZERO`).
    #[serde(rename = "SAT_ZERO")]
    SatZero,
    /// Clamp to the symmetric range `[-max, max]` (`AP_SAT_SYM`).
    #[serde(rename = "SAT_SYM")]
    SatSym,
}

impl Overflow {
    /// Every mode, for tests and tools that iterate over them.
    pub const ALL: [Overflow; 4] = [
        Overflow::Wrap,
        Overflow::Sat,
        Overflow::SatZero,
        Overflow::SatSym,
    ];

    /// The `ap_fixed` spelling without the `AP_` prefix, as used in TOML.
    pub fn name(self) -> &'static str {
        match self {
            Overflow::Wrap => "WRAP",
            Overflow::Sat => "SAT",
            Overflow::SatZero => "SAT_ZERO",
            Overflow::SatSym => "SAT_SYM",
        }
    }
}

/// A validated fixed-point format: `bits` total bits of which `frac` are
/// fraction bits, two's complement if `signed`, and the modes applied when
/// a value is assigned into it.
///
/// Invariant (checked by [`Format::new`]): `1 <= bits <= MAX_BITS` and
/// `0 <= frac <= bits`. A signed format with `frac == bits` has no integer
/// bit besides the sign and holds `[-0.5, 0.5)`, as `FixedI16<U16>` does.
///
/// Serialises as a [`FormatSpec`] table, e.g.
/// `{ bits = 12, frac = 12, signed = false, quant = "RND", overflow = "SAT" }`,
/// and deserialisation validates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "FormatSpec", into = "FormatSpec")]
// Eight bytes, aligned: a format then copies as one word, so a value built
// in a register file and read back whole does not stall on five byte-wide
// stores (measured: a third of the datapath's time).
#[repr(C, align(8))]
pub struct Format {
    bits: u8,
    frac: u8,
    signed: bool,
    quant: Quant,
    overflow: Overflow,
}

impl Format {
    /// Validates and builds a format.
    pub fn new(
        bits: u8,
        frac: u8,
        signed: bool,
        quant: Quant,
        overflow: Overflow,
    ) -> Result<Format, FormatError> {
        FormatSpec {
            bits: i64::from(bits),
            frac: i64::from(frac),
            signed,
            quant,
            overflow,
        }
        .try_into()
    }

    /// A signed format with the `ap_fixed` default modes (`TRN`, `WRAP`).
    pub fn signed(bits: u8, frac: u8) -> Result<Format, FormatError> {
        Format::new(bits, frac, true, Quant::Trn, Overflow::Wrap)
    }

    /// An unsigned format with the `ap_fixed` default modes (`TRN`, `WRAP`).
    pub fn unsigned(bits: u8, frac: u8) -> Result<Format, FormatError> {
        Format::new(bits, frac, false, Quant::Trn, Overflow::Wrap)
    }

    /// The same layout with another quantisation mode.
    pub fn with_quant(self, quant: Quant) -> Format {
        Format { quant, ..self }
    }

    /// The same layout with another overflow mode.
    pub fn with_overflow(self, overflow: Overflow) -> Format {
        Format { overflow, ..self }
    }

    /// Total width in bits.
    pub fn bits(self) -> u8 {
        self.bits
    }

    /// Number of fraction bits.
    pub fn frac(self) -> u8 {
        self.frac
    }

    /// Number of integer bits including the sign bit (`ap_fixed`'s `I`).
    pub fn int_bits(self) -> u8 {
        // frac <= bits is an invariant, so this cannot underflow.
        self.bits.wrapping_sub(self.frac)
    }

    /// Whether values are two's complement.
    pub fn is_signed(self) -> bool {
        self.signed
    }

    /// Quantisation mode applied on assignment.
    pub fn quant(self) -> Quant {
        self.quant
    }

    /// Overflow mode applied on assignment.
    pub fn overflow(self) -> Overflow {
        self.overflow
    }

    /// Whether two formats store values identically (same width, fraction
    /// and signedness); the modes only matter when assigning.
    pub fn same_layout(self, other: Format) -> bool {
        self.bits == other.bits && self.frac == other.frac && self.signed == other.signed
    }

    /// Smallest raw word: `-2^(bits-1)` if signed, else 0.
    pub fn min_raw(self) -> i64 {
        if self.signed {
            // bits <= 63 so the shift is at most 62 and cannot overflow.
            -(1i64 << (self.bits - 1))
        } else {
            0
        }
    }

    /// Largest raw word: `2^(bits-1) - 1` if signed, else `2^bits - 1`.
    pub fn max_raw(self) -> i64 {
        let magnitude_bits = if self.signed {
            self.bits - 1
        } else {
            self.bits
        };
        // magnitude_bits <= 63; 1 << 63 would overflow i64, so go via u64.
        ((1u64 << magnitude_bits) - 1) as i64
    }

    /// Weight of the least significant bit, `2^-frac`.
    pub fn lsb(self) -> f64 {
        // Exact: frac <= 63 is far inside f64's exponent range.
        f64::powi(2.0, -i32::from(self.frac))
    }

    /// The parameters as a serialisable [`FormatSpec`].
    pub fn spec(self) -> FormatSpec {
        self.into()
    }
}

impl fmt::Display for Format {
    /// `ap_fixed`-style: `fixed<W,I,Q,O>` or `ufixed<W,I,Q,O>` with `I` the
    /// integer bits including the sign.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}fixed<{},{},{},{}>",
            if self.signed { "" } else { "u" },
            self.bits,
            self.int_bits(),
            self.quant.name(),
            self.overflow.name()
        )
    }
}

/// Unvalidated format parameters, the TOML/JSON form of a [`Format`].
///
/// `quant` and `overflow` may be omitted and then default to the
/// `ap_fixed` defaults `TRN` and `WRAP`. Unknown keys are rejected so a
/// misspelt mode key cannot silently fall back to a default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FormatSpec {
    /// Total width in bits, `1..=63`.
    pub bits: i64,
    /// Fraction bits, `0..=bits`.
    pub frac: i64,
    /// Two's complement if true.
    pub signed: bool,
    /// Quantisation mode.
    #[serde(default)]
    pub quant: Quant,
    /// Overflow mode.
    #[serde(default)]
    pub overflow: Overflow,
}

impl TryFrom<FormatSpec> for Format {
    type Error = FormatError;

    fn try_from(s: FormatSpec) -> Result<Format, FormatError> {
        if s.bits < 1 || s.bits > i64::from(MAX_BITS) {
            return Err(FormatError::BitsOutOfRange { bits: s.bits });
        }
        if s.frac < 0 {
            return Err(FormatError::FracNegative { frac: s.frac });
        }
        if s.frac > s.bits {
            return Err(FormatError::FracExceedsBits {
                frac: s.frac,
                bits: s.bits,
            });
        }
        // Both are now in 0..=63, so the narrowing casts are lossless.
        Ok(Format {
            bits: s.bits as u8,
            frac: s.frac as u8,
            signed: s.signed,
            quant: s.quant,
            overflow: s.overflow,
        })
    }
}

impl From<Format> for FormatSpec {
    fn from(f: Format) -> FormatSpec {
        FormatSpec {
            bits: i64::from(f.bits),
            frac: i64::from(f.frac),
            signed: f.signed,
            quant: f.quant,
            overflow: f.overflow,
        }
    }
}

impl fmt::Display for FormatSpec {
    /// The inline-table TOML form, so config dumps read like the input.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{{ bits = {}, frac = {}, signed = {}, quant = \"{}\", overflow = \"{}\" }}",
            self.bits,
            self.frac,
            self.signed,
            self.quant.name(),
            self.overflow.name()
        )
    }
}
