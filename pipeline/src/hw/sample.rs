//! The plain sample's datapath (no shading, volume of interest or
//! pre-integration) described once: ray position and slope, address
//! weight, bilinear interpolation, classification (two table reads and the
//! post-classification lerp), path length, opacity correction and
//! compositing in the configured order. Each step is the assignment
//! sequence of its [`crate::datapath::Datapath`] method, same operations,
//! same formats, so the evaluator's words are the model's
//! (`hw::tests` checks it op by op): golden twins
//! `golden::slices::bilinear`, `golden::tf::Lut::lookup` and
//! `golden::sampling`'s compositing.
//!
//! Ports: the row broadcast (`a`, `t`, `b`, `k`, `row.wy`, `sy`, `sz`),
//! the ray index from the ray slot (`slot.m`) and the ray's accumulators from
//! the compositing buffer (`acc_r`, `acc_g`, `acc_b`, `acc_a`). Outputs:
//! the accumulators to write back (unchanged for an invisible sample) and
//! `x0`, the column the taps are read at. The four voxel taps (`v00`,
//! `v01`, `v10`, `v11`) are reads of the `voxels` memory at `x0` (its
//! row and column addressing is outside the description).
//!
//! The nodes carry the cost inventory's items for the ray position and
//! slope, the x weight, interpolation, classification, path length,
//! opacity correction and compositing ([`super::units::items`]); the PE's
//! address clamps and run compare around the module are
//! [`super::address::address`]'s.

use super::{joint, Graph, MemId, NodeId, Word};
use crate::config::{Order, PipelineConfig};
use crate::cost::inventory::addr_bits;
use crate::cost::shapes::{MulAdd, RAY_INDEX_BITS};
use crate::fixed::Format;

/// Memories of the plain sample, in [`super::MemId`] order: the
/// classification table's R, G, B and opacity columns, the log table and
/// the exp table (then the voxel memory's taps, `voxels`).
pub const MEMORIES: [&str; 6] = [
    "class_r",
    "class_g",
    "class_b",
    "class_a",
    "log_table",
    "exp_table",
];

/// `base + m step` into `out`, sized by [`MulAdd`] (`name.mt`, `name.s`,
/// `name`).
fn position(
    g: &mut Graph,
    name: &str,
    base: NodeId,
    m: NodeId,
    step: NodeId,
    out: Format,
) -> NodeId {
    let sh = MulAdd::new(g.word(base), g.word(m), g.word(step), out);
    let mt = g.mul(&format!("{name}.mt"), m, step, sh.p);
    let s = g.add(&format!("{name}.s"), base, mt, sh.s);
    g.quantize(name, s, out)
}

/// The weight of a fraction field: the field itself when the weight
/// format holds all its bits (the assignment is exact wiring), else its
/// assignment into `weight` (as [`crate::cost::shapes::class_weight`]
/// sizes it).
fn weight_of(g: &mut Graph, name: &str, frac: NodeId, weight: Format) -> NodeId {
    let f = g.word(frac);
    let exact = f.frac <= i32::from(weight.frac())
        && f.bits as i32 - f.frac <= i32::from(weight.int_bits());
    if exact {
        frac
    } else {
        g.quantize(name, frac, weight)
    }
}

/// The probe names of the classified R, G, B and opacity in `g` (the
/// lerps', or the entries' when the table has an entry per position).
pub fn class_names(g: &Graph) -> [&'static str; 4] {
    if g.find("color.r").is_some() {
        ["color.r", "color.g", "color.b", "alpha"]
    } else {
        ["class.r0", "class.g0", "class.b0", "class.a0"]
    }
}

/// The plain sample's description for `cfg` (a validated configuration:
/// the formats read as unsigned words are unsigned).
pub fn plain(cfg: &PipelineConfig) -> Graph {
    with_units(cfg, &mut |_, c| (c.rgb, c.alpha))
}

/// The classified sample, where units between the classification and the
/// opacity correction read it ([`with_units`]).
#[derive(Debug, Clone, Copy)]
pub struct Classified {
    /// The ray's x position (`position`).
    pub x: NodeId,
    /// The x interpolation weight.
    pub wx: NodeId,
    /// The y interpolation weight (the PE's copy of the row's).
    pub wy: NodeId,
    /// The voxel taps `v00`, `v01`, `v10`, `v11`.
    pub taps: [NodeId; 4],
    /// The classified colour (`color`).
    pub rgb: [NodeId; 3],
    /// The classified opacity (`alpha`).
    pub alpha: NodeId,
}

