//! Pre-integrated classification (Engel, Kraus and Ertl 2001): instead of
//! classifying one scalar per slice crossing, a ray's step from slice `z`
//! to slice `z + 1` is classified as a whole from its front and back
//! scalars, `s_f` (at slice `z`) and `s_b` (at slice `z + 1`, where the
//! same ray crosses it), assuming the scalar varies linearly between
//! them. Thin features that a step jumps over (the skin where
//! interpolation between air and floor passes through a wall's value)
//! are then seen, at one sample per slice.
//!
//! **The table and the path length.** Engel's table holds the segment's
//! colour and opacity for one fixed length. ER's rays have a different
//! world length per slice step each (their slopes differ, constant over
//! a region), so this table holds what does not depend on the length: per
//! pair of table positions `(i, j)` the mean extinction over the segment,
//! `tau(i, j) = 1/(j - i) * int_i^j tau(f) df` with
//! `tau(f) = -ln(1 - a(f))` (`a(f)` the classification table's opacity per
//! unit length, interpolated linearly like [`Lut::lookup`]), and the
//! extinction-weighted mean colour `c(i, j) = int tau c / int tau`. A ray
//! with step length `ds` then composites opacity
//! `1 - exp(-ds tau(s_f, s_b))`, exact for the linear scalar, and colour
//! `c(s_f, s_b)`: exact for a constant colour and ignoring only the order
//! of colours inside one step (self-attenuation within a segment, the
//! approximation Engel's fast variant also makes). With `s_f = s_b` the
//! step is the ordinary post-classified sample of the same length.
//!
//! The table is `n x n` with `n` the classification table's entries for
//! 8-bit data (256: bins are the entries) and 256 for larger tables
//! (bins `(entries - 1)/255` entries apart); lookups interpolate
//! bilinearly. The integrals are composite Simpson sums of 16 intervals
//! per bin in `f64`, prefix-summed, so a span of transparent entries has
//! exactly zero extinction (empty-space skipping stays bit-identical, see
//! [`PreTable::occupancy_lut`]).
//!
//! **Self-attenuation ([`Colouring::Attenuated`]).** The fast variant's
//! colour weighs the segment's colours by extinction alone, so in a thick
//! step (`ds tau` near or above 1) a bright back half shows as much as the
//! front half that hides it. The attenuated variant corrects it to first
//! order: with `x` the fraction of the segment's extinction in front of a
//! point, the colour taken as linear in `x`, `c(x) = c + k (x - 1/2)`
//! (`c` the fast colour, `k = 12 int c (x - 1/2) dx` its least-squares
//! slope), integrates exactly against the attenuation `e^(-lambda x)`
//! (`lambda = ds tau`): the step's colour is `c - k h(lambda)` with
//! `h = 1/(1 - e^-lambda) - 1/lambda - 1/2`, which runs from 0 (a thin
//! step: the fast colour) to `1/2` (an opaque one: the front colour). The
//! table keeps `k tau` per bin pair beside the colour (interpolated alike,
//! so a transparent neighbour bin does not shift it). The pipeline models
//! the fast variant only.
//!
//! **Where the segments lie.** Slice `z`'s step is `[z, z + 1]`; the last
//! slice's is `[nz - 1, nz - 1/2]` (the volume's face), and slice 0 adds
//! the half step `[-1/2, 0]` at its own scalar in front, so that the
//! steps tile the volume's box like the one-sample-per-slice scheme's.

use crate::opacity::neg_expm1;
use crate::tf::{clear_bound, Lut};

mod exact;
pub use exact::{layer_depth, layer_position, LAYERS, LAYER_MAX_EXP, LAYER_MIN_EXP};

/// Largest table side.
pub const MAX_BINS: usize = 256;

/// Extinction per unit length where the table's opacity is 1: `e^-80` is
/// far below an `f32` ulp of 1 for any step of a sixteenth of a voxel or
/// more, so the step is opaque.
const TAU_MAX: f64 = 80.0;

/// How a pre-integrated step's colour weighs the colours along it (see
/// the module notes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Colouring {
    /// Engel's fast variant: the extinction-weighted mean colour,
    /// ignoring attenuation within the step (the pipeline's twin).
    #[default]
    Fast,
    /// The mean colour corrected to first order for attenuation within
    /// the step (golden only).
    Attenuated,
    /// The self-attenuated colour integrated at table-build time for a
    /// ladder of step optical depths and interpolated between them (see
    /// the module notes; golden and the pipeline).
    Exact,
}

