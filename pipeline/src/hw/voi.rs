//! The volume-of-interest stage described once: the opacity factor of a
//! sample from its position ([`crate::voi::VoiUnit::factor`], steps 1 to
//! 5) and the classified opacity scaled by it
//! ([`crate::voi::VoiUnit::scale`], step 6), the same operations into the
//! same formats (`hw::units_tests` checks it word for word). Golden twin:
//! `golden::voi::ViewVoi::factor`.
//!
//! Both shapes and both weightings are built, as the chip has them; the
//! host's per-frame flags (`sphere`, `step`, `outside`) pick one. The
//! three axes share one square per axis (the box's `max(e, 0)` or the
//! sphere's `q`), one sum and one integer square root.
//!
//! Ports: the sample's position (`x`, `y` in `position`, the slice `z`),
//! the per-frame broadcast (`centre.*`, `axis.*`, `half.*`, `radius`,
//! its square `radius2`, `gain`, the flags) and the classified opacity `class.a`. Outputs: `weight`
//! (`voi_weight`), `factor` (`voi_factor`) and `alpha` (`alpha`).

use super::{Graph, NodeId, Word};
use crate::config::PipelineConfig;
use crate::fixed::{Format, QuantStats, Wide};

/// The raw word of `1` assigned into `f` (a constant of the unit).
pub(crate) fn one_in(f: Format) -> i128 {
    i128::from(f.assign(Wide::new(1, 0), &mut QuantStats::default()).raw())
}

/// The bits of a slice index `z`: the position's integer magnitude.
pub fn slice_bits(cfg: &PipelineConfig) -> u32 {
    let p = cfg.position;
    (u32::from(p.bits()) - u32::from(p.frac()) - u32::from(p.is_signed())).max(1)
}