/// What [`with_units`] calls between the classification and the opacity
/// correction: adds the units' nodes, returns the colour and opacity.
pub type UnitsFn<'a> = dyn FnMut(&mut Graph, &Classified) -> ([NodeId; 3], NodeId) + 'a;

/// The sample and its path length, where a unit in the classification's
/// and the log table's place reads them ([`with_preint`]).
#[derive(Debug, Clone, Copy)]
pub struct Sampled {
    /// The interpolated sample (`sample`).
    pub sample: NodeId,
    /// The ray's path per slice step (`path`).
    pub ds: NodeId,
}

/// What a unit in the classification's and the log table's place
/// returns to the compositing: colour, corrected opacity, visibility.
#[derive(Debug, Clone, Copy)]
pub struct Corrected {
    /// The colour (`color`).
    pub rgb: [NodeId; 3],
    /// The corrected opacity (`opacity_corr`).
    pub alpha: NodeId,
    /// Whether the sample composites (an invisible one keeps the
    /// accumulators).
    pub visible: NodeId,
}

/// What [`with_preint`] calls in the classification's and the log
/// table's place.
pub type PreintFn<'a> = dyn FnMut(&mut Graph, &Sampled) -> Corrected + 'a;

/// What sits between the interpolation and the compositing.
enum Middle<'a, 'b> {
    /// The classification, `units`, the path length and the opacity
    /// correction.
    Classify(&'b mut UnitsFn<'a>),
    /// The path length, then a unit that makes the corrected opacity
    /// itself (the pre-integration unit).
    Preint(&'b mut PreintFn<'a>),
}

/// The ray's position or slope on x item names, as the inventory lists
/// them.
pub const RAY_X: &str = "ray x: A + m t";
/// The slope's item name.
pub const SLOPE_X: &str = "slope x: b + m k";

/// The sample's description with `units` between the classification and
/// the opacity correction: `units` adds its nodes and returns the colour
/// and opacity the rest of the datapath reads ([`super::compose`] splices
/// the shading unit and the volume-of-interest stage there).
pub fn with_units(cfg: &PipelineConfig, units: &mut UnitsFn<'_>) -> Graph {
    build(cfg, Middle::Classify(units))
}

/// The sample's description with `unit` in the place of the
/// classification and the opacity correction's `-log2(1 - a) ds`: it
/// reads the sample and the path length and returns what the compositing
/// reads ([`super::compose`] splices the pre-integration unit there, as
/// `crate::stages::sample`'s pre-integrated half runs it).
pub fn with_preint(cfg: &PipelineConfig, unit: &mut PreintFn<'_>) -> Graph {
    build(cfg, Middle::Preint(unit))
}

