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

use golden::preint::PreTable;

use crate::config::PipelineConfig;
use crate::datapath::{lerp, Datapath};
use crate::fixed::{Format, Fx, FxError, QuantStats, Wide};

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
        if pt.colouring() != golden::preint::Colouring::Fast {
            return Err(PreintError::Unsupported(format!(
                "the pre-integration unit models the fast colouring only, not {}",
                pt.colouring().name()
            )));
        }
        let bins = pt.bins;
        if bins < 2 || entries < bins || entries != cfg.table_entries as usize {
            return Err(PreintError::Table(format!(
                "{} entries (the table has {bins} bins over {entries})",
                cfg.table_entries
            )));
        }
        let mut q = |f: Format, v: f64| -> Result<Fx, FxError> {
            let r = f.from_f64(v)?;
            st.record(&r);
            Ok(r.value)
        };
        let k = 2f64.powi(cfg.table_shift()) * (bins - 1) as f64 / (entries - 1) as f64;
        let scale = q(cfg.step, k)?;
        let ln2 = std::f64::consts::LN_2;
        let n = bins + 1;
        let mut table = Vec::with_capacity(n * n);
        for i in 0..n {
            for j in 0..n {
                let e = pt.entry(i.min(bins - 1), j.min(bins - 1));
                table.push([
                    q(cfg.preint_color, f64::from(e[0]) / ln2)?,
                    q(cfg.preint_color, f64::from(e[1]) / ln2)?,
                    q(cfg.preint_color, f64::from(e[2]) / ln2)?,
                    q(cfg.preint_tau, f64::from(e[3]) / ln2)?,
                ]);
            }
        }
        Ok(PreintUnit { bins, scale, table })
    }

    /// The unit from its words, for the description's checks
    /// (`crate::hw::units_tests`).
    #[cfg(test)]
    pub(crate) fn from_words(bins: usize, scale: Fx, table: Vec<[Fx; 4]>) -> PreintUnit {
        PreintUnit { bins, scale, table }
    }

    /// Bins per table axis.
    pub fn bins(&self) -> usize {
        self.bins
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
        (int as usize, cfg.weight.assign(Wide::new(rem, f.frac), st))
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
    ) -> Result<[Fx; 4], FxError> {
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
                cfg.preint_color
            } else {
                cfg.preint_tau
            };
            let top = lerp(a[k], b[k], wj, f, st)?;
            let bot = lerp(c[k], d[k], wj, f, st)?;
            out[k] = lerp(top, bot, wi, f, st)?;
        }
        Ok(out)
    }

    /// The colour and opacity of a step with table words `e` over a path
    /// of `len` (a `path` word, halved when `half`), steps 4 and 5; `None`
    /// when the step's extinction is zero.
    #[inline(always)]
    pub fn step(
        dp: &Datapath,
        e: [Fx; 4],
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
        let p = cfg.log_transmittance.assign(p, st);
        let a = dp.transmit(p, st)?;
        let c = cfg.color;
        let one = Wide::new(1, 0);
        let mut rgb = [c.zero(); 3];
        for (out, &wc) in rgb.iter_mut().zip(&e[..3]) {
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
