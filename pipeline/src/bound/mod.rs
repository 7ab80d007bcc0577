//! The derived worst-case difference between the pipeline's image and the
//! golden model's `er` image, per channel, from the datapath widths and a
//! few facts about the data. No factor is tuned: each term is one
//! quantisation or one propagated difference, in the order the datapath
//! computes them (see [`crate::datapath`]).
//!
//! Notation: `q(F)` is a format's LSB and `r(F)` its assignment error,
//! `q` for truncating modes and `q/2` for rounding ones; `e = 2^-24` is the
//! golden model's `f32` rounding. Units: positions in voxels, samples in
//! data units (u8: 0..255), colours and opacities in `[0, 1]`.
//!
//! 1. Position `x = A + m t`: the host rounds `A` (`position`) and `t`
//!    (`step`), the PE rounds the sum: `ex = 2 r(position) + M r(step)`,
//!    plus golden's `f32` position `X e` (`M` largest ray index, `X`
//!    largest coordinate).
//! 2. Sample: bilinear interpolation is `G`-Lipschitz along each axis
//!    (`G` the largest difference of neighbouring voxels in a slice), the
//!    weight truncation adds `r(weight)`, and three assignments into
//!    `sample` add `r(sample)` each (only two reach the result, the top and
//!    bottom rows are combined convexly):
//!    `ds = Gx (ex + r(w)) + Gy (ey + r(w)) + 2 r(sample) 2^(b - w)`,
//!    plus golden's `4 V e` (`V` the data range, `b`/`w` data and voxel bits).
//! 3. Classification: table position `f = s 2^(e - b)` (`e` = log2 of the
//!    entries); colour error `Sc (df + r(w)) + 2 r(color)` (entry rounding
//!    and the assignment), with `Sc` the largest step between adjacent
//!    entries; the same for opacity with `Sa` and `r(alpha)`.
//! 4. Path length: slopes carry `es = 2 r(position) + M r(step)`, the norm
//!    is 1-Lipschitz in each slope (`sqrt 2 es` for two), the integer
//!    square root truncates (`q(path)`).
//! 5. Opacity correction `a' = 1 - (1 - a)^ds`, for `ds >= 1`:
//!    `d a'/d a <= ds_max`, `|d a'/d ds| <= 1/e`; the log table and the
//!    product `p` round (`(1 + ds_max) r(log_t)`, scaled by `ln 2` through
//!    `2^-p`), the exp table's entries, interpolation (`(ln 2)^2 h^2 / 8`,
//!    `h = 2^-exp_table_bits`), weight, assignment and shift round
//!    (`3 r(opacity_corr)` plus `ln 2 h r(weight)` when the weight drops
//!    bits).
//! 6. Compositing, back to front: `C' = a' c + (1 - a') C` gives
//!    `|dC'| <= a' |dc| + |da'| + (1 - a') |dC| + r(accum)`. Unrolled over
//!    a ray, the colour terms are weighted by `a'_k T_k` (`T_k` the
//!    transmittance in front of sample `k`), which sum to at most 1, so the
//!    colour difference counts once; the opacity terms are weighted by
//!    `T_k <= 1` and add up per slice: `E = da' + r(accum)`. The same holds
//!    for `A' = a' + (1 - a') A`.
//! 7. A Bartlett merge is a convex combination (weights sum to at most 1)
//!    with two roundings: `r(merge) + r(accum)`.
//! 8. Accumulators saturate one LSB below 1: `q(accum)` once. The warp is
//!    a convex combination in `f32` on both sides.
//!
//! Total: `B = dc + nz E + merges (r(merge) + r(accum)) + q(accum)` plus
//! the golden `f32` terms.
//!
//! # Front to back ([`ftb_error_bound`], against golden `er-ftb`)
//!
//! Terms 1 to 5 (the sample: position, interpolation, classification,
//! path, opacity correction) are the same. What differs:
//!
//! 6'. Compositing, front to back: `C' = C + (1 - A) a c`,
//!    `A' = A + (1 - A) a`. For fixed samples a region's composite is
//!    *affine* in the state it starts from: `C_end = C_0 + (1 - A_0) R`,
//!    `A_end = A_0 + (1 - A_0)(1 - T)` (`R` the region's own back-to-front
//!    colour, `T` its transmittance, both in `[0, 1]`). So an error `dC`,
//!    `dA` in the state at any step reaches the region's end as
//!    `dC - R dA` (at most `|dC| + |dA|`) and `T dA` (at most `|dA|`).
//!    Each sample injects its opacity difference (at most `da'`, in both
//!    channels), its colour difference weighted by `(1 - A) a'` (these sum
//!    to the opacity the region adds, at most `1 + n r(accum_alpha)` with
//!    the roundings), and two roundings: `r(accum_color)` into colour,
//!    `r(accum_alpha)` into opacity *and*, through `- R dA`, into colour.
//!    Saturation one LSB below 1 clips at most `q(accum)` of what a region
//!    adds. A region of `n_i` slices therefore adds to its rays, from an
//!    exact start, at most
//!    `Lc_i = n_i (da' + r(accum_color) + r(accum_alpha)) + dc (1 + n_i r(accum_alpha)) + q(accum)`
//!    in colour and `La_i = n_i (da' + r(accum_alpha)) + q(accum)` in
//!    opacity.
//! 7'. Split: every child is a convex combination of at most four parents
//!    (weights 1, 1/2, 1/4), so a parent error passes at most as is, plus
//!    two roundings: the x pass into `merge` and the y pass into the
//!    accumulator, `rho = r(merge) + r(accum)`. The opacity error region
//!    `i` inherits is then at most `IA_i = sum_(j < i) La_j + i rho`.
//! 8'. Fold: `result_0 = final_0 + sum_(i >= 1) M^i (final_i - inh_i)`
//!    (`M` the Bartlett merge, a convex combination). By 6' the colour
//!    error of `final_i - inh_i` is that region's own `Lc_i` plus
//!    `- R_i dA(inh_i)`: the inherited colour error cancels exactly in the
//!    difference, the inherited opacity error counts once, at most `IA_i`.
//!    The difference and the add are exact (both operands lie on `merge`'s
//!    grid, validated, and the values are non-negative and in range: the
//!    pipeline's words only grow); each merge rounds twice (x and y pass
//!    into `merge`): `2 r(merge)` per boundary.
//!
//! Total: `B = sum_i Lc_i + sum_(i >= 1) IA_i + (K - 1) 2 r(merge)` plus the
//! golden `f32` terms (a few `e` per operation on values below 2). The
//! opacity channel's bound is the same with `La_i` and the factor
//! `1 - T <= 1` in place of `R`, so `B` covers all four channels. The
//! `sum IA_i` term grows with the regions: an opacity rounding in region
//! `j` shifts what every later region contributes, and a per-region bound
//! cannot see that those contributions share one transmittance (along one
//! ray they add up to at most 1), because the split and the fold mix
//! neighbouring rays. It assumes early ray termination is off.
//!
//! # Pre-integrated frames ([`preint_error_bound`], [`preint_ftb_error_bound`])
//!
//! Steps 1, 2, 4 and the exp stage of 5 stay; classification (3) and the
//! log table of 5 are replaced by the pre-integration unit's terms, with
//! each step's opacity and colour *contribution* `a c` bounded (never the
//! ill-conditioned colour `wc / tau` alone), and a window's position term
//! split into a per-step part and a part weighted by the step's opacity
//! (summing to at most once over a ray, as `dc` above). Derivation in
//! [`preint`] (the module `bound::preint`); the facts come
//! from golden's table ([`PreintInputs`]).