fn build(cfg: &PipelineConfig, middle: Middle<'_, '_>) -> Graph {
    let c = cfg;
    let mut g = Graph::new();
    let entries = u64::from(c.table_entries);
    // A pre-integrating datapath reads its unit's tables instead (the
    // exp table among them).
    let mems = match middle {
        Middle::Classify(_) => vec![
            g.mem(MEMORIES[0], entries, c.color),
            g.mem(MEMORIES[1], entries, c.color),
            g.mem(MEMORIES[2], entries, c.color),
            g.mem(MEMORIES[3], entries, c.alpha),
            g.mem(MEMORIES[4], 1 << c.alpha.bits(), c.log_transmittance),
            g.mem(MEMORIES[5], (1 << c.exp_table_bits) + 1, c.opacity_corr),
        ],
        Middle::Preint(_) => Vec::new(),
    };

    // Position and address.
    g.no_item();
    let slot_m = g.input_word("slot.m", Word::signed(RAY_INDEX_BITS, 0));
    let m = g.reg("m", slot_m);
    let (a, t) = (g.input("a", c.position), g.input("t", c.step));
    let (b, k) = (g.input("b", c.position), g.input("k", c.step));
    let row_wy = g.input("row.wy", c.weight);
    let (sy, sz) = (g.input("sy", c.position), g.input("sz", c.position));
    g.item("position", RAY_X, 0);
    let x = position(&mut g, "x", a, m, t, c.position);
    g.step_out(x);
    g.no_item();
    let fp = u32::from(c.position.frac());
    let int_bits = (c.position.bits() - c.position.frac()).max(1);
    let x0 = g.field("x0", x, fp as i32, Word::signed(u32::from(int_bits), 0));
    let xf = g.field("x.frac", x, 0, Word::unsigned(fp.max(1), fp as i32));
    g.item("position", "x weight: the fraction into weight", 0);
    let wx = g.quantize("wx", xf, c.weight);
    g.step_out(wx);
    g.no_item();
    // The y weight: the PE's copy of the row broadcast.
    let wy = g.reg("wy", row_wy);

    // Bilinear interpolation.
    // The four taps, one clock after the column is known (the voxel
    // memory's row and column addressing is outside the description).
    let vox = g.mem("voxels", 0, c.voxel);
    let v = ["v00", "v01", "v10", "v11"].map(|n| g.read(n, vox, x0));
    let s = c.sample;
    g.item("interpolation", "x lerp (rows y0, y0+1)", 0);
    let top = g.lerp("bilinear.top", v[0], Some(v[1]), wx, s);
    g.step_out(top);
    g.item("interpolation", "x lerp (rows y0, y0+1)", 1);
    let bot = g.lerp("bilinear.bot", v[2], Some(v[3]), wx, s);
    g.step_out(bot);
    g.item("interpolation", "y lerp", 0);
    let sample = g.lerp("sample", top, Some(bot), wy, s);
    g.step_out(sample);

    let (rgb, corrected, visible) = match middle {
        Middle::Classify(units) => {
            let (rgb, alpha) = classify(&mut g, c, sample, &mems[..4]);
            let classified = Classified {
                x,
                wx,
                wy,
                taps: v,
                rgb,
                alpha,
            };
            let (rgb, alpha) = units(&mut g, &classified);
            g.item("classification", "opacity != 0", 0);
            let visible = g.push(
                "visible",
                super::Op::NonZero(alpha),
                Word::unsigned(1, 0),
                None,
            );
            g.step_out(visible);
            let ds = path_length(&mut g, c, [b, m, k, sy, sz]);

            // Opacity correction: p = -log2(1 - a) ds, T = 2^-frac(p) >>
            // int(p), a' = 1 - T.
            let lf = c.log_transmittance;
            g.no_item();
            let log_t = g.read("log_t", mems[4], alpha);
            g.item("opacity", "p = -log2(1 - a) ds", 0);
            let prod = g.mul_exact("p.prod", log_t, ds);
            let p = g.quantize("p", prod, lf);
            (rgb, transmit(&mut g, c, p, mems[5]), visible)
        }
        Middle::Preint(unit) => {
            let ds = path_length(&mut g, c, [b, m, k, sy, sz]);
            let out = unit(&mut g, &Sampled { sample, ds });
            (out.rgb, out.alpha, out.visible)
        }
    };

    // Compositing into the ray's accumulators, written straight back.
    let (fc, fa) = (c.accum_color, c.accum_alpha);
    g.no_item();
    let acc = [
        g.input("acc_r", fc),
        g.input("acc_g", fc),
        g.input("acc_b", fc),
        g.input("acc_a", fa),
    ];
    let mut out = Vec::new();
    if c.order == Order::BackToFront {
        // C + a (c - C) per colour, A + a (1 - A): the model's
        // `a c + (1 - a) C`, the same exact value.
        for (i, ch) in ["r", "g", "b"].iter().enumerate() {
            g.item("compositing", "colour: C + a (c - C)", i as u32);
            out.push(g.lerp(&format!("comp.{ch}"), acc[i], Some(rgb[i]), corrected, fc));
        }
        g.item("compositing", "opacity: A + a (1 - A)", 0);
        out.push(g.lerp("comp.a", acc[3], None, corrected, fa));
    } else {
        // k = (1 - A) a, exact; C + k c per colour, A + k.
        g.item("compositing", "front to back: k = (1 - A) a", 0);
        let fr = i32::from(fa.frac());
        let one = g.constant("comp.one", 1 << fr, Word::unsigned(fr as u32 + 1, fr));
        let wa = g.word(acc[3]);
        let dw = joint(g.word(one), wa, fr, 0, true);
        let d = g.sub("comp.d", one, acc[3], dw);
        let kk = g.mul_exact("comp.k", d, corrected);
        for (i, ch) in ["r", "g", "b"].iter().enumerate() {
            g.item("compositing", "colour: C + k c", i as u32);
            let p = g.mul_exact(&format!("comp.{ch}.p"), kk, rgb[i]);
            let (wc, wp) = (g.word(acc[i]), g.word(p));
            let sw = joint(wc, wp, wc.frac.max(wp.frac), 1, true);
            let s = g.add(&format!("comp.{ch}.s"), acc[i], p, sw);
            out.push(g.quantize(&format!("comp.{ch}"), s, fc));
        }
        g.item("compositing", "opacity: A + k", 0);
        let (wa, wk) = (g.word(acc[3]), g.word(kk));
        let sw = joint(wa, wk, wa.frac.max(wk.frac), 1, true);
        let s = g.add("comp.a.s", acc[3], kk, sw);
        out.push(g.quantize("comp.a", s, fa));
    }
    // An invisible sample leaves the accumulators as they were: a select
    // per accumulator bit.
    for (i, ch) in ["r", "g", "b", "a"].iter().enumerate() {
        g.item(
            "compositing",
            "accumulator select (invisible sample)",
            i as u32,
        );
        let w = g.word(acc[i]);
        let kept = g.push(
            &format!("acc_out.{ch}"),
            super::Op::Mux {
                sel: visible,
                f: acc[i],
                t: out[i],
            },
            w,
            g.node(acc[i]).fmt,
        );
        g.output(&format!("acc_out_{ch}"), kept);
    }
    g.no_item();
    g.output("x0", x0);
    g
}