impl Colouring {
    /// The name on the command line and in labels.
    pub fn name(self) -> &'static str {
        match self {
            Colouring::Fast => "fast",
            Colouring::Attenuated => "attenuated",
            Colouring::Exact => "exact",
        }
    }
}

impl std::str::FromStr for Colouring {
    type Err = crate::error::Error;

    fn from_str(s: &str) -> crate::error::Result<Colouring> {
        match s {
            "fast" => Ok(Colouring::Fast),
            "attenuated" => Ok(Colouring::Attenuated),
            "exact" => Ok(Colouring::Exact),
            _ => Err(crate::error::input(format!(
                "unknown pre-integrated colouring {s:?}: use fast, attenuated or exact"
            ))),
        }
    }
}

/// A pre-integrated classification table (see the module notes).
#[derive(Debug, Clone)]
pub struct PreTable {
    /// Bins per axis.
    pub bins: usize,
    /// What the steps' colours weigh.
    colouring: Colouring,
    /// Bin position per scalar unit.
    per_scalar: f32,
    /// `[front * bins + back]`: mean extinction-weighted colour and mean
    /// extinction per unit length (the colour is their ratio; both are
    /// interpolated, so a transparent neighbour bin does not darken it).
    data: Vec<[f32; 4]>,
    /// Table entries per bin (1 for 8-bit tables).
    stride: f64,
    /// The classification table with each opacity widened over the
    /// entries a bin reaches, when bins are coarser than entries.
    widened: Option<Lut>,
    /// See [`PreTable::clear_below`].
    clear_below: f32,
    /// `[front * bins + back]`: the colour's slope times the mean
    /// extinction, `k tau`, per channel (the fourth word 0); empty for
    /// [`Colouring::Fast`].
    slope: Vec<[f32; 4]>,
    /// `[(front * bins + back) * LAYERS + layer]`: the exact colouring's
    /// colour words per depth layer ([`exact`]); empty for the others.
    layers: Vec<[f32; 4]>,
}

impl PreTable {
    /// Pre-integrates `lut` for Engel's fast variant.
    pub fn new(lut: &Lut) -> PreTable {
        PreTable::with_colouring(lut, Colouring::Fast)
    }

    /// Pre-integrates `lut` with `colouring`.
    pub fn with_colouring(lut: &Lut, colouring: Colouring) -> PreTable {
        let entries = lut.rgba.len();
        let bins = entries.min(MAX_BINS);
        let stride = (entries - 1) as f64 / (bins - 1) as f64;
        // Linear interpolation of the table at position f (entries).
        let at = |f: f64| -> [f64; 4] {
            let f = f.clamp(0.0, (entries - 1) as f64);
            let i = (f as usize).min(entries - 2);
            let t = f - i as f64;
            let (a, b) = (lut.rgba[i], lut.rgba[i + 1]);
            std::array::from_fn(|k| f64::from(a[k]) + t * (f64::from(b[k]) - f64::from(a[k])))
        };
        let tau = |a: f64| {
            if a <= 0.0 {
                0.0
            } else if a >= 1.0 {
                TAU_MAX
            } else {
                (-(-a).ln_1p()).min(TAU_MAX)
            }
        };
        // Prefix integrals at the bins: extinction and extinction-weighted
        // colour.
        const SUB: usize = 16;
        let mut prefix = vec![[0f64; 4]; bins];
        for i in 1..bins {
            let (f0, h) = ((i - 1) as f64 * stride, stride / SUB as f64);
            let mut sum = [0f64; 4];
            for k in 0..=SUB {
                let w = if k == 0 || k == SUB {
                    1.0
                } else if k % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                let c = at(f0 + k as f64 * h);
                let t = tau(c[3]);
                for ch in 0..3 {
                    sum[ch] += w * t * c[ch];
                }
                sum[3] += w * t;
            }
            prefix[i] = std::array::from_fn(|k| prefix[i - 1][k] + sum[k] * h / 3.0);
        }
        let mut data = vec![[0f32; 4]; bins * bins];
        for i in 0..bins {
            for j in 0..bins {
                let e = if i == j {
                    let c = at(i as f64 * stride);
                    let t = tau(c[3]);
                    [c[0] * t, c[1] * t, c[2] * t, t]
                } else {
                    let (lo, hi) = (i.min(j), i.max(j));
                    let d: [f64; 4] = std::array::from_fn(|k| prefix[hi][k] - prefix[lo][k]);
                    let len = (hi - lo) as f64 * stride;
                    d.map(|v| v / len)
                };
                data[i * bins + j] = e.map(|v| v as f32);
            }
        }
        let widened = (bins < entries).then(|| {
            let reach = stride.ceil() as usize + 1;
            let mut w = lut.clone();
            for (k, e) in w.rgba.iter_mut().enumerate() {
                let (lo, hi) = (k.saturating_sub(reach), (k + reach).min(entries - 1));
                e[3] = lut.rgba[lo..=hi].iter().map(|c| c[3]).fold(0.0, f32::max);
            }
            w
        });
        let clear_below = clear_square(&data, bins);
        let slope = match colouring {
            Colouring::Attenuated => slopes(&at, &tau, bins, stride),
            _ => Vec::new(),
        };
        let layers = match colouring {
            Colouring::Exact => exact::layers(&at, &tau, bins, stride, &data),
            _ => Vec::new(),
        };
        PreTable {
            bins,
            colouring,
            per_scalar: (f64::from(lut.per_scalar) / stride) as f32,
            data,
            stride,
            widened,
            clear_below,
            slope,
            layers,
        }
    }

