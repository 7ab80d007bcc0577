//! The kernel in lanes: up to [`LANES`] plain samples of one ray column
//! at once (the column's rays in consecutive rows of a slice, whose
//! accumulators lie side by side in memory), each operation a loop over
//! the lanes, which the compiler turns into vector instructions (one
//! 512-bit register holds the eight 64-bit words); the per-lane event
//! flags are vector compares into bit masks ([`wide::i64x8`]). Lane by lane the same
//! words and the same quantisation events as the general datapath's
//! [`Datapath::bilinear`], [`Datapath::classify`], [`Datapath::path`],
//! [`Datapath::correct`] and compositing (a proptest compares them); the
//! rays are independent (each has its own accumulators), so evaluating
//! eight together changes nothing but speed.
//!
//! Every lane computes every step: a transparent sample's lane runs the
//! opacity correction and compositing too, and its results and their
//! events are dropped (what the general path never computes, it never
//! counts). Lanes at and above [`Batch::n`] are padding copied from lane
//! 0, computed and dropped likewise.

use super::{lerp, Kernel, Step, Tally, CLASS_SLOTS};
#[cfg(doc)]
use crate::datapath::Datapath;
use wide::i64x8;

/// Lanes of a batch: eight 64-bit words (an [`i64x8`]).
pub(crate) const LANES: usize = 8;

type Lanes = [i64; LANES];

/// Which lanes count their events: bit `l` for lane `l`.
pub(crate) type Mask = u8;

/// Up to [`LANES`] plain samples of one ray column (one `mx`, so one x
/// address and slope), each lane a row of the slice.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Batch {
    /// Lanes in use; the rest are padding.
    pub n: usize,
    /// The column's x weight and the exact word of its x slope (the same
    /// in every lane).
    pub wx: i64,
    pub slope: i64,
    /// Each lane's y weight and `sy^2 + sz^2` ([`super::KernelRow`]).
    pub wy: Lanes,
    pub yz: Lanes,
    /// Voxel taps: row `y0` at columns `c0`, `c1`, then row `y0 + 1`.
    pub v: [Lanes; 4],
    /// The rays' accumulators (R, G, B, A words), replaced by
    /// [`Kernel::sample_lanes`] in the lanes whose sample is visible.
    pub acc: [Lanes; 4],
    /// Which lanes' samples were visible (composited), bit `l` for lane
    /// `l`.
    pub visible: Mask,
    /// Front to back, each visible lane's termination comparator, bit `l`
    /// for lane `l`.
    pub done: Mask,
}

impl Batch {
    /// Copies lane 0's inputs into the padding lanes.
    #[inline(always)]
    pub(crate) fn pad(&mut self) {
        for l in self.n..LANES {
            self.wy[l] = self.wy[0];
            self.yz[l] = self.yz[0];
            for w in self.v.iter_mut().chain(self.acc.iter_mut()) {
                w[l] = w[0];
            }
        }
    }
}

impl Step {
    /// [`Step::apply`] in every lane, counting the overflows and inexact
    /// assignments of the lanes `on` marks: each lane's flags gathered
    /// into a bit mask, the marked ones counted (a compare mask and a
    /// population count per step, not a counter per lane). The
    /// assignments themselves are counted per lane ([`Tally::lanes`],
    /// [`Kernel::settle`]). Overflows are rare (a saturating clamp), so
    /// their count is added only when some marked lane overflowed, and
    /// a step proven in range ([`Step::in_range`]) neither clamps nor
    /// looks; an
    /// assignment that drops no bits (`mask` 0) is never inexact, so its
    /// test is left out.
    #[inline(always)]
    fn lanes(&self, raw: &Lanes, t: &mut Tally, on: Mask) -> Lanes {
        let q = each(|l| (((raw[l] << self.left) >> self.sh1) + self.add) >> self.sh2);
        let n = &mut t.counts[self.slot];
        let out = if self.in_range {
            q
        } else {
            let out = each(|l| q[l].max(self.min).min(self.max));
            let over = ne_mask(&out, &q) & on;
            if over != 0 {
                n[1] += u64::from(over.count_ones());
            }
            out
        };
        if self.mask != 0 {
            let inexact = nonzero_mask(&each(|l| raw[l] & self.mask)) & on;
            n[2] += u64::from(inexact.count_ones());
        }
        out
    }
}

