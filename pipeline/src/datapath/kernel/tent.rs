//! The Bartlett merge's assignments worked out once per frame
//! ([`Tents`]), beside the sample's: the same words and quantisation
//! events as [`Datapath::tent`] (a proptest compares them over many
//! formats).

use super::{mag, Step, Tally};
use crate::config::Reg;
#[cfg(doc)]
use crate::datapath::Datapath;
#[cfg(doc)]
use crate::fixed::QuantStats;

/// The Bartlett merge's four assignments ([`Datapath::tent`]): the x
/// pass's tent of accumulator words (colour, opacity) into `merge`, and
/// the y pass's of `merge` words back into each accumulator, worked out
/// once per frame like the sample's. The tent of three words below
/// `2^B` stays below `2^(B + 2)`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tents {
    x: [Step; 2],
    y: [Step; 2],
}

impl Tents {
    /// The configuration's tents, or `None` when one is not modelled.
    pub(super) fn new(c: &crate::config::PipelineConfig) -> Option<Tents> {
        let tent = |from: Reg, to: Reg| Step::new(i32::from(from.frac()) + 2, mag(*from) + 2, to);
        let (fc, fa, fm) = (
            crate::reg!(c, accum_color),
            crate::reg!(c, accum_alpha),
            crate::reg!(c, merge),
        );
        Some(Tents {
            x: [tent(fc, fm)?, tent(fa, fm)?],
            y: [tent(fm, fc)?, tent(fm, fa)?],
        })
    }

    /// [`Datapath::tent`] of every channel (R, G, B, A) of parents `p`:
    /// the x pass's (`y` false) or the y pass's, its events counted in
    /// `t` under each destination's format: a pass's tally, added to the
    /// PE's [`QuantStats`] once when the pass ends (sums commute), where
    /// adding each ray's counts cost as much as its tents.
    #[inline(always)]
    pub(crate) fn apply_rgba(&self, y: bool, p: [[i64; 4]; 3], t: &mut Tally) -> [i64; 4] {
        let steps = if y { &self.y } else { &self.x };
        let mut out = [0; 4];
        // Colour channels, then opacity: each pair's events.
        let mut n = [[0u64; 3]; 2];
        for (ch, o) in out.iter_mut().enumerate() {
            let i = usize::from(ch == 3);
            let (c, over, inexact) = steps[i].eval(p[0][ch] + 2 * p[1][ch] + p[2][ch]);
            *o = c;
            n[i][0] += 1;
            n[i][1] += u64::from(over);
            n[i][2] += u64::from(inexact);
        }
        for (s, n) in steps.iter().zip(&n) {
            for (a, b) in t.counts[s.slot].iter_mut().zip(n) {
                *a += b;
            }
        }
        out
    }

