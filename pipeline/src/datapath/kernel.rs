//! The plain sample's datapath (no shading, volume of interest or
//! pre-integration) as the model evaluates it quickly: the same
//! assignments as [`Datapath::position`], [`Datapath::address`],
//! [`Datapath::bilinear`], [`Datapath::classify`], [`Datapath::path`],
//! [`Datapath::correct`] and [`Datapath::composite_btf`] /
//! [`Datapath::composite_ftb`], in the same order, each into the same
//! format, with every assignment's shift, rounding bias and range worked
//! out once per frame ([`Step`]) instead of from the operands' formats at
//! every operation.
//!
//! This is how the model computes, not a different unit: every value is
//! the exact operator result assigned into its register's format, and an
//! assignment's word depends only on the exact value, not on how it is
//! written, so the words and the quantisation counts equal the general
//! path's (tests compare both over many configurations and scenes). A
//! [`Kernel`] exists only for configurations whose every assignment here
//! rounds with `TRN` or `RND` and saturates (`SAT`), and whose widths prove
//! every intermediate fits a 64-bit word; a row's constants
//! ([`Kernel::row`]) only when the broadcast's formats allow the same proof.
//! Anything else runs the general path, as does a sample whose position
//! would not fit (checked per sample) or that breaks the ownership rules
//! (the general path reports it).

#[cfg(test)]
mod description_tests;
mod lanes;
mod step;
mod tent;
#[cfg(test)]
mod tests;

pub(crate) use lanes::{Batch, LANES};
pub(crate) use step::Tally;
use step::{NSLOTS, SLOTS};
pub(crate) use tent::Tents;

use super::{Classes, Datapath};
use crate::config::Order;
use crate::fixed::{Format, Fx};
use crate::reg;
use step::{rnd, Step};

/// `a + w (b - a)` of words `a`, `b` with fraction `fa` and weight `w`
/// with fraction `fw`, exactly, with fraction `fa + fw` (in range by the
/// caller's proof).
#[inline(always)]
fn lerp(a: i64, b: i64, w: i64, fw: u32) -> i64 {
    (a << fw) + w * (b - a)
}

/// Magnitude bits of a format's words.
fn mag(f: Format) -> u32 {
    u32::from(f.bits())
}

/// Ray `m`'s exact `a + m t` (aligned words), or `None` when it would
/// not stay below 2^62.
#[inline(always)]
fn exact(m: i64, a: i64, t: i64) -> Option<i64> {
    let v = m.checked_mul(t)?.checked_add(a)?;
    (v.unsigned_abs() < 1 << 62).then_some(v)
}

/// The classification unit's output for every sample word ([`Classes`]),
/// one 64-bit word each: raw R, G, B (`color_bits` each) and A
/// (`alpha_bits`) side by side from bit 0, and above them
/// ([`ClassTable::events_at`]) the quantisation events classifying the
/// word records: nine counts (slot by slot of [`CLASS_SLOTS`], then
/// assignments, overflows, inexact), each at most 3, in 2-bit fields.
/// Eight bytes a sample word and no second read: the table is read at
/// every sample, at scattered words.
#[derive(Debug, Clone)]
struct ClassTable {
    words: Vec<u64>,
    /// Bits of a colour channel's field.
    color_bits: u32,
    /// Bits of the opacity's field.
    alpha_bits: u32,
    /// Where the event counts start.
    events_at: u32,
}

/// Event counts in a class word.
const EVENTS: u32 = 9;

/// Every third 2-bit event field of a class word's events, spread 6
/// bits apart: a batch adds its lanes' fields `k`, `k + 3`, `k + 6`
/// ([`ClassTable::event_group`]) in one word each, eight lanes of at most
/// 3 staying below 2^6.
const GROUP: u64 = 0b11 | 0b11 << 6 | 0b11 << 12;