    /// A bin position below which every lookup has zero extinction: with
    /// bins `0..m` the largest square of zero-extinction entries, a
    /// lookup whose front and back positions both lie under `m - 1` reads
    /// four of them (`0 + t (0 - 0) = 0` exactly), so its step composites
    /// nothing (edge cases as [`Lut::clear_below`]'s).
    pub fn clear_below(&self) -> f32 {
        self.clear_below
    }

    /// The table the empty-space map must be built from so that skipping
    /// stays exact: `lut` itself when bins are entries; otherwise `lut`
    /// with every opacity widened over the entries a bin's interpolation
    /// reaches (a coarse bin's segment average sees entries a little beyond
    /// the scalars it was asked for).
    pub fn occupancy_lut<'a>(&'a self, lut: &'a Lut) -> &'a Lut {
        self.widened.as_ref().unwrap_or(lut)
    }

    /// How the table's steps weigh their colours.
    pub fn colouring(&self) -> Colouring {
        self.colouring
    }

    /// Table entries per bin.
    pub fn stride(&self) -> f64 {
        self.stride
    }

    /// Bin position per scalar unit (what [`PreTable::lookup`] scales a
    /// scalar by).
    pub fn per_scalar(&self) -> f32 {
        self.per_scalar
    }

    /// The words at bins `(front, back)`: mean extinction-weighted colour
    /// and mean extinction per unit length, what [`PreTable::lookup`]
    /// interpolates (the pipeline's host quantises them into its table).
    pub fn entry(&self, front: usize, back: usize) -> [f32; 4] {
        self.data[front * self.bins + back]
    }

    /// Mean extinction-weighted colour (`int tau c / len`, per channel)
    /// and mean extinction per unit length of a linear segment from scalar
    /// `front` to scalar `back`, interpolated bilinearly between bins; the
    /// segment's colour is the first three over the fourth.
    #[inline(always)]
    pub fn lookup(&self, front: f32, back: f32) -> [f32; 4] {
        let at = self.taps(front, back);
        bilinear(&self.data, self.bins, at)
    }

    /// [`PreTable::lookup`] and, for [`Colouring::Attenuated`], the
    /// colour's slope times the mean extinction (`k tau` per channel,
    /// interpolated alike; zeros for [`Colouring::Fast`]).
    #[inline(always)]
    pub fn lookup_with_slope(&self, front: f32, back: f32) -> ([f32; 4], [f32; 4]) {
        let at = self.taps(front, back);
        let e = bilinear(&self.data, self.bins, at);
        let k = if self.slope.is_empty() {
            [0.0; 4]
        } else {
            bilinear(&self.slope, self.bins, at)
        };
        (e, k)
    }

    /// A step's colour from its table words `e` and slope words `k`
    /// ([`PreTable::lookup_with_slope`]) and colour weight `h`
    /// ([`segment_attenuation`]; unused by [`Colouring::Fast`]): `e / tau`
    /// per channel, or `(e - h k) / tau`, clamped to `[0, 1]`.
    #[inline(always)]
    pub fn step_colour(&self, e: &[f32; 4], k: &[f32; 4], h: f32) -> [f32; 3] {
        let inv = 1.0 / e[3];
        match self.colouring {
            Colouring::Fast | Colouring::Exact => [e[0], e[1], e[2]].map(|v| (v * inv).min(1.0)),
            Colouring::Attenuated => {
                let mut c = [0f32; 3];
                for ch in 0..3 {
                    c[ch] = ((e[ch] - h * k[ch]) * inv).clamp(0.0, 1.0);
                }
                c
            }
        }
    }

