//! The pre-integration terms of the derived bound ([`crate::preint`]
//! against golden's pre-integrated `er` / `er-ftb`): what replaces steps 3
//! and 5 of the parent module when a ray's step from slice `z` to `z + 1`
//! is classified as a whole from its front and back scalars. Units as the
//! parent's; the table's words are in `log2` units (golden's value over
//! `ln 2`), `k = L ln 2` for a step of length `L`, and a step composites
//! opacity `A(tau, L) = 1 - 2^(-tau L)` and colour contribution
//! `P = A c` with `c = min(wc / tau, 1)`.
//!
//! 1. Table position: each scalar carries step 2's sample difference `ds`
//!    (the back scalar's golden position adds two `f32` roundings,
//!    `2 X e`); the positions `f = s K` differ by
//!    `df = ds P + 2^v r(step) + 2 e (bins - 1) + r(weight)` bins (`P`
//!    golden's bins per data unit, `v` the voxel bits: `K` rounds into
//!    `step` and multiplies a sample below `2^v`; golden rounds its scale
//!    and product; the pipeline truncates the position's fraction into
//!    `weight`). Both clamp at the last bin continuously.
//! 2. Interpolated words at one position: the host rounds each entry and
//!    three lerps assign (the top and bottom rows' roundings pass through
//!    the convex last lerp): `dq = 3 r(F)` per word (`F` = `preint_tau`,
//!    `preint_color`), plus golden's `f32` entries and lerps, `8 e M`
//!    (`M` the table's largest word).
//! 3. The step's exact function. `A` is increasing and concave in `tau`,
//!    `dA/dtau = k 2^(-tau L) <= k`, `|dA/dL| <= 1/(e L)`. The colour is
//!    ill-conditioned as `tau -> 0`, but the contribution is not: with
//!    `m = min(wc, tau)`, `P = g(tau) m`, `g = A/tau <= k`, and on
//!    `0 <= m <= tau` (convex, both ends lie in it)
//!    `|dP/dm| = g <= k`, `|dP/dtau| = |g'| m <= k phi` with
//!    `phi = max_u (1 - e^-u - u e^-u)/u < 0.3` ([`PHI_MAX`]),
//!    `|dP/dL| = m ln 2 2^(-tau L) <= 1/(e L)`.
//!    So at one position the pipeline's step differs from the exact one
//!    by `Qa = L k dq_tau + ln 2 r(log_t) + X` in opacity (`X` step 5's
//!    exp stage from an exact `p`, `p`'s own rounding through `2^-p`) and
//!    `QP = k max(dq_color, dq_tau) + k phi dq_tau + ln 2 r(log_t) + X`
//!    in contribution, with `k` at the longest step, `ds_max`, plus
//!    `a dq_div` (`dq_div = 2^-8 q(color) + r(color)`: the divider's
//!    quotient truncated to [`crate::preint::GUARD_BITS`] guard bits, the
//!    clamp at 1 being 1-Lipschitz, and the assignment), weighted by the
//!    pipeline's opacity `a`, at most golden's plus the step's opacity
//!    difference. The path length adds
//!    `dL/(e L) <= dpath / (e (1 - dpath))` to both (a half step halves
//!    `L` and `dL` alike).
//! 4. The position difference, per window: golden's position lies in
//!    cell `(i, j)`, the pipeline's within `df` of it, so both lie in the
//!    window of entries `i - R ..= i + 1 + R` per axis (`R = ceil(df)`);
//!    bilinear interpolation stays within the window's extinctions
//!    `[tau_lo, tau_hi]` and is Lipschitz with the window's largest steps
//!    between adjacent bins along each axis, `Sf`, `Sb`. The opacity then
//!    differs by at most
//!    `eA = min(sup_L k 2^(-tau_lo L) (Sf + Sb) df, 2^(-L0 tau_lo) - 2^(-L1 tau_hi))`
//!    over the step's lengths `L0 ..= L1` ([`Window`]). Both colours are
//!    means of the window's entry colours weighted by `w tau` (convex), so
//!    they differ by at most the window's colour spread `D`; writing
//!    `dP = dA c* + A (c* - c)`, the contribution differs by
//!    `|dA| + A D`.
//! 5. Into compositing, back to front, `dC' = dP - dA C + (1 - A) dC`:
//!    the `dA c*` part of `dP` and the `- dA C` part combine into
//!    `dA (c* - C)`, at most `|dA|`, so a step injects at most
//!    `eA + A (D + dq_div) + da dq_div + dL + Qa + QP` into colour
//!    (`da` the step's opacity bound) and `da = eA + dL + Qa` into
//!    opacity, weighted by the transmittance in front (at most 1).
//!    `A (D + dq_div)` sums to at most `D + dq_div` over a ray
//!    (`sum A_k T_k <= 1`, as the parent's `dc`). The window term `eA` is large only where the extinction jumps
//!    (an opaque entry next to a translucent one), and there the step is
//!    opaque: for any `W >= 0`, `eA <= max(eA - W a_lo, 0) + W A` with
//!    `a_lo = 1 - 2^(-L0 tau_lo) <= A`, so the opacity-weighted part
//!    counts once. The bound takes the best `W` (a split, not a factor:
//!    every `W` gives a bound) from the upper convex hull of the windows'
//!    `(a_lo, eA)`. Full steps (`L` in `1 ..= ds_max`) and half steps
//!    (slice 0's lead and the last slice's, `1/2 ..= ds_max/2`) have
//!    their own hulls.
//! 6. Steps per ray: back to front `nz - 1` full steps and two half
//!    steps, each with one accumulator rounding; then the parent's merges,
//!    saturation and warp. Front to back, region `i` of `n_i` slices
//!    composites `n_i` steps (one more in region 0, the lead); the
//!    parent's 6' to 8' with these per-step terms.

