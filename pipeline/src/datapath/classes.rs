//! The classification unit listed word by word, so the model classifies
//! a sample with one read.

use super::Datapath;
use crate::config::FormatId;
use crate::fixed::{Counts, Format, Fx, QuantStats};

/// The classification unit's truth table: its output and the
/// quantisation events it records for every word of the sample format,
/// each computed once per frame by [`Datapath::classify`]'s own
/// arithmetic. Classification is a function of the sample word alone, so
/// looking a sample up here returns the bits and counts the unit would
/// have produced, in one read instead of five rounded assignments (the
/// hardware is still the table and interpolator; this is how the model
/// evaluates it quickly). Listed only for sample formats of at most
/// [`Classes::MAX_BITS`] bits and when no word's classification fails.
#[derive(Debug, Clone)]
pub(super) struct Classes {
    /// Per sample word: raw R, G, B (`color`) and opacity (`alpha`), and
    /// the quantisation events classifying it records, per format of
    /// [`CLASS_FORMATS`]: assignments, overflows, inexact (at most 3
    /// each).
    pub(super) words: Vec<([i64; 4], [[u8; 3]; 3])>,
    color: Format,
    alpha: Format,
}

/// The formats classification assigns: the interpolation weight, the
/// colour channels and the opacity.
pub(super) const CLASS_FORMATS: [FormatId; 3] = [
    FormatId::named("weight"),
    FormatId::named("color"),
    FormatId::named("alpha"),
];

impl Classes {
    /// Widest sample format listed (64 Ki words).
    pub(super) const MAX_BITS: u8 = 16;

    pub(super) fn list(dp: &Datapath) -> Option<Classes> {
        let f = dp.cfg.sample;
        if f.bits() > Self::MAX_BITS || f.is_signed() {
            return None;
        }
        let (color, alpha) = (dp.cfg.color, dp.cfg.alpha);
        let mut words = Vec::with_capacity(1 << f.bits());
        for raw in 0..=f.max_raw() {
            let mut st = QuantStats::default();
            let (rgb, a) = dp.classify_unit(Fx::from_raw(raw, f).ok()?, &mut st).ok()?;
            // The unit's words are in the table's formats (its entries and
            // its interpolations are assigned into them).
            debug_assert!(rgb.iter().all(|c| c.format() == color) && a.format() == alpha);
            let ev = CLASS_FORMATS.map(|id| {
                let c = st.by_format.get(id);
                [c.assignments, c.overflows, c.inexact].map(|n| u8::try_from(n).unwrap_or(u8::MAX))
            });
            // Every event is in one of those formats.
            let listed: u64 = ev.iter().map(|e| u64::from(e[0])).sum();
            if listed != st.assignments {
                return None;
            }
            words.push(([rgb[0].raw(), rgb[1].raw(), rgb[2].raw(), a.raw()], ev));
        }
        Some(Classes {
            words,
            color,
            alpha,
        })
    }

    #[inline(always)]
    pub(super) fn get(&self, s: Fx, st: &mut QuantStats) -> ([Fx; 3], Fx) {
        let (raw, events) = &self.words[s.raw() as usize];
        for (&id, e) in CLASS_FORMATS.iter().zip(events) {
            if e[0] > 0 {
                st.add_as(
                    id,
                    &Counts {
                        assignments: u64::from(e[0]),
                        overflows: u64::from(e[1]),
                        inexact: u64::from(e[2]),
                    },
                );
            }
        }
        let c = |r: i64| Fx::from_raw_unchecked(r, self.color);
        (
            [c(raw[0]), c(raw[1]), c(raw[2])],
            Fx::from_raw_unchecked(raw[3], self.alpha),
        )
    }
}
