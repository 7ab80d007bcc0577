//! Assignment of an exact intermediate into a format: rounding, then
//! overflow handling, as in `ap_fixed_base`'s converting constructor.

use super::format::{Format, Overflow, Quant};
use super::value::{Fx, Wide};
use crate::config::FormatId;
use serde::{Deserialize, Serialize};

/// The result of assigning a [`Wide`] into a [`Format`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Quantized {
    /// The stored value.
    pub value: Fx,
    /// The rounded value did not fit and the overflow mode replaced it
    /// (including `SAT_SYM` turning the most negative code into `-max`).
    pub overflow: bool,
    /// Nonzero fraction bits were dropped, i.e. the quantisation mode had
    /// to decide something; the result may still be exact after
    /// saturation by coincidence, which is not tracked.
    pub inexact: bool,
}

/// Counters of assignment events, so the pipeline can report how often a
/// register saturated or rounded. Counters saturate at `u64::MAX` instead
/// of wrapping, so a report can never show fewer events than happened.
///
/// The totals are serialised; the per-format breakdown
/// ([`QuantStats::by_format`]) is reported by its users beside the
/// configuration's names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct QuantStats {
    /// Number of assignments recorded.
    pub assignments: u64,
    /// Assignments whose value overflowed (see [`Quantized::overflow`]).
    pub overflows: u64,
    /// Assignments that dropped nonzero fraction bits.
    pub inexact: u64,
    /// The same counts per register format, indexed by [`FormatId`].
    #[serde(skip)]
    pub by_format: FormatCounts,
}

/// One format's assignment events.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Counts {
    /// Number of assignments.
    pub assignments: u64,
    /// Assignments whose value overflowed.
    pub overflows: u64,
    /// Assignments that dropped nonzero fraction bits.
    pub inexact: u64,
}

impl Counts {
    /// Adds another set of counts, saturating.
    #[inline(always)]
    pub fn add(&mut self, o: &Counts) {
        self.assignments = self.assignments.saturating_add(o.assignments);
        self.overflows = self.overflows.saturating_add(o.overflows);
        self.inexact = self.inexact.saturating_add(o.inexact);
    }
}

/// [`Counts`] per register format, indexed by [`FormatId::index`]: a
/// fixed-size array, so counting allocates nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FormatCounts(pub [Counts; FormatId::COUNT]);

impl Default for FormatCounts {
    fn default() -> Self {
        FormatCounts([Counts::default(); FormatId::COUNT])
    }
}

impl FormatCounts {
    /// The counts of format `id`.
    pub fn get(&self, id: FormatId) -> &Counts {
        &self.0[id.index()]
    }

    /// Every format with its counts, in table order.
    pub fn iter(&self) -> impl Iterator<Item = (FormatId, &Counts)> {
        FormatId::all().zip(self.0.iter())
    }
}

impl QuantStats {
    /// Counts one assignment into a format that is no field of its own
    /// ([`FormatId::OTHER`]); the datapath's registers count through
    /// [`QuantStats::record_as`].
    #[inline]
    pub fn record(&mut self, q: &Quantized) {
        self.record_as(FormatId::OTHER, q);
    }

    /// Counts one assignment into register format `id`.
    #[inline(always)]
    pub fn record_as(&mut self, id: FormatId, q: &Quantized) {
        self.add_as(
            id,
            &Counts {
                assignments: 1,
                overflows: u64::from(q.overflow),
                inexact: u64::from(q.inexact),
            },
        );
    }

    /// Adds `c` to the totals and to format `id`'s counts.
    #[inline(always)]
    pub fn add_as(&mut self, id: FormatId, c: &Counts) {
        self.assignments = self.assignments.saturating_add(c.assignments);
        self.overflows = self.overflows.saturating_add(c.overflows);
        self.inexact = self.inexact.saturating_add(c.inexact);
        self.by_format.0[id.index()].add(c);
    }

    /// Adds another set of counters, e.g. from a worker thread.
    pub fn merge(&mut self, other: &QuantStats) {
        self.assignments = self.assignments.saturating_add(other.assignments);
        self.overflows = self.overflows.saturating_add(other.overflows);
        self.inexact = self.inexact.saturating_add(other.inexact);
        for (a, b) in self.by_format.0.iter_mut().zip(&other.by_format.0) {
            a.add(b);
        }
    }

    /// `k` times these counters (the events of `k` identical
    /// assignments), saturating.
    pub fn times(&self, k: u64) -> QuantStats {
        let m = |c: &Counts| Counts {
            assignments: c.assignments.saturating_mul(k),
            overflows: c.overflows.saturating_mul(k),
            inexact: c.inexact.saturating_mul(k),
        };
        let t = m(&Counts {
            assignments: self.assignments,
            overflows: self.overflows,
            inexact: self.inexact,
        });
        QuantStats {
            assignments: t.assignments,
            overflows: t.overflows,
            inexact: t.inexact,
            by_format: FormatCounts(self.by_format.0.map(|c| m(&c))),
        }
    }

