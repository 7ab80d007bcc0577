//! Stored values ([`Fx`]) and exact intermediates ([`Wide`]).

use super::error::FxError;
use super::format::Format;
use std::cmp::Ordering;
use std::fmt;
use std::ops::{Add, Mul, Neg, Shl, Shr, Sub};

/// A value stored in a register of a given [`Format`]: `raw * 2^-frac`.
///
/// Invariant: `format.min_raw() <= raw <= format.max_raw()`.
///
/// The operators `+`, `-`, `*`, unary `-`, `<< n` and `>> n` are full
/// precision and return a [`Wide`]; assign the result into a format with
/// [`Format::quantize`] or [`Format::assign`]. They never overflow: see the
/// module documentation for the bound.
///
/// `==` compares raw word *and* format; compare values across formats with
/// [`Fx::cmp_value`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Fx {
    raw: i64,
    format: Format,
}

impl Fx {
    /// A value from its raw word, which must be in range for `format`.
    pub fn from_raw(raw: i64, format: Format) -> Result<Fx, FxError> {
        if raw < format.min_raw() || raw > format.max_raw() {
            return Err(FxError::RawOutOfRange { raw, format });
        }
        Ok(Fx { raw, format })
    }

    /// For callers that have just established the range invariant.
    #[inline]
    pub(crate) fn from_raw_unchecked(raw: i64, format: Format) -> Fx {
        debug_assert!(raw >= format.min_raw() && raw <= format.max_raw());
        Fx { raw, format }
    }

    /// A value from the low `format.bits()` bits of `bits` (two's complement
    /// if the format is signed); higher bits are ignored, as when a memory
    /// word is sliced into fields.
    pub fn from_bits(bits: u64, format: Format) -> Fx {
        let width = u32::from(format.bits());
        let up = 64 - width; // width is 1..=63
        let low = bits & (u64::MAX >> up);
        let raw = if format.is_signed() {
            ((low << up) as i64) >> up
        } else {
            // width <= 63 so low < 2^63.
            low as i64
        };
        Fx { raw, format }
    }

    /// The value's word as stored: the low `bits` bits of the raw word in
    /// two's complement, higher bits zero.
    pub fn to_bits(self) -> u64 {
        (self.raw as u64) & (u64::MAX >> (64 - u32::from(self.format.bits())))
    }

    /// The raw word (`value * 2^frac`).
    #[inline]
    pub fn raw(self) -> i64 {
        self.raw
    }

    /// The format the value is stored in.
    #[inline]
    pub fn format(self) -> Format {
        self.format
    }

    /// The value as a [`Wide`] with the same raw word and fraction.
    #[inline]
    pub fn wide(self) -> Wide {
        Wide::new(i128::from(self.raw), i32::from(self.format.frac()))
    }

    /// The value as `f64`: exact when `bits <= 53`, otherwise the raw word
    /// is rounded to nearest (ties to even) by the integer-to-float cast.
    #[inline]
    pub fn to_f64(self) -> f64 {
        self.raw as f64 * self.format.lsb()
    }

    /// The integer part, rounded toward −∞ (`floor`): the address bits of
    /// a position.
    #[inline]
    pub fn int_part(self) -> i64 {
        self.raw >> self.format.frac()
    }

    /// The fraction bits as an unsigned integer in `0..2^frac`: the
    /// interpolation weight bits of a position (`value - floor(value)` in
    /// units of the LSB).
    #[inline]
    pub fn frac_part(self) -> u64 {
        let f = u32::from(self.format.frac());
        if f == 0 {
            0
        } else {
            (self.raw as u64) & (u64::MAX >> (64 - f))
        }
    }

    /// Exact comparison of values, whatever their formats.
    pub fn cmp_value(self, other: Fx) -> Ordering {
        self.wide().cmp_value(other.wide())
    }

    /// Whether the value is exactly zero.
    pub fn is_zero(self) -> bool {
        self.raw == 0
    }
}

impl fmt::Display for Fx {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.to_f64())
    }
}

impl From<Fx> for Wide {
    fn from(x: Fx) -> Wide {
        x.wide()
    }
}

/// Raw words of two [`Fx`] aligned to the larger fraction.
///
/// Cannot overflow: both raw words are below `2^63` in magnitude and the
/// shift is at most 63 (fractions are `0..=63`), so each result is below
/// `2^126`.
#[inline]
fn align(a: Fx, b: Fx) -> (i128, i128, i32) {
    let fa = a.format.frac();
    let fb = b.format.frac();
    let f = fa.max(fb);
    (
        i128::from(a.raw) << (f - fa),
        i128::from(b.raw) << (f - fb),
        i32::from(f),
    )
}