use crate::config::PipelineConfig;
use crate::fixed::{Format, Quant};

mod inputs;
pub mod preint;
mod shading;
mod voi;

pub use inputs::{region_slices, BoundInputs};

pub use preint::{
    preint_error_bound, preint_ftb_error_bound, preint_step_bound, PreintInputs, StepBound,
    StepTerms, Window,
};
pub use shading::ShadeInputs;
pub use voi::VoiInputs;

/// The narrowest `path` format with `path`'s fraction bits, rounding and
/// overflow that holds path length `ds` (`None` past 48 bits): what a
/// view whose largest path length saturates `path` needs for a bound.
pub fn path_holding(path: Format, ds: f64) -> Option<Format> {
    (path.int_bits()..=48 - path.frac()).find_map(|i| {
        let f = Format::new(
            i + path.frac(),
            path.frac(),
            false,
            path.quant(),
            path.overflow(),
        );
        f.ok().filter(|f| f.max_value().to_f64() > ds)
    })
}

/// The formats whose overflows in `quant` are range violations rather
/// than designed clamps ([`crate::config::FormatId::clamps`]), with their
/// overflow counts, in table order. The bounds assume none: a frame with
/// any has no derived bound (a saturated `path` under-corrects its
/// steepest rays' opacity, which no width of the other formats covers).
pub fn range_violations(quant: &crate::fixed::QuantStats) -> Vec<(&'static str, u64)> {
    quant
        .by_format
        .iter()
        .filter(|(id, c)| !id.clamps() && c.overflows > 0)
        .map(|(id, c)| (id.name(), c.overflows))
        .collect()
}

