//! One assignment of the plain sample's kernel, worked out once per
//! frame ([`Step`]), and the quantisation events the kernel counts
//! ([`Tally`]).

use crate::config::{FormatId, Reg};
use crate::fixed::{Counts, Format, Overflow, Quant, QuantStats};

/// The register formats the kernel assigns: the slots of its tallies.
pub(crate) const SLOTS: [FormatId; 11] = [
    FormatId::named("position"),
    FormatId::named("weight"),
    FormatId::named("sample"),
    FormatId::named("color"),
    FormatId::named("alpha"),
    FormatId::named("path"),
    FormatId::named("log_transmittance"),
    FormatId::named("opacity_corr"),
    FormatId::named("accum_color"),
    FormatId::named("accum_alpha"),
    FormatId::named("merge"),
];

/// How many slots a tally has.
pub(crate) const NSLOTS: usize = SLOTS.len();

/// The slot of format `id`, `None` when the kernel does not assign it.
pub(crate) fn slot(id: FormatId) -> Option<usize> {
    SLOTS.iter().position(|&s| s == id)
}

/// Quantisation events counted while a PE samples a slice on the fast
/// path, per format the kernel assigns ([`SLOTS`]): assignments,
/// overflows and inexact assignments. Added to its [`QuantStats`]
/// afterwards: sums commute, and no slice's counts come near `u64::MAX`,
/// so the saturating totals are the general path's.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Tally {
    pub(super) counts: [[u64; 3]; NSLOTS],
    /// Lanes of the kernel's batches that were in use and that were
    /// visible, whose assignments (a fixed number per slot each,
    /// [`super::Kernel::settle`]) are not yet in `counts`: one count per
    /// batch instead of one per assignment.
    pub(super) lanes: [u64; 2],
}

impl Tally {
    /// Adds these counts to `st`, each under its format (the lanes'
    /// assignments settled, [`super::Kernel::settle`]).
    pub(crate) fn add_to(&self, st: &mut QuantStats) {
        debug_assert_eq!(self.lanes, [0; 2], "the lanes' assignments are settled");
        for (&id, c) in SLOTS.iter().zip(&self.counts) {
            if c[0] > 0 {
                st.add_as(
                    id,
                    &Counts {
                        assignments: c[0],
                        overflows: c[1],
                        inexact: c[2],
                    },
                );
            }
        }
    }

    /// Adds `k` times another tally (the events of `k` samples that
    /// assign the same words).
    #[inline(always)]
    pub(crate) fn add_times(&mut self, o: &Tally, k: u64) {
        for (a, b) in self.counts.iter_mut().zip(&o.counts) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += k * y;
            }
        }
        for (x, y) in self.lanes.iter_mut().zip(&o.lanes) {
            *x += k * y;
        }
    }

    /// Adds another tally.
    #[inline(always)]
    pub(crate) fn add(&mut self, o: &Tally) {
        self.add_times(o, 1);
    }

    /// Counts one assignment into `slot` in each lane `on` marks (bit
    /// `l` for lane `l`), of which those `over` marks overflowed and
    /// those `inexact` marks dropped nonzero bits.
    #[inline(always)]
    pub(crate) fn count(&mut self, slot: usize, on: u8, over: u8, inexact: u8) {
        self.counts[slot][0] += u64::from(on.count_ones());
        self.events(slot, on, over, inexact);
    }

    /// [`Tally::count`]'s overflows and inexact assignments only (the
    /// assignments counted per lane, [`Tally::lanes`]).
    #[inline(always)]
    pub(crate) fn events(&mut self, slot: usize, on: u8, over: u8, inexact: u8) {
        let n = &mut self.counts[slot];
        n[1] += u64::from((over & on).count_ones());
        n[2] += u64::from((inexact & on).count_ones());
    }
}

