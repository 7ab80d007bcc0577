//! The gradient and shading unit described once, for a given number of
//! lights: the twelve central differences, the gradient's bilinear
//! interpolation, `|g|`, the normal fade, per light the dot products,
//! the dividers and the specular power table, the light mix, the shaded
//! colour and the gradient opacity, as
//! [`crate::shading::ShadeUnit::gradient`] and
//! [`crate::shading::ShadeUnit::shade`] (`hw::units_tests` checks it
//! word for word). Golden twin: `golden::shading::Shader::shade`.
//!
//! The per-frame choices are ports: `fade` (a normal fade is set: `r =
//! min(1, |g| / F)`, else `r = 1` for a non-zero gradient) and `gopac`
//! (gradient opacity is set). A zero gradient makes `r = 0`, so the
//! lights' terms (whose dividers then see a zero divisor) drop out of the
//! colour without a select.
//!
//! Ports: the voxel words around the sample (`tx.<row>.<col>`,
//! `ty.<col>.<k>`, `tz.<k>.<row>.<col>`, as [`crate::shading::Taps`]),
//! the scalar's weights `wx`, `wy`, the per-frame broadcast (`scale.*`,
//! `light<i>.*`, `halfv<i>.*`, `ka`, `kd`, `ks`, `inv_fade`, `inv_g`,
//! the flags) and the classified `class.r`, `class.g`, `class.b`,
//! `class.a`. Outputs: the shaded
//! `c_r`, `c_g`, `c_b` (`color`), `alpha` (`alpha`).

use super::{Graph, NodeId, Word};
use crate::config::PipelineConfig;

/// The memory of the specular power table.
pub const POWER_TABLE: &str = "power_table";

/// `a b + c d + e f` exact.
fn dot(g: &mut Graph, name: &str, x: [NodeId; 3], y: [NodeId; 3]) -> NodeId {
    let p = [0, 1, 2].map(|k| g.mul_exact(&format!("{name}.p{k}"), x[k], y[k]));
    let s = g.sum(&format!("{name}.s01"), p[0], p[1], false);
    g.sum(name, s, p[2], false)
}

