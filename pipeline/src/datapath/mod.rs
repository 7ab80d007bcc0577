//! The PE's per-sample arithmetic, bit for bit: ray position, bilinear
//! interpolation, classification, opacity correction and compositing, and
//! the Bartlett merge. Each step mirrors its float counterpart in
//! `golden::sampling` / `golden::merge` (same order of operations), and
//! every value is assigned into a declared [`Format`] of the
//! [`PipelineConfig`]: full-precision operators, quantise on assignment.

use crate::config::PipelineConfig;
use crate::fixed::{Format, Fx, FxError, QuantStats, Wide, Word64};
use crate::tables::Tables;

mod kernel;

use kernel::Tents;
pub(crate) use kernel::{Batch, LaneTally, Ray, Tally, LANES};
pub use kernel::{Kernel, KernelRow};

/// One ray's compositing accumulators: premultiplied R, G, B and opacity,
/// as raw words of `accum_color` / `accum_alpha`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct Acc {
    /// Raw R, G, B, A words.
    pub raw: [i64; 4],
}

/// What a PE did in its last sampling cycle, for waveforms and tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SampleTrace {
    /// Whether the PE sampled (false: idle).
    pub busy: bool,
    /// Ray index along x.
    pub mx: i64,
    /// Row of the ray in the region's buffer.
    pub row: usize,
    /// The ray's accumulators after compositing.
    pub acc: Acc,
    /// Interpolated sample, raw `sample` word.
    pub sample: i64,
    /// Classified opacity, raw `alpha` word.
    pub alpha: i64,
    /// Corrected opacity, raw `opacity_corr` word.
    pub corrected: i64,
    /// Front to back: this sample brought the ray's opacity to the
    /// termination threshold, so the ray's termination flag was set.
    pub terminated: bool,
    /// The gradient and shading unit's words (zero when not shading).
    pub shade: crate::shading::ShadeTrace,
    /// The volume-of-interest stage's words (zero without a VOI).
    pub voi: crate::voi::VoiTrace,
    /// The pre-integration unit's words (zero unless pre-integrating).
    pub preint: crate::preint::PreintTrace,
}

/// The fixed-point datapath: the configuration, its tables and the
/// per-format saturation and rounding counters.
#[derive(Debug, Clone)]
pub struct Datapath {
    /// Widths and modes.
    pub cfg: PipelineConfig,
    /// Classification and opacity tables.
    tables: Tables,
    /// The classification unit's output for every sample word, when the
    /// sample format is narrow enough to list ([`Classes`]).
    classes: Option<Classes>,
    /// The plain sample's per-frame constants, when the configuration
    /// allows them ([`Kernel`]).
    kernel: Option<Kernel>,
    /// The early-termination comparator's constant, a raw `accum_alpha`
    /// word ([`PipelineConfig::termination_raw`]), fixed per frame.
    threshold: Option<i64>,
    /// Cycles from a sample's issue to its write-back into the compositing
    /// buffer ([`PipelineConfig::datapath_latency`], resolved).
    pub latency: u64,
    /// The gradient and shading unit's per-frame constants, when the frame
    /// is shaded ([`Datapath::with_shading`]).
    pub shade: Option<crate::shading::ShadeUnit>,
    /// The volume-of-interest stage's per-frame constants, when the frame
    /// has one ([`Datapath::with_voi`]).
    pub voi: Option<crate::voi::VoiUnit>,
    /// The pre-integration unit's table and constants, when the frame is
    /// pre-integrated ([`Datapath::with_preint`]).
    pub preint: Option<crate::preint::PreintUnit>,
}

/// `a + w (b - a)`, exactly, assigned into `out`.
#[inline(always)]
pub fn lerp(a: Fx, b: Fx, w: Fx, out: Format, st: &mut QuantStats) -> Result<Fx, FxError> {
    if let Some(v) = lerp64(a, b, w) {
        return Ok(out.assign(v, st));
    }
    let d = b - a;
    let wd = Wide::from(w).checked_mul(d)?;
    Ok(out.assign(Wide::from(a).checked_add(wd)?, st))
}