/// Assignment error of a format: one LSB when it truncates, half otherwise.
pub fn r(f: Format) -> f64 {
    match f.quant() {
        Quant::Trn | Quant::TrnZero => f.lsb(),
        _ => f.lsb() / 2.0,
    }
}

/// Per-sample error terms shared by both orders (steps 1 to 5).
struct SampleTerms {
    /// Colour difference of a classified sample.
    dc: f64,
    /// Corrected-opacity difference of a sample.
    dcorr: f64,
}

/// The per-channel bound `B` on `|pipeline - golden er|` of the final
/// image (and of the baseplane).
pub fn error_bound(cfg: &PipelineConfig, d: &BoundInputs) -> f64 {
    btf_bound(cfg, d, None, None)
}

/// [`error_bound`] of a shaded frame (against golden `er` shaded alike):
/// the shading terms of [`ShadeInputs`] enter the sample's colour and
/// opacity differences. Infinite when `s` has no normal fade.
pub fn shaded_error_bound(cfg: &PipelineConfig, d: &BoundInputs, s: &ShadeInputs) -> f64 {
    btf_bound(cfg, d, Some(s), None)
}

/// [`ftb_error_bound`] of a shaded frame.
pub fn shaded_ftb_error_bound(
    cfg: &PipelineConfig,
    d: &BoundInputs,
    regions: &[usize],
    s: &ShadeInputs,
) -> f64 {
    ftb_bound(cfg, d, regions, Some(s), None)
}

/// [`error_bound`] of a frame with a volume of interest (against golden
/// `er` with the same VOI), shaded with `shade` when given: the terms of
/// [`VoiInputs`] enter the sample's opacity difference, and without a
/// ramp each region adds its boundary samples' flips.
pub fn voi_error_bound(
    cfg: &PipelineConfig,
    d: &BoundInputs,
    shade: Option<&ShadeInputs>,
    voi: &VoiInputs,
) -> f64 {
    btf_bound(cfg, d, shade, Some(voi))
}

/// [`ftb_error_bound`] of a frame with a volume of interest.
pub fn voi_ftb_error_bound(
    cfg: &PipelineConfig,
    d: &BoundInputs,
    regions: &[usize],
    shade: Option<&ShadeInputs>,
    voi: &VoiInputs,
) -> f64 {
    ftb_bound(cfg, d, regions, shade, Some(voi))
}

fn btf_bound(
    cfg: &PipelineConfig,
    d: &BoundInputs,
    shade: Option<&ShadeInputs>,
    voi: Option<&VoiInputs>,
) -> f64 {
    let e = 2f64.powi(-24);
    let SampleTerms { dc, dcorr } = sample_terms(cfg, d, shade, voi);
    // 3v. boundary samples of a step VOI, one opacity error each.
    let flips = voi.map_or(0.0, |v| {
        v.flips_er.iter().sum::<usize>() as f64 * v.flip(d.ds_max)
    });
    // 6-8. compositing, merges, saturation, warp.
    let racc = r(cfg.accum_color).max(r(cfg.accum_alpha));
    let per_slice = dcorr + racc + 3.0 * e;
    let qacc = cfg.accum_color.lsb().max(cfg.accum_alpha.lsb());
    dc + d.slices as f64 * per_slice
        + flips
        + d.merges as f64 * (r(cfg.merge) + racc + 3.0 * e)
        + qacc
        + 16.0 * e
}

/// The per-channel bound `B` on `|pipeline - golden er-ftb|` of the final
/// image and the baseplane, front to back without early ray termination
/// (steps 6' to 8' of the module documentation). `regions[i]` is the
/// number of slices region `i` can sample ([`region_slices`]); `d.slices`
/// and `d.merges` are not used.
pub fn ftb_error_bound(cfg: &PipelineConfig, d: &BoundInputs, regions: &[usize]) -> f64 {
    ftb_bound(cfg, d, regions, None, None)
}

