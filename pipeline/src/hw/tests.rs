//! The description against the model: the plain sample's evaluator gives
//! the words of `crate::datapath::Datapath`'s methods, op by op, over many
//! formats, rounding and overflow modes and both orders.

use super::eval::{eval, Values};
use super::sample::{class_names, plain};
use super::{Graph, MemId};
use crate::config::{Order, PipelineConfig};
use crate::datapath::{Acc, Datapath};
use crate::fixed::{Format, Fx, Overflow, Quant, QuantStats};
use crate::tables::Tables;
use proptest::prelude::*;

/// A raw word of `f` from any `r`.
pub(crate) fn word(r: i64, f: Format) -> i64 {
    let span = i128::from(f.max_raw()) - i128::from(f.min_raw()) + 1;
    (i128::from(r).rem_euclid(span) + i128::from(f.min_raw())) as i64
}

/// An unsigned format of `bits` with `frac` fraction bits (at most
/// `bits`) and the given modes.
pub(crate) fn ufmt(bits: u8, frac: u8, q: usize, o: usize) -> Format {
    Format::new(bits, frac.min(bits), false, Quant::ALL[q], Overflow::ALL[o]).expect("format")
}

/// Configurations around the defaults: every width of the plain sample's
/// units varied, every rounding mode, saturating or wrapping, both orders.
fn configs() -> impl Strategy<Value = PipelineConfig> {
    (
        (6u8..=12, 4u8..=16, 0usize..7, 0u8..=6, 0usize..7),
        (6u8..=13, 0usize..7, 6u8..=14, 0usize..7, 0usize..2),
        (10u8..=18, 0usize..7, 3u8..=10, 10u8..=20, 0usize..7),
        (0u8..=4, 0usize..7, 0usize..2, any::<bool>(), 0u8..=3),
    )
        .prop_map(
            |(
                (vb, wb, wq, sf, sq),
                (cb, cq, ab, aq, ovf),
                (ob, oq, eb, lb, lq),
                (xb, accq, tab, ftb, sat),
            )| {
                let d = PipelineConfig::default();
                // Saturating, or wrapping where the rules allow it.
                let o = [1usize, 0][ovf];
                let voxel = ufmt(vb, 0, 0, 1);
                let sample = ufmt(vb + sf + xb.min(2), sf, sq, 1);
                let entries = 1u32
                    << (vb as u32 + [0, 1, 0][tab])
                        .saturating_sub([0, 0, 2][tab])
                        .max(2);
                PipelineConfig {
                    voxel,
                    weight: ufmt(wb, wb, wq, 1),
                    sample,
                    table_entries: entries,
                    color: ufmt(cb, cb - 1, cq, o),
                    alpha: ufmt(ab, ab, aq, 1),
                    opacity_corr: ufmt(ob, ob - 1, oq, 1),
                    exp_table_bits: eb.min(lb - 4),
                    log_transmittance: ufmt(lb, lb - 4, lq, 1),
                    accum_color: ufmt(ob + sat, ob + sat, accq, 1),
                    accum_alpha: ufmt(ob + sat, ob + sat, accq, 1),
                    merge: ufmt(ob + sat + 4, ob + sat, 2, 1),
                    order: if ftb {
                        Order::FrontToBack
                    } else {
                        Order::BackToFront
                    },
                    ..d
                }
            },
        )
}

