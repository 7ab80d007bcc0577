//! The exact colouring's layers ([`super::Colouring::Exact`]).
//!
//! **What a step's colour depends on.** Along a linear segment from front
//! scalar `s_f` to back scalar `s_b`, let `x` be the fraction of the
//! segment's extinction in front of a point and `c(x)` the colour there;
//! `c` depends on `(s_f, s_b)` only. A step of length `ds` has optical
//! depth `lambda = ds tau(s_f, s_b)`, and its self-attenuated colour is
//!
//! `C(s_f, s_b, lambda) = int_0^1 c(x) lambda e^(-lambda x) dx / (1 - e^-lambda)`
//!
//! (the step's opacity `1 - e^-lambda` is the fast table's, exactly). So
//! the length enters through `lambda` alone, and one more table axis over
//! the step's depth makes the colour exact at its nodes for every length.
//!
//! **The depth axis.** Nodes in `p = lambda / ln 2` (the `-log2`
//! transmittance the pipeline computes anyway): `0`, then two per octave,
//! `2^e` and `1.5 2^e` for `e` in `LAYER_MIN_EXP..LAYER_MAX_EXP`, and
//! `2^LAYER_MAX_EXP`: [`LAYERS`] layers. A step's colour interpolates
//! linearly in `p` between its two nodes (below the first octave, between
//! `0` and `2^LAYER_MIN_EXP`; at or above the last node, the last layer).
//! The node and weight are `p`'s exponent and its mantissa's top bit and
//! the bits below it, as the pipeline reads them from its `p` word. Layer
//! `0` is the fast table's colour (`lambda = 0`: no attenuation inside).
//!
//! **Its error.** The node colours are the integral above by quadrature
//! (colour linear in `x` between 2 nodes per bin, the exponential
//! integrated exactly over each interval, in `f64`); between nodes the
//! linear interpolation in `p` is off the exact colour by at most 0.011
//! of a colour step inside the segment (the worst case: the colour jumps
//! from 0 to 1 at one extinction fraction, over every fraction and every
//! `p` up to 32), and 0.0004 for a colour linear in `x`. Steps deeper than
//! `p = 32` (transmittance below `2^-32`) take the colour of `p = 32`:
//! only a colour change inside the front `1/22` of such a step's
//! extinction is weighed differently.

use rayon::prelude::*;

/// The first octave of the depth axis: `p = 2^LAYER_MIN_EXP`.
pub const LAYER_MIN_EXP: i32 = -3;

/// The last node of the depth axis: `p = 2^LAYER_MAX_EXP` (the pipeline's
/// default `log_transmittance` saturates just below it).
pub const LAYER_MAX_EXP: i32 = 5;

/// Layers of the exact colouring: `p = 0`, two per octave, and the top.
pub const LAYERS: usize = 2 + 2 * (LAYER_MAX_EXP - LAYER_MIN_EXP) as usize;

/// Quadrature nodes per bin.
const SUB: usize = 2;

/// The depth `p` (`-log2` transmittance) of layer `l`.
pub fn layer_depth(l: usize) -> f64 {
    match l {
        0 => 0.0,
        l if l + 1 >= LAYERS => 2f64.powi(LAYER_MAX_EXP),
        l => {
            let e = LAYER_MIN_EXP + ((l - 1) / 2) as i32;
            2f64.powi(e) * (1.0 + 0.5 * ((l - 1) % 2) as f64)
        }
    }
}

/// The layer below depth `p` and the weight of the one above it (see the
/// module notes): `(0, p / 2^LAYER_MIN_EXP)` below the first octave,
/// `(LAYERS - 1, 0)` at or above the top node.
#[inline(always)]
pub fn layer_position(p: f64) -> (usize, f32) {
    let first = 2f64.powi(LAYER_MIN_EXP);
    if p.is_nan() || p <= 0.0 {
        return (0, 0.0);
    }
    if p < first {
        return (0, (p / first) as f32);
    }
    if p >= 2f64.powi(LAYER_MAX_EXP) {
        return (LAYERS - 1, 0.0);
    }
    // `p` is normal here: exponent and mantissa from its bits, exactly.
    let bits = p.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let mant = (bits & ((1u64 << 52) - 1)) as f64 / (1u64 << 52) as f64;
    let m2 = 2.0 * mant;
    let m = m2 as usize;
    let l = 1 + 2 * (e - LAYER_MIN_EXP) as usize + m;
    (l, (m2 - m as f64) as f32)
}

