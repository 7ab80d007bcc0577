//! The PE's pre-integration unit, bit for bit: the fixed-point twin of
//! golden's pre-integrated step ([`golden::preint::PreTable::lookup`] and
//! [`golden::preint::segment_opacity`], as `golden::sampling` composites
//! them), which classifies a ray's step from slice `z` to slice `z + 1` as
//! a whole from its front and back scalars.
//!
//! **The back scalar is the ray's previous sample.** Within a region a
//! ray's crossing of slice `z + 1` is the sample it took one pass earlier
//! (back to front) or takes one pass later (front to back), at the
//! position the host's plan of that slice gives. So each ray keeps its
//! last sample word in a register beside its accumulators
//! ([`crate::pe::RayColumn::prev`]), which migrates with the ray and is
//! dropped at a merge or split. The controller broadcasts, per pass, which
//! rays composite a step, which record their sample and which take
//! slice 0's half step in front ([`crate::host::PreStep`]); a region's
//! first pass back to front (a *prime*) and its last front to back (a
//! *finish*) sample the next region's first slice, or the volume's face,
//! with this region's plan ([`crate::host::preint_passes`]).
//!
//! **The unit.** Per step, from sample words `s_f`, `s_b`:
//!
//! 1. table positions `f = s K` with `K = 2^shift (bins - 1) / (entries -
//!    1)` (golden's bin per table entry; a per-frame constant in
//!    [`PipelineConfig::step`]), exact, split into a bin index and a
//!    [`PipelineConfig::weight`] (truncating the position's fraction, as
//!    the classification's table position does);
//! 2. four words of a `(bins + 1)^2` table (golden's, with its last row
//!    and column repeated so the top bin interpolates without a special
//!    case) per channel: extinction-weighted colour in
//!    [`PipelineConfig::preint_color`], mean extinction in `log2` units in
//!    [`PipelineConfig::preint_tau`];
//! 3. bilinear interpolation of the four channels, along the back scalar
//!    first on both rows, then along the front, each lerp assigned into
//!    its channel's format (golden's order);
//! 4. `p = tau len` into [`PipelineConfig::log_transmittance`] (a whole
//!    step's `len` is the ray's path length per slice step in
//!    [`PipelineConfig::path`]; a half step's is half of it, exactly);
//!    the opacity `1 - 2^-p` from the opacity correction's own
//!    [`Datapath::transmit`] stage;
//! 5. the colour `min(wc / tau, 1)` per channel from a divider into
//!    [`PipelineConfig::color`]: the quotient truncated to
//!    [`GUARD_BITS`] bits below `color`'s LSB, then assigned with the
//!    format's rounding.
//!
//! A step whose interpolated extinction is zero composites nothing
//! (golden's `a > 0`).
//!
//! **The exact colouring** (golden's [`golden::preint::Colouring::Exact`]):
//! the same steps 1 to 4 and 5, and between them the colour words come
//! from a depth-layered table instead of step 2's words:
//!
//! 4b. the layer and weight from `p` (the `log_transmittance` word of
//!    step 4): below `2^LAYER_MIN_EXP`, layer 0 with weight
//!    `p / 2^LAYER_MIN_EXP` (the word's bits, shifted); at or above
//!    `2^LAYER_MAX_EXP`, the last layer with weight 0; else with `b` the
//!    position of `p`'s leading one, layer `1 + 2 (b - frac - LAYER_MIN_EXP)
//!    + bit(b - 1)` and weight the bits below `b - 1` (truncated into
//!    [`PipelineConfig::weight`]) — a leading-one detector and a shifter;
//! 4c. three channels of the layer's `(bins + 1)^2` table
//!    ([`PipelineConfig::preint_color`], layer 0 being step 2's colour
//!    words) at step 1's bins and weights, interpolated as in step 3, and
//!    of the next layer when the weight is not zero, then one lerp per
//!    channel between the two layers (into `preint_color`).
//!
//! Step 5 divides those colour words by step 3's extinction. So the
//! exact colouring adds the layers' memory (`LAYERS - 1` more colour
//! tables), a second, dependent table read after `p`, nine lerps and the
//! layer position; the extinction, opacity and divider are unchanged.