    /// Overflows of formats whose overflow is no designed clamp
    /// ([`FormatId::clamps`]): range violations.
    pub fn harmful_overflows(&self) -> u64 {
        self.by_format
            .iter()
            .filter(|(id, _)| !id.clamps())
            .map(|(_, c)| c.overflows)
            .fold(0, u64::saturating_add)
    }
}

/// Bit `i` of `raw` in infinite two's complement: bits at and above 127
/// repeat the sign.
#[inline]
fn bit(raw: i128, i: u64) -> bool {
    if i >= 127 {
        raw < 0
    } else {
        (raw >> i) & 1 == 1
    }
}

/// Whether any of bits `0..n` of `raw` (infinite two's complement) is set.
#[inline]
fn any_below(raw: i128, n: u64) -> bool {
    if n == 0 {
        false
    } else if n >= 128 {
        // Bits 0..128 are all of the word; any higher bit copies the sign,
        // which is set only if some lower bit is.
        raw != 0
    } else {
        // 1 <= n <= 127: the mask is nonzero and the shift is in range.
        (raw as u128) & (u128::MAX >> (128 - n)) != 0
    }
}

/// `raw * 2^-k` rounded to an integer with `quant`, for `k >= 1`.
/// Returns the rounded integer and whether dropped bits were nonzero.
#[inline]
fn round_shift(raw: i128, k: u64, quant: Quant) -> (i128, bool) {
    let neg = raw < 0;
    let q = if k >= 127 {
        // |raw| < 2^127 so the floor of raw / 2^k is 0 or -1.
        if neg {
            -1
        } else {
            0
        }
    } else {
        raw >> k
    };
    let qb = bit(raw, k - 1);
    let r = any_below(raw, k - 1);
    let carry = match quant {
        Quant::Trn => false,
        Quant::TrnZero => neg && (qb || r),
        Quant::Rnd => qb,
        Quant::RndZero => qb && (neg || r),
        Quant::RndMinInf => qb && r,
        Quant::RndInf => qb && (!neg || r),
        Quant::RndConv => qb && (q & 1 == 1 || r),
    };
    // k >= 1 gives |q| <= 2^126, so adding one cannot overflow i128.
    (q.wrapping_add(i128::from(carry)), qb || r)
}

/// `raw * 2^s`. Returns the low 128 bits of the product and whether the
/// exact product fits `i128`.
#[inline]
fn shift_left(raw: i128, s: u64) -> (i128, bool) {
    if raw == 0 || s == 0 {
        return (raw, true);
    }
    if s >= 128 {
        return (0, false);
    }
    // s < 128, so wrapping_shl shifts by exactly s and keeps the low bits;
    // the product fits iff shifting back recovers raw.
    let shifted = raw.wrapping_shl(s as u32);
    (shifted, shifted >> s == raw)
}

/// Low `bits` bits of `v`, sign-extended when `signed` (`bits <= 63`).
#[inline]
fn wrap(v: i128, bits: u8, signed: bool) -> i64 {
    let low = (v as u128 as u64) & (u64::MAX >> (64 - u32::from(bits)));
    if signed {
        let up = 64 - u32::from(bits);
        ((low << up) as i64) >> up
    } else {
        // bits <= 63, so low < 2^63 and the cast is lossless.
        low as i64
    }
}

impl Format {
    /// Assigns an exact value into this format: rounds with
    /// [`quant`](Format::quant) if fraction bits are dropped, then applies
    /// [`overflow`](Format::overflow) if the rounded value is out of range.
    ///
    /// This is exact for every [`Wide`]: no intermediate step rounds.
    #[inline(always)]
    pub fn quantize(&self, w: Wide) -> Quantized {
        // i32 minus u8 in i64 cannot overflow.
        let k = i64::from(w.frac) - i64::from(self.frac());
        // Fast path for the datapath's common case, in 64-bit words: a
        // source that fits i64, at most 62 fraction bits dropped or added,
        // TRN or RND (or nothing dropped), the result in range. It computes
        // what the general path does for these cases; anything else takes
        // it.
        if let (Ok(raw), true) = (i64::try_from(w.raw), (-62..63).contains(&k)) {
            let q = match (k, self.quant()) {
                (0, _) => Some(raw),
                // Exact when shifting back recovers the word.
                (..0, _) => Some(raw << -k).filter(|v| v >> -k == raw),
                (_, Quant::Trn) => Some(raw >> k),
                // floor((raw / 2^(k-1) + 1) / 2) = floor(raw / 2^k + 1/2).
                (_, Quant::Rnd) => (raw >> (k - 1)).checked_add(1).map(|v| v >> 1),
                _ => None,
            };
            let max = self.max_raw();
            // SAT_SYM's lower limit is -max, not min_raw.
            let min = if self.overflow() == Overflow::SatSym && self.is_signed() {
                -max
            } else {
                self.min_raw()
            };
            if let Some(q) = q.filter(|q| (min..=max).contains(q)) {
                // Dropped bits: k in 1..63 keeps the mask exact in i64.
                let dropped = k > 0 && raw & ((1i64 << k) - 1) != 0;
                return Quantized {
                    value: Fx::from_raw_unchecked(q, *self),
                    overflow: false,
                    inexact: dropped,
                };
            }
        }
        self.quantize_general(w, k)
    }

