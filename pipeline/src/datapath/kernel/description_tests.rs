//! The kernel against the datapath's description (`hw::sample::plain`),
//! op by op, with no general path between them: on random formats (every
//! width of the plain sample's units, `TRN` or `RND` assignments,
//! saturating: the configurations a kernel exists for), both orders,
//! three transfer functions and random samples, each of the kernel's
//! per-frame assignments ([`Step`]) applied to the kernel's own exact
//! intermediate gives the description's node word (position, address and
//! weight, both x lerps, the y lerp, the classification table's four
//! fields, the visibility, the x slope, the path length, `p`, the exp
//! table's weight and lerp), and a batch through the lanes, where the
//! transmittance's shift, `1 - T` and the compositing are fused, gives
//! lane by lane the description's write-back and visibility.

use super::lanes::{Batch, LANES};
use super::*;
use crate::config::PipelineConfig;
use crate::hw::sample::{class_names, plain};
use crate::hw::tests::{run, ufmt, word};
use crate::tables::Tables;
use proptest::prelude::*;

/// Configurations a kernel exists for: the widths of `hw::tests`'
/// strategy (sample words of at most 16 bits, which the classification
/// table lists), rounding `TRN` or `RND`, saturating.
fn configs() -> impl Strategy<Value = PipelineConfig> {
    // Quant::ALL's TRN and RND.
    let q = |i: usize| [0usize, 2][i];
    (
        (6u8..=12, 4u8..=16, 0usize..2, 0u8..=4, 0usize..2),
        (6u8..=13, 0usize..2, 6u8..=14, 0usize..2),
        (10u8..=18, 0usize..2, 3u8..=10, 10u8..=20, 0usize..2),
        (0u8..=2, 0usize..2, 0usize..3, any::<bool>(), 0u8..=3),
    )
        .prop_map(
            move |(
                (vb, wb, wq, sf, sq),
                (cb, cq, ab, aq),
                (ob, oq, eb, lb, lq),
                (xb, accq, tab, ftb, sat),
            )| {
                let d = PipelineConfig::default();
                let sb = (vb + sf + xb).min(16);
                let entries = 1u32
                    << (vb as u32 + [0, 1, 0][tab])
                        .saturating_sub([0, 0, 2][tab])
                        .max(2);
                PipelineConfig {
                    voxel: ufmt(vb, 0, 0, 1),
                    weight: ufmt(wb, wb, q(wq), 1),
                    sample: ufmt(sb, sf, q(sq), 1),
                    table_entries: entries,
                    color: ufmt(cb, cb - 1, q(cq), 1),
                    alpha: ufmt(ab, ab, q(aq), 1),
                    opacity_corr: ufmt(ob, ob - 1, q(oq), 1),
                    exp_table_bits: eb.min(lb - 4),
                    log_transmittance: ufmt(lb, lb - 4, q(lq), 1),
                    accum_color: ufmt(ob + sat, ob + sat, q(accq), 1),
                    accum_alpha: ufmt(ob + sat, ob + sat, q(accq), 1),
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

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn the_kernel_is_the_description_op_by_op(
        cfg in configs(),
        r in any::<[i64; 5]>(),
        m in -300i64..300,
        n in 1usize..=LANES,
        wy in any::<[i64; LANES]>(),
        sy in any::<[i64; LANES]>(),
        taps in any::<[[u16; 4]; LANES]>(),
        acc in any::<[[i64; 4]; LANES]>(),
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
        let dp = Datapath::new(cfg, tables.clone());
        prop_assume!(dp.kernel().is_some());
        let kernel = dp.kernel().expect("a kernel");
        let fx = |r: i64, f: Format| Fx::from_raw(word(r, f), f).expect("in range");
        let (a, t) = (fx(r[0] >> 8, cfg.position), fx(r[1], cfg.step));
        let (b, k) = (fx(r[2] >> 20, cfg.position), fx(r[3] >> 30, cfg.step));
        let sz = fx(r[4] >> 24, cfg.position);
        let (fc, fa) = (cfg.accum_color, cfg.accum_alpha);
        let lane = |l: usize| {
            let (wy, sy) = (fx(wy[l], cfg.weight), fx(sy[l] >> 24, cfg.position));
            let v = taps[l].map(|x| i64::from(x) & cfg.voxel.max_raw());
            let acc = [word(acc[l][0], fc), word(acc[l][1], fc), word(acc[l][2], fc), word(acc[l][3], fa)];
            (wy, sy, v, acc)
        };
        let g = plain(&cfg);
        // The description's words for lane `l`'s sample.
        let described = |l: usize| {
            let (wy, sy, v, acc) = lane(l);
            let inputs = [
                ("slot.m", m), ("a", a.raw()), ("t", t.raw()), ("b", b.raw()), ("k", k.raw()),
                ("row.wy", wy.raw()), ("sy", sy.raw()), ("sz", sz.raw()),
                ("acc_r", acc[0]), ("acc_g", acc[1]), ("acc_b", acc[2]), ("acc_a", acc[3]),
            ];
            run(&g, &cfg, &tables, &inputs, v)
        };
        let node = |v: &crate::hw::eval::Values, name: &str| -> i64 {
            v[g.find(name).unwrap_or_else(|| panic!("node {name}")).0] as i64
        };
        let rows: Option<Vec<KernelRow>> = (0..n)
            .map(|l| {
                let (wy, sy, ..) = lane(l);
                kernel.row((a, t), (b, k), wy, (sy, sz))
            })
            .collect();
        // A row or a sample whose words the kernel's proofs do not cover
        // runs the general path.
        let Some(rows) = rows else { return Ok(()) };
        let tally = &mut Tally::default();
        let Some(ray) = kernel.address(&rows[0], m, tally) else { return Ok(()) };

        // Lane 0, op by op.
        let d = described(0);
        let (_, _, v, _) = lane(0);
        let row = rows[0];
        let x = kernel.line.apply(exact(m, row.a, row.t).expect("in range"), tally);
        prop_assert_eq!(x, node(&d, "x"));
        prop_assert_eq!(ray.x0, node(&d, "x0"));
        prop_assert_eq!(ray.wx, node(&d, "wx"));
        let fw = u32::from(cfg.weight.frac());
        let top = kernel.lerp_x.apply(lerp(v[0], v[1], ray.wx, fw), tally);
        let bot = kernel.lerp_x.apply(lerp(v[2], v[3], ray.wx, fw), tally);
        prop_assert_eq!(top, node(&d, "bilinear.top"));
        prop_assert_eq!(bot, node(&d, "bilinear.bot"));
        let s = kernel.lerp_y.apply(lerp(top, bot, row.wy, fw), tally);
        prop_assert_eq!(s, node(&d, "sample"));
        let table = &kernel.classes;
        let cw = table.words[s as usize];
        let (cb, ab) = (table.color_bits, table.alpha_bits);
        let fields = [0, 1, 2]
            .map(|ch| ((cw >> (ch * cb)) & ((1 << cb) - 1)) as i64);
        let alpha = ((cw >> (3 * cb)) & ((1 << ab) - 1)) as i64;
        let names = class_names(&g);
        for (ch, want) in fields.iter().enumerate() {
            prop_assert_eq!(*want, node(&d, names[ch]), "{}", names[ch]);
        }
        prop_assert_eq!(alpha, node(&d, names[3]));
        prop_assert_eq!(alpha != 0, node(&d, "visible") != 0);
        let sx = kernel.line.apply(ray.slope, tally);
        prop_assert_eq!(sx, node(&d, "sx"));
        let rs = kernel.rad_shift;
        let sum = sx * sx + row.yz;
        let rad = if rs >= 0 { sum << rs } else { sum >> -rs };
        let ds = kernel.root.apply(crate::datapath::isqrt(rad as u128) as i64, tally);
        prop_assert_eq!(ds, node(&d, "ds"));
        let last = kernel.log_t.len() - 1;
        let p = kernel.log_p.apply(kernel.log_t[(alpha as usize).min(last)] * ds, tally);
        prop_assert_eq!(p, node(&d, "p"));
        let (fb, rb) = (kernel.p_frac, kernel.p_frac - kernel.exp_bits);
        let rem = p & ((1i64 << rb) - 1);
        let w = kernel.exp_w.apply(rem, tally);
        match (g.find("exp.w"), g.find("exp.frac")) {
            (Some(_), _) => prop_assert_eq!(w, node(&d, "exp.w")),
            // The remainder is the weight as wired: the same value.
            (None, Some(_)) => prop_assert_eq!(w, node(&d, "exp.frac") << (fw - rb)),
            (None, None) => prop_assert_eq!(rb, 0),
        }
        if g.find("exp").is_some() {
            let idx = ((p & ((1i64 << fb) - 1)) >> rb) as usize;
            let (lo, hi) = (kernel.exp[idx], kernel.exp[idx + 1]);
            let e = kernel.exp_lerp.apply(lerp(lo, hi, w, fw), tally);
            prop_assert_eq!(e, node(&d, "exp"));
        }

        // Every lane through the batch: the write-back and visibility.
        let mut batch = Batch { n, wx: ray.wx, slope: ray.slope, ..Batch::default() };
        for (l, row) in rows.iter().enumerate() {
            let (_, _, v, acc) = lane(l);
            (batch.wy[l], batch.yz[l]) = row.lane_constants();
            for i in 0..4 {
                batch.v[i][l] = v[i];
                batch.acc[i][l] = acc[i];
            }
        }
        batch.pad();
        kernel.sample_lanes(&mut batch, &mut Tally::default());
        for l in 0..n {
            let d = described(l);
            for (i, ch) in ["r", "g", "b", "a"].iter().enumerate() {
                prop_assert_eq!(batch.acc[i][l], node(&d, &format!("acc_out.{ch}")), "lane {} {}", l, ch);
            }
            prop_assert_eq!((batch.visible >> l) & 1 != 0, node(&d, "visible") != 0, "lane {}", l);
        }
    }
}