/// [`lerp`]'s exact `a + w (b - a)` before assignment, in 64-bit words,
/// when the operands' widths prove every intermediate fits (`None`
/// otherwise, and the caller takes the 128-bit path). The same value and
/// fraction as the 128-bit path: exact integer arithmetic does not depend
/// on the word it runs in. With `a`, `b` aligned to their larger fraction
/// in `B` bits and `w` in `bw`: `|b - a| < 2^(B+1)`, the product below
/// `2^(B+bw+1)`, `a` shifted by `w`'s fraction below `2^(B+bw)`, so the
/// sum stays below `2^(B+bw+2)`.
#[inline(always)]
fn lerp64(a: Fx, b: Fx, w: Fx) -> Option<Wide> {
    let (fa, fb, fw) = (a.format().frac(), b.format().frac(), w.format().frac());
    let f = fa.max(fb);
    let (sa, sb) = (f - fa, f - fb);
    // Widths and fractions are at most 63, so these sums fit u8.
    let bits = (a.format().bits() + sa).max(b.format().bits() + sb);
    if u32::from(bits) + u32::from(w.format().bits()) + 2 > 62 {
        return None;
    }
    let (x, y) = (a.raw() << sa, b.raw() << sb);
    let v = (x << fw) + w.raw() * (y - x);
    Some(Wide::new(i128::from(v), i32::from(f) + i32::from(fw)))
}

/// `sqrt(v)` truncated onto `f`'s grid: an exact integer square root of
/// the radicand aligned to `2 f.frac` fraction bits (the path length's and
/// the gradient norm's unit). `op` names it in an overflow error.
#[inline(always)]
pub fn isqrt_into(
    v: Wide,
    f: Format,
    op: &'static str,
    st: &mut QuantStats,
) -> Result<Fx, FxError> {
    let pf = i32::from(f.frac());
    // sqrt(raw 2^-k) 2^pf = sqrt(raw 2^(2 pf - k)).
    let shift = 2 * pf - v.frac;
    // `Wide` shifts move the exponent, so align the raw word by hand.
    let radicand = if shift >= 0 {
        // Exact iff shifting back recovers the word.
        u32::try_from(shift)
            .ok()
            .filter(|&s| s < 127)
            .map(|s| (v.raw << s, s))
            .filter(|&(r, s)| r >> s == v.raw)
            .map(|(r, _)| r)
            .ok_or(FxError::WideOverflow { op })?
    } else {
        v.raw >> (-shift) as u32
    };
    let root = isqrt(radicand.max(0) as u128) as i128;
    Ok(f.assign(Wide::new(root, pf), st))
}

/// `floor(sqrt(v))`, exactly: a float estimate corrected by at most a few
/// steps when `v` fits 64 bits (the datapath's radicands), the integer
/// algorithm otherwise. The unit it models is the exact root either way.
#[inline]
fn isqrt(v: u128) -> u128 {
    let Ok(small) = u64::try_from(v) else {
        return v.isqrt();
    };
    // The estimate is within one or two of the root for any u64; the
    // loops make it exact (squares of roots below 2^32 + 2 fit u128).
    let mut r = u128::from((small as f64).sqrt() as u64);
    while r * r > v {
        r -= 1;
    }
    while (r + 1) * (r + 1) <= v {
        r += 1;
    }
    r
}

/// Integer and fraction of a non-negative or negative fixed value at a
/// given number of fraction bits: `(floor, fraction raw)`.
#[inline]
fn split(raw: i64, frac: u32) -> (i64, i64) {
    (raw >> frac, raw & ((1i64 << frac) - 1))
}

impl Datapath {
    /// Builds the datapath for `cfg` and its tables.
    pub fn new(cfg: PipelineConfig, tables: Tables) -> Datapath {
        let mut dp = Datapath {
            threshold: cfg.termination_raw(),
            latency: u64::from(crate::cost::datapath_latency(&cfg)),
            cfg,
            tables,
            classes: None,
            kernel: None,
            shade: None,
            voi: None,
            preint: None,
        };
        dp.classes = Classes::list(&dp);
        dp.kernel = dp.classes.as_ref().and_then(|c| Kernel::new(&dp, c));
        dp
    }

    /// The plain sample's kernel, when the frame neither shades nor has a
    /// volume of interest nor pre-integrates and the configuration allows
    /// one ([`Kernel`]).
    #[inline]
    pub fn kernel(&self) -> Option<&Kernel> {
        let plain = self.shade.is_none() && self.voi.is_none() && self.preint.is_none();
        self.kernel.as_ref().filter(|_| plain)
    }

