//! The PE's per-sample arithmetic, bit for bit: ray position, bilinear
//! interpolation, classification, opacity correction and compositing, and
//! the Bartlett merge. Each step mirrors its float counterpart in
//! `golden::sampling` / `golden::merge` (same order of operations), and
//! every value is assigned into a declared [`Format`](crate::fixed::Format) of the
//! [`PipelineConfig`]: full-precision operators, quantise on assignment.

use crate::config::PipelineConfig;
use crate::fixed::{Fx, FxError, QuantStats, Wide, Word64};
use crate::tables::Tables;

mod classes;
mod kernel;
mod ops;
mod passes;
mod units;

use classes::Classes;
pub(crate) use kernel::Tents;
pub(crate) use kernel::{Batch, Ray, Tally, LANES};
pub use kernel::{Kernel, KernelRow};
#[cfg(test)]
pub(crate) use ops::isqrt;
use ops::split;
pub use ops::{isqrt_into, lerp};
pub use units::{units_for, FrameUnit, Loaded, UnitFrame};

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
    /// The words the plain sample took at issue, for a capture
    /// ([`crate::cosim::capture`]; zero on other paths).
    pub issue: crate::cosim::capture::SampleIn,
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
    /// The units beside the plain sample with their per-frame constants
    /// ([`Datapath::with_units`]; none by default).
    pub loaded: crate::hw::compose::FrameUnits,
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
            loaded: Default::default(),
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
        self.kernel.as_ref().filter(|_| self.loaded.plain())
    }

    /// The Bartlett merge's assignments worked out once ([`Kernel`]'s,
    /// shaded frames too: the merge is the same), `None` without a
    /// kernel or when a merge format is not modelled.
    pub(crate) fn tents(&self) -> Option<&Tents> {
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

    /// The units beside the plain sample this datapath carries (shading
    /// with its light count, the VOI, pre-integration), as
    /// [`crate::hw::compose`] composes them.
    pub fn units(&self) -> crate::hw::compose::Units {
        self.loaded.units()
    }

    /// This datapath with `loaded`'s units and their constants. A derived
    /// latency becomes the depth of the composed sample's schedule
    /// ([`crate::cost::sample_latency`]): a unit beside the interpolation
    /// or the classification (the VOI's distance and weight, the shading
    /// unit) makes the datapath deeper, which lengthens only what waits
    /// for samples in flight. One the configuration states is kept.
    pub fn with_units(mut self, loaded: crate::hw::compose::FrameUnits) -> Datapath {
        self.loaded = loaded;
        self.latency = u64::from(crate::cost::sample_latency(&self.cfg, self.units()));
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
        Ok(crate::reg!(self.cfg, position).assign(v, st))
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
            crate::reg!(self.cfg, weight).assign(Wide::new(i128::from(r), f as i32), st),
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
        let s = crate::reg!(self.cfg, sample);
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
            (
                i,
                crate::reg!(self.cfg, weight).assign(Wide::new(i128::from(r), f), st),
            )
        } else {
            (s.raw() << (-f) as u32, self.cfg.weight.zero())
        };
        let i = i.max(0) as usize;
        if i >= last {
            return Ok((t.color[last], t.alpha[last]));
        }
        let c = crate::reg!(self.cfg, color);
        let rgb = [
            lerp(t.color[i][0], t.color[i + 1][0], w, c, st)?,
            lerp(t.color[i][1], t.color[i + 1][1], w, c, st)?,
            lerp(t.color[i][2], t.color[i + 1][2], w, c, st)?,
        ];
        let a = lerp(
            t.alpha[i],
            t.alpha[i + 1],
            w,
            crate::reg!(self.cfg, alpha),
            st,
        )?;
        Ok((rgb, a))
    }

    /// Opacity correction `1 - (1 - a)^ds` in the log domain:
    /// `p = -log2(1 - a) ds`, `T = 2^-frac(p)` from the interpolated exp
    /// table, shifted right by `int(p)`, and `a' = 1 - T`.
    #[inline(always)]
    pub fn correct(&self, a: Fx, ds: Fx, st: &mut QuantStats) -> Result<Fx, FxError> {
        let t = &self.tables;
        let lf = crate::reg!(self.cfg, log_transmittance);
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
        let oc = crate::reg!(self.cfg, opacity_corr);
        let fbits = u32::from(lf.frac());
        let (int, frac) = split(p.raw(), fbits);
        let e = u32::from(self.cfg.exp_table_bits);
        let (idx, rem) = split(frac, fbits - e);
        let w = crate::reg!(self.cfg, weight)
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
        let (fc, fa) = (
            crate::reg!(self.cfg, accum_color),
            crate::reg!(self.cfg, accum_alpha),
        );
        let k = Wide::new(1, 0).checked_sub(a)?;
        // The same expressions in 64-bit words where they fit.
        let (a64, k64) = (Word64::of(a), Word64::int(1).checked_sub(Word64::of(a)));
        for (word, &colour) in acc.raw.iter_mut().zip(&c) {
            let old = Fx::from_raw_unchecked(*word, *fc);
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
        let old = Fx::from_raw_unchecked(acc.raw[3], *fa);
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
        let (fc, fa) = (
            crate::reg!(self.cfg, accum_color),
            crate::reg!(self.cfg, accum_alpha),
        );
        let old_a = Fx::from_raw_unchecked(acc.raw[3], *fa);
        let k = Wide::new(1, 0).checked_sub(old_a)?.checked_mul(a)?;
        // The same expressions in 64-bit words where they fit.
        let k64 = Word64::int(1)
            .checked_sub(Word64::of(old_a))
            .and_then(|d| d.checked_mul(Word64::of(a)));
        for (word, &colour) in acc.raw.iter_mut().zip(&c) {
            let old = Fx::from_raw_unchecked(*word, *fc);
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

    /// The ray's path length per slice step, `sqrt(sx^2 + sy^2 + sz^2)`
    /// from its spacing-scaled slopes, truncated into the `path` format
    /// (an exact integer square root).
    #[inline(always)]
    pub fn path(&self, sx: Fx, sy: Fx, sz: Fx, st: &mut QuantStats) -> Result<Fx, FxError> {
        let sum = (sx * sx).checked_add(sy * sy)?.checked_add(sz * sz)?;
        isqrt_into(sum, crate::reg!(self.cfg, path), "path length", st)
    }
}

#[cfg(test)]
mod tests;