/// The stage's description for `cfg`.
pub fn voi(cfg: &PipelineConfig) -> Graph {
    let c = cfg;
    let dist = c.voi_dist;
    let wf = c.voi_weight;
    let mut g = Graph::new();
    g.no_item();
    let p = [
        g.input("x", c.position),
        g.input("y", c.position),
        g.input_word("z", Word::unsigned(slice_bits(c), 0)),
    ];
    let axes = ["x", "y", "z"];
    let centre = axes.map(|a| g.input(&format!("centre.{a}"), c.position));
    let axis = axes.map(|a| g.input(&format!("axis.{a}"), c.voi_axis));
    let half = axes.map(|a| g.input(&format!("half.{a}"), dist));
    let radius = g.input("radius", dist);
    // The radius squared, exact: a per-frame constant of the host (a
    // port of twice `voi_dist`'s bits).
    let dw2 = Word::signed(2 * u32::from(dist.bits()), 2 * i32::from(dist.frac()));
    let r2 = g.input_word("radius2", dw2);
    let gain = g.input("gain", c.voi_gain);
    let bit = Word::unsigned(1, 0);
    let [sphere, step, outside] = ["sphere", "step", "outside"].map(|n| g.input_word(n, bit));
    let a = g.input("class.a", c.alpha);

    // 1. q = |p - c| k per axis.
    let fd = i32::from(dist.frac());
    let mut q = [NodeId(0); 3];
    for k in 0..3 {
        g.item("voi", "|p - c| per axis", k as u32);
        let n = axes[k];
        let d = g.sum(&format!("voi.d.{n}"), p[k], centre[k], true);
        let nd = g.sum(&format!("voi.nd.{n}"), centre[k], p[k], true);
        let dw = g.word(d);
        // The difference's sign bit picks the other one.
        let neg = g.field(&format!("voi.neg.{n}"), d, dw.bits as i32 - 1, bit);
        let mag = g.mux(&format!("voi.mag.{n}"), neg, d, nd, dw);
        // The magnitude's sign bit is zero: its other bits are the word.
        let mag = g.field(
            &format!("voi.abs.{n}"),
            mag,
            0,
            Word::unsigned(dw.bits - 1, dw.frac),
        );
        g.step_out(mag);
        g.item("voi", "q = |p - c| k per axis", k as u32);
        let prod = g.mul_exact(&format!("voi.qk.{n}"), mag, axis[k]);
        q[k] = g.quantize(&format!("voi.q.{n}"), prod, dist);
        g.step_out(q[k]);
    }

    // 2. The box's e = q - h and the square per axis: the box squares
    // max(e, 0), the sphere q.
    let lsb = g.constant("voi.lsb", 1, Word::unsigned(1, fd));
    let zero = g.constant("voi.zero", 0, bit);
    let mut e = [NodeId(0); 3];
    let mut pos = [NodeId(0); 3];
    let mut sq = [NodeId(0); 3];
    for k in 0..3 {
        g.item("voi", "box e = q - h, square per axis", k as u32);
        let n = axes[k];
        let s = g.sum(&format!("voi.es.{n}"), q[k], half[k], true);
        e[k] = g.quantize(&format!("voi.e.{n}"), s, dist);
        pos[k] = g.ge(&format!("voi.out.{n}"), e[k], lsb);
        let ew = g.word(e[k]);
        let emax = g.mux(&format!("voi.emax.{n}"), pos[k], zero, e[k], ew);
        let x = g.mux(&format!("voi.sqin.{n}"), sphere, emax, q[k], ew);
        sq[k] = g.mul_exact(&format!("voi.sq.{n}"), x, x);
        g.step_out(sq[k]);
    }
    g.item("voi", "sum of squares", 0);
    let s01 = g.sum("voi.s01", sq[0], sq[1], false);
    let sum = g.sum("voi.sum", s01, sq[2], false);
    g.step_out(sum);
    g.item("voi", "distance: square root", 0);
    let len = g.push("voi.len", super::Op::Isqrt(sum), dist.into(), Some(dist));
    g.step_out(len);

    // 3. The signed distance and the comparators.
    g.item("voi", "comparators: e <= 0, |q|^2 <= r^2, max e", 0);
    let out01 = g.mux("voi.out01", pos[0], pos[1], pos[0], bit);
    let out = g.mux("voi.outside_box", out01, pos[2], out01, bit);
    let in_sphere = g.ge("voi.in_sphere", r2, sum);
    let m01 = g.max("voi.emax01", e[0], e[1]);
    let e_max = g.max("voi.emax", m01, e[2]);
    let dw = g.word(e[0]);
    let d_box = g.mux("voi.d_box", out, e_max, len, dw);
    let ds = g.sum("voi.ds", len, radius, true);
    let d_sphere = g.quantize("voi.d_sphere", ds, dist);
    let d = g.mux("voi.dist", sphere, d_box, d_sphere, dw);
    g.step_out(d);

    // The weight: clamp(1/2 - d, 0, 1) with a ramp, the comparator's 0 or
    // 1 without; 1 - w outside.
    g.item("voi", "weight clamp(1/2 - d, 0, 1), 1 - w", 0);
    let halfc = g.constant("voi.half", 1, Word::unsigned(1, 1));
    let v = g.sum("voi.v", halfc, d, true);
    let le0 = g.ge("voi.le0", zero, v);
    let one = g.constant("voi.one", 1, bit);
    let ge1 = g.ge("voi.ge1", v, one);
    let wq = g.quantize("voi.wq", v, wf);
    let ww: Word = wf.into();
    let one_w = g.constant("voi.one_w", one_in(wf), ww);
    let zero_w = g.constant("voi.zero_w", 0, ww);
    let w1 = g.mux("voi.w1", ge1, wq, one_w, ww);
    let ramp = g.mux("voi.ramp", le0, w1, zero_w, ww);
    let one_b = g.constant("voi.one_b", 1, bit);
    let in_box = g.mux("voi.in_box", out, one_b, zero, bit);
    let inside = g.mux("voi.inside", sphere, in_box, in_sphere, bit);
    let stepw = g.mux("voi.stepw", inside, zero_w, one_w, ww);
    let w = g.mux("voi.w", step, ramp, stepw, ww);
    let inv = g.sum("voi.inv", one, w, true);
    let inv = g.quantize("voi.w_inv", inv, wf);
    let weight = g.mux("weight", outside, w, inv, ww);
    g.step_out(weight);

    // 5. f = 1 + (S - 1) w.
    g.item("voi", "factor 1 + (S - 1) w", 0);
    let gw = g.mul_exact("voi.gw", gain, weight);
    let fs = g.sum("voi.fs", one, gw, false);
    let factor = g.quantize("factor", fs, c.voi_factor);
    g.step_out(factor);

    // 6. a' = a f.
    g.item("voi", "opacity a f", 0);
    let af = g.mul_exact("voi.af", a, factor);
    let alpha = g.quantize("alpha", af, c.alpha);
    g.step_out(alpha);
    g.output("weight", weight);
    g.output("factor", factor);
    g.output("alpha", alpha);
    g
}