/// `format.frac() + offset`. Callers pass offsets of magnitude at most
/// 65535 and fractions are at most 63, so the sum cannot overflow `i32`.
#[inline]
fn offset_frac(format: Format, offset: i32) -> i32 {
    i32::from(format.frac()) + offset
}

impl Add for Fx {
    type Output = Wide;
    /// Exact sum. Aligned operands are below `2^126` (see `align`), so the
    /// sum is below `2^127` and `wrapping_add` never wraps.
    #[inline]
    fn add(self, rhs: Fx) -> Wide {
        let (a, b, f) = align(self, rhs);
        Wide::new(a.wrapping_add(b), f)
    }
}

impl Sub for Fx {
    type Output = Wide;
    /// Exact difference; bounded like [`Add`].
    #[inline]
    fn sub(self, rhs: Fx) -> Wide {
        let (a, b, f) = align(self, rhs);
        Wide::new(a.wrapping_sub(b), f)
    }
}

impl Mul for Fx {
    type Output = Wide;
    /// Exact product with fraction `fa + fb`. Factors are at most `2^63` in
    /// magnitude, so the product is at most `2^126` and `wrapping_mul` never
    /// wraps.
    #[inline]
    fn mul(self, rhs: Fx) -> Wide {
        let frac = offset_frac(self.format, i32::from(rhs.format.frac()));
        Wide::new(i128::from(self.raw).wrapping_mul(i128::from(rhs.raw)), frac)
    }
}

impl Neg for Fx {
    type Output = Wide;
    /// Exact negation (`-min` of a signed format needs one more bit, which
    /// the `i128` has).
    fn neg(self) -> Wide {
        Wide::new(-i128::from(self.raw), i32::from(self.format.frac()))
    }
}

impl Shl<u16> for Fx {
    type Output = Wide;
    /// Exact `value * 2^n`: only the fraction exponent changes, which stays
    /// inside `i32` because `frac <= 63` and `n <= 65535`. Quantise into
    /// the operand's own format with `TRN`/`WRAP` to get `ap_fixed`'s `<<`.
    fn shl(self, n: u16) -> Wide {
        Wide::new(
            i128::from(self.raw),
            offset_frac(self.format, -i32::from(n)),
        )
    }
}

impl Shr<u16> for Fx {
    type Output = Wide;
    /// Exact `value * 2^-n`, like [`Shl`]. Quantise into the operand's own
    /// format with `TRN` to get `ap_fixed`'s arithmetic `>>`.
    fn shr(self, n: u16) -> Wide {
        Wide::new(i128::from(self.raw), offset_frac(self.format, i32::from(n)))
    }
}

/// An exact intermediate: `raw * 2^-frac`, the "full precision" type of an
/// HLS expression before it is assigned into a register.
///
/// `frac` may be negative, so scaling by powers of two is exact and free.
/// Operations on `Wide` values are checked, because chained products can
/// outgrow 128 bits; operations on two [`Fx`] values never do.
///
/// `==` is structural (`1·2^0` and `2·2^-1` differ); use
/// [`Wide::cmp_value`] to compare values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Wide {
    /// The integer word.
    pub raw: i128,
    /// The power of two dividing `raw`.
    pub frac: i32,
}

/// `x * 2^s`, or `None` if the exact product does not fit `i128`.
#[inline]
fn checked_scale(x: i128, s: u64) -> Option<i128> {
    if x == 0 || s == 0 {
        return Some(x);
    }
    if s >= 127 {
        return None;
    }
    let y = x << s;
    (y >> s == x).then_some(y)
}

impl Wide {
    /// A value `raw * 2^-frac`.
    #[inline]
    pub fn new(raw: i128, frac: i32) -> Wide {
        Wide { raw, frac }
    }

    /// The exact value of a finite `f64`, as its 53-bit significand times a
    /// power of two.
    pub fn from_f64(x: f64) -> Result<Wide, FxError> {
        if !x.is_finite() {
            return Err(FxError::NotFinite { value: x });
        }
        let bits = x.to_bits();
        let biased = ((bits >> 52) & 0x7ff) as i32;
        let fraction = bits & ((1u64 << 52) - 1);
        let (significand, exp) = if biased == 0 {
            // Subnormal (or zero): no implicit leading one.
            (fraction, -1074)
        } else {
            (fraction | (1u64 << 52), biased - 1075)
        };
        let magnitude = i128::from(significand);
        let raw = if x.is_sign_negative() {
            -magnitude
        } else {
            magnitude
        };
        // exp is in -1074..=971, so -exp fits i32.
        Ok(Wide::new(raw, -exp))
    }