    /// The Bartlett merge's assignments worked out once ([`Kernel`]'s,
    /// shaded frames too: the merge is the same), `None` without a
    /// kernel or when a merge format is not modelled.
    fn tents(&self) -> Option<&Tents> {
        self.kernel.as_ref().and_then(Kernel::tents)
    }

    /// This datapath without its kernel: every sample then runs the
    /// general path (how tests compare the two).
    pub fn without_kernel(mut self) -> Datapath {
        self.kernel = None;
        self
    }

    /// Classification and opacity tables.
    pub fn tables(&self) -> &Tables {
        &self.tables
    }

    /// This datapath with the volume-of-interest stage loaded with
    /// `unit`'s constants. A derived latency becomes the depth of the
    /// schedule with the stage ([`crate::cost::unit_latency`]): its
    /// distance and weight run beside interpolation and classification,
    /// its multiply between classification and the opacity correction;
    /// the distance's square root makes the datapath deeper (49 clocks
    /// against 26 at the default widths), which lengthens only what waits
    /// for samples in flight. One the configuration states is kept.
    pub fn with_voi(mut self, unit: crate::voi::VoiUnit) -> Datapath {
        if self.cfg.datapath_latency == 0 {
            let units = (self.shade.is_some(), true);
            self.latency = u64::from(crate::cost::unit_latency(&self.cfg, units));
        }
        self.voi = Some(unit);
        self
    }

    /// This datapath with the gradient and shading unit loaded with
    /// `unit`'s constants. A derived latency grows by what the unit adds
    /// to the schedule ([`crate::cost::shaded_latency`]); one the
    /// configuration states is kept.
    pub fn with_shading(mut self, unit: crate::shading::ShadeUnit) -> Datapath {
        if self.cfg.datapath_latency == 0 {
            let units = (true, self.voi.is_some());
            self.latency = u64::from(crate::cost::unit_latency(&self.cfg, units));
        }
        self.shade = Some(unit);
        self
    }

    /// This datapath with the pre-integration unit loaded
    /// ([`crate::preint`]). A derived latency becomes the depth of the
    /// schedule with the unit ([`crate::cost::preint_latency`]); one the
    /// configuration states is kept.
    pub fn with_preint(mut self, unit: crate::preint::PreintUnit) -> Datapath {
        if self.cfg.datapath_latency == 0 {
            self.latency = u64::from(crate::cost::preint_latency(&self.cfg));
        }
        self.preint = Some(unit);
        self
    }

    /// The termination comparator: whether a ray whose opacity word is
    /// `acc.raw[3]` takes no more samples (a compare against a per-frame
    /// constant; never when termination is off).
    #[inline(always)]
    pub fn terminated(&self, acc: &Acc) -> bool {
        self.threshold.is_some_and(|t| acc.raw[3] >= t)
    }

    /// Ray position `a + m t` on one axis, in the `position` format (the
    /// host broadcasts `a` in `position` and `t` in `step`).
    #[inline(always)]
    pub fn position(&self, a: Fx, t: Fx, m: i64, st: &mut QuantStats) -> Result<Fx, FxError> {
        let fast = Word64::int(m)
            .checked_mul(Word64::of(t))
            .and_then(|mt| Word64::of(a).checked_add(mt));
        let v = match fast {
            Some(v) => Wide::from(v),
            None => {
                let mt = Wide::new(i128::from(m), 0).checked_mul(t)?;
                Wide::from(a).checked_add(mt)?
            }
        };
        Ok(self.cfg.position.assign(v, st))
    }

    /// Voxel address and interpolation weight of a position:
    /// `(floor(x), weight)`, the weight being the position's fraction
    /// assigned into the `weight` format.
    #[inline(always)]
    pub fn address(&self, x: Fx, st: &mut QuantStats) -> (i64, Fx) {
        let f = u32::from(self.cfg.position.frac());
        let (i, r) = split(x.raw(), f);
        (
            i,
            self.cfg
                .weight
                .assign(Wide::new(i128::from(r), f as i32), st),
        )
    }