/// One assignment of exact words with a fixed number of fraction bits
/// into a format rounding with `TRN` or `RND` and saturating:
/// [`Format::quantize`]'s result for such words, computed as
/// `(((raw << left) >> sh1) + add) >> sh2` and clamped to the range.
/// `RND` dropping `k` bits is `floor((floor(raw / 2^(k-1)) + 1) / 2)`, as
/// the quantiser's fast path writes it; `TRN` is `floor(raw / 2^k)`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Step {
    pub(super) left: u32,
    pub(super) sh1: u32,
    pub(super) add: i64,
    pub(super) sh2: u32,
    /// The dropped bits (an inexact assignment has one set).
    pub(super) mask: i64,
    pub(super) min: i64,
    pub(super) max: i64,
    /// The destination's tally slot ([`SLOTS`]).
    pub(super) slot: usize,
    /// Whether every word the kernel assigns here is proven in range
    /// ([`Step::in_range`]): then the lanes neither clamp nor look for an
    /// overflow.
    pub(super) in_range: bool,
}

/// The rounding of a format the kernel models: whether it is `RND` (else
/// `TRN`), `None` for any other rounding or overflow mode.
pub(super) fn rnd(dst: Format) -> Option<bool> {
    let sat = match dst.overflow() {
        Overflow::Sat => true,
        // Symmetric saturation differs from SAT only in a signed format.
        Overflow::SatSym => !dst.is_signed(),
        Overflow::Wrap | Overflow::SatZero => false,
    };
    match dst.quant() {
        Quant::Trn if sat => Some(false),
        Quant::Rnd if sat => Some(true),
        _ => None,
    }
}

impl Step {
    /// The assignment into register `dst` of words with `src` fraction
    /// bits and magnitude below `2^src_bits`; `None` unless `dst` is
    /// modelled ([`rnd`]), one of the kernel's [`SLOTS`], and every shifted
    /// word stays below `2^62`.
    pub(super) fn new(src: i32, src_bits: u32, dst: Reg) -> Option<Step> {
        let slot = slot(dst.id)?;
        let dst = dst.format;
        let r = rnd(dst)?;
        let k = src - i32::from(dst.frac());
        let (left, sh1, add, sh2, mask) = match k {
            ..0 => ((-k) as u32, 0, 0, 0, 0),
            0 => (0, 0, 0, 0, 0),
            _ => {
                let (k, r) = (k as u32, u32::from(r));
                (0, k - r, i64::from(r), r, (1i64 << k.min(62)) - 1)
            }
        };
        (src_bits + left <= 62 && k <= 62).then_some(Step {
            left,
            sh1,
            add,
            sh2,
            mask,
            min: dst.min_raw(),
            max: dst.max_raw(),
            slot,
            in_range: false,
        })
    }

    /// Whether every exact word in `lo..=hi` assigns without overflowing:
    /// the assignment is monotone, so the unclamped words of the two ends
    /// decide. `lo` and `hi` lie within the source range the step was
    /// built for.
    pub(super) fn holds(&self, lo: i64, hi: i64) -> bool {
        let q = |raw: i64| (((raw << self.left) >> self.sh1) + self.add) >> self.sh2;
        q(lo) >= self.min && q(hi) <= self.max
    }

    /// The assigned word of `raw`, whether it overflowed and whether it
    /// dropped nonzero bits.
    #[inline(always)]
    pub(super) fn eval(&self, raw: i64) -> (i64, bool, bool) {
        let q = (((raw << self.left) >> self.sh1) + self.add) >> self.sh2;
        // `max` then `min`, not `clamp`: the range is valid by
        // construction, and `clamp` would check it at every assignment.
        let c = q.max(self.min).min(self.max);
        (c, c != q, raw & self.mask != 0)
    }

    #[inline(always)]
    pub(super) fn apply(&self, raw: i64, t: &mut Tally) -> i64 {
        let (c, over, inexact) = self.eval(raw);
        let n = &mut t.counts[self.slot];
        n[0] += 1;
        n[1] += u64::from(over);
        n[2] += u64::from(inexact);
        c
    }
}