impl ClassTable {
    /// The table of `classes`, or `None` when a word does not fit its
    /// field, a count exceeds 3 or the fields do not fit 64 bits.
    fn new(classes: &Classes, color: Format, alpha: Format) -> Option<ClassTable> {
        let (cb, ab) = (mag(color), mag(alpha));
        let events_at = 3 * cb + ab;
        if events_at + 2 * EVENTS > 64 {
            return None;
        }
        let field = |v: i64, bits: u32| u64::try_from(v).ok().filter(|&v| v >> bits == 0);
        let words = classes
            .words
            .iter()
            .map(|(w, ev)| {
                let mut word = 0;
                for (ch, &v) in w.iter().enumerate() {
                    let ch = ch as u32;
                    word |= field(v, if ch < 3 { cb } else { ab })? << (ch * cb);
                }
                for (i, &n) in ev.iter().flatten().enumerate() {
                    word |= field(i64::from(n), 2)? << (events_at + 2 * i as u32);
                }
                Some(word)
            })
            .collect::<Option<Vec<u64>>>()?;
        Some(ClassTable {
            words,
            color_bits: cb,
            alpha_bits: ab,
            events_at,
        })
    }

    /// Group `k` (0..3) of a class word's event fields, each in its own
    /// 6-bit field ([`GROUP`]): counts `k`, `k + 3`, `k + 6`.
    #[inline(always)]
    fn event_group(&self, word: u64, k: u32) -> u64 {
        (word >> (self.events_at + 2 * k)) & GROUP
    }
}

/// The tally slots of the classification's formats (`weight`, `color`,
/// `alpha`, the order of [`super::classes::CLASS_FORMATS`]).
const CLASS_SLOTS: [usize; 3] = {
    let f = super::classes::CLASS_FORMATS;
    let mut out = [0; 3];
    let mut k = 0;
    while k < 3 {
        let mut i = 0;
        while SLOTS[i].index() != f[k].index() {
            i += 1;
        }
        out[k] = i;
        k += 1;
    }
    out
};

/// What [`Kernel::address`] finds for one ray.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ray {
    /// Base column, unclamped.
    pub x0: i64,
    /// x weight (raw `weight`).
    pub wx: i64,
    /// The x slope's exact word.
    pub slope: i64,
}

/// The per-frame constants of the plain sample (no shading, volume of
/// interest or pre-integration): every assignment of
/// [`Datapath::position`], [`Datapath::address`], [`Datapath::bilinear`],
/// [`Datapath::classify`], [`Datapath::path`], [`Datapath::correct`] and
/// the compositing with its shift, rounding bias and range worked out
/// once, so the whole-slice path evaluates a sample on 64-bit words
/// instead of from the operands' formats at every operation. The same
/// words and quantisation counts: an assignment's word depends only on
/// the exact value. Built only for configurations whose every such
/// assignment rounds with `TRN` or `RND` and saturates, and whose widths
/// prove every intermediate fits.
#[derive(Debug, Clone)]
pub struct Kernel {
    ftb: bool,
    threshold: Option<i64>,
    /// The `position` format (the address's fraction bits).
    position: Format,
    /// The `step` format (ray spacings and slope increments).
    step: Format,
    weight: Format,
    /// `a + m t` (positions, `a` in `position` and `t` in `step`, and
    /// slopes alike) at the larger fraction: the shifts aligning `a` and
    /// `t`, and the assignment into `position`.
    line_shift: [u32; 2],
    line: Step,
    /// The y interpolation (sample words times a `weight` word).
    lerp_y: Step,
    /// `sx^2 + sy^2 + sz^2` of `position` words, aligned to the path
    /// format's `2 frac` fraction bits: left (`>= 0`) or right.
    rad_shift: i32,
    /// The root into `path`.
    root: Step,
    /// The position's fraction into `weight`.
    address_w: Step,
    /// The x interpolations: voxel words times an address weight.
    lerp_x: Step,
    /// Classification per sample word.
    classes: ClassTable,
    /// `log_t` raw words.
    log_t: Vec<i64>,
    /// `log_t * ds` into `log_transmittance`.
    log_p: Step,
    p_frac: u32,
    exp_bits: u32,
    /// The exp table's index remainder into `weight`.
    exp_w: Step,
    exp: Vec<i64>,
    /// The exp interpolation into `opacity_corr`.
    exp_lerp: Step,
    /// `opacity_corr` (the transmittance's shift and `1 - T`).
    oc: Format,
    oc_rnd: bool,
    one_minus: Step,
    /// The compositing's colour and opacity assignments.
    comp_c: Step,
    comp_a: Step,
    /// Shifts aligning the compositing's terms to their common fraction.
    comp_shift: [u32; 2],
    /// `accum_alpha`'s fraction bits.
    alpha_frac: u32,
    /// The Bartlett merge's assignments, when modelled.
    tents: Option<Tents>,
    /// The assignments into each slot of a batch lane in use and of a
    /// visible one ([`Kernel::settle`]), besides the classification's
    /// (counted from its table) and the transmittance's shift (counted
    /// where it assigns).
    per_lane: [[u64; NSLOTS]; 2],
}