use golden::preint::{Colouring, PreTable, LAYERS, LAYER_MAX_EXP, LAYER_MIN_EXP};

use crate::config::PipelineConfig;
use crate::datapath::{lerp, Datapath, FrameUnit, Loaded, UnitFrame};
use crate::fixed::{Fx, FxError, QuantStats, Wide};
use crate::hw::compose::FrameUnits;

/// Guard bits of the colour divider's quotient below `color`'s LSB.
pub const GUARD_BITS: i32 = 8;

/// The pre-integration unit's per-frame constants and table.
#[derive(Debug, Clone)]
pub struct PreintUnit {
    /// Bins per table axis (golden's).
    bins: usize,
    /// Bin position per sample unit, `K` (`step`).
    scale: Fx,
    /// `(bins + 1)^2` entries, `[front * (bins + 1) + back]`: R, G, B in
    /// `preint_color`, extinction in `preint_tau`.
    table: Vec<[Fx; 4]>,
    /// The exact colouring's layers 1 and up, `(bins + 1)^2` entries each
    /// (`[(layer - 1) (bins + 1)^2 + front (bins + 1) + back]`), R, G, B
    /// in `preint_color`; empty for the fast colouring.
    layers: Vec<[Fx; 3]>,
    /// Golden's classification-table entries per bin
    /// ([`PreTable::stride`]), which the occupancy memory's bin ranges
    /// follow ([`crate::skip::plan_preint_mask`]).
    stride: f64,
}

/// A step's interpolated table words (step 3) and the bins and weights
/// they were read at, which the exact colouring's layer read reuses
/// (step 4c). Dereferences to the four words.
#[derive(Debug, Clone, Copy)]
pub struct PreintWords {
    /// R, G, B in `preint_color`, extinction in `preint_tau`.
    pub words: [Fx; 4],
    /// Front and back bins and weights (step 1).
    at: [(usize, Fx); 2],
}

impl std::ops::Deref for PreintWords {
    type Target = [Fx; 4];
    fn deref(&self) -> &[Fx; 4] {
        &self.words
    }
}

/// The words of one step, for waveforms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PreintTrace {
    /// The back scalar the step used, raw `sample`.
    pub back: i64,
    /// The interpolated extinction, raw `preint_tau`.
    pub tau: i64,
}

/// Why the unit could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum PreintError {
    /// A table word or the scale does not fit its format.
    #[error("pre-integration table: {0}")]
    Fixed(#[from] FxError),
    /// The table's geometry does not match the classification table.
    #[error("pre-integration needs the classification table's {0}")]
    Table(String),
    /// The frame asks for what a pre-integrated frame does not model.
    #[error("{0}")]
    Unsupported(String),
}

/// The frame's pre-integration table ([`crate::datapath::FrameUnit`]),
/// pre-integrated from the frame's classification table: quantised into
/// the unit. A frame clipped by planes is refused (the unit integrates
/// whole steps).
impl FrameUnit for PreTable {
    fn load(&self, f: &UnitFrame, units: &mut FrameUnits, st: &mut QuantStats) -> Loaded {
        if f.clipped {
            return Err(PreintError::Unsupported(
                "the pipeline's pre-integrated frames take no clip planes; drop --clip or --preintegrate"
                    .into(),
            )
            .into());
        }
        let entries = f.dp.tables().color.len();
        units.preint = Some(PreintUnit::new(&f.dp.cfg, self, entries, st)?);
        Ok(())
    }
}