/// The model's words for one sample, named as the description's probes.
struct Model {
    words: Vec<(&'static str, i64)>,
}

/// Evaluates the description on one sample's inputs and tables.
pub(crate) fn run(
    g: &Graph,
    cfg: &PipelineConfig,
    t: &Tables,
    inputs: &[(&str, i64)],
    taps: [i64; 4],
) -> Values {
    let class: Vec<[i64; 4]> = t
        .color
        .iter()
        .zip(&t.alpha)
        .map(|(c, a)| [c[0].raw(), c[1].raw(), c[2].raw(), a.raw()])
        .collect();
    let log_t: Vec<i64> = t.log_t.iter().map(|x| x.raw()).collect();
    let exp: Vec<i64> = t.exp.iter().map(|x| x.raw()).collect();
    let read = |name: &str, m: MemId, addr: i128| -> Option<i64> {
        let i = usize::try_from(addr).ok();
        match m.0 {
            0..=3 => class.get(i?).map(|e| e[m.0]),
            4 => log_t.get(i?).copied(),
            5 => exp.get(i?).copied(),
            _ => ["v00", "v01", "v10", "v11"]
                .iter()
                .position(|&v| v == name)
                .map(|k| taps[k]),
        }
    };
    let input = |name: &str| inputs.iter().find(|(n, _)| *n == name).map(|x| x.1);
    let _ = cfg;
    eval(g, &input, &read, &mut QuantStats::default()).expect("the description evaluates")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    /// On random configurations and samples, every step's word of the
    /// description is the model's: position and address, the four taps'
    /// interpolation, classification, the slope and path length, the
    /// corrected opacity, and the accumulators after compositing in
    /// either order (unchanged for an invisible sample).
    #[test]
    fn the_description_is_the_datapath_op_by_op(
        cfg in configs(),
        r in any::<[i64; 8]>(),
        m in -400i64..400,
        taps in any::<[u16; 4]>(),
        acc in any::<[i64; 4]>(),
        tf in 0usize..3,
    ) {
        prop_assume!(cfg.validate().is_ok());
        let preset = ["ml", "grey-ramp", "brain"][tf];
        let lut = golden::tf::Lut::for_bits(
            &golden::scenes::tf_preset(preset).expect("preset"),
            cfg.table_entries as usize,
            u32::from(cfg.voxel.bits()),
        );
        let tables = Tables::new(&cfg, &lut).expect("tables");
        let dp = Datapath::new(cfg, tables.clone()).without_kernel();
        let fx = |r: i64, f: Format| Fx::from_raw(word(r, f), f).expect("in range");
        let (a, t) = (fx(r[0] >> 8, cfg.position), fx(r[1], cfg.step));
        let (b, k) = (fx(r[2] >> 20, cfg.position), fx(r[3] >> 30, cfg.step));
        let wy = fx(r[4], cfg.weight);
        let (sy, sz) = (fx(r[5] >> 24, cfg.position), fx(r[6] >> 24, cfg.position));
        let taps = taps.map(|v| i64::from(v) & cfg.voxel.max_raw());
        let (fc, fa) = (cfg.accum_color, cfg.accum_alpha);
        let acc0 = Acc { raw: [word(acc[0], fc), word(acc[1], fc), word(acc[2], fc), word(acc[3], fa)] };

        // The model, step by step.
        let st = &mut QuantStats::default();
        let model = (|| -> Result<Model, crate::fixed::FxError> {
            let x = dp.position(a, t, m, st)?;
            let (x0, wx) = dp.address(x, st);
            let v = [[taps[0] as u16, taps[1] as u16], [taps[2] as u16, taps[3] as u16]];
            let s = dp.bilinear(v, wx, wy, st)?;
            let (rgb, alpha) = dp.classify(s, st)?;
            let sx = dp.position(b, k, m, st)?;
            let ds = dp.path(sx, sy, sz, st)?;
            let oc = dp.correct(alpha, ds, st)?;
            let mut out = acc0;
            if alpha.raw() > 0 {
                match cfg.order {
                    Order::BackToFront => dp.composite_btf(&mut out, rgb, oc, st)?,
                    Order::FrontToBack => dp.composite_ftb(&mut out, rgb, oc, st)?,
                }
            }
            let mut words = vec![
                ("x", x.raw()), ("x0", x0), ("wx", wx.raw()), ("sample", s.raw()),
                ("sx", sx.raw()), ("ds", ds.raw()),
                ("corrected", oc.raw()),
                ("acc_out.r", out.raw[0]), ("acc_out.g", out.raw[1]),
                ("acc_out.b", out.raw[2]), ("acc_out.a", out.raw[3]),
            ];
            words.extend([0, 1, 2].map(|i| ("", rgb[i].raw())));
            words.push(("", alpha.raw()));
            Ok(Model { words })
        })();
        let Ok(mut model) = model else {
            // The model refuses (a position beyond 128 bits): nothing to compare.
            return Ok(());
        };

        let g = plain(&cfg);
        let names = class_names(&g);
        for (i, w) in model.words.iter_mut().filter(|w| w.0.is_empty()).enumerate() {
            w.0 = names[i];
        }
        let inputs = [
            ("slot.m", m), ("a", a.raw()), ("t", t.raw()), ("b", b.raw()), ("k", k.raw()),
            ("row.wy", wy.raw()), ("sy", sy.raw()), ("sz", sz.raw()),
            ("acc_r", acc0.raw[0]), ("acc_g", acc0.raw[1]), ("acc_b", acc0.raw[2]),
            ("acc_a", acc0.raw[3]),
        ];
        let v = run(&g, &cfg, &tables, &inputs, taps);
        for (name, want) in &model.words {
            let id = g.find(name).unwrap_or_else(|| panic!("probe {name}"));
            prop_assert_eq!(v[id.0], i128::from(*want), "{}", name);
        }
    }
}

/// The default configuration's description: its probes are unique, and
/// its pipelined schedule is the depth docs/pipeline.md lists (35 clocks
/// back to front, 36 front to back), the model's derived latency.
#[test]
fn default_description_shape() {
    let cfg = PipelineConfig::default();
    let g = plain(&cfg);
    let names = g.probe_names();
    let mut sorted = names.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), names.len(), "probe names are unique");
    let depth = |order| super::schedule::schedule(&plain(&PipelineConfig { order, ..cfg })).depth;
    assert_eq!(depth(Order::BackToFront), 35);
    assert_eq!(depth(Order::FrontToBack), 36);
    assert_eq!(crate::cost::datapath_latency(&cfg), 35);
}