/// A row's constants for [`Kernel`]: the broadcast's words aligned to the
/// fractions the kernel computes in.
#[derive(Debug, Clone, Copy)]
pub struct KernelRow {
    /// `a`, `t` of the slice's x position, aligned.
    a: i64,
    t: i64,
    /// `b`, `k` of the ray's x slope, aligned.
    b: i64,
    k: i64,
    /// The y weight's word.
    wy: i64,
    /// `sy^2 + sz^2` (both `position` words, so at twice its fraction).
    yz: i64,
}

impl KernelRow {
    /// The row's y weight word and `sy^2 + sz^2`, a column batch's
    /// per-lane constants ([`Batch`]).
    #[inline(always)]
    pub(crate) fn lane_constants(&self) -> (i64, i64) {
        (self.wy, self.yz)
    }
}

impl Kernel {
    /// The kernel of `dp`'s configuration, or `None` when some assignment
    /// is not modelled or a width does not prove its intermediate fits.
    pub(super) fn new(dp: &Datapath, classes: &Classes) -> Option<Kernel> {
        let c = &dp.cfg;
        let t = &dp.tables;
        let fw = u32::from(c.weight.frac());
        let fpos = u32::from(c.position.frac());
        let address_w = Step::new(fpos as i32, fpos, reg!(c, weight))?;
        let fstep = u32::from(c.step.frac());
        let fline = fpos.max(fstep);
        // The exact `a + m t` is checked below 2^62 per sample.
        let line = Step::new(fline as i32, 62, reg!(c, position))?;
        let line_shift = [fline - fpos, fline - fstep];
        let fs = u32::from(c.sample.frac());
        let lerp_y = Step::new(
            (fs + fw) as i32,
            mag(c.sample) + mag(c.weight) + 2,
            reg!(c, sample),
        )?;
        // Three squares of `position` words: below 2^(2 bits + 2).
        let rad_bits = 2 * mag(c.position) + 2;
        let pf = i32::from(c.path.frac());
        let rad_shift = 2 * pf - 2 * fpos as i32;
        if rad_bits as i32 + rad_shift.max(0) > 62 || c.path.is_signed() {
            return None;
        }
        let root = Step::new(pf, 62, reg!(c, path))?;
        let voxel_frac = u32::from(c.voxel.frac());
        // A lerp's words stay below 2^(B + bw + 2) (see `super::lerp64`).
        let lerp_bits = |ab: Format| mag(ab) + mag(c.weight) + 2;
        let lerp_x = Step::new(
            (voxel_frac + fw) as i32,
            lerp_bits(c.voxel),
            reg!(c, sample),
        )?;
        if c.voxel.is_signed() || c.sample.is_signed() || c.weight.is_signed() {
            return None;
        }
        // The taps are voxel words (`0..=vmax`), and a weight word of at
        // most 2^fw makes each interpolation a convex combination:
        // `a (2^fw - w) + b w` of words in `0..=hi` lies in `0..=hi << fw`.
        // Where both ends assign in range, no tap can overflow the sample.
        let convex = c.weight.max_raw() <= 1 << fw;
        let vmax = c.voxel.max_raw();
        let mut lerp_x = lerp_x;
        lerp_x.in_range = convex && lerp_x.holds(0, vmax << fw);
        let smax = lerp_x.eval(vmax << fw).0;
        let mut lerp_y = lerp_y;
        lerp_y.in_range = convex && lerp_y.holds(0, smax << fw);
        let classes = ClassTable::new(classes, c.color, c.alpha)?;
        let raw_of = |v: &[Fx]| -> Option<(Vec<i64>, Format)> {
            let f = v.first()?.format();
            v.iter()
                .all(|x| x.format() == f)
                .then(|| (v.iter().map(|x| x.raw()).collect(), f))
        };
        let (log_t, lf_t) = raw_of(&t.log_t)?;
        let (exp, ef) = raw_of(&t.exp)?;
        let lf = c.log_transmittance;
        let (log_frac, log_bits) = (u32::from(lf_t.frac()), mag(lf_t));
        let path = c.path;
        if lf.is_signed() || path.is_signed() || lf_t.is_signed() || ef.is_signed() {
            return None;
        }
        let log_p = Step::new(
            (log_frac + u32::from(path.frac())) as i32,
            log_bits + mag(path),
            reg!(c, log_transmittance),
        )?;
        let p_frac = u32::from(lf.frac());
        let exp_bits = u32::from(c.exp_table_bits);
        let rem = p_frac.checked_sub(exp_bits)?;
        let exp_w = Step::new(rem as i32, rem, reg!(c, weight))?;
        let exp_frac = u32::from(ef.frac());
        let oc = c.opacity_corr;
        let exp_lerp = Step::new((exp_frac + fw) as i32, lerp_bits(ef), reg!(c, opacity_corr))?;
        let oc_rnd = rnd(oc)?;
        // The transmittance's shift is taken up to 62 bits: an `oc` word
        // below 2^61 shifted 62 or more is 0 either way.
        if mag(oc) > 60 || oc.is_signed() {
            return None;
        }
        let foc = u32::from(oc.frac());
        let one_minus = Step::new(foc as i32, mag(oc).max(foc + 1) + 1, reg!(c, opacity_corr))?;
        let (fc, fac, faa) = (
            u32::from(c.color.frac()),
            u32::from(c.accum_color.frac()),
            u32::from(c.accum_alpha.frac()),
        );
        // `k = 1 - a` (back to front) or `(1 - A) a` (front to back) stays
        // below 2^kb.
        let kb = mag(oc).max(foc + 1) + 1;
        let ftb = c.order == Order::FrontToBack;
        let (comp_c, comp_a, comp_shift) = if ftb {
            let kb = mag(c.accum_alpha).max(faa + 1) + 1 + mag(oc);
            let f = fac.max(faa + foc + fc);
            let sh = [f - fac, f - (faa + foc + fc)];
            let bits = (mag(c.accum_color) + sh[0]).max(kb + mag(c.color) + sh[1]) + 1;
            let fa = faa + foc;
            let abits = (mag(c.accum_alpha) + foc).max(kb) + 1;
            (
                Step::new(f as i32, bits, reg!(c, accum_color))?,
                Step::new(fa as i32, abits, reg!(c, accum_alpha))?,
                sh,
            )
        } else {
            let f = foc + fc.max(fac);
            let sh = [f - foc - fc, f - foc - fac];
            let bits = (mag(oc) + mag(c.color) + sh[0]).max(kb + mag(c.accum_color) + sh[1]) + 1;
            let fa = foc + faa;
            let abits = (mag(oc) + faa).max(kb + mag(c.accum_alpha)) + 1;
            (
                Step::new(f as i32, bits, reg!(c, accum_color))?,
                Step::new(fa as i32, abits, reg!(c, accum_alpha))?,
                sh,
            )
        };
        let signed = [c.color, c.alpha, c.accum_color, c.accum_alpha];
        if signed.iter().any(|f| f.is_signed()) {
            return None;
        }
        // Every lane in use interpolates (two x steps, one y step); a
        // visible one takes the slope, the root, the opacity correction's
        // three steps and `1 - T`, and the four compositing steps: the
        // steps `Kernel::sample_lanes` runs.
        let mut per_lane = [[0; NSLOTS]; 2];
        for s in [&lerp_x, &lerp_x, &lerp_y] {
            per_lane[0][s.slot] += 1;
        }
        let shown = [
            &line, &root, &log_p, &exp_w, &exp_lerp, &one_minus, &comp_c, &comp_c, &comp_c, &comp_a,
        ];
        for s in shown {
            per_lane[1][s.slot] += 1;
        }
        Some(Kernel {
            per_lane,
            ftb,
            threshold: dp.threshold,
            position: c.position,
            step: c.step,
            weight: c.weight,
            line_shift,
            line,
            lerp_y,
            rad_shift,
            root,
            address_w,
            lerp_x,
            classes,
            log_t,
            log_p,
            p_frac,
            exp_bits,
            exp_w,
            exp,
            exp_lerp,
            oc,
            oc_rnd,
            one_minus,
            comp_c,
            comp_a,
            comp_shift,
            alpha_frac: faa,
            tents: Tents::new(c),
        })
    }