    /// [`Format::quantize`] for every case: `k` is the number of fraction
    /// bits dropped (negative: added).
    #[cold]
    #[inline(never)]
    fn quantize_general(&self, w: Wide, k: i64) -> Quantized {
        let (v, fits, inexact) = if k > 0 {
            let (v, inexact) = round_shift(w.raw, k.unsigned_abs(), self.quant());
            (v, true, inexact)
        } else {
            let (v, fits) = shift_left(w.raw, k.unsigned_abs());
            (v, fits, false)
        };
        // A value too big for i128 has the sign of the source, since a left
        // shift of an exact value preserves sign.
        let neg = if fits { v < 0 } else { w.raw < 0 };
        let max = i128::from(self.max_raw());
        let min = if self.overflow() == Overflow::SatSym && self.is_signed() {
            -max
        } else {
            i128::from(self.min_raw())
        };
        let above = if fits { v > max } else { !neg };
        let below = if fits { v < min } else { neg };
        let raw = if !(above || below) {
            // min <= v <= max, which is inside i64.
            v as i64
        } else {
            match self.overflow() {
                Overflow::Wrap => wrap(v, self.bits(), self.is_signed()),
                Overflow::Sat | Overflow::SatSym => {
                    if above {
                        self.max_raw()
                    } else {
                        min as i64
                    }
                }
                Overflow::SatZero => 0,
            }
        };
        Quantized {
            value: Fx::from_raw_unchecked(raw, *self),
            overflow: above || below,
            inexact,
        }
    }

    /// [`quantize`](Format::quantize), recording the event in `stats`.
    #[inline(always)]
    pub fn assign(&self, w: impl Into<Wide>, stats: &mut QuantStats) -> Fx {
        let q = self.quantize(w.into());
        stats.record(&q);
        q.value
    }

    /// Quantises a real number exactly (no intermediate rounding through a
    /// narrower float), with this format's modes.
    pub fn from_f64(&self, x: f64) -> Result<Quantized, super::FxError> {
        Ok(self.quantize(Wide::from_f64(x)?))
    }

    /// Quantises an integer with this format's modes.
    pub fn from_int(&self, i: i64) -> Quantized {
        self.quantize(Wide::new(i128::from(i), 0))
    }

    /// The value zero.
    pub fn zero(&self) -> Fx {
        Fx::from_raw_unchecked(0, *self)
    }

    /// The smallest representable value.
    pub fn min_value(&self) -> Fx {
        Fx::from_raw_unchecked(self.min_raw(), *self)
    }

    /// The largest representable value.
    pub fn max_value(&self) -> Fx {
        Fx::from_raw_unchecked(self.max_raw(), *self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A source word of any magnitude: small ones make ties and carries
    /// common, large ones reach the edges of i64.
    fn words() -> impl Strategy<Value = i64> {
        prop_oneof![
            -300i64..300,
            any::<i64>(),
            (0u32..63).prop_map(|s| -(1i64 << s))
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// [`Format::quantize`] (its 64-bit fast path where that applies)
        /// gives what the general path gives, word, overflow and inexact
        /// flag, for every rounding and overflow mode and shift in both
        /// directions.
        #[test]
        fn fast_path_is_the_general_path(
            raw in words(),
            wfrac in -70i32..=70,
            bits in 1u8..=63,
            frac in 0u8..=63,
            signed in any::<bool>(),
            q in 0usize..Quant::ALL.len(),
            o in 0usize..Overflow::ALL.len(),
        ) {
            let Ok(f) = Format::new(bits, frac, signed, Quant::ALL[q], Overflow::ALL[o]) else {
                return Ok(());
            };
            let w = Wide::new(i128::from(raw), wfrac);
            let k = i64::from(wfrac) - i64::from(frac);
            let (fast, general) = (f.quantize(w), f.quantize_general(w, k));
            prop_assert_eq!(fast.value.raw(), general.value.raw());
            prop_assert_eq!(fast.overflow, general.overflow);
            prop_assert_eq!(fast.inexact, general.inexact);
        }
    }
}
