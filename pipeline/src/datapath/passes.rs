//! The words of the boundary passes: the bilinear split's halving taps,
//! the fold's difference and add, and the Bartlett merge's tents (through
//! the assignments worked out once per frame when the formats allow),
//! each assigned into a declared [`Format`].

use super::{Datapath, Tally};
use crate::config::Reg;
use crate::fixed::{Format, Fx, QuantStats, Wide};

impl Datapath {
    /// One tap pair of the bilinear split, `(p[0] + p[1]) / 2` of raw
    /// words in format `from`, assigned into `to` (the x pass goes from an
    /// accumulator into `merge`, the y pass from `merge` back). A child on
    /// its parent's line passes `p[0] = p[1]`, which is exact whenever
    /// `to` holds `from`'s grid.
    #[inline]
    pub fn halve(&self, p: [i64; 2], from: Format, to: Reg, st: &mut QuantStats) -> Fx {
        // Two words of at most 63 bits: the sum fits i128 trivially.
        let sum = i128::from(p[0]) + i128::from(p[1]);
        to.assign(Wide::new(sum, i32::from(from.frac()) + 1), st)
    }

    /// The fold's difference `result - inherited` (what a ray's samples
    /// and its children added behind the boundary), from a result word in
    /// `rf` and an inherited accumulator word in `inf`, into `merge`. Exact
    /// while it fits: `merge` has at least both formats' fraction bits
    /// (validated), and the difference is non-negative because front-to-
    /// back words only grow; a negative one (a wrap-around) would clamp to
    /// zero with `merge`'s unsigned overflow and be counted.
    #[inline]
    pub fn fold_diff(&self, r: i64, rf: Format, inh: i64, inf: Format, st: &mut QuantStats) -> Fx {
        let d = Fx::from_raw_unchecked(r, rf) - Fx::from_raw_unchecked(inh, inf);
        crate::reg!(self.cfg, merge).assign(d, st)
    }

    /// The fold's add `final + merged`: a ray's own final accumulator word
    /// (format `ff`) plus the merged differences of its children (a
    /// `merge` word), into `merge`. Exact while it fits, for the same
    /// reason as [`Datapath::fold_diff`]; above `merge`'s range it
    /// saturates (counted).
    #[inline]
    pub fn fold_add(&self, f: i64, ff: Format, merged: i64, st: &mut QuantStats) -> Fx {
        let m = crate::reg!(self.cfg, merge);
        let s = Fx::from_raw_unchecked(f, ff) + Fx::from_raw_unchecked(merged, m.format);
        m.assign(s, st)
    }

    /// One Bartlett tap row `(p[-1] + 2 p[0] + p[1]) / 4` of raw words in
    /// format `from`, assigned into `to` (the x pass goes from an
    /// accumulator into `merge`, the y pass from `merge` back).
    #[inline]
    pub fn tent(&self, p: [i64; 3], from: Format, to: Reg, st: &mut QuantStats) -> Fx {
        // Three words of at most 63 bits: the sum fits i128 trivially.
        let sum = i128::from(p[0]) + 2 * i128::from(p[1]) + i128::from(p[2]);
        to.assign(Wide::new(sum, i32::from(from.frac()) + 2), st)
    }

    /// A whole ray's [`Datapath::tent`], R, G, B and A, of parents `p`:
    /// the x pass's (`y` false) of accumulator words into `merge`, or the
    /// y pass's of `merge` words back into the accumulators; through the
    /// assignments worked out once ([`Datapath::tents`]) when the formats
    /// are modelled, whose events go to `pass` (the pass's tally, added to
    /// `st` when the pass ends); the general path's go to `st`.
    pub(crate) fn tent_rgba(
        &self,
        y: bool,
        p: [[i64; 4]; 3],
        st: &mut QuantStats,
        pass: &mut Tally,
    ) -> [i64; 4] {
        if let Some(tents) = self.tents() {
            return tents.apply_rgba(y, p, pass);
        }
        let tap = |ch: usize| [p[0][ch], p[1][ch], p[2][ch]];
        let mut out = [0; 4];
        let c = &self.cfg;
        for (ch, o) in out.iter_mut().enumerate() {
            let acc = if ch < 3 {
                crate::reg!(c, accum_color)
            } else {
                crate::reg!(c, accum_alpha)
            };
            let merge = crate::reg!(c, merge);
            let (from, to) = if y { (merge, acc) } else { (acc, merge) };
            *o = self.tent(tap(ch), from.format, to, st).raw();
        }
        out
    }
}
