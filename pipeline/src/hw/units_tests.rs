//! The units' descriptions against the model: the volume-of-interest
//! stage, the merge's tents, the pre-integration unit and the shading
//! unit evaluate to the words of their hand-written model
//! (`crate::voi`, `crate::datapath::Datapath::tent_rgba`,
//! `crate::preint`, `crate::shading`), over many formats and inputs.

use super::eval::{eval, Values};
use super::{Graph, MemId};
use crate::config::PipelineConfig;
use crate::datapath::Datapath;
use crate::fixed::{Format, Fx, Overflow, Quant, QuantStats};
use crate::tables::Tables;
use proptest::prelude::*;

/// A raw word of `f` from any `r`.
fn word(r: i64, f: Format) -> i64 {
    let span = i128::from(f.max_raw()) - i128::from(f.min_raw()) + 1;
    (i128::from(r).rem_euclid(span) + i128::from(f.min_raw())) as i64
}

fn fx(r: i64, f: Format) -> Fx {
    Fx::from_raw(word(r, f), f).expect("in range")
}

/// A format of `bits` with `frac` fraction bits (at most `bits`),
/// rounding mode `q`, saturating.
fn fmt(bits: u8, frac: u8, signed: bool, q: usize) -> Format {
    Format::new(bits, frac.min(bits), signed, Quant::ALL[q], Overflow::Sat).expect("format")
}

/// A datapath for `cfg`'s tables (the exp stage, the tents).
fn datapath(cfg: &PipelineConfig) -> Option<(Datapath, Tables)> {
    let lut = golden::tf::Lut::for_bits(
        &golden::scenes::tf_preset("ml").expect("preset"),
        cfg.table_entries as usize,
        u32::from(cfg.voxel.bits()),
    );
    let tables = Tables::new(cfg, &lut).ok()?;
    Some((Datapath::new(*cfg, tables.clone()).without_kernel(), tables))
}

/// Evaluates `g` on named inputs and a memory reader.
fn run(
    g: &Graph,
    inputs: &[(String, i64)],
    read: &dyn Fn(&str, MemId, i128) -> Option<i64>,
) -> Values {
    let input = |name: &str| inputs.iter().find(|(n, _)| n == name).map(|x| x.1);
    eval(g, &input, read, &mut QuantStats::default()).expect("the description evaluates")
}