    /// The exact colouring's step colour ([`Colouring::Exact`]) from
    /// front and back scalars, the step's table words `e`
    /// ([`PreTable::lookup`]) and its depth layer and weight
    /// ([`layer_position`]): the layers' words interpolated bilinearly
    /// like `e`, then linearly between the two layers, over `e`'s
    /// extinction, clamped to `[0, 1]`.
    #[inline(always)]
    pub fn layered_colour(
        &self,
        front: f32,
        back: f32,
        e: &[f32; 4],
        (layer, w): (usize, f32),
    ) -> [f32; 3] {
        let (r, ti, tj) = self.taps(front, back);
        // Entry `r`'s layer `layer` and its bilinear neighbours, `LAYERS`
        // words apart per bin.
        let words = &self.layers[layer..];
        let at = |k: usize| words[k * LAYERS];
        let mix = |a: [f32; 4], b: [f32; 4], c: [f32; 4], d: [f32; 4]| {
            let mut e = [0f32; 3];
            for k in 0..3 {
                let top = a[k] + tj * (b[k] - a[k]);
                let bot = c[k] + tj * (d[k] - c[k]);
                e[k] = top + ti * (bot - top);
            }
            e
        };
        let n = self.bins;
        let lo = mix(at(r), at(r + 1), at(r + n), at(r + n + 1));
        let mut c = lo;
        if w > 0.0 {
            let up = |k: usize| words[k * LAYERS + 1];
            let hi = mix(up(r), up(r + 1), up(r + n), up(r + n + 1));
            for ch in 0..3 {
                c[ch] += w * (hi[ch] - c[ch]);
            }
        }
        let inv = 1.0 / e[3];
        c.map(|v| (v * inv).clamp(0.0, 1.0))
    }

    /// The exact colouring's words of layer `layer` at bins `(front,
    /// back)` (colour times mean extinction, as [`PreTable::entry`]'s
    /// first three; the pipeline's host quantises them). Panics unless the
    /// table is [`Colouring::Exact`].
    pub fn layer_entry(&self, layer: usize, front: usize, back: usize) -> [f32; 4] {
        self.layers[(front * self.bins + back) * LAYERS + layer]
    }

    /// The first of the four entries a lookup reads, and its weights
    /// along the front and the back scalar.
    #[inline(always)]
    fn taps(&self, front: f32, back: f32) -> (usize, f32, f32) {
        let last = (self.bins - 1) as f32;
        let pos = |s: f32| {
            let f = (s * self.per_scalar).clamp(0.0, last);
            // `f` lies in `0..=last` (at most 255), so truncating through
            // `u32` is truncating through `usize`, and the conversions
            // stay one instruction each (`usize` to `f32` is several).
            let i = (f as u32).min(self.bins as u32 - 2);
            (i as usize, f - i as f32)
        };
        let ((i, ti), (j, tj)) = (pos(front), pos(back));
        (i * self.bins + j, ti, tj)
    }
}

/// The bilinear interpolation of `data` (`bins` by `bins`) at `(r, ti, tj)`
/// from [`PreTable::taps`]: along the back scalar first on both rows, then
/// along the front.
#[inline(always)]
fn bilinear(data: &[[f32; 4]], bins: usize, (r, ti, tj): (usize, f32, f32)) -> [f32; 4] {
    let (a, b) = (data[r], data[r + 1]);
    let (c, d) = (data[r + bins], data[r + bins + 1]);
    // A plain loop: `array::from_fn` kept this call out of line.
    let mut e = [0f32; 4];
    for k in 0..4 {
        let top = a[k] + tj * (b[k] - a[k]);
        let bot = c[k] + tj * (d[k] - c[k]);
        e[k] = top + ti * (bot - top);
    }
    e
}