/// The layers' words, `[(front * bins + back) * LAYERS + layer]` (a bin
/// pair's layers side by side, so a step's two layers share cache
/// lines): the node colours
/// times the fast table's mean extinction (so that they interpolate as
/// its colour words do), layer 0 the fast table's own. `at` interpolates
/// the classification table at a position in entries, `tau` turns an
/// opacity into an extinction, `data` is the fast table.
pub(super) fn layers(
    at: &(impl Fn(f64) -> [f64; 4] + Sync),
    tau: &(impl Fn(f64) -> f64 + Sync),
    bins: usize,
    stride: f64,
    data: &[[f32; 4]],
) -> Vec<[f32; 4]> {
    let nodes = (bins - 1) * SUB + 1;
    let h = stride / SUB as f64;
    // Colours and prefix extinction (trapezoids) at the nodes.
    let mut colour = vec![[0f64; 3]; nodes];
    let mut prefix = vec![0f64; nodes];
    let mut last = 0.0;
    for k in 0..nodes {
        let c = at(k as f64 * h);
        let t = tau(c[3]);
        colour[k] = [c[0], c[1], c[2]];
        if k > 0 {
            prefix[k] = prefix[k - 1] + h * (last + t) / 2.0;
        }
        last = t;
    }
    let lambdas: [f64; LAYERS] = std::array::from_fn(|l| layer_depth(l) * std::f64::consts::LN_2);
    let n2 = bins * bins;
    let rows: Vec<Vec<[[f32; 4]; LAYERS]>> = (0..bins)
        .into_par_iter()
        .map(|i| {
            (0..bins)
                .map(|j| {
                    let fast = data[i * bins + j];
                    let words = if i == j {
                        None
                    } else {
                        pair(&colour, &prefix, &lambdas, (i * SUB, j * SUB))
                    };
                    let mut out = [fast; LAYERS];
                    if let Some(c) = words {
                        let t = f64::from(fast[3]);
                        for (o, c) in out.iter_mut().zip(c).skip(1) {
                            *o = [
                                (c[0] * t) as f32,
                                (c[1] * t) as f32,
                                (c[2] * t) as f32,
                                fast[3],
                            ];
                        }
                    }
                    out
                })
                .collect()
        })
        .collect();
    let mut out = Vec::with_capacity(LAYERS * n2);
    for row in &rows {
        for w in row {
            out.extend_from_slice(w);
        }
    }
    out
}

/// The node colours of the segment from node `a` (front) to node `b`
/// (back) at every layer's depth, or `None` when the segment has no
/// extinction (its colour is then the fast one). Over each interval the
/// colour is linear in the extinction fraction `x` and the weight
/// `lambda e^(-lambda x)` is integrated exactly: with `mu = lambda dx`,
/// `q = e^-mu` and `P` the transmittance to the interval's front, it adds
/// `P (c0 (1 - q) + (c1 - c0) g(mu))`, `g(mu) = (1 - q (1 + mu)) / mu`;
/// the sum is divided by the summed weight `sum P (1 - q)`, so a constant
/// colour comes out exactly. Layers two apart are an octave apart, so
/// their `q` is the square of the lower one's.
fn pair(
    colour: &[[f64; 3]],
    prefix: &[f64],
    lambdas: &[f64; LAYERS],
    (a, b): (usize, usize),
) -> Option<[[f64; 3]; LAYERS]> {
    let total = (prefix[b] - prefix[a]).abs();
    if total <= 0.0 {
        return None;
    }
    let inv_lambdas: [f64; LAYERS] = std::array::from_fn(|l| 1.0 / lambdas[l]);
    let mut sum = [[0f64; 3]; LAYERS];
    let mut weight = [0f64; LAYERS];
    let mut trans = [1f64; LAYERS];
    // Layers above `live` have transmittance below an f32 ulp's worth.
    let mut live = LAYERS;
    let forward = b > a;
    let steps = a.abs_diff(b);
    for s in 0..steps {
        let (k0, k1) = if forward {
            (a + s, a + s + 1)
        } else {
            (a - s, a - s - 1)
        };
        let dx = (prefix[k1] - prefix[k0]).abs() / total;
        if dx == 0.0 {
            continue;
        }
        let (c0, c1) = (colour[k0], colour[k1]);
        let dc: [f64; 3] = std::array::from_fn(|ch| c1[ch] - c0[ch]);
        // Layer 2's depth is 1.5 times layer 1's; each further layer
        // doubles the one two below.
        let mut q = [0f64; LAYERS];
        q[1] = (-lambdas[1] * dx).exp();
        q[2] = q[1] * q[1].sqrt();
        for l in 3..live {
            q[l] = q[l - 2] * q[l - 2];
        }
        let inv_dx = 1.0 / dx;
        for l in 1..live {
            let mu = lambdas[l] * dx;
            let one_minus = 1.0 - q[l];
            let g = if mu < 1e-3 {
                mu * (0.5 - mu * (1.0 / 3.0 - mu / 8.0))
            } else {
                (one_minus - mu * q[l]) * inv_lambdas[l] * inv_dx
            };
            let p = trans[l];
            for ch in 0..3 {
                sum[l][ch] += p * (c0[ch] * one_minus + dc[ch] * g);
            }
            weight[l] += p * one_minus;
            trans[l] = p * q[l];
        }
        while live > 1 && trans[live - 1] < 1e-18 {
            live -= 1;
        }
    }
    let mut out = [[0f64; 3]; LAYERS];
    for l in 1..LAYERS {
        if weight[l] > 0.0 {
            out[l] = sum[l].map(|v| (v / weight[l]).clamp(0.0, 1.0));
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_positions_hit_their_nodes_and_interpolate_linearly_in_p() {
        for l in 1..LAYERS - 1 {
            let p = layer_depth(l);
            assert_eq!(layer_position(p), (l, 0.0), "node {l} at p = {p}");
            let mid = (p + layer_depth(l + 1)) / 2.0;
            let (k, w) = layer_position(mid);
            assert_eq!(k, l);
            assert!((w - 0.5).abs() < 1e-6, "{l}: {w}");
        }
        assert_eq!(layer_position(0.0), (0, 0.0));
        assert_eq!(layer_position(1.0 / 16.0), (0, 0.5));
        assert_eq!(layer_position(32.0), (LAYERS - 1, 0.0));
        assert_eq!(layer_position(1e9), (LAYERS - 1, 0.0));
    }
}