    /// Bilinear interpolation of four voxel codes (`v[row][col]`, rows
    /// `y0, y0 + 1`, columns `x0, x0 + 1`) with weights `wx`, `wy`: first
    /// along x on both rows, then along y, as `golden::slices::bilinear`.
    #[inline(always)]
    pub fn bilinear(
        &self,
        v: [[u16; 2]; 2],
        wx: Fx,
        wy: Fx,
        st: &mut QuantStats,
    ) -> Result<Fx, FxError> {
        let vf = self.cfg.voxel;
        let vox = |c: u16| Fx::from_raw_unchecked(i64::from(c), vf);
        let s = self.cfg.sample;
        let top = lerp(vox(v[0][0]), vox(v[0][1]), wx, s, st)?;
        let bot = lerp(vox(v[1][0]), vox(v[1][1]), wx, s, st)?;
        lerp(top, bot, wy, s, st)
    }

    /// Classification: the sample's table position `sample * 2^shift`
    /// splits into an entry index and a weight; colour and opacity are
    /// interpolated between adjacent entries (a dual-port table), as
    /// `golden::tf::Lut::lookup`.
    #[inline(always)]
    pub fn classify(&self, s: Fx, st: &mut QuantStats) -> Result<([Fx; 3], Fx), FxError> {
        match &self.classes {
            Some(c) => Ok(c.get(s, st)),
            None => self.classify_unit(s, st),
        }
    }

    /// [`Datapath::classify`]'s arithmetic, operation by operation.
    #[inline(always)]
    fn classify_unit(&self, s: Fx, st: &mut QuantStats) -> Result<([Fx; 3], Fx), FxError> {
        let t = &self.tables;
        let last = t.color.len() - 1;
        let shift = self.cfg.table_shift();
        let f = i32::from(self.cfg.sample.frac()) - shift;
        let (i, w) = if f > 0 {
            let (i, r) = split(s.raw(), f as u32);
            (i, self.cfg.weight.assign(Wide::new(i128::from(r), f), st))
        } else {
            (s.raw() << (-f) as u32, self.cfg.weight.zero())
        };
        let i = i.max(0) as usize;
        if i >= last {
            return Ok((t.color[last], t.alpha[last]));
        }
        let c = self.cfg.color;
        let rgb = [
            lerp(t.color[i][0], t.color[i + 1][0], w, c, st)?,
            lerp(t.color[i][1], t.color[i + 1][1], w, c, st)?,
            lerp(t.color[i][2], t.color[i + 1][2], w, c, st)?,
        ];
        let a = lerp(t.alpha[i], t.alpha[i + 1], w, self.cfg.alpha, st)?;
        Ok((rgb, a))
    }

    /// Opacity correction `1 - (1 - a)^ds` in the log domain:
    /// `p = -log2(1 - a) ds`, `T = 2^-frac(p)` from the interpolated exp
    /// table, shifted right by `int(p)`, and `a' = 1 - T`.
    #[inline(always)]
    pub fn correct(&self, a: Fx, ds: Fx, st: &mut QuantStats) -> Result<Fx, FxError> {
        let t = &self.tables;
        let lf = self.cfg.log_transmittance;
        let code = (a.raw().max(0) as usize).min(t.log_t.len() - 1);
        let p = lf.assign(t.log_t[code] * ds, st);
        self.transmit(p, st)
    }

    /// Steps 3 and 4 of the opacity correction: from `p`
    /// (`log_transmittance`), `T = 2^-frac(p)` from the interpolated exp
    /// table shifted right by `int(p)`, and the opacity `1 - T`
    /// (`opacity_corr`). The pre-integration unit shares it
    /// ([`crate::preint`]).
    #[inline(always)]
    pub fn transmit(&self, p: Fx, st: &mut QuantStats) -> Result<Fx, FxError> {
        let t = &self.tables;
        let lf = self.cfg.log_transmittance;
        let oc = self.cfg.opacity_corr;
        let fbits = u32::from(lf.frac());
        let (int, frac) = split(p.raw(), fbits);
        let e = u32::from(self.cfg.exp_table_bits);
        let (idx, rem) = split(frac, fbits - e);
        let w = self
            .cfg
            .weight
            .assign(Wide::new(i128::from(rem), (fbits - e) as i32), st);
        let idx = idx as usize;
        let tf = lerp(t.exp[idx], t.exp[idx + 1], w, oc, st)?;
        let trans = if int >= 64 {
            oc.zero()
        } else {
            oc.assign(tf >> int as u16, st)
        };
        let one = Wide::new(1, 0);
        Ok(oc.assign(one.checked_sub(trans)?, st))
    }