/// The attenuated variant's `k tau` per bin pair (see the module notes):
/// `12 / len * int c (x - 1/2) tau df` over the segment, with `x(f)` the
/// fraction of the segment's extinction between its front and `f`. From
/// prefix integrals (trapezoids, 16 per bin, in `f64`) of `tau`, `c tau`
/// and `c tau T` (`T` the prefix extinction): between nodes `a` (front)
/// and `b` (back), either way round, the integral is
/// `num / |E| - sign(E) (P1(b) - P1(a)) / 2` with `E = T(b) - T(a)` and
/// `num = P2(b) - P2(a) - T(a) (P1(b) - P1(a))`. A segment without
/// extinction has slope 0, so transparent spans stay exactly clear.
fn slopes(
    at: &impl Fn(f64) -> [f64; 4],
    tau: &impl Fn(f64) -> f64,
    bins: usize,
    stride: f64,
) -> Vec<[f32; 4]> {
    const SUB: usize = 16;
    let nodes = (bins - 1) * SUB + 1;
    let h = stride / SUB as f64;
    let (mut t, mut p1, mut p2) = (
        vec![0f64; nodes],
        vec![[0f64; 3]; nodes],
        vec![[0f64; 3]; nodes],
    );
    let sample = |k: usize| {
        let c = at(k as f64 * h);
        (c, tau(c[3]))
    };
    let (mut c0, mut t0) = sample(0);
    for k in 1..nodes {
        let (c1, t1) = sample(k);
        t[k] = t[k - 1] + h * (t0 + t1) / 2.0;
        for ch in 0..3 {
            p1[k][ch] = p1[k - 1][ch] + h * (c0[ch] * t0 + c1[ch] * t1) / 2.0;
            p2[k][ch] = p2[k - 1][ch] + h * (c0[ch] * t0 * t[k - 1] + c1[ch] * t1 * t[k]) / 2.0;
        }
        (c0, t0) = (c1, t1);
    }
    let mut out = vec![[0f32; 4]; bins * bins];
    for i in 0..bins {
        for j in 0..bins {
            let (a, b) = (i * SUB, j * SUB);
            let e = t[b] - t[a];
            if i == j || e == 0.0 {
                continue;
            }
            let len = i.abs_diff(j) as f64 * stride;
            for ch in 0..3 {
                let d1 = p1[b][ch] - p1[a][ch];
                let num = p2[b][ch] - p2[a][ch] - t[a] * d1;
                let integral = num / e.abs() - e.signum() * d1 / 2.0;
                out[i * bins + j][ch] = (12.0 * integral / len) as f32;
            }
        }
    }
    out
}

/// The bound of [`PreTable::clear_below`] for `data` (`bins` by `bins`).
fn clear_square(data: &[[f32; 4]], bins: usize) -> f32 {
    let clear = |i: usize, j: usize| data[i * bins + j][3] == 0.0;
    // Grow the square while its new row and column stay clear.
    let mut m = 0;
    while m < bins && (0..=m).all(|k| clear(m, k) && clear(k, m)) {
        m += 1;
    }
    clear_bound(m, bins)
}

/// Opacity and colour weight of an attenuated step ([`Colouring::Attenuated`])
/// of length `ds` at mean extinction `tau`: [`segment_opacity`]'s
/// opacity (the same bits) and `h(lambda) = 1/(1 - e^-lambda) - 1/lambda
/// - 1/2` at `lambda = ds tau`, in `f64` (its series
/// `lambda/12 - lambda^3/720 + lambda^5/30240` below `lambda = 1/4`, where
/// the difference would cancel; the next term is below `6e-11`). The
/// step's colour is `(c tau - h k tau) / tau` per channel.
#[inline]
pub fn segment_attenuation(tau: f32, ds: f32) -> (f32, f32) {
    if tau <= 0.0 {
        return (0.0, 0.0);
    }
    let y = -f64::from(ds) * f64::from(tau);
    let a = neg_expm1(y);
    (a as f32, attenuation_weight(-y, a) as f32)
}

/// Opacity and depth layer of an exact step ([`Colouring::Exact`]) of
/// length `ds` at mean extinction `tau`: [`segment_opacity`]'s opacity
/// (the same bits) and [`layer_position`] at `p = ds tau / ln 2`.
#[inline]
pub fn segment_exact(tau: f32, ds: f32) -> (f32, (usize, f32)) {
    if tau <= 0.0 {
        return (0.0, (0, 0.0));
    }
    let y = -f64::from(ds) * f64::from(tau);
    let a = neg_expm1(y);
    (a as f32, layer_position(-y / std::f64::consts::LN_2))
}

/// `h(lambda)` of [`segment_attenuation`] from `lambda >= 0` and
/// `a = 1 - e^-lambda` (both `f64`).
#[inline(always)]
pub(crate) fn attenuation_weight(lambda: f64, a: f64) -> f64 {
    if lambda < 0.25 {
        let l2 = lambda * lambda;
        lambda * (1.0 / 12.0 - l2 * (1.0 / 720.0 - l2 * (1.0 / 30_240.0)))
    } else {
        1.0 / a - 1.0 / lambda - 0.5
    }
}

/// Opacity of a step of length `ds` at mean extinction `tau`:
/// `1 - e^(-ds tau)`, within one `f32` ulp (see [`crate::opacity`]).
#[inline]
pub fn segment_opacity(tau: f32, ds: f32) -> f32 {
    if tau <= 0.0 {
        return 0.0;
    }
    neg_expm1(-f64::from(ds) * f64::from(tau)) as f32
}