use golden::preint::PreTable;

use super::{ftb_total, path_error, position_error, r, sample_error, transmit_error, BoundInputs};
use crate::config::PipelineConfig;
use crate::preint::GUARD_BITS;

/// An upper bound of `max_(u > 0) (1 - e^-u - u e^-u) / u` (about 0.2984,
/// near `u = 1.79`): `|g'(tau)| tau <= k PHI_MAX` for `g = A / tau`.
pub const PHI_MAX: f64 = 0.3;

/// The facts of a pre-integrated table the bound needs, for one
/// configuration and data ([`PreintInputs::measure`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PreintInputs {
    /// Bins per table axis.
    pub bins: usize,
    /// Golden's bins per data unit.
    pub per_scalar: f64,
    /// Largest extinction of the table, `log2` units.
    pub tau_max: f64,
    /// Largest extinction-weighted colour of the table, `log2` units.
    pub color_max: f64,
    /// Largest step between adjacent bins along the front axis, then the
    /// back axis, per channel R, G, B, extinction, `log2` units.
    pub table_step: [[f64; 4]; 2],
    /// The table-position difference `df` in bins (step 1).
    pub df: f64,
    /// The largest colour spread of a window, `D` (step 4).
    pub spread: f64,
    /// Upper hull of the windows' `(a_lo, eA)` for full steps, by `a_lo`.
    pub full: Vec<[f64; 2]>,
    /// The same for half steps.
    pub half: Vec<[f64; 2]>,
}

/// What a window of the table gives a step (step 4 of the module notes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// The opacity difference from the positions, `eA`.
    pub e: f64,
    /// The smallest opacity of a step in the window, `a_lo`.
    pub a_lo: f64,
    /// The window's colour spread, `D`.
    pub spread: f64,
}

/// The per-step terms that do not depend on the window (steps 2 and 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepTerms {
    /// Opacity at one position, `Qa`.
    pub q_a: f64,
    /// Contribution at one position, `QP`.
    pub q_p: f64,
    /// The path length's share, `dL / (e L)`, in both.
    pub d_len: f64,
    /// The divider's colour rounding, `dq_div`: it enters as `a dq_div`,
    /// so it is weighted by the pipeline's opacity.
    pub q_div: f64,
}

/// The bound on one step's differences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepBound {
    /// `|a - a_golden|`.
    pub opacity: f64,
    /// `|a c - a_golden c_golden|` per channel.
    pub contribution: f64,
}

/// The table's words in `log2` units.
fn words(pt: &PreTable) -> Vec<[f64; 4]> {
    let ln2 = std::f64::consts::LN_2;
    let n = pt.bins;
    (0..n * n)
        .map(|k| pt.entry(k / n, k % n).map(|v| f64::from(v) / ln2))
        .collect()
}