/// The word of probe `name`.
fn at(g: &Graph, v: &Values, name: &str) -> i128 {
    v[g.find(name).unwrap_or_else(|| panic!("probe {name}")).0]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// The volume-of-interest stage: the weight, the factor and the
    /// scaled opacity of `crate::voi::VoiUnit`, for either shape, with
    /// and without a ramp, inside or outside, over its formats.
    #[test]
    fn voi_description_is_the_model(
        (pb, pf, pq) in (20u8..=30, 6u8..=16, 0usize..7),
        (axb, axf, dq) in (12u8..=28, 4u8..=20, 0usize..7),
        // Up to 32 bits: the radius' square is a 64-bit port.
        (db, df, wq) in (18u8..=32, 4u8..=16, 0usize..7),
        (wb, gb, gf, fb, ff) in (6u8..=13, 10u8..=20, 4u8..=12, 10u8..=20, 4u8..=12),
        (ab, aq) in (6u8..=12, 0usize..7),
        r in any::<[i64; 16]>(),
        z in any::<u32>(),
        flags in any::<(bool, bool, bool)>(),
    ) {
        let cfg = PipelineConfig {
            position: fmt(pb, pf, true, pq),
            voi_axis: fmt(axb, axf, false, dq),
            voi_dist: fmt(db, df, true, wq),
            voi_weight: fmt(wb, wb - 1, false, wq),
            voi_gain: fmt(gb, gf, true, dq),
            voi_factor: fmt(fb, ff.min(fb - 1), false, pq),
            alpha: fmt(ab, ab, false, aq),
            ..PipelineConfig::default()
        };
        prop_assume!(cfg.validate().is_ok());
        let c = &cfg;
        let pos = |r: i64| fx(r >> 20, c.position);
        let z = (z as u64 % (1u64 << super::voi::slice_bits(c))) as usize;
        let centre = [pos(r[2]), pos(r[3]), pos(r[4])];
        // Mostly near the centre, where the ramp's weights lie between 0
        // and 1.
        let near = |k: usize, r: i64| {
            if r & 1 == 0 {
                pos(r)
            } else {
                fx(centre[k].raw().saturating_add(r >> (40 + (r >> 2 & 15))), c.position)
            }
        };
        let (x, y) = (near(0, r[0]), near(1, r[1]));
        let axis = [fx(r[5], c.voi_axis), fx(r[6], c.voi_axis), fx(r[7], c.voi_axis)];
        let dist = |r: i64| fx(r >> 8, c.voi_dist);
        let half = [dist(r[8]), dist(r[9]), dist(r[10])];
        let radius = dist(r[11]);
        let gain = fx(r[12], c.voi_gain);
        let a = fx(r[13], c.alpha);
        let unit = crate::voi::VoiUnit::from_words(centre, axis, half, radius, gain, flags);
        let st = &mut QuantStats::default();
        let Ok((f, trace)) = unit.factor(c, (x, y, z), st) else {
            return Ok(());
        };
        let alpha = crate::voi::VoiUnit::scale(c, a, f, st);

        let g = super::voi::voi(c);
        let mut inputs: Vec<(String, i64)> = vec![
            ("x".into(), x.raw()), ("y".into(), y.raw()), ("z".into(), z as i64),
            ("radius".into(), radius.raw()), ("radius2".into(), radius.raw() * radius.raw()), ("gain".into(), gain.raw()), ("class.a".into(), a.raw()),
            ("sphere".into(), i64::from(flags.0)), ("outside".into(), i64::from(flags.1)),
            ("step".into(), i64::from(flags.2)),
        ];
        for (k, n) in ["x", "y", "z"].iter().enumerate() {
            inputs.push((format!("centre.{n}"), centre[k].raw()));
            inputs.push((format!("axis.{n}"), axis[k].raw()));
            inputs.push((format!("half.{n}"), half[k].raw()));
        }
        let v = run(&g, &inputs, &|_, _, _| None);
        prop_assert_eq!(at(&g, &v, "weight"), i128::from(trace.weight));
        prop_assert_eq!(at(&g, &v, "factor"), i128::from(f.raw()));
        prop_assert_eq!(at(&g, &v, "alpha"), i128::from(alpha.raw()));
    }

    /// The merge's tents: both passes' four channels are
    /// `Datapath::tent_rgba`'s words, over accumulator and merge formats
    /// of many widths, signed or unsigned merge words.
    #[test]
    fn tents_description_is_the_model(
        (cb, cf, ab, af) in (4u8..=24, 0u8..=24, 4u8..=24, 0u8..=24),
        (mb, mf, signed) in (6u8..=32, 0u8..=28, any::<bool>()),
        q in (0usize..7, 0usize..7, 0usize..7),
        words in any::<[[i64; 4]; 6]>(),
    ) {
        let cfg = PipelineConfig {
            accum_color: fmt(cb, cf, false, q.0),
            accum_alpha: fmt(ab, af, false, q.1),
            merge: fmt(mb, mf, signed, q.2),
            ..PipelineConfig::default()
        };
        let Some((dp, _)) = datapath(&cfg) else {
            return Err(TestCaseError::reject("no tables"));
        };
        let g = super::tents::tents(&cfg);
        let acc = |ch: usize| if ch < 3 { cfg.accum_color } else { cfg.accum_alpha };
        for (pass, y) in [("x", false), ("y", true)] {
            let off = if y { 3 } else { 0 };
            let p: [[i64; 4]; 3] = std::array::from_fn(|k| {
                std::array::from_fn(|ch| {
                    word(words[off + k][ch], if y { cfg.merge } else { acc(ch) })
                })
            });
            let want = dp.tent_rgba(y, p, &mut QuantStats::default(), &mut Default::default());
            let mut inputs = Vec::new();
            for (ch, n) in super::tents::CHANNELS.iter().enumerate() {
                for (k, pk) in p.iter().enumerate() {
                    inputs.push((format!("{pass}.{n}.{k}"), pk[ch]));
                }
            }
            // The other pass's ports: any words.
            let other = if y { "x" } else { "y" };
            for n in super::tents::CHANNELS {
                for k in 0..3 {
                    inputs.push((format!("{other}.{n}.{k}"), 0));
                }
            }
            let v = run(&g, &inputs, &|_, _, _| None);
            for (ch, n) in super::tents::CHANNELS.iter().enumerate() {
                prop_assert_eq!(at(&g, &v, &format!("{pass}_{n}")), i128::from(want[ch]), "{} {}", pass, n);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(150))]

    /// The pre-integration unit: the four interpolated channels, the
    /// zero-extinction test, the colour dividers and the opacity of
    /// `crate::preint::PreintUnit::lookup` and `step`, for whole steps,
    /// lead (half) steps and whole steps over half a path, over table sizes and formats, on random table words.
    #[test]
    fn preint_description_is_the_model(
        entries_log in 2u32..=7,
        (sb, sf, sq) in (8u8..=16, 0u8..=4, 0usize..7),
        (pcb, pcf, ptb, ptf, q) in (12u8..=24, 6u8..=15, 12u8..=24, 6u8..=15, 0usize..7),
        (colb, colq, wb) in (8u8..=12, 0usize..7, 6u8..=14),
        seed in any::<u64>(),
        (front, prev, len) in any::<(i64, i64, i64)>(),
        (lead, half) in any::<(bool, bool)>(),
    ) {
        let d = PipelineConfig::default();
        let entries = 1u32 << (entries_log + 1);
        let voxel = fmt(entries_log as u8 + 1, 0, false, 0);
        let cfg = PipelineConfig {
            voxel,
            sample: fmt(voxel.bits() + sf, sf, false, sq),
            table_entries: entries,
            preint_color: fmt(pcb, pcf, false, q),
            preint_tau: fmt(ptb, ptf, false, q),
            color: fmt(colb, colb - 1, false, colq),
            weight: fmt(wb, wb, false, q),
            ..d
        };
        prop_assume!(cfg.validate().is_ok());
        let _ = sb;
        let Some((dp, tables)) = datapath(&cfg) else {
            return Err(TestCaseError::reject("no tables"));
        };
        let c = &cfg;
        let bins = super::preint::bins(c) as usize;
        let n = bins + 1;
        let kf = 2f64.powi(c.table_shift()) * (bins - 1) as f64 / (entries - 1) as f64;
        let k = c.step.from_f64(kf).expect("scale").value;
        // Random table words from the seed.
        let mut s = seed | 1;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s as i64
        };
        let table: Vec<[Fx; 4]> = (0..n * n)
            .map(|_| {
                // Some zero extinctions: steps that composite nothing.
                let t = if next() & 3 == 0 { fx(0, c.preint_tau) } else { fx(next(), c.preint_tau) };
                [fx(next(), c.preint_color), fx(next(), c.preint_color), fx(next(), c.preint_color), t]
            })
            .collect();
        let unit = crate::preint::PreintUnit::from_words(bins, k, table.clone());
        let (front, prev) = (fx(front, c.sample), fx(prev, c.sample));
        let len = fx(len, c.path);
        // A lead step is slice 0's half step at the sample; `half` alone
        // halves the path between two scalars (the last slice's step).
        let back = if lead { front } else { prev };
        let st = &mut QuantStats::default();
        let e = unit.lookup(c, front, back, st).expect("lookup");
        let Ok(res) = crate::preint::PreintUnit::step(&dp, e, (len, half || lead), st) else {
            return Ok(());
        };

        let g = super::preint::preint(c);
        let inputs: Vec<(String, i64)> = vec![
            ("front".into(), front.raw()), ("prev".into(), prev.raw()),
            ("lead".into(), i64::from(lead)), ("half".into(), i64::from(half)),
            ("scale".into(), k.raw()), ("len".into(), len.raw()),
        ];
        let exp: Vec<i64> = tables.exp.iter().map(|x| x.raw()).collect();
        let read = |_: &str, m: MemId, addr: i128| -> Option<i64> {
            let addr = usize::try_from(addr).ok()?;
            if m.0 == 8 {
                return exp.get(addr).copied();
            }
            let (ch, odd) = (m.0 / 2, m.0 % 2);
            let (row, col) = (addr / n, addr % n);
            let r = 2 * row + odd;
            (r < n).then(|| table[r * n + col][ch].raw())
        };
        let v = run(&g, &inputs, &read);
        for (k, ch) in super::preint::CHANNELS.iter().enumerate() {
            prop_assert_eq!(at(&g, &v, &format!("pre.{ch}")), i128::from(e[k].raw()), "{}", ch);
        }
        prop_assert_eq!(at(&g, &v, "visible"), i128::from(res.is_some()));
        if let Some((rgb, a)) = res {
            for (k, ch) in ["r", "g", "b"].iter().enumerate() {
                prop_assert_eq!(at(&g, &v, &format!("c_{ch}")), i128::from(rgb[k].raw()), "{}", ch);
            }
            prop_assert_eq!(at(&g, &v, "corrected"), i128::from(a.raw()));
        }
    }

    /// The gradient and shading unit: the interpolated gradient, `|g|`,
    /// the shaded colour and the gradient opacity of
    /// `crate::shading::ShadeUnit::gradient` and `shade`, for one to
    /// three lights, with and without the fade and gradient opacity, over
    /// its formats, on random voxels, constants and power tables.
    #[test]
    fn shading_description_is_the_model(
        lights in 1usize..=3,
        (vb, gb, gf, gsb, q) in (6u8..=12, 16u8..=24, 0u8..=8, 10u8..=16, 0usize..7),
        (nb, nf, lb, ndb, stb) in (14u8..=24, 0u8..=8, 10u8..=16, 8u8..=13, 2u8..=8),
        (spb, mb, mf, rb, rf) in (8u8..=13, 10u8..=16, 6u8..=12, 14u8..=24, 10u8..=20),
        (colb, ab, wb, q2) in (8u8..=12, 8u8..=12, 6u8..=14, 0usize..7),
        taps in any::<[u16; 20]>(),
        r in any::<[i64; 32]>(),
        opts in any::<(bool, bool)>(),
    ) {
        let cfg = PipelineConfig {
            voxel: fmt(vb, 0, false, 0),
            gradient: fmt(gb, gf.min(gb - vb - 3), true, q),
            grad_scale: fmt(gsb, gsb - 1, false, q2),
            grad_norm: fmt(nb, nf, false, 0),
            light: fmt(lb, lb - 2, true, q),
            normal_dot: fmt(ndb, ndb - 1, false, 0),
            specular: fmt(spb, spb - 1, false, q2),
            shade_table_bits: stb.min(ndb - 1),
            material: fmt(mb, mf, false, q),
            grad_recip: fmt(rb, rf, false, q),
            color: fmt(colb, colb - 1, false, q2),
            alpha: fmt(ab, ab, false, q2),
            weight: fmt(wb, wb, false, q),
            ..PipelineConfig::default()
        };
        prop_assume!(cfg.validate().is_ok());
        let c = &cfg;
        let vmask = c.voxel.max_raw() as u16;
        // Some flat neighbourhoods: a zero gradient.
        let flat = r[20] & 3 == 0;
        let t = taps.map(|x| if flat { taps[0] & vmask } else { x & vmask });
        let taps_m = crate::shading::Taps {
            x: [[t[0], t[1], t[2], t[3]], [t[4], t[5], t[6], t[7]]],
            y: [[t[8], t[9]], [t[10], t[11]]],
            z: [[[t[12], t[13]], [t[14], t[15]]], [[t[16], t[17]], [t[18], t[19]]]],
        };
        let scale = [fx(r[0], c.grad_scale), fx(r[1], c.grad_scale), fx(r[2], c.grad_scale)];
        let vecs = |o: usize| -> Vec<[Fx; 3]> {
            (0..lights)
                .map(|i| std::array::from_fn(|k| fx(r[o + 3 * i + k] >> 3, c.light)))
                .collect()
        };
        let (lv, hv) = (vecs(3), vecs(12));
        let k = [fx(r[21], c.material), fx(r[22], c.material), fx(r[23], c.material)];
        let inv_fade = fx(r[24], c.grad_recip);
        let inv_g = fx(r[25], c.grad_recip);
        let power: Vec<Fx> = (0..=(1usize << c.shade_table_bits))
            .map(|j| fx(r[26].wrapping_mul(j as i64 + 7) >> 5, c.specular))
            .collect();
        let rgb = [fx(r[27], c.color), fx(r[28], c.color), fx(r[29], c.color)];
        let a = fx(r[30], c.alpha);
        let (wx, wy) = (fx(r[31], c.weight), fx(r[31] >> 20, c.weight));
        let unit = crate::shading::ShadeUnit::from_words(
            lv.clone(), hv.clone(), k, scale,
            opts.0.then_some(inv_fade), opts.1.then_some(inv_g), power.clone(),
        );
        let st = &mut QuantStats::default();
        let Ok(grad) = unit.gradient(c, &taps_m, (wx, wy), st) else {
            return Ok(());
        };
        let Ok((out, alpha, trace)) = unit.shade(c, rgb, a, &grad, st) else {
            return Ok(());
        };

        let g = super::shading::shading(c, lights);
        let mut inputs: Vec<(String, i64)> = Vec::new();
        for (j, row) in taps_m.x.iter().enumerate() {
            for (i, &x) in row.iter().enumerate() {
                inputs.push((format!("tx.{j}.{i}"), i64::from(x)));
            }
        }
        for (col, v) in taps_m.y.iter().enumerate() {
            for (kk, &x) in v.iter().enumerate() {
                inputs.push((format!("ty.{col}.{kk}"), i64::from(x)));
            }
        }
        for (kk, s) in taps_m.z.iter().enumerate() {
            for (j, row) in s.iter().enumerate() {
                for (i, &x) in row.iter().enumerate() {
                    inputs.push((format!("tz.{kk}.{j}.{i}"), i64::from(x)));
                }
            }
        }
        let axes = ["x", "y", "z"];
        for (kk, n) in axes.iter().enumerate() {
            inputs.push((format!("scale.{n}"), scale[kk].raw()));
            for i in 0..lights {
                inputs.push((format!("light{i}.{n}"), lv[i][kk].raw()));
                inputs.push((format!("halfv{i}.{n}"), hv[i][kk].raw()));
            }
        }
        for (n, x) in [
            ("ka", k[0]), ("kd", k[1]), ("ks", k[2]), ("inv_fade", inv_fade), ("inv_g", inv_g),
            ("class.r", rgb[0]), ("class.g", rgb[1]), ("class.b", rgb[2]), ("class.a", a), ("wx", wx), ("wy", wy),
        ] {
            inputs.push((n.into(), x.raw()));
        }
        inputs.push(("fade".into(), i64::from(opts.0)));
        inputs.push(("gopac".into(), i64::from(opts.1)));
        let read = |_: &str, _: MemId, addr: i128| -> Option<i64> {
            power.get(usize::try_from(addr).ok()?).map(|x| x.raw())
        };
        let v = run(&g, &inputs, &read);
        for (kk, n) in axes.iter().enumerate() {
            prop_assert_eq!(at(&g, &v, &format!("grad.{n}")), i128::from(grad[kk].raw()), "grad {}", n);
        }
        prop_assert_eq!(at(&g, &v, "norm"), i128::from(trace.norm));
        if trace.norm > 0 {
            prop_assert_eq!(at(&g, &v, "ndotl0"), i128::from(trace.diffuse));
        }
        for (kk, n) in ["r", "g", "b"].iter().enumerate() {
            prop_assert_eq!(at(&g, &v, &format!("c_{n}")), i128::from(out[kk].raw()), "colour {}", n);
        }
        prop_assert_eq!(at(&g, &v, "alpha"), i128::from(alpha.raw()));
    }
}

/// The units' descriptions at the default widths: unique probe names,
/// and the node counts and pipelined depths docs/pipeline.md lists
/// (each unit alone, from its ports to its outputs' register).
#[test]
fn default_unit_shapes() {
    let want = [
        ("shading", 202, 59),
        ("voi", 97, 49),
        ("preint", 155, 34),
        ("tents", 64, 3),
    ];
    let cfg = PipelineConfig::default();
    let graphs = [
        ("shading", super::shading::shading(&cfg, 1)),
        ("voi", super::voi::voi(&cfg)),
        ("preint", super::preint::preint(&cfg)),
        ("tents", super::tents::tents(&cfg)),
    ];
    let mut got = Vec::new();
    for (name, g) in &graphs {
        let mut names = g.probe_names();
        let n = names.len();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), n, "{name}: probe names are unique");
        got.push((*name, n, super::schedule::schedule(g).depth));
    }
    assert_eq!(got, want);
}