/// The lanes where `a` and `b` differ, bit `l` for lane `l`: one vector
/// compare into a mask register (a loop gathering the flags bit by bit
/// compiles to a scalar chain of shifts and ors).
#[inline(always)]
fn ne_mask(a: &Lanes, b: &Lanes) -> Mask {
    i64x8::new(*a).simd_ne(i64x8::new(*b)).to_bitmask() as Mask
}

/// The lanes whose word is not zero, bit `l` for lane `l`.
#[inline(always)]
fn nonzero_mask(a: &Lanes) -> Mask {
    ne_mask(a, &[0; LANES])
}

/// `f` of every lane (a plain loop, which vectorises; `array::from_fn`'s
/// guarded writes did not).
#[inline(always)]
fn each(f: impl Fn(usize) -> i64) -> Lanes {
    let mut out = [0; LANES];
    for (l, o) in out.iter_mut().enumerate() {
        *o = f(l);
    }
    out
}

/// [`lerp`] in every lane.
#[inline(always)]
fn lerps(a: &Lanes, b: &Lanes, w: &Lanes, fw: u32) -> Lanes {
    each(|l| lerp(a[l], b[l], w[l], fw))
}

/// [`crate::datapath::ops::isqrt`] in every lane: the float estimate of a root below
/// 2^31 is within one of it (its error is below 2^-20), so one correction
/// each way makes it exact. The truncated estimate, an integer below
/// 2^31, is read from the bits of its sum with 2^52 (exact, the sum's
/// unit in the last place being 1): a vector add and subtract, where a
/// float-to-integer conversion (`as`, which saturates) compiles to a
/// scalar compare and conversion per lane.
#[inline(always)]
fn isqrts(v: &Lanes) -> Lanes {
    const MAGIC: f64 = (1u64 << 52) as f64;
    let mut out = [0; LANES];
    for l in 0..LANES {
        let v = v[l].max(0);
        let est = (v as f64).sqrt().trunc();
        let mut r = ((est + MAGIC).to_bits() - MAGIC.to_bits()) as i64;
        r -= i64::from(r * r > v);
        r += i64::from((r + 1) * (r + 1) <= v);
        out[l] = r;
    }
    out
}

impl Kernel {
    /// The sample after its address ([`Kernel::address`]) in every lane
    /// of `b` (padded, taps and accumulators loaded): the bilinear
    /// interpolation, the classification, and for a visible sample the
    /// path length, the opacity correction and the compositing. `t` counts
    /// what every lane in use assigns (the interpolation and
    /// classification) and what only a visible one does (the rest). Sets
    /// [`Batch::visible`] and [`Batch::done`] and replaces the visible
    /// lanes' accumulators.
    #[cfg(test)]
    pub(crate) fn sample_lanes(&self, b: &mut Batch, t: &mut Tally) {
        self.sample_lanes_with(b, t, |_| {});
    }