/// `sup_(L in l0..=l1) L ln 2 2^(-tau L)`.
fn slope_sup(tau: f64, [l0, l1]: [f64; 2]) -> f64 {
    let ln2 = std::f64::consts::LN_2;
    let x = tau * ln2;
    let l = if x > 0.0 { (1.0 / x).clamp(l0, l1) } else { l1 };
    l * ln2 * (-l * x).exp()
}

fn window_of(w: &[[f64; 4]], bins: usize, df: f64, cell: [usize; 2], lens: [f64; 2]) -> Window {
    let reach = df.ceil().max(1.0) as usize;
    let span = |c: usize| c.saturating_sub(reach)..=(c + 1 + reach).min(bins - 1);
    let (fi, bi) = (span(cell[0]), span(cell[1]));
    let at = |i: usize, j: usize| &w[i * bins + j];
    let (mut lo, mut hi) = (f64::INFINITY, 0f64);
    let (mut sf, mut sb) = (0f64, 0f64);
    let mut cmin = [f64::INFINITY; 3];
    let mut cmax = [f64::NEG_INFINITY; 3];
    for i in fi.clone() {
        for j in bi.clone() {
            let e = at(i, j);
            lo = lo.min(e[3]);
            hi = hi.max(e[3]);
            if i < *fi.end() {
                sf = sf.max((at(i + 1, j)[3] - e[3]).abs());
            }
            if j < *bi.end() {
                sb = sb.max((at(i, j + 1)[3] - e[3]).abs());
            }
            if e[3] > 0.0 {
                for k in 0..3 {
                    let c = (e[k] / e[3]).min(1.0);
                    cmin[k] = cmin[k].min(c);
                    cmax[k] = cmax[k].max(c);
                }
            }
        }
    }
    let spread = (0..3)
        .map(|k| (cmax[k] - cmin[k]).max(0.0))
        .fold(0.0, f64::max);
    let [l0, l1] = lens;
    let by_slope = slope_sup(lo, lens) * (sf + sb) * df;
    let by_range = ((-l0 * lo).exp2() - (-l1 * hi).exp2()).max(0.0);
    Window {
        e: by_slope.min(by_range),
        a_lo: 1.0 - (-l0 * lo).exp2(),
        spread,
    }
}