impl PreintUnit {
    /// Quantises golden's table `pt`, pre-integrated from a classification
    /// table of `entries` entries, for `cfg`. Counts the host's roundings
    /// into `st`.
    pub fn new(
        cfg: &PipelineConfig,
        pt: &PreTable,
        entries: usize,
        st: &mut QuantStats,
    ) -> Result<PreintUnit, PreintError> {
        if pt.colouring() == Colouring::Attenuated {
            return Err(PreintError::Unsupported(format!(
                "the pre-integration unit models the fast and exact colourings, not {}",
                pt.colouring().name()
            )));
        }
        let exact = pt.colouring() == Colouring::Exact;
        let lf = i32::from(cfg.log_transmittance.frac());
        if exact && lf + LAYER_MIN_EXP < 1 {
            return Err(PreintError::Unsupported(format!(
                "the exact colouring's depth layers need log_transmittance.frac >= {}, not {lf}",
                1 - LAYER_MIN_EXP
            )));
        }
        let bins = pt.bins;
        if bins < 2 || entries < bins || entries != cfg.table_entries as usize {
            return Err(PreintError::Table(format!(
                "{} entries (the table has {bins} bins over {entries})",
                cfg.table_entries
            )));
        }
        let mut q = |f: crate::config::Reg, v: f64| -> Result<Fx, FxError> {
            let r = f.from_f64(v)?;
            st.record_as(f.id, &r);
            Ok(r.value)
        };
        let k = 2f64.powi(cfg.table_shift()) * (bins - 1) as f64 / (entries - 1) as f64;
        let scale = q(crate::reg!(cfg, step), k)?;
        let ln2 = std::f64::consts::LN_2;
        let n = bins + 1;
        let mut table = Vec::with_capacity(n * n);
        for i in 0..n {
            for j in 0..n {
                let e = pt.entry(i.min(bins - 1), j.min(bins - 1));
                table.push([
                    q(crate::reg!(cfg, preint_color), f64::from(e[0]) / ln2)?,
                    q(crate::reg!(cfg, preint_color), f64::from(e[1]) / ln2)?,
                    q(crate::reg!(cfg, preint_color), f64::from(e[2]) / ln2)?,
                    q(crate::reg!(cfg, preint_tau), f64::from(e[3]) / ln2)?,
                ]);
            }
        }
        let mut layers = Vec::new();
        if exact {
            layers.reserve((LAYERS - 1) * n * n);
            for l in 1..LAYERS {
                for i in 0..n {
                    for j in 0..n {
                        let e = pt.layer_entry(l, i.min(bins - 1), j.min(bins - 1));
                        layers.push([
                            q(crate::reg!(cfg, preint_color), f64::from(e[0]) / ln2)?,
                            q(crate::reg!(cfg, preint_color), f64::from(e[1]) / ln2)?,
                            q(crate::reg!(cfg, preint_color), f64::from(e[2]) / ln2)?,
                        ]);
                    }
                }
            }
        }
        Ok(PreintUnit {
            bins,
            scale,
            table,
            layers,
            stride: pt.stride(),
        })
    }

    /// Golden's classification-table entries per bin.
    pub fn stride(&self) -> f64 {
        self.stride
    }

    /// Whether the unit holds the exact colouring's layers.
    pub fn exact(&self) -> bool {
        !self.layers.is_empty()
    }

    /// Step 4b: the depth layer and its weight of a step with `p`
    /// (`log_transmittance`, unsigned).
    #[inline(always)]
    fn layer(cfg: &PipelineConfig, p: Fx, st: &mut QuantStats) -> (usize, Fx) {
        let r = p.raw().max(0);
        let frac = i32::from(p.format().frac());
        let first = frac + LAYER_MIN_EXP;
        if r < 1i64 << first {
            return (
                0,
                crate::reg!(cfg, weight).assign(Wide::new(i128::from(r), first), st),
            );
        }
        let b = 63 - r.leading_zeros() as i32;
        let e = b - frac;
        if e >= LAYER_MAX_EXP {
            return (LAYERS - 1, cfg.weight.zero());
        }
        let m = ((r >> (b - 1)) & 1) as usize;
        let rem = r & ((1i64 << (b - 1)) - 1);
        let l = 1 + 2 * (e - LAYER_MIN_EXP) as usize + m;
        (
            l,
            crate::reg!(cfg, weight).assign(Wide::new(i128::from(rem), b - 1), st),
        )
    }