/// Classification of `sample` from the table columns `mems` (R, G, B,
/// opacity): the table position splits into an entry index and a
/// weight; the last entry is read on both ports past the table's end.
fn classify(
    g: &mut Graph,
    c: &PipelineConfig,
    sample: NodeId,
    mems: &[MemId],
) -> ([NodeId; 3], NodeId) {
    g.item("classification", "table position", 0);
    let f = i32::from(c.sample.frac()) - c.table_shift();
    let sb = u32::from(c.sample.bits());
    let index_bits = (sb as i32 - f).max(1) as u32;
    let ab = addr_bits(u64::from(c.table_entries));
    // Fewer sample codes than entries (`f < 0`): the index is the sample
    // with `-f` zero bits below it.
    let index = g.field("class.index", sample, f, Word::unsigned(index_bits, 0));
    let last = g.constant(
        "class.last",
        i128::from(c.table_entries - 1),
        Word::unsigned(ab, 0),
    );
    let clamp = g.push(
        "class.clamp",
        super::Op::Ge(index, last),
        Word::unsigned(1, 0),
        None,
    );
    let one = g.constant("class.one", 1, Word::unsigned(1, 0));
    let next = g.add(
        "class.next",
        index,
        one,
        Word::unsigned(g.word(index).bits + 1, 0),
    );
    let aw = Word::unsigned(ab, 0);
    let a1 = g.push(
        "class.addr1",
        super::Op::Mux {
            sel: clamp,
            f: next,
            t: last,
        },
        aw,
        None,
    );
    // The first port needs its own clamp only if the index can pass the
    // table's end.
    let a0 = if g.word(index).bits > ab {
        g.push(
            "class.addr0",
            super::Op::Mux {
                sel: clamp,
                f: index,
                t: last,
            },
            aw,
            None,
        )
    } else {
        index
    };
    let w = (f > 0).then(|| {
        let r = g.field("class.frac", sample, 0, Word::unsigned(f as u32, f));
        weight_of(g, "class.w", r, c.weight)
    });
    g.step_out(a0);
    g.step_out(a1);
    if let Some(w) = w {
        g.step_out(w);
    }
    g.no_item();
    let ends: Vec<[NodeId; 2]> = ["r", "g", "b", "a"]
        .iter()
        .zip(mems)
        .map(|(ch, &mem)| {
            [
                g.read(&format!("class.{ch}0"), mem, a0),
                g.read(&format!("class.{ch}1"), mem, a1),
            ]
        })
        .collect();
    let (rgb, alpha) = match w {
        Some(w) => {
            let mut rgb = Vec::new();
            for (i, ch) in ["r", "g", "b"].iter().enumerate() {
                g.item("classification", "colour lerp (R, G, B)", i as u32);
                let e = ends[i];
                let x = g.lerp(&format!("color.{ch}"), e[0], Some(e[1]), w, c.color);
                rgb.push(g.step_out(x));
            }
            g.item("classification", "opacity lerp", 0);
            let al = g.lerp("alpha", ends[3][0], Some(ends[3][1]), w, c.alpha);
            (rgb, g.step_out(al))
        }
        None => {
            // One entry per table position: the entry is the class.
            g.item("classification", "entry register (no interpolation)", 0);
            let rgb: Vec<NodeId> = (0..3).map(|i| g.step_out(ends[i][0])).collect();
            (rgb, g.step_out(ends[3][0]))
        }
    };
    ([rgb[0], rgb[1], rgb[2]], alpha)
}