    /// Adds the assignments of the lanes `t` counted ([`Tally::lanes`])
    /// to its counts: each lane in use and each visible lane assigns a
    /// fixed number of words into each slot.
    pub(crate) fn settle(&self, t: &mut Tally) {
        for (n, per) in t.lanes.iter().zip(&self.per_lane) {
            for (c, &k) in t.counts.iter_mut().zip(per) {
                c[0] += n * k;
            }
        }
        t.lanes = [0; 2];
    }

    /// The Bartlett merge's assignments, when modelled.
    pub(crate) fn tents(&self) -> Option<&Tents> {
        self.tents.as_ref()
    }

    /// Whether the frame composites front to back (the termination flag
    /// follows each composited sample).
    #[inline(always)]
    pub fn front_to_back(&self) -> bool {
        self.ftb
    }

    /// A row's constants, from the slice's x position `(a, t)`, the
    /// region's x slope `(b, k)`, the row's y weight and its y and z slope
    /// terms; `None` when their formats are not the configuration's
    /// (`position`, `step`, `weight`), for which the kernel's width
    /// proofs were made (the row then runs the general path).
    pub fn row(
        &self,
        (a, t): (Fx, Fx),
        (b, k): (Fx, Fx),
        wy: Fx,
        (sy, sz): (Fx, Fx),
    ) -> Option<KernelRow> {
        let (p, st) = (self.position, self.step);
        let formats = [a, t, b, k, wy, sy, sz].map(Fx::format);
        if formats != [p, st, p, st, self.weight, p, p] {
            return None;
        }
        let [sa, st] = self.line_shift;
        // Exact left shifts of words: a word that would not come back
        // leaves the row to the general path.
        let up = |v: i64, s: u32| v.checked_shl(s).filter(|w| w >> s == v);
        let (y, z) = (sy.raw(), sz.raw());
        Some(KernelRow {
            a: up(a.raw(), sa)?,
            t: up(t.raw(), st)?,
            b: up(b.raw(), sa)?,
            k: up(k.raw(), st)?,
            wy: wy.raw(),
            yz: y * y + z * z,
        })
    }

    /// The base column (unclamped) and x weight of ray `m`'s sample, with
    /// the counts of their assignments in `tally`, and the exact word of
    /// the ray's x slope `b + m k` (assigned only if the sample is
    /// visible). `None`: a word would not stay below 2^62, and the general
    /// path takes the sample.
    #[inline(always)]
    pub(crate) fn address(&self, row: &KernelRow, m: i64, tally: &mut Tally) -> Option<Ray> {
        let slope = exact(m, row.b, row.k)?;
        let x = self.line.apply(exact(m, row.a, row.t)?, tally);
        let f = u32::from(self.position.frac());
        let w = self.address_w.apply(x & ((1i64 << f) - 1), tally);
        Some(Ray {
            x0: x >> f,
            wx: w,
            slope,
        })
    }
}