    /// Step 4c: the colour words of layer `l` (at least 1) at the step's
    /// bins and weights.
    #[inline(always)]
    fn layer_words(
        &self,
        cfg: &PipelineConfig,
        l: usize,
        [(i, wi), (j, wj)]: [(usize, Fx); 2],
        st: &mut QuantStats,
    ) -> Result<[Fx; 3], FxError> {
        let n = self.bins + 1;
        let base = &self.layers[(l - 1) * n * n..l * n * n];
        let r = i * n + j;
        let (a, b, c, d) = (base[r], base[r + 1], base[r + n], base[r + n + 1]);
        let f = crate::reg!(cfg, preint_color);
        let mut out = [f.zero(); 3];
        for k in 0..3 {
            let top = lerp(a[k], b[k], wj, f, st)?;
            let bot = lerp(c[k], d[k], wj, f, st)?;
            out[k] = lerp(top, bot, wi, f, st)?;
        }
        Ok(out)
    }

    /// The unit from its words, for the description's checks
    /// (`crate::hw::units_tests`): the fast colouring, without the exact
    /// colouring's layers (the description covers the fast unit).
    #[cfg(test)]
    pub(crate) fn from_words(bins: usize, scale: Fx, table: Vec<[Fx; 4]>) -> PreintUnit {
        PreintUnit {
            bins,
            scale,
            table,
            layers: Vec::new(),
            stride: 1.0,
        }
    }

    /// Bins per table axis.
    pub fn bins(&self) -> usize {
        self.bins
    }

    /// The table scale `K` (`step`), the unit's per-frame port `scale`.
    pub fn scale(&self) -> Fx {
        self.scale
    }

    /// The raw words of channel `ch`'s even (`odd` false) or odd bank as
    /// the described unit holds them ([`crate::hw::preint`]): the table's
    /// rows of that parity, `bins + 1` words each.
    pub fn bank_words(&self, ch: usize, odd: bool) -> Vec<i64> {
        let n = self.bins + 1;
        (usize::from(odd)..n)
            .step_by(2)
            .flat_map(|r| {
                self.table[r * n..(r + 1) * n]
                    .iter()
                    .map(move |w| w[ch].raw())
            })
            .collect()
    }

    /// The bin index and weight of sample `s` (step 1 of the module notes):
    /// positions at or above the last bin read it with weight 0 (the
    /// repeated row), as golden clamps.
    #[inline(always)]
    fn position(&self, cfg: &PipelineConfig, s: Fx, st: &mut QuantStats) -> (usize, Fx) {
        // Two unsigned words below 2^63: the product is exact in i128.
        let f = Wide::from(s)
            .checked_mul(self.scale)
            .expect("two 64-bit words multiply within 128 bits");
        let frac = f.frac.max(0) as u32;
        let int = (f.raw >> frac).max(0);
        let last = (self.bins - 1) as i128;
        if int >= last {
            return (self.bins - 1, cfg.weight.zero());
        }
        let rem = f.raw & ((1i128 << frac) - 1);
        (
            int as usize,
            crate::reg!(cfg, weight).assign(Wide::new(rem, f.frac), st),
        )
    }

    /// The bin sample `s` interpolates from (its table position's
    /// integer part, at most the last bin): what the controller's
    /// occupancy memory classifies by ([`crate::skip`]).
    pub fn bin(&self, cfg: &PipelineConfig, s: Fx) -> usize {
        self.position(cfg, s, &mut QuantStats::default()).0
    }