/// Upper convex hull of points `(a, e)`, by `a`: `max(e - W a)` over the
/// points is the maximum over the hull, for every `W`.
fn upper_hull(mut pts: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    pts.sort_by(|p, q| p[0].total_cmp(&q[0]).then(q[1].total_cmp(&p[1])));
    let mut h: Vec<[f64; 2]> = Vec::new();
    for p in pts {
        if h.last().is_some_and(|l| l[0] == p[0]) {
            continue;
        }
        while h.len() >= 2 {
            let (a, b) = (h[h.len() - 2], h[h.len() - 1]);
            // Drop b when it lies on or below the segment a-p.
            if (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0.0 {
                h.pop();
            } else {
                break;
            }
        }
        h.push(p);
    }
    h
}

impl PreintInputs {
    /// The table-position difference `df` (step 1) for a sample
    /// difference of `ds` data units.
    pub fn position_difference(cfg: &PipelineConfig, pt: &PreTable, ds: f64) -> f64 {
        let e = 2f64.powi(-24);
        ds * f64::from(pt.per_scalar())
            + 2f64.powi(i32::from(cfg.voxel.bits())) * r(cfg.step)
            + 2.0 * e * (pt.bins - 1) as f64
            + r(cfg.weight)
    }

    /// Measures golden's table `pt` for a pipeline of `cfg` on data of
    /// `d` (the position difference depends on both).
    pub fn measure(cfg: &PipelineConfig, d: &BoundInputs, pt: &PreTable) -> PreintInputs {
        let e = 2f64.powi(-24);
        let ex = position_error(cfg, d) + 2.0 * d.max_coord * e;
        let df = Self::position_difference(cfg, pt, sample_error(cfg, d, ex));
        Self::with_df(pt, df, d.ds_max)
    }

    /// [`PreintInputs::measure`] at a given position difference `df` and
    /// longest step `ds_max`.
    pub fn with_df(pt: &PreTable, df: f64, ds_max: f64) -> PreintInputs {
        let bins = pt.bins;
        let w = words(pt);
        let mut table_step = [[0f64; 4]; 2];
        let (mut tau_max, mut color_max) = (0f64, 0f64);
        for i in 0..bins {
            for j in 0..bins {
                let a = w[i * bins + j];
                tau_max = tau_max.max(a[3]);
                color_max = color_max.max(a[0]).max(a[1]).max(a[2]);
                for k in 0..4 {
                    if i + 1 < bins {
                        let s = (w[(i + 1) * bins + j][k] - a[k]).abs();
                        table_step[0][k] = table_step[0][k].max(s);
                    }
                    if j + 1 < bins {
                        let s = (w[i * bins + j + 1][k] - a[k]).abs();
                        table_step[1][k] = table_step[1][k].max(s);
                    }
                }
            }
        }
        let (mut full, mut half) = (Vec::new(), Vec::new());
        let mut spread = 0f64;
        for i in 0..bins - 1 {
            for j in 0..bins - 1 {
                let f = window_of(&w, bins, df, [i, j], [1.0, ds_max]);
                let h = window_of(&w, bins, df, [i, j], [0.5, ds_max / 2.0]);
                spread = spread.max(f.spread);
                full.push([f.a_lo, f.e]);
                half.push([h.a_lo, h.e]);
            }
        }
        PreintInputs {
            bins,
            per_scalar: f64::from(pt.per_scalar()),
            tau_max,
            color_max,
            table_step,
            df,
            spread,
            full: upper_hull(full),
            half: upper_hull(half),
        }
    }

    /// The window of golden's table position `f` (front, back, in bins)
    /// for steps of lengths `lens` (step 4).
    pub fn window(pt: &PreTable, df: f64, f: [f64; 2], lens: [f64; 2]) -> Window {
        let bins = pt.bins;
        let cell = f.map(|v| (v.clamp(0.0, (bins - 1) as f64) as usize).min(bins - 2));
        window_of(&words(pt), bins, df, cell, lens)
    }

    /// `max over the hull of max(eA - W a_lo, 0)`.
    fn excess(hull: &[[f64; 2]], w: f64) -> f64 {
        hull.iter().map(|p| p[1] - w * p[0]).fold(0.0, f64::max)
    }

    /// The splits worth trying: the bounds are convex and piecewise
    /// linear in `W`, with corners where the hull's maximum changes point
    /// (its edges' slopes) or reaches zero (`eA / a_lo`), and at 0.
    fn splits(&self) -> Vec<f64> {
        let mut ws = vec![0.0];
        for h in [&self.full, &self.half] {
            for p in h.windows(2) {
                let dw = p[1][0] - p[0][0];
                if dw > 0.0 && p[1][1] > p[0][1] {
                    ws.push((p[1][1] - p[0][1]) / dw);
                }
            }
            ws.extend(h.iter().filter(|p| p[0] > 0.0).map(|p| p[1] / p[0]));
        }
        ws
    }
}

/// The window-independent per-step terms (steps 2 and 3) for `cfg`, the
/// table facts `p` and the data `d` (its `ds_max` and path).
pub fn step_terms(cfg: &PipelineConfig, d: &BoundInputs, p: &PreintInputs) -> StepTerms {
    let e = 2f64.powi(-24);
    let ln2 = std::f64::consts::LN_2;
    let k = d.ds_max * ln2;
    let dq_t = 3.0 * r(cfg.preint_tau) + 8.0 * e * p.tau_max;
    let dq_c = 3.0 * r(cfg.preint_color) + 8.0 * e * p.color_max;
    let exp = ln2 * r(cfg.log_transmittance) + transmit_error(cfg);
    let c = cfg.color;
    let mut div = c.lsb() * 2f64.powi(-GUARD_BITS) + r(c);
    if c.int_bits() == 0 {
        div += r(c);
    }
    let dpath = path_error(cfg, d);
    StepTerms {
        // golden's segment opacity is within an f32 ulp.
        q_a: k * dq_t + exp + e,
        // golden's colour: the reciprocal and the product round.
        q_p: k * dq_c.max(dq_t) + k * PHI_MAX * dq_t + exp + 3.0 * e,
        d_len: dpath / (std::f64::consts::E * (1.0 - dpath).max(f64::MIN_POSITIVE)),
        q_div: div,
    }
}

/// One step's bound (steps 3 and 4) in window `w`, for a step whose
/// golden opacity is `a`: what [`preint_error_bound`] sums, per step.
pub fn preint_step_bound(t: &StepTerms, w: &Window, a: f64) -> StepBound {
    let opacity = w.e + t.d_len + t.q_a;
    StepBound {
        opacity,
        contribution: w.e + a * w.spread + (a + opacity) * t.q_div + t.d_len + t.q_p,
    }
}

/// The per-channel bound on `|pipeline - golden er|` of a pre-integrated
/// frame, back to front (the image and the baseplane).
pub fn preint_error_bound(cfg: &PipelineConfig, d: &BoundInputs, p: &PreintInputs) -> f64 {
    let e = 2f64.powi(-24);
    let t = step_terms(cfg, d, p);
    let racc = r(cfg.accum_color).max(r(cfg.accum_alpha));
    let qacc = cfg.accum_color.lsb().max(cfg.accum_alpha.lsb());
    let (n_full, n_half) = (d.slices.saturating_sub(1) as f64, 2.0);
    // Per step into colour (step 5), besides the window's excess.
    let opacity = t.d_len + t.q_a;
    let per_step = opacity + t.q_p + racc + 3.0 * e;
    let weighted = p.spread + t.q_div;
    let merges = d.merges as f64 * (r(cfg.merge) + racc + 3.0 * e) + qacc + 16.0 * e;
    p.splits()
        .into_iter()
        .map(|w| {
            let (xf, xh) = (
                PreintInputs::excess(&p.full, w),
                PreintInputs::excess(&p.half, w),
            );
            // The divider's rounding at the pipeline's opacity, above
            // golden's by at most the step's opacity difference.
            let div = t.q_div * (opacity + xf.max(xh));
            n_full * (xf + per_step + div) + n_half * (xh + per_step + div) + w + weighted + merges
        })
        .fold(f64::INFINITY, f64::min)
}

/// The per-channel bound on `|pipeline - golden er-ftb|` of a
/// pre-integrated frame, front to back without early ray termination
/// (the parent's 6' to 8' with this module's per-step terms); `regions`
/// as [`super::ftb_error_bound`]'s.
pub fn preint_ftb_error_bound(
    cfg: &PipelineConfig,
    d: &BoundInputs,
    p: &PreintInputs,
    regions: &[usize],
) -> f64 {
    let e = 2f64.powi(-24);
    let t = step_terms(cfg, d, p);
    let (rc, ra, rm) = (r(cfg.accum_color), r(cfg.accum_alpha), r(cfg.merge));
    let qacc = cfg.accum_color.lsb().max(cfg.accum_alpha.lsb());
    let last = regions.len().saturating_sub(1);
    let total = |w: f64| {
        let (xf, xh) = (
            PreintInputs::excess(&p.full, w),
            PreintInputs::excess(&p.half, w),
        );
        let div = t.q_div * (t.d_len + t.q_a + xf.max(xh));
        let ec = t.d_len + t.q_a + t.q_p + div + rc + ra + 6.0 * e;
        let ea = t.d_len + t.q_a + ra + 4.0 * e;
        let rho = rm + ra + 4.0 * e;
        let per_region = regions.iter().enumerate().map(|(i, &n)| {
            // Half steps: region 0's lead, the last region's face.
            let halves = usize::from(i == 0) + usize::from(i == last && n > 0);
            let steps = n + usize::from(i == 0);
            let fulls = steps.saturating_sub(halves) as f64;
            let (steps, halves) = (steps as f64, halves as f64);
            let window = fulls * xf + halves * xh;
            let lc = steps * ec + window + (w + p.spread + t.q_div) * (1.0 + steps * ra) + qacc;
            let la = steps * ea + window + w * (1.0 + steps * ra) + qacc;
            (lc, la)
        });
        ftb_total(per_region, rho, rm)
    };
    p.splits()
        .into_iter()
        .map(total)
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests;