fn ftb_bound(
    cfg: &PipelineConfig,
    d: &BoundInputs,
    regions: &[usize],
    shade: Option<&ShadeInputs>,
    voi: Option<&VoiInputs>,
) -> f64 {
    let e = 2f64.powi(-24);
    let SampleTerms { dc, dcorr } = sample_terms(cfg, d, shade, voi);
    let flip = voi.map_or(0.0, |v| v.flip(d.ds_max));
    let (rc, ra, rm) = (r(cfg.accum_color), r(cfg.accum_alpha), r(cfg.merge));
    let qacc = cfg.accum_color.lsb().max(cfg.accum_alpha.lsb());
    // 6'. per sample: k = (1 - A) a, then C += k c and A += k in f32.
    let ec = dcorr + rc + ra + 6.0 * e;
    let ea = dcorr + ra + 4.0 * e;
    // 7'. a split: two roundings, and golden's weighted f32 sum.
    let rho = rm + ra + 4.0 * e;
    let per_region = regions.iter().enumerate().map(|(i, &n)| {
        let n = n as f64;
        // 3v. a step VOI's boundary samples: one opacity error each, in
        // both channels.
        let flips = voi.map_or(0.0, |v| {
            v.flips_ftb.get(i).copied().unwrap_or(0) as f64 * flip
        });
        let lc = n * ec + dc * (1.0 + n * ra) + qacc + flips;
        let la = n * ea + qacc + flips;
        (lc, la)
    });
    ftb_total(per_region, rho, rm)
}

/// 7' and 8': the front-to-back total from each region's own colour and
/// opacity errors from an exact start (`lc_i`, `la_i`), a split's two
/// roundings `rho` and the fold's merge rounding `rm`: region `i` inherits
/// the opacity errors of the regions before it and the splits' roundings,
/// which the fold's difference carries once, and the warp adds golden's
/// `f32` terms.
fn ftb_total(regions: impl Iterator<Item = (f64, f64)>, rho: f64, rm: f64) -> f64 {
    let e = 2f64.powi(-24);
    let mut total = 0.0;
    let mut inherited = 0.0;
    for (i, (lc, la)) in regions.enumerate() {
        if i > 0 {
            inherited += rho;
            // 8'. the inherited opacity error, once, and the fold's merge.
            total += inherited + 2.0 * rm + 16.0 * e;
        }
        total += lc;
        inherited += la;
    }
    // The warp: a convex combination in f32 on both sides.
    total + 16.0 * e
}

/// Step 1: the position difference `ex` in voxels.
fn position_error(cfg: &PipelineConfig, d: &BoundInputs) -> f64 {
    let e = 2f64.powi(-24);
    2.0 * r(cfg.position) + d.max_index * r(cfg.step) + d.max_coord * e
}

/// Step 2: the sample difference in data units, from a position
/// difference `ex` in voxels.
fn sample_error(cfg: &PipelineConfig, d: &BoundInputs, ex: f64) -> f64 {
    let e = 2f64.powi(-24);
    let rw = r(cfg.weight);
    let word = 2f64.powi(d.data_bits as i32 - i32::from(cfg.voxel.bits()));
    let range = 2f64.powi(d.data_bits as i32);
    let vox = if cfg.voxel.bits() as u32 >= d.data_bits {
        0.0
    } else {
        r(cfg.voxel) * word
    };
    d.gradient[0] * (ex + rw)
        + d.gradient[1] * (ex + rw)
        + 2.0 * r(cfg.sample) * word
        + vox
        + 4.0 * range * e
}

/// Step 4: the path-length difference per slice step.
fn path_error(cfg: &PipelineConfig, d: &BoundInputs) -> f64 {
    let e = 2f64.powi(-24);
    let es = 2.0 * r(cfg.position) + d.max_index * r(cfg.step);
    2f64.sqrt() * es + cfg.path.lsb() + d.ds_max * 2.0 * e
}

/// Step 5's exp stage ([`crate::datapath::Datapath::transmit`]) from an
/// exact `p`: the exp table's entries, its interpolation (`(ln 2)^2 h^2 /
/// 8`), the assignment and the shift (`3 r(opacity_corr)`), the weight
/// when it drops bits (`ln 2 h r(weight)`), and `1 - T` saturating below
/// 1 when `opacity_corr` has no integer bit.
fn transmit_error(cfg: &PipelineConfig) -> f64 {
    let ln2 = std::f64::consts::LN_2;
    let lt = cfg.log_transmittance;
    let h = 2f64.powi(-i32::from(cfg.exp_table_bits));
    let weight_drop =
        i32::from(lt.frac()) - i32::from(cfg.exp_table_bits) > i32::from(cfg.weight.frac());
    let oc = cfg.opacity_corr;
    let mut t = 3.0 * r(oc) + ln2 * ln2 * h * h / 8.0;
    if weight_drop {
        t += ln2 * h * r(cfg.weight);
    }
    if oc.int_bits() == 0 {
        t += r(oc);
    }
    t
}