    /// The interpolated table words of a step from `front` to `back`
    /// (steps 1 to 3): extinction-weighted colour in `preint_color`, mean
    /// extinction in `preint_tau`.
    #[inline(always)]
    pub fn lookup(
        &self,
        cfg: &PipelineConfig,
        front: Fx,
        back: Fx,
        st: &mut QuantStats,
    ) -> Result<PreintWords, FxError> {
        let (i, wi) = self.position(cfg, front, st);
        let (j, wj) = self.position(cfg, back, st);
        let n = self.bins + 1;
        let r = i * n + j;
        let (a, b, c, d) = (
            self.table[r],
            self.table[r + 1],
            self.table[r + n],
            self.table[r + n + 1],
        );
        let mut out = [cfg.preint_tau.zero(); 4];
        for k in 0..4 {
            let f = if k < 3 {
                crate::reg!(cfg, preint_color)
            } else {
                crate::reg!(cfg, preint_tau)
            };
            let top = lerp(a[k], b[k], wj, f, st)?;
            let bot = lerp(c[k], d[k], wj, f, st)?;
            out[k] = lerp(top, bot, wi, f, st)?;
        }
        Ok(PreintWords {
            words: out,
            at: [(i, wi), (j, wj)],
        })
    }

    /// The colour and opacity of a step with table words `e` over a path
    /// of `len` (a `path` word, halved when `half`), steps 4 and 5 (and
    /// 4b, 4c when the frame's unit is exact); `None` when the step's
    /// extinction is zero.
    #[inline(always)]
    pub fn step(
        dp: &Datapath,
        e: PreintWords,
        (len, half): (Fx, bool),
        st: &mut QuantStats,
    ) -> Result<Option<([Fx; 3], Fx)>, FxError> {
        let cfg = &dp.cfg;
        let tau = e[3];
        if tau.raw() <= 0 {
            return Ok(None);
        }
        let mut p = Wide::from(tau).checked_mul(len)?;
        if half {
            p.frac += 1;
        }
        let p = crate::reg!(cfg, log_transmittance).assign(p, st);
        let a = dp.transmit(p, st)?;
        let mut colour = [e[0], e[1], e[2]];
        if let Some(unit) = dp.loaded.preint.as_ref().filter(|u| u.exact()) {
            let (l, w) = PreintUnit::layer(cfg, p, st);
            if l > 0 {
                colour = unit.layer_words(cfg, l, e.at, st)?;
            }
            if w.raw() > 0 {
                let hi = unit.layer_words(cfg, l + 1, e.at, st)?;
                for (lo, hi) in colour.iter_mut().zip(hi) {
                    *lo = lerp(*lo, hi, w, crate::reg!(cfg, preint_color), st)?;
                }
            }
        }
        let c = crate::reg!(cfg, color);
        let one = Wide::new(1, 0);
        let mut rgb = [c.zero(); 3];
        for (out, &wc) in rgb.iter_mut().zip(&colour) {
            // Quotient raw at `color.frac + GUARD_BITS` fraction bits:
            // wc / tau = (wc_raw 2^-fw) / (tau_raw 2^-ft).
            let qf = i32::from(c.frac()) + GUARD_BITS;
            let shift = qf + i32::from(tau.format().frac()) - i32::from(wc.format().frac());
            let raw = i128::from(wc.raw());
            let num = if shift >= 0 {
                // Exact iff shifting back recovers the word.
                u32::try_from(shift)
                    .ok()
                    .filter(|&s| s < 127)
                    .map(|s| raw << s)
                    .filter(|&v| v >> shift == raw)
                    .ok_or(FxError::WideOverflow {
                        op: "pre-integration divider",
                    })?
            } else {
                raw >> (-shift).min(127)
            };
            // Both non-negative: truncating division, in 64 bits where the
            // numerator fits (the same quotient; a 128-bit divide is a
            // library call).
            let quot = match i64::try_from(num) {
                Ok(n) => i128::from(n / tau.raw()),
                Err(_) => num / i128::from(tau.raw()),
            };
            let q = Wide::new(quot, qf);
            let q = if q.cmp_value(one).is_gt() { one } else { q };
            *out = c.assign(q, st);
        }
        Ok(Some((rgb, a)))
    }
}