    /// Approximate value: the raw word is rounded to 53 bits and the result
    /// can under- or overflow `f64` for extreme exponents.
    #[inline]
    pub fn to_f64(self) -> f64 {
        // |raw| < 2^127, so beyond 2^±1300 the result is 0 or infinite
        // anyway; clamping keeps the exponent halves inside powi's range.
        let e = (-i64::from(self.frac)).clamp(-1300, 1300) as i32;
        let half = e / 2;
        // Two factors so that neither leaves f64's range on its own.
        self.raw as f64 * f64::powi(2.0, half) * f64::powi(2.0, e - half)
    }

    /// Both raw words at the larger fraction, or `None` if that does not fit.
    #[inline(always)]
    fn aligned(self, rhs: Wide) -> Option<(i128, i128, i32)> {
        let f = self.frac.max(rhs.frac);
        // Words below 2^63 shifted by less than 64 stay below 2^127: no
        // check needed (the datapath's common case).
        let (da, db) = (
            i64::from(f) - i64::from(self.frac),
            i64::from(f) - i64::from(rhs.frac),
        );
        if da < 64 && db < 64 && i64::try_from(self.raw).is_ok() && i64::try_from(rhs.raw).is_ok() {
            return Some((self.raw << da, rhs.raw << db, f));
        }
        // f >= each frac and both are i32, so the differences fit u64.
        let a = checked_scale(self.raw, (i64::from(f) - i64::from(self.frac)) as u64)?;
        let b = checked_scale(rhs.raw, (i64::from(f) - i64::from(rhs.frac)) as u64)?;
        Some((a, b, f))
    }

    /// Exact sum, or [`FxError::WideOverflow`].
    #[inline(always)]
    pub fn checked_add(self, rhs: impl Into<Wide>) -> Result<Wide, FxError> {
        let rhs = rhs.into();
        self.aligned(rhs)
            .and_then(|(a, b, f)| Some(Wide::new(a.checked_add(b)?, f)))
            .ok_or(FxError::WideOverflow { op: "add" })
    }

    /// Exact difference, or [`FxError::WideOverflow`].
    #[inline(always)]
    pub fn checked_sub(self, rhs: impl Into<Wide>) -> Result<Wide, FxError> {
        let rhs = rhs.into();
        self.aligned(rhs)
            .and_then(|(a, b, f)| Some(Wide::new(a.checked_sub(b)?, f)))
            .ok_or(FxError::WideOverflow { op: "sub" })
    }

    /// Exact product, or [`FxError::WideOverflow`].
    #[inline(always)]
    pub fn checked_mul(self, rhs: impl Into<Wide>) -> Result<Wide, FxError> {
        let rhs = rhs.into();
        // Two words below 2^63 multiply to below 2^126: no check needed.
        if let (Ok(a), Ok(b), Some(frac)) = (
            i64::try_from(self.raw),
            i64::try_from(rhs.raw),
            self.frac.checked_add(rhs.frac),
        ) {
            return Ok(Wide::new(i128::from(a) * i128::from(b), frac));
        }
        match (
            self.raw.checked_mul(rhs.raw),
            self.frac.checked_add(rhs.frac),
        ) {
            (Some(raw), Some(frac)) => Ok(Wide::new(raw, frac)),
            _ => Err(FxError::WideOverflow { op: "mul" }),
        }
    }

    /// Exact negation, or [`FxError::WideOverflow`] for `i128::MIN`.
    pub fn checked_neg(self) -> Result<Wide, FxError> {
        self.raw
            .checked_neg()
            .map(|raw| Wide::new(raw, self.frac))
            .ok_or(FxError::WideOverflow { op: "neg" })
    }

    /// Exact `value * 2^n`, or [`FxError::WideOverflow`] if the exponent
    /// leaves `i32`.
    pub fn checked_shl(self, n: u32) -> Result<Wide, FxError> {
        i32::try_from(i64::from(self.frac) - i64::from(n))
            .map(|frac| Wide::new(self.raw, frac))
            .map_err(|_| FxError::WideOverflow { op: "shl" })
    }

    /// Exact `value * 2^-n`, or [`FxError::WideOverflow`] if the exponent
    /// leaves `i32`.
    pub fn checked_shr(self, n: u32) -> Result<Wide, FxError> {
        i32::try_from(i64::from(self.frac) + i64::from(n))
            .map(|frac| Wide::new(self.raw, frac))
            .map_err(|_| FxError::WideOverflow { op: "shr" })
    }

    /// Exact comparison of values, never overflowing.
    pub fn cmp_value(self, other: Wide) -> Ordering {
        if let Some((a, b, _)) = self.aligned(other) {
            return a.cmp(&b);
        }
        // The operand that had to be scaled up is nonzero and, once scaled,
        // larger in magnitude than anything in i128, so its sign decides.
        if self.frac < other.frac {
            if self.raw < 0 {
                Ordering::Less
            } else {
                Ordering::Greater
            }
        } else if other.raw < 0 {
            Ordering::Greater
        } else {
            Ordering::Less
        }
    }
}
