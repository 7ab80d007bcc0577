//! [`Word64`]: an exact intermediate in one 64-bit word, for the
//! datapath's hot expressions.

use super::value::{Fx, Wide};

/// An exact intermediate `raw * 2^-frac` in an `i64`: the same values as
/// [`Wide`] where they fit, every operation checked, `None` where it does
/// not fit (the caller then evaluates the expression in [`Wide`]). Exact
/// integer arithmetic does not depend on the word it runs in, so a
/// [`Word64`] result converts to the very [`Wide`] (raw word and fraction)
/// the 128-bit path computes; the model is the same, only faster.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Word64 {
    raw: i64,
    frac: i32,
}

impl Word64 {
    /// A stored value's raw word and fraction.
    #[inline(always)]
    pub fn of(x: Fx) -> Word64 {
        Word64 {
            raw: x.raw(),
            frac: i32::from(x.format().frac()),
        }
    }

    /// An integer.
    #[inline(always)]
    pub fn int(v: i64) -> Word64 {
        Word64 { raw: v, frac: 0 }
    }

    /// Both words at the larger fraction, if they fit.
    #[inline(always)]
    fn aligned(self, rhs: Word64) -> Option<(i64, i64, i32)> {
        let f = self.frac.max(rhs.frac);
        let up = |x: i64, s: i32| {
            // s >= 0; the shift is exact iff shifting back recovers x.
            let s = u32::try_from(s).ok().filter(|&s| s < 63)?;
            let y = x << s;
            (y >> s == x).then_some(y)
        };
        Some((up(self.raw, f - self.frac)?, up(rhs.raw, f - rhs.frac)?, f))
    }

    /// Exact sum, if it fits.
    #[inline(always)]
    pub fn checked_add(self, rhs: Word64) -> Option<Word64> {
        let (a, b, frac) = self.aligned(rhs)?;
        Some(Word64 {
            raw: a.checked_add(b)?,
            frac,
        })
    }

    /// Exact difference, if it fits.
    #[inline(always)]
    pub fn checked_sub(self, rhs: Word64) -> Option<Word64> {
        let (a, b, frac) = self.aligned(rhs)?;
        Some(Word64 {
            raw: a.checked_sub(b)?,
            frac,
        })
    }

    /// Exact product, if it fits.
    #[inline(always)]
    pub fn checked_mul(self, rhs: Word64) -> Option<Word64> {
        Some(Word64 {
            raw: self.raw.checked_mul(rhs.raw)?,
            frac: self.frac.checked_add(rhs.frac)?,
        })
    }
}

impl From<Word64> for Wide {
    #[inline(always)]
    fn from(w: Word64) -> Wide {
        Wide::new(i128::from(w.raw), w.frac)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::Format;
    use proptest::prelude::*;

    fn fx(raw: i64, bits: u8, frac: u8) -> Fx {
        let f = Format::signed(bits, frac.min(bits)).unwrap();
        let raw = raw.clamp(f.min_raw(), f.max_raw());
        Fx::from_raw(raw, f).unwrap()
    }

    proptest! {
        /// Where a Word64 result exists it is the Wide result, word and
        /// fraction; where it does not, the exact value leaves i64.
        #[test]
        fn word64_agrees_with_wide(
            ra in any::<i64>(), rb in any::<i64>(),
            ba in 1u8..=63, bb in 1u8..=63, fa in 0u8..=63, fb in 0u8..=63,
        ) {
            let (a, b) = (fx(ra, ba, fa), fx(rb, bb, fb));
            let (wa, wb) = (Word64::of(a), Word64::of(b));
            // Whether both operands, aligned to the larger fraction, fit
            // an i64 (with a shift below 63): what add and sub need.
            let f = fa.min(ba).max(fb.min(bb));
            let fits = |x: Fx| {
                let s = f - x.format().frac();
                s < 63 && i64::try_from(i128::from(x.raw()) << s).is_ok()
            };
            let aligned = fits(a) && fits(b);
            for (got, want, needs_aligned) in [
                (wa.checked_add(wb), a + b, true),
                (wa.checked_sub(wb), a - b, true),
                (wa.checked_mul(wb), a * b, false),
            ] {
                match got {
                    Some(w) => prop_assert_eq!(Wide::from(w), want),
                    // Refused only where an operand or the result leaves i64.
                    None => prop_assert!(
                        i64::try_from(want.raw).is_err() || (needs_aligned && !aligned)
                    ),
                }
            }
        }
    }
}