    /// Back-to-front compositing of colour `c` with corrected opacity `a`:
    /// `C = a c + (1 - a) C`, `A = a + (1 - a) A`.
    #[inline(always)]
    pub fn composite_btf(
        &self,
        acc: &mut Acc,
        c: [Fx; 3],
        a: Fx,
        st: &mut QuantStats,
    ) -> Result<(), FxError> {
        let (fc, fa) = (self.cfg.accum_color, self.cfg.accum_alpha);
        let k = Wide::new(1, 0).checked_sub(a)?;
        // The same expressions in 64-bit words where they fit.
        let (a64, k64) = (Word64::of(a), Word64::int(1).checked_sub(Word64::of(a)));
        for (word, &colour) in acc.raw.iter_mut().zip(&c) {
            let old = Fx::from_raw_unchecked(*word, fc);
            let fast = k64.and_then(|k| {
                a64.checked_mul(Word64::of(colour))?
                    .checked_add(k.checked_mul(Word64::of(old))?)
            });
            let v = match fast {
                Some(v) => Wide::from(v),
                None => (a * colour).checked_add(k.checked_mul(old)?)?,
            };
            *word = fc.assign(v, st).raw();
        }
        let old = Fx::from_raw_unchecked(acc.raw[3], fa);
        let fast = k64.and_then(|k| a64.checked_add(k.checked_mul(Word64::of(old))?));
        let v = match fast {
            Some(v) => Wide::from(v),
            None => Wide::from(a).checked_add(k.checked_mul(old)?)?,
        };
        acc.raw[3] = fa.assign(v, st).raw();
        Ok(())
    }

    /// Front-to-back compositing of colour `c` with corrected opacity `a`:
    /// `k = (1 - A) a` (exact, not a register: it feeds four
    /// multiply-adds), `C += k c` into `accum_color`, `A += k` into
    /// `accum_alpha`, as `golden::sampling` composites front to back. Two
    /// roundings per sample (colour and opacity), each the accumulator's
    /// mode; with a monotone rounding and no wrap-around, neither word
    /// ever decreases (the fold's differences rely on it).
    #[inline(always)]
    pub fn composite_ftb(
        &self,
        acc: &mut Acc,
        c: [Fx; 3],
        a: Fx,
        st: &mut QuantStats,
    ) -> Result<(), FxError> {
        let (fc, fa) = (self.cfg.accum_color, self.cfg.accum_alpha);
        let old_a = Fx::from_raw_unchecked(acc.raw[3], fa);
        let k = Wide::new(1, 0).checked_sub(old_a)?.checked_mul(a)?;
        // The same expressions in 64-bit words where they fit.
        let k64 = Word64::int(1)
            .checked_sub(Word64::of(old_a))
            .and_then(|d| d.checked_mul(Word64::of(a)));
        for (word, &colour) in acc.raw.iter_mut().zip(&c) {
            let old = Fx::from_raw_unchecked(*word, fc);
            let fast =
                k64.and_then(|k| Word64::of(old).checked_add(k.checked_mul(Word64::of(colour))?));
            let v = match fast {
                Some(v) => Wide::from(v),
                None => Wide::from(old).checked_add(k.checked_mul(colour)?)?,
            };
            *word = fc.assign(v, st).raw();
        }
        let fast = k64.and_then(|k| Word64::of(old_a).checked_add(k));
        let v = match fast {
            Some(v) => Wide::from(v),
            None => Wide::from(old_a).checked_add(k)?,
        };
        acc.raw[3] = fa.assign(v, st).raw();
        Ok(())
    }

    /// One tap pair of the bilinear split, `(p[0] + p[1]) / 2` of raw
    /// words in format `from`, assigned into `to` (the x pass goes from an
    /// accumulator into `merge`, the y pass from `merge` back). A child on
    /// its parent's line passes `p[0] = p[1]`, which is exact whenever
    /// `to` holds `from`'s grid.
    #[inline]
    pub fn halve(&self, p: [i64; 2], from: Format, to: Format, st: &mut QuantStats) -> Fx {
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
        self.cfg.merge.assign(d, st)
    }