    /// [`Datapath::tent`] of channel `ch` (R, G, B, A) of parents `p`
    /// (the tests' reference for [`Tents::apply_rgba`]):
    /// the x pass's (`y` false) or the y pass's, its events counted in
    /// `t`.
    #[cfg(test)]
    pub(crate) fn apply(&self, y: bool, ch: usize, p: [i64; 3], t: &mut Tally) -> i64 {
        let steps = if y { &self.y } else { &self.x };
        steps[usize::from(ch == 3)].apply(p[0] + 2 * p[1] + p[2], t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datapath::Datapath;
    use crate::fixed::{Format, Overflow, Quant, QuantStats};
    use proptest::prelude::*;

    /// The configuration of accumulator colour, alpha and merge formats
    /// `widths` (bits, fraction), each `RND` or `TRN` by `rounds`, the
    /// merge word signed by `signed`, and its tents; a rejection when the
    /// formats or the tents do not exist.
    fn tent_case(
        widths: [(u8, u8); 3],
        rounds: [bool; 3],
        signed: bool,
    ) -> Result<(crate::config::PipelineConfig, Tents), TestCaseError> {
        let q = |r: bool| if r { Quant::Rnd } else { Quant::Trn };
        let f = |i: usize, s: bool| {
            let (b, fr) = widths[i];
            Format::new(b, fr.min(b), s, q(rounds[i]), Overflow::Sat)
        };
        let (Ok(accum_color), Ok(accum_alpha), Ok(merge)) =
            (f(0, false), f(1, false), f(2, signed))
        else {
            return Err(TestCaseError::reject("no such format"));
        };
        let cfg = crate::config::PipelineConfig {
            accum_color,
            accum_alpha,
            merge,
            ..crate::config::PipelineConfig::default()
        };
        let Some(tents) = Tents::new(&cfg) else {
            return Err(TestCaseError::reject("a width the tents do not model"));
        };
        Ok((cfg, tents))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        /// A tent worked out once is the general path's [`Datapath::tent`],
        /// word and quantisation events, for either pass and channel, over
        /// accumulator and merge formats of many widths and fractions,
        /// `TRN` or `RND`, a signed or unsigned merge word.
        #[test]
        fn a_tent_is_the_general_tent(
            widths in proptest::array::uniform3((2u8..=40, 0u8..=40)),
            rounds in any::<[bool; 3]>(),
            signed in any::<bool>(),
            y in any::<bool>(),
            ch in 0usize..4,
            words in any::<[u64; 3]>(),
        ) {
            let (cfg, tents) = tent_case(widths, rounds, signed)?;
            let acc = if ch == 3 {
                crate::reg!(cfg, accum_alpha)
            } else {
                crate::reg!(cfg, accum_color)
            };
            let merge = crate::reg!(cfg, merge);
            let (from, to) = if y { (merge, acc) } else { (acc, merge) };
            let from = from.format;
            // Any three words of the source format.
            let span = (from.max_raw() - from.min_raw()) as u64 + 1;
            let p = words.map(|w| from.min_raw() + (w % span) as i64);
            let mut want_st = QuantStats::default();
            // The general tent reads only its formats, not the datapath's.
            static DP: std::sync::OnceLock<Datapath> = std::sync::OnceLock::new();
            let dp = DP.get_or_init(|| {
                let cfg = crate::config::PipelineConfig::default();
                let tf = golden::scenes::tf_preset("ml").unwrap();
                let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, 8);
                Datapath::new(cfg, crate::tables::Tables::new(&cfg, &lut).unwrap())
            });
            let want = dp.tent(p, from, to, &mut want_st).raw();
            let mut t = Tally::default();
            let got = tents.apply(y, ch, p, &mut t);
            let mut got_st = QuantStats::default();
            t.add_to(&mut got_st);
            prop_assert_eq!(got, want);
            prop_assert_eq!(got_st, want_st);
        }

        /// A whole ray's tents at once ([`Tents::apply_rgba`], the merge's
        /// path) give the general [`Datapath::tent`]'s words channel by
        /// channel and the same quantisation counts, per format, for
        /// either pass.
        #[test]
        fn a_ray_of_tents_is_the_general_tent(
            widths in proptest::array::uniform3((2u8..=40, 0u8..=40)),
            rounds in any::<[bool; 3]>(),
            signed in any::<bool>(),
            y in any::<bool>(),
            words in any::<[[u64; 4]; 3]>(),
        ) {
            let (cfg, tents) = tent_case(widths, rounds, signed)?;
            let merge = crate::reg!(cfg, merge);
            let mut p = [[0i64; 4]; 3];
            let mut want = [0i64; 4];
            let mut want_st = QuantStats::default();
            for ch in 0..4 {
                let acc = if ch == 3 {
                    crate::reg!(cfg, accum_alpha)
                } else {
                    crate::reg!(cfg, accum_color)
                };
                let (from, to) = if y { (merge, acc) } else { (acc, merge) };
                let from = from.format;
                let span = (from.max_raw() - from.min_raw()) as u64 + 1;
                for (i, row) in p.iter_mut().enumerate() {
                    row[ch] = from.min_raw() + (words[i][ch] % span) as i64;
                }
                want[ch] = general().tent([p[0][ch], p[1][ch], p[2][ch]], from, to, &mut want_st).raw();
            }
            let mut t = Tally::default();
            let got = tents.apply_rgba(y, p, &mut t);
            let mut got_st = QuantStats::default();
            t.add_to(&mut got_st);
            prop_assert_eq!(got, want);
            prop_assert_eq!(got_st, want_st);
        }
    }

    /// A datapath for the general tent, which reads only the formats it
    /// is given, not the datapath's.
    fn general() -> &'static Datapath {
        static DP: std::sync::OnceLock<Datapath> = std::sync::OnceLock::new();
        DP.get_or_init(|| {
            let cfg = crate::config::PipelineConfig::default();
            let tf = golden::scenes::tf_preset("ml").unwrap();
            let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, 8);
            Datapath::new(cfg, crate::tables::Tables::new(&cfg, &lut).unwrap())
        })
    }
}