/// The unit's description for `cfg` and `lights` lights (at least one).
pub fn shading(cfg: &PipelineConfig, lights: usize) -> Graph {
    let c = cfg;
    let mut g = Graph::new();
    let nd = c.normal_dot;
    let power = g.mem(POWER_TABLE, (1u64 << c.shade_table_bits) + 1, c.specular);
    g.no_item();
    let vox = |g: &mut Graph, n: String| g.input(&n, c.voxel);
    let mut tx = [[NodeId(0); 4]; 2];
    for (r, row) in tx.iter_mut().enumerate() {
        for (k, t) in row.iter_mut().enumerate() {
            *t = vox(&mut g, format!("tx.{r}.{k}"));
        }
    }
    let mut ty = [[NodeId(0); 2]; 2];
    for (col, v) in ty.iter_mut().enumerate() {
        for (k, t) in v.iter_mut().enumerate() {
            *t = vox(&mut g, format!("ty.{col}.{k}"));
        }
    }
    let mut tz = [[[NodeId(0); 2]; 2]; 2];
    for (k, s) in tz.iter_mut().enumerate() {
        for (r, row) in s.iter_mut().enumerate() {
            for (col, t) in row.iter_mut().enumerate() {
                *t = vox(&mut g, format!("tz.{k}.{r}.{col}"));
            }
        }
    }
    let wx = g.input("wx", c.weight);
    let wy = g.input("wy", c.weight);
    let axes = ["x", "y", "z"];
    let scale = axes.map(|a| g.input(&format!("scale.{a}"), c.grad_scale));
    let lv: Vec<[NodeId; 3]> = (0..lights)
        .map(|i| axes.map(|a| g.input(&format!("light{i}.{a}"), c.light)))
        .collect();
    let hv: Vec<[NodeId; 3]> = (0..lights)
        .map(|i| axes.map(|a| g.input(&format!("halfv{i}.{a}"), c.light)))
        .collect();
    let [ka, kd, ks] = ["ka", "kd", "ks"].map(|n| g.input(n, c.material));
    let inv_fade = g.input("inv_fade", c.grad_recip);
    let inv_g = g.input("inv_g", c.grad_recip);
    let bit = Word::unsigned(1, 0);
    let fade = g.input_word("fade", bit);
    let gopac = g.input_word("gopac", bit);
    let rgb = ["r", "g", "b"].map(|n| g.input(&format!("class.{n}"), c.color));
    let a = g.input("class.a", c.alpha);

    // 1. Central differences (hi - lo) k into `gradient`, per axis and
    // corner [row][col].
    let mut corner = [[[NodeId(0); 2]; 2]; 3];
    let mut copy = 0;
    for (axis, co) in corner.iter_mut().enumerate() {
        for (j, row) in co.iter_mut().enumerate() {
            for (i, cn) in row.iter_mut().enumerate() {
                let (hi, lo) = match axis {
                    0 => (tx[j][i + 2], tx[j][i]),
                    1 if j == 0 => (tx[1][i + 1], ty[i][0]),
                    1 => (ty[i][1], tx[0][i + 1]),
                    _ => (tz[1][j][i], tz[0][j][i]),
                };
                g.item("gradient", "central difference x scale", copy);
                copy += 1;
                let n = format!("grad.d.{}{j}{i}", axes[axis]);
                let d = g.sum(&format!("{n}.diff"), hi, lo, true);
                let p = g.mul_exact(&format!("{n}.p"), d, scale[axis]);
                *cn = g.quantize(&n, p, c.gradient);
                g.step_out(*cn);
            }
        }
    }

    // 2. Each component bilinear with the scalar's weights.
    let mut grad = [NodeId(0); 3];
    for (axis, gr) in grad.iter_mut().enumerate() {
        let n = axes[axis];
        let co = corner[axis];
        g.item("gradient", "x lerp (3 components, 2 rows)", 2 * axis as u32);
        let top = g.lerp(
            &format!("grad.{n}.top"),
            co[0][0],
            Some(co[0][1]),
            wx,
            c.gradient,
        );
        g.step_out(top);
        g.item(
            "gradient",
            "x lerp (3 components, 2 rows)",
            2 * axis as u32 + 1,
        );
        let bot = g.lerp(
            &format!("grad.{n}.bot"),
            co[1][0],
            Some(co[1][1]),
            wx,
            c.gradient,
        );
        g.step_out(bot);
        g.item("gradient", "y lerp (3 components)", axis as u32);
        *gr = g.lerp(&format!("grad.{n}"), top, Some(bot), wy, c.gradient);
        g.step_out(*gr);
    }

    // 3. |g|: the exact sum of squares and its integer square root.
    let sq: Vec<NodeId> = (0..3)
        .map(|k| {
            g.item("shading", "squares of the gradient", k as u32);
            g.mul_exact(&format!("norm.sq{}", axes[k]), grad[k], grad[k])
        })
        .collect();
    g.item("shading", "sum of squares", 0);
    let s01 = g.sum("norm.s01", sq[0], sq[1], false);
    let sum = g.sum("norm.sum", s01, sq[2], false);
    g.step_out(sum);
    g.item("shading", "|g|: square root", 0);
    let norm = g.push(
        "norm",
        super::Op::Isqrt(sum),
        c.grad_norm.into(),
        Some(c.grad_norm),
    );
    g.step_out(norm);

    // 4. The fade r: min(1, |g| (1/F)) with a fade, else 1 for a
    // non-zero gradient.
    g.item("shading", "normal fade min(1, |g| / F)", 0);
    let one = g.constant("shade.one", 1, bit);
    let fp = g.mul_exact("fade.p", norm, inv_fade);
    let fm = g.min("fade.min", fp, one);
    let rf = g.quantize("fade.r", fm, nd);
    let nz = g.nonzero("norm.nz", norm);
    let ndw: Word = nd.into();
    let one_nd = g.constant("fade.one", super::voi::one_in(nd), ndw);
    let zero_nd = g.constant("fade.zero", 0, ndw);
    let r1 = g.mux("fade.r1", nz, zero_nd, one_nd, ndw);
    let r = g.mux("fade.out", fade, r1, rf, ndw);
    g.step_out(r);

    // Per light: |g . v| / |g| capped at 1 into `normal_dot`, and the
    // power table at |n . H|.
    let fo = u32::from(nd.frac());
    let b = u32::from(c.shade_table_bits);
    let last = 1i128 << b;
    let qw = Word::unsigned(fo + 1, fo as i32);
    let mut diffuse: Option<NodeId> = None;
    let mut spec: Option<NodeId> = None;
    let cosine = |g: &mut Graph, name: &str, v: [NodeId; 3], copy: u32| {
        g.item("shading", "g . L, g . H (3 multiply-adds each)", copy);
        let d = dot(g, &format!("{name}.dot"), grad, v);
        g.step_out(d);
        g.item("shading", "divider |g . v| / |g|", copy);
        let zero = g.constant(&format!("{name}.zero"), 0, bit);
        let neg = g.sum(&format!("{name}.neg"), zero, d, true);
        let dw = g.word(neg);
        let dd = g.word(d);
        let is_neg = g.field(&format!("{name}.is_neg"), d, dd.bits as i32 - 1, bit);
        let m = g.mux(&format!("{name}.abs"), is_neg, d, neg, dw);
        let m = g.field(
            &format!("{name}.mag"),
            m,
            0,
            Word::unsigned(dw.bits - 1, dw.frac),
        );
        let q = g.div(&format!("{name}.q"), m, norm, qw);
        let qm = g.min(&format!("{name}.min"), q, one);
        let x = g.quantize(name, qm, nd);
        g.step_out(x)
    };
    for i in 0..lights {
        let dl = cosine(&mut g, &format!("ndotl{i}"), lv[i], 2 * i as u32);
        let dh = cosine(&mut g, &format!("ndoth{i}"), hv[i], 2 * i as u32 + 1);
        // x^p: the table at the top `b` fraction bits, interpolated with
        // the rest; the last entry past the table's end.
        g.item("shading", "power table index", i as u32);
        let iw = Word::unsigned(u32::from(nd.bits()).saturating_sub(fo - b).max(1), 0);
        let idx = g.field(&format!("pow{i}.index"), dh, (fo - b) as i32, iw);
        let lastc = g.constant(&format!("pow{i}.last"), last, Word::unsigned(b + 1, 0));
        let clamp = g.ge(&format!("pow{i}.clamp"), idx, lastc);
        let aw = Word::unsigned(b + 1, 0);
        let a0 = g.mux(&format!("pow{i}.a0"), clamp, idx, lastc, aw);
        let one_i = g.constant(&format!("pow{i}.one"), 1, bit);
        let next = g.add(
            &format!("pow{i}.next"),
            idx,
            one_i,
            Word::unsigned(iw.bits + 1, 0),
        );
        let a1 = g.mux(&format!("pow{i}.a1"), clamp, next, lastc, aw);
        g.step_out(a0);
        g.step_out(a1);
        g.no_item();
        let e0 = g.read(&format!("pow{i}.e0"), power, a0);
        let e1 = g.read(&format!("pow{i}.e1"), power, a1);
        let pw = if fo > b {
            g.item("shading", "power lerp", i as u32);
            let rem = g.field(
                &format!("pow{i}.rem"),
                dh,
                0,
                Word::unsigned(fo - b, (fo - b) as i32),
            );
            let w = g.quantize(&format!("pow{i}.w"), rem, c.weight);
            let l = g.lerp(&format!("pow{i}"), e0, Some(e1), w, c.specular);
            g.step_out(l)
        } else {
            e0
        };
        if i > 0 {
            g.item("shading", "sums over the lights", 0);
        }
        diffuse = Some(match diffuse {
            None => dl,
            Some(s) => g.sum(&format!("diffuse.s{i}"), s, dl, false),
        });
        spec = Some(match spec {
            None => pw,
            Some(s) => g.sum(&format!("spec.s{i}"), s, pw, false),
        });
    }
    let (diffuse, spec) = (diffuse.expect("a light"), spec.expect("a light"));

    // 5. r D + (1 - r) n_L as n_L + r (D - n_L), r S, the gain and the
    // highlight, exact.
    g.item("shading", "light mix r D + (1 - r) n_L", 0);
    let nl = g.constant(
        "n_l",
        lights as i128,
        Word::unsigned(64 - (lights as u64).leading_zeros(), 0),
    );
    let dm = g.sum("mix.d", diffuse, nl, true);
    let rd = g.mul_exact("mix.p", r, dm);
    let mix = g.sum("mix", nl, rd, false);
    g.step_out(mix);
    g.item("shading", "gain ka + kd D, highlight ks r S", 0);
    let kdm = g.mul_exact("gain.p", kd, mix);
    let gain = g.sum("gain", ka, kdm, false);
    g.step_out(gain);
    g.item("shading", "gain ka + kd D, highlight ks r S", 1);
    let rs = g.mul_exact("high.rs", r, spec);
    let high = g.mul_exact("high", ks, rs);
    g.step_out(high);

    // 6. c gain + highlight, capped at 1, into `color`.
    let mut out = Vec::new();
    for (k, ch) in ["r", "g", "b"].iter().enumerate() {
        g.item("shading", "c gain + highlight, clamp at 1", k as u32);
        let p = g.mul_exact(&format!("shade.{ch}.p"), rgb[k], gain);
        let v = g.sum(&format!("shade.{ch}.v"), p, high, false);
        let m = g.min(&format!("shade.{ch}.min"), v, one);
        let col = g.quantize(&format!("c_{ch}"), m, c.color);
        out.push(g.step_out(col));
    }

    // The gradient opacity a min(1, |g| (1/G)).
    g.item("shading", "gradient opacity a min(1, |g| / G)", 0);
    let gp = g.mul_exact("gop.p", norm, inv_g);
    let gm = g.min("gop.min", gp, one);
    let ag = g.mul_exact("gop.a", a, gm);
    let aq = g.quantize("gop.q", ag, c.alpha);
    let alpha = g.mux("alpha", gopac, a, aq, c.alpha.into());
    g.step_out(alpha);
    for (ch, &x) in ["r", "g", "b"].iter().zip(&out) {
        g.output(&format!("c_{ch}"), x);
    }
    g.output("alpha", alpha);
    g
}