    /// The fold's add `final + merged`: a ray's own final accumulator word
    /// (format `ff`) plus the merged differences of its children (a
    /// `merge` word), into `merge`. Exact while it fits, for the same
    /// reason as [`Datapath::fold_diff`]; above `merge`'s range it
    /// saturates (counted).
    #[inline]
    pub fn fold_add(&self, f: i64, ff: Format, merged: i64, st: &mut QuantStats) -> Fx {
        let m = self.cfg.merge;
        let s = Fx::from_raw_unchecked(f, ff) + Fx::from_raw_unchecked(merged, m);
        m.assign(s, st)
    }

    /// The ray's path length per slice step, `sqrt(sx^2 + sy^2 + sz^2)`
    /// from its spacing-scaled slopes, truncated into the `path` format
    /// (an exact integer square root).
    #[inline(always)]
    pub fn path(&self, sx: Fx, sy: Fx, sz: Fx, st: &mut QuantStats) -> Result<Fx, FxError> {
        let sum = (sx * sx).checked_add(sy * sy)?.checked_add(sz * sz)?;
        isqrt_into(sum, self.cfg.path, "path length", st)
    }

    /// One Bartlett tap row `(p[-1] + 2 p[0] + p[1]) / 4` of raw words in
    /// format `from`, assigned into `to` (the x pass goes from an
    /// accumulator into `merge`, the y pass from `merge` back).
    #[inline]
    pub fn tent(&self, p: [i64; 3], from: Format, to: Format, st: &mut QuantStats) -> Fx {
        // Three words of at most 63 bits: the sum fits i128 trivially.
        let sum = i128::from(p[0]) + 2 * i128::from(p[1]) + i128::from(p[2]);
        to.assign(Wide::new(sum, i32::from(from.frac()) + 2), st)
    }

    /// A whole ray's [`Datapath::tent`], R, G, B and A, of parents `p`:
    /// the x pass's (`y` false) of accumulator words into `merge`, or the
    /// y pass's of `merge` words back into the accumulators; through the
    /// assignments worked out once ([`Datapath::tents`]) when the formats
    /// are modelled.
    pub(crate) fn tent_rgba(&self, y: bool, p: [[i64; 4]; 3], st: &mut QuantStats) -> [i64; 4] {
        let tap = |ch: usize| [p[0][ch], p[1][ch], p[2][ch]];
        let mut out = [0; 4];
        if let Some(tents) = self.tents() {
            let mut t = Tally::default();
            for (ch, o) in out.iter_mut().enumerate() {
                *o = tents.apply(y, ch, tap(ch), &mut t);
            }
            t.add_to(st);
        } else {
            let c = &self.cfg;
            for (ch, o) in out.iter_mut().enumerate() {
                let acc = if ch < 3 { c.accum_color } else { c.accum_alpha };
                let (from, to) = if y { (c.merge, acc) } else { (acc, c.merge) };
                *o = self.tent(tap(ch), from, to, st).raw();
            }
        }
        out
    }
}

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
struct Classes {
    /// Per sample word: raw R, G, B (`color`) and opacity (`alpha`), and
    /// the quantisation events classifying it records.
    words: Vec<([i64; 4], QuantStats)>,
    color: Format,
    alpha: Format,
}

impl Classes {
    /// Widest sample format listed (64 Ki words).
    const MAX_BITS: u8 = 16;