/// Steps 1 to 5: the colour and corrected-opacity differences of one
/// sample (with a VOI, step 3 is followed by its opacity terms; shaded,
/// by the shading terms).
fn sample_terms(
    cfg: &PipelineConfig,
    d: &BoundInputs,
    shade: Option<&ShadeInputs>,
    voi: Option<&VoiInputs>,
) -> SampleTerms {
    let e = 2f64.powi(-24);
    let rw = r(cfg.weight);
    // 1. positions.
    let ex = position_error(cfg, d);
    // 2. sample, in data units.
    let ds = sample_error(cfg, d, ex);
    // 3. classification.
    let entries = f64::from(cfg.table_entries);
    let range = 2f64.powi(d.data_bits as i32);
    let df = ds * entries / range;
    let dc = d.table_step[0] * (df + rw) + 2.0 * r(cfg.color) + 3.0 * e;
    let da = d.table_step[1] * (df + rw) + 2.0 * r(cfg.alpha) + 3.0 * e;
    // 3v. the volume of interest scales the opacity.
    let da = match voi {
        Some(v) => v.alpha_term(cfg, ex, da),
        None => da,
    };
    // 3s. shading.
    let (dc, da) = match shade {
        Some(s) => s.terms(cfg, d, ex, (dc, da)),
        None => (dc, da),
    };
    // 4. path length.
    let dpath = path_error(cfg, d);
    // 5. opacity correction: the log table's entry and the product round
    // (`(1 + ds_max) r(log_t)` through `2^-p`), then the exp stage.
    let ln2 = std::f64::consts::LN_2;
    let dcorr = d.ds_max * da
        + dpath / std::f64::consts::E
        + ln2 * (1.0 + d.ds_max) * r(cfg.log_transmittance)
        + transmit_error(cfg)
        + 4.0 * e;
    SampleTerms { dc, dcorr }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Data facts of a typical 256-wide view.
    fn inputs() -> BoundInputs {
        BoundInputs {
            gradient: [40.0, 40.0],
            table_step: [0.01, 0.01],
            max_index: 300.0,
            max_coord: 260.0,
            ds_max: 2.0,
            slices: 64,
            merges: 3,
            data_bits: 8,
        }
    }

    #[test]
    fn more_bits_never_loosen_the_bound() {
        let d = inputs();
        let base = PipelineConfig::default();
        let b0 = error_bound(&base, &d);
        let mut wide = base;
        wide.weight = Format::new(14, 14, false, Quant::Trn, crate::fixed::Overflow::Sat).unwrap();
        assert!(error_bound(&wide, &d) < b0);
        let mut alpha = base;
        alpha.alpha = Format::new(14, 14, false, Quant::Rnd, crate::fixed::Overflow::Sat).unwrap();
        assert!(error_bound(&alpha, &d) < b0);
        let mut flat = d;
        flat.gradient = [0.0, 0.0];
        assert!(error_bound(&base, &flat) < b0);
        // Each slice adds the same per-slice term.
        let mut deep = d;
        deep.slices *= 2;
        let grown = error_bound(&base, &deep) - b0;
        let mut deeper = d;
        deeper.slices *= 3;
        let grown2 = error_bound(&base, &deeper) - b0;
        assert!(grown > 0.0 && (grown2 - 2.0 * grown).abs() < 1e-9 * b0);
    }

    #[test]
    fn ftb_bound_terms() {
        let d = inputs();
        let base = PipelineConfig::default();
        let regions = [4, 8, 16, 36];
        let b0 = ftb_error_bound(&base, &d, &regions);
        // One region of all the slices is the back-to-front bound's
        // structure with two accumulator roundings per slice and no merge.
        let one = ftb_error_bound(&base, &d, &[64]);
        assert!(one < b0);
        // Wider formats never loosen it.
        let mut wide = base;
        wide.merge = Format::new(24, 20, false, Quant::Rnd, crate::fixed::Overflow::Sat).unwrap();
        assert!(ftb_error_bound(&wide, &d, &regions) < b0);
        let mut acc = base;
        acc.accum_alpha =
            Format::new(20, 20, false, Quant::Rnd, crate::fixed::Overflow::Sat).unwrap();
        assert!(ftb_error_bound(&acc, &d, &regions) < b0);
        // An opacity error in region j counts again in every later region:
        // moving slices to the front costs more than keeping them behind.
        let front_heavy = ftb_error_bound(&base, &d, &[36, 16, 8, 4]);
        assert!(front_heavy > b0);
        // Above the back-to-front bound of the same frame (two roundings
        // per sample, the inherited errors, the split roundings).
        assert!(b0 > error_bound(&base, &d));
    }
}