    /// [`Kernel::sample_lanes`] with the accumulators loaded by `load`
    /// only once some lane's sample is visible (a transparent sample
    /// never reads them): a column's transparent batches skip the copy.
    /// Until `load` runs, `b.acc` holds whatever words it held, which the
    /// interpolation and the classification do not read; after it, the
    /// lanes `load` leaves alone hold accumulator words of earlier
    /// batches, in range like any (their results are dropped).
    #[inline(always)]
    pub(crate) fn sample_lanes_with(
        &self,
        b: &mut Batch,
        t: &mut Tally,
        load: impl FnOnce(&mut Batch),
    ) {
        let fw = u32::from(self.weight.frac());
        let wx = [b.wx; LANES];
        // `n <= LANES = 8`, so the shift stays below 16.
        let used = ((1u16 << b.n) - 1) as Mask;
        let top = self
            .lerp_x
            .lanes(&lerps(&b.v[0], &b.v[1], &wx, fw), t, used);
        let bot = self
            .lerp_x
            .lanes(&lerps(&b.v[2], &b.v[3], &wx, fw), t, used);
        let s = self.lerp_y.lanes(&lerps(&top, &bot, &b.wy, fw), t, used);
        let table = &self.classes;
        let (cb, ab) = (table.color_bits, table.alpha_bits);
        let (cm, am) = ((1u64 << cb) - 1, (1u64 << ab) - 1);
        // The table's words first (eight loads), then each field of every
        // lane in its own loop, each a few vector operations.
        let mut words = [0u64; LANES];
        for (w, &s) in words.iter_mut().zip(&s) {
            *w = table.words[s as usize];
        }
        let mut rgba = [[0; LANES]; 4];
        for (ch, w) in rgba[..3].iter_mut().enumerate() {
            *w = each(|l| ((words[l] >> (ch as u32 * cb)) & cm) as i64);
        }
        rgba[3] = each(|l| ((words[l] >> (3 * cb)) & am) as i64);
        // The lanes in use as all-ones words, the rest zero (a compare of
        // the lane numbers, one vector operation).
        let in_use = each(|l| -i64::from(l < b.n));
        let mut groups = [0u64; 3];
        for (k, g) in groups.iter_mut().enumerate() {
            for l in 0..LANES {
                *g += table.event_group(words[l], k as u32) & in_use[l] as u64;
            }
        }
        let shown = nonzero_mask(&rgba[3]);
        b.visible = shown;
        t.lanes[0] += u64::from(used.count_ones());
        // Count `i` (format `i / 3`, kind `i % 3`) is field `i / 3` of
        // group `i % 3`.
        for (f, &slot) in CLASS_SLOTS.iter().enumerate() {
            for (k, n) in t.counts[slot].iter_mut().enumerate() {
                let i = 3 * f + k;
                *n += (groups[i % 3] >> (6 * (i / 3))) & 63;
            }
        }
        let shown = shown & used;
        if shown == 0 {
            return;
        }
        t.lanes[1] += u64::from(shown.count_ones());
        load(b);
        // The x slope is the column's, the same word in every lane: one
        // assignment evaluated once, its events those of every lane shown.
        let (sx, over, inexact) = self.line.eval(b.slope);
        let all = |f: bool| if f { Mask::MAX } else { 0 };
        t.events(self.line.slot, shown, all(over), all(inexact));
        let rs = self.rad_shift;
        let rad: Lanes = each(|l| {
            let sum = sx * sx + b.yz[l];
            if rs >= 0 {
                sum << rs
            } else {
                sum >> -rs
            }
        });
        let ds = self.root.lanes(&isqrts(&rad), t, shown);
        let a = self.correct_lanes(&rgba[3], &ds, t, shown);
        let new = if self.ftb {
            self.composite_ftb_lanes(&b.acc, &rgba, &a, t, shown)
        } else {
            self.composite_btf_lanes(&b.acc, &rgba, &a, t, shown)
        };
        for (w, n) in b.acc.iter_mut().zip(&new) {
            for l in 0..LANES {
                w[l] = if (b.visible >> l) & 1 != 0 {
                    n[l]
                } else {
                    w[l]
                };
            }
        }
        b.done = match self.threshold {
            Some(th) if self.ftb => ne_mask(&each(|l| i64::from(new[3][l] >= th)), &[0; LANES]),
            _ => 0,
        };
    }