    fn list(dp: &Datapath) -> Option<Classes> {
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
            words.push(([rgb[0].raw(), rgb[1].raw(), rgb[2].raw(), a.raw()], st));
        }
        Some(Classes {
            words,
            color,
            alpha,
        })
    }

    #[inline(always)]
    fn get(&self, s: Fx, st: &mut QuantStats) -> ([Fx; 3], Fx) {
        let (raw, events) = &self.words[s.raw() as usize];
        st.merge(events);
        let c = |r: i64| Fx::from_raw_unchecked(r, self.color);
        (
            [c(raw[0]), c(raw[1]), c(raw[2])],
            Fx::from_raw_unchecked(raw[3], self.alpha),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn fx(raw: i64, bits: u8, frac: u8, signed: bool) -> Fx {
        let f = if signed {
            Format::signed(bits, frac.min(bits))
        } else {
            Format::unsigned(bits, frac.min(bits))
        }
        .unwrap();
        let span = i128::from(f.max_raw()) - i128::from(f.min_raw()) + 1;
        let raw = i128::from(raw).rem_euclid(span) + i128::from(f.min_raw());
        Fx::from_raw(raw as i64, f).unwrap()
    }

    /// The listed classification gives, for every sample word, the words
    /// and the quantisation counts of the unit's own arithmetic: 8- and
    /// 12-bit voxels, tables with fewer and more entries than voxel codes
    /// (the weight split both ways), several rounding modes. A sample
    /// format wider than the list's limit classifies through the unit.
    #[test]
    fn listed_classes_are_the_unit_word_for_word() {
        use crate::fixed::{Overflow, Quant};
        let tf = golden::scenes::tf_preset("grey-ramp").unwrap();
        let base = PipelineConfig::default();
        let u = |bits, frac, q| Format::new(bits, frac, false, q, Overflow::Sat).unwrap();
        let cases = [
            base,
            PipelineConfig {
                voxel: u(12, 0, Quant::Trn),
                sample: u(16, 4, Quant::RndConv),
                ..base
            },
            PipelineConfig {
                table_entries: 64,
                color: u(9, 8, Quant::Rnd),
                ..base
            },
            PipelineConfig {
                table_entries: 1 << 12,
                voxel: u(8, 0, Quant::Trn),
                sample: u(13, 5, Quant::Trn),
                alpha: u(12, 12, Quant::RndInf),
                ..base
            },
        ];
        for (n, cfg) in cases.into_iter().enumerate() {
            let bits = u32::from(cfg.voxel.bits());
            let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, bits);
            let dp = Datapath::new(cfg, Tables::new(&cfg, &lut).unwrap());
            assert!(dp.classes.is_some(), "case {n} is listed");
            let mut lit = 0;
            for raw in 0..=cfg.sample.max_raw() {
                let s = Fx::from_raw(raw, cfg.sample).unwrap();
                let (mut a, mut b) = (QuantStats::default(), QuantStats::default());
                let listed = dp.classify(s, &mut a).unwrap();
                let unit = dp.classify_unit(s, &mut b).unwrap();
                assert_eq!(listed, unit, "case {n} word {raw}");
                assert_eq!(a, b, "case {n} word {raw}");
                lit += usize::from(unit.1.raw() > 0);
            }
            assert!(lit > 0, "case {n} classifies something visible");
        }
        let wide = PipelineConfig {
            sample: Format::new(Classes::MAX_BITS + 1, 4, false, Quant::Trn, Overflow::Sat)
                .unwrap(),
            ..base
        };
        let lut = golden::tf::Lut::for_bits(&tf, wide.table_entries as usize, 8);
        assert!(Datapath::new(wide, Tables::new(&wide, &lut).unwrap())
            .classes
            .is_none());
    }

    proptest! {
        /// Where the 64-bit lerp runs, it gives the 128-bit expression's
        /// word and fraction.
        #[test]
        fn lerp64_is_the_wide_lerp(
            r in any::<[i64; 3]>(),
            bits in proptest::array::uniform3(1u8..=63),
            frac in proptest::array::uniform3(0u8..=63),
            signed in any::<[bool; 3]>(),
        ) {
            let v: Vec<Fx> = (0..3).map(|i| fx(r[i], bits[i], frac[i], signed[i])).collect();
            let (a, b, w) = (v[0], v[1], v[2]);
            if let Some(got) = lerp64(a, b, w) {
                let want = Wide::from(a).checked_add(Wide::from(w).checked_mul(b - a).unwrap());
                prop_assert_eq!(got, want.unwrap());
            }
        }
    }

    /// The default widths take the 64-bit path in every lerp of the
    /// datapath (interpolation, classification, the exp table), so the
    /// fast path is the one that runs.
    #[test]
    fn default_lerps_run_in_64_bits() {
        let c = PipelineConfig::default();
        let max = |f: Format| f.max_value();
        for (ab, w) in [
            (c.voxel, c.weight),
            (c.sample, c.weight),
            (c.color, c.weight),
            (c.alpha, c.weight),
            (c.opacity_corr, c.weight),
        ] {
            assert!(
                lerp64(max(ab), ab.min_value(), max(w)).is_some(),
                "{ab:?} {w:?}"
            );
        }
    }
}