/// The ray's slope on x and the path length `sqrt(sx^2 + sy^2 + sz^2)`
/// into `path` from the row broadcast's `b`, the ray index `m`, `k`,
/// `sy` and `sz`.
fn path_length(g: &mut Graph, c: &PipelineConfig, [b, m, k, sy, sz]: [NodeId; 5]) -> NodeId {
    g.item("position", SLOPE_X, 0);
    let sx = position(g, "sx", b, m, k, c.position);
    g.step_out(sx);
    let mut sq = Vec::new();
    for (i, (n, x)) in [("sx2", sx), ("sy2", sy), ("sz2", sz)]
        .into_iter()
        .enumerate()
    {
        g.item("path length", "slope squares sx^2, sy^2, sz^2", i as u32);
        let p = g.mul_exact(n, x, x);
        sq.push(g.step_out(p));
    }
    g.item("path length", "sum of squares", 0);
    let (w0, w1, w2) = (g.word(sq[0]), g.word(sq[1]), g.word(sq[2]));
    let s01 = g.add("path.s01", sq[0], sq[1], joint(w0, w1, w0.frac, 1, false));
    let w01 = g.word(s01);
    let sum = g.add("path.sum", s01, sq[2], joint(w01, w2, w01.frac, 1, false));
    g.step_out(sum);
    g.item("path length", "square root", 0);
    let ds = g.push("ds", super::Op::Isqrt(sum), c.path.into(), Some(c.path));
    g.step_out(ds);
    g.no_item();
    ds
}

/// The opacity correction's `2^-p` stage from `p` (a
/// `log_transmittance` word, the step's `-log2 T`): the exp table `exp`
/// read at `p`'s top fraction bits and interpolated with the rest,
/// shifted by `p`'s integer part, `a' = 1 - T` into `opacity_corr`
/// ([`crate::datapath::Datapath::transmit`]). The plain sample's `p` is
/// `-log2(1 - a) ds`; the pre-integration unit's `tau len`.
pub(crate) fn transmit(g: &mut Graph, c: &PipelineConfig, p: NodeId, exp: super::MemId) -> NodeId {
    let lf = c.log_transmittance;
    let fb = u32::from(lf.frac());
    let e = u32::from(c.exp_table_bits);
    let idx = g.field("exp.index", p, (fb - e) as i32, Word::unsigned(e.max(1), 0));
    let one = g.constant("exp.one", 1, Word::unsigned(1, 0));
    let idx1 = g.add("exp.next", idx, one, Word::unsigned(e.max(1) + 1, 0));
    g.step_out(p);
    g.no_item();
    let e0 = g.read("exp.e0", exp, idx);
    let e1 = g.read("exp.e1", exp, idx1);
    let oc = c.opacity_corr;
    let tf = if fb > e {
        g.item("opacity", "exp lerp 2^-frac(p)", 0);
        let r = g.field("exp.frac", p, 0, Word::unsigned(fb - e, (fb - e) as i32));
        let w = weight_of(g, "exp.w", r, c.weight);
        let tf = g.lerp("exp", e0, Some(e1), w, oc);
        g.step_out(tf)
    } else {
        e0
    };
    g.item("opacity", "T = 2^-frac >> int(p)", 0);
    let lt_int = u32::from(lf.int_bits()).max(1);
    let int = g.field("p.int", p, fb as i32, Word::unsigned(lt_int, 0));
    let trans = g.push(
        "trans",
        super::Op::ShrQuantize(tf, int),
        oc.into(),
        Some(oc),
    );
    g.step_out(trans);
    g.item("opacity", "a' = 1 - T", 0);
    let foc = i32::from(oc.frac());
    let one = g.constant(
        "one_minus.one",
        1 << foc,
        Word::unsigned(foc as u32 + 1, foc),
    );
    let ocb = u32::from(oc.bits());
    let d = g.sub("one_minus.d", one, trans, Word::signed(ocb + 1, foc));
    let corrected = g.quantize("corrected", d, oc);
    g.step_out(corrected)
}