    /// [`Datapath::correct`] and [`Datapath::transmit`] in every lane: the
    /// corrected opacity words.
    #[inline(always)]
    fn correct_lanes(&self, alpha: &Lanes, ds: &Lanes, t: &mut Tally, on: Mask) -> Lanes {
        let last = self.log_t.len() - 1;
        let prod: Lanes = each(|l| self.log_t[(alpha[l].max(0) as usize).min(last)] * ds[l]);
        let p = self.log_p.lanes(&prod, t, on);
        let fb = self.p_frac;
        let rb = fb - self.exp_bits;
        let mut int = [0; LANES];
        let mut idx = [0; LANES];
        let mut rem = [0; LANES];
        for l in 0..LANES {
            int[l] = p[l] >> fb;
            let frac = p[l] & ((1i64 << fb) - 1);
            idx[l] = frac >> rb;
            rem[l] = frac & ((1i64 << rb) - 1);
        }
        let w = self.exp_w.lanes(&rem, t, on);
        let lo: Lanes = each(|l| self.exp[idx[l] as usize]);
        let hi: Lanes = each(|l| self.exp[idx[l] as usize + 1]);
        let fw = u32::from(self.weight.frac());
        let tf = self.exp_lerp.lanes(&lerps(&lo, &hi, &w, fw), t, on);
        let (min, max) = (self.oc.min_raw(), self.oc.max_raw());
        let foc = u32::from(self.oc.frac());
        // `tf >> int` into `opacity_corr` (no assignment at all when
        // `int >= 64`: the transmittance is zero).
        let shifts = ne_mask(&each(|l| i64::from(int[l] < 64)), &[0; LANES]);
        let k = each(|l| int[l].clamp(0, 62));
        let r = each(|l| i64::from(self.oc_rnd && k[l] > 0));
        let q = each(|l| ((tf[l] >> (k[l] - r[l])) + r[l]) >> r[l]);
        let c = each(|l| q[l].max(min).min(max));
        let over = shifts & ne_mask(&c, &q);
        let inexact = shifts & nonzero_mask(&each(|l| tf[l] & ((1i64 << k[l]) - 1)));
        let diff = each(|l| (1i64 << foc) - if int[l] < 64 { c[l] } else { 0 });
        t.count(self.one_minus.slot, on & shifts, over, inexact);
        self.one_minus.lanes(&diff, t, on)
    }

    /// [`Datapath::composite_btf`] in every lane: the new accumulators.
    #[inline(always)]
    fn composite_btf_lanes(
        &self,
        acc: &[Lanes; 4],
        c: &[Lanes; 4],
        a: &Lanes,
        t: &mut Tally,
        on: Mask,
    ) -> [Lanes; 4] {
        let foc = u32::from(self.oc.frac());
        let k: Lanes = each(|l| (1i64 << foc) - a[l]);
        let [sc, so] = self.comp_shift;
        let mut new = [[0; LANES]; 4];
        for ch in 0..3 {
            let v: Lanes = each(|l| ((a[l] * c[ch][l]) << sc) + ((k[l] * acc[ch][l]) << so));
            new[ch] = self.comp_c.lanes(&v, t, on);
        }
        let v: Lanes = each(|l| (a[l] << self.alpha_frac) + k[l] * acc[3][l]);
        new[3] = self.comp_a.lanes(&v, t, on);
        new
    }

    /// [`Datapath::composite_ftb`] in every lane: the new accumulators.
    #[inline(always)]
    fn composite_ftb_lanes(
        &self,
        acc: &[Lanes; 4],
        c: &[Lanes; 4],
        a: &Lanes,
        t: &mut Tally,
        on: Mask,
    ) -> [Lanes; 4] {
        let k: Lanes = each(|l| ((1i64 << self.alpha_frac) - acc[3][l]) * a[l]);
        let [so, sc] = self.comp_shift;
        let mut new = [[0; LANES]; 4];
        for ch in 0..3 {
            let v: Lanes = each(|l| (acc[ch][l] << so) + ((k[l] * c[ch][l]) << sc));
            new[ch] = self.comp_c.lanes(&v, t, on);
        }
        let foc = u32::from(self.oc.frac());
        let v: Lanes = each(|l| (acc[3][l] << foc) + k[l]);
        new[3] = self.comp_a.lanes(&v, t, on);
        new
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// The lanes' one-step corrected root is the exact integer root
        /// for every radicand the kernel forms (below 2^62), near squares
        /// included.
        #[test]
        fn lane_roots_are_exact(v in prop_oneof![
            0i64..(1i64 << 62),
            (0i64..(1i64 << 31)).prop_map(|r| r * r),
            (1i64..(1i64 << 31)).prop_map(|r| r * r - 1),
        ]) {
            let got = isqrts(&[v; LANES]);
            let want = crate::datapath::isqrt(v as u128) as i64;
            prop_assert!(got.iter().all(|&g| g == want), "{v}: {got:?} vs {want}");
        }
    }
}
