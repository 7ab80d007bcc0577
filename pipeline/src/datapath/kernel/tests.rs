//! The kernel checked against the general datapath: a batch of lanes
//! word for word and count for count, and the test configurations' kernels.

use super::*;
use crate::datapath::Acc;
use crate::fixed::{Overflow, Quant, QuantStats};
use crate::tables::Tables;
use proptest::prelude::*;

fn fmt(bits: u8, frac: u8, q: Quant) -> Format {
    Format::new(bits, frac, false, q, Overflow::Sat).unwrap()
}

/// The default widths, and narrow ones that round with `TRN` in
/// places and saturate often, in both orders.
fn configs() -> Vec<crate::config::PipelineConfig> {
    let base = crate::config::PipelineConfig::default();
    let narrow = crate::config::PipelineConfig {
        weight: fmt(6, 6, Quant::Rnd),
        sample: fmt(14, 2, Quant::Trn),
        alpha: fmt(8, 8, Quant::Rnd),
        opacity_corr: fmt(9, 8, Quant::Rnd),
        log_transmittance: fmt(10, 6, Quant::Trn),
        exp_table_bits: 4,
        accum_color: fmt(9, 8, Quant::Trn),
        accum_alpha: fmt(8, 8, Quant::Rnd),
        ..base
    };
    let mut out = Vec::new();
    for c in [base, narrow] {
        for order in [Order::BackToFront, Order::FrontToBack] {
            out.push(crate::config::PipelineConfig { order, ..c });
        }
    }
    out
}

fn datapath(cfg: crate::config::PipelineConfig) -> Datapath {
    let tf = golden::scenes::tf_preset("ml").unwrap();
    let lut = golden::tf::Lut::for_bits(&tf, cfg.table_entries as usize, 8);
    Datapath::new(cfg, Tables::new(&cfg, &lut).unwrap())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    /// A batch through the kernel's lanes gives, lane by lane, the
    /// general datapath's words and quantisation counts (per format): one column's
    /// address and weight (random broadcast words and ray index), and
    /// in each of up to eight lanes a row with its own y weight, y
    /// slope, voxel taps and accumulators, the accumulators after
    /// compositing, whether the sample was visible and the termination
    /// comparator.
    #[test]
    fn a_kernel_batch_is_the_general_sample(
        c in 0usize..4,
        a in -(1i64 << 26)..(1i64 << 26),
        t in 1i64..(1i64 << 24),
        b in -(1i64 << 24)..(1i64 << 24),
        k in 0i64..(1i64 << 20),
        sz in 1i64..(1i64 << 17),
        m in -300i64..300,
        n in 1usize..=LANES,
        wy in any::<[u16; LANES]>(),
        sy in proptest::array::uniform8(-(1i64 << 20)..(1i64 << 20)),
        v in any::<[[u16; 4]; LANES]>(),
        acc in any::<[[u16; 4]; LANES]>(),
    ) {
        let cfg = configs()[c];
        let dp = datapath(cfg);
        let kernel = dp.kernel().expect("the configuration has a kernel");
        let fx = |raw: i64, f: Format| Fx::from_raw(raw.clamp(f.min_raw(), f.max_raw()), f).unwrap();
        let (a, t) = (fx(a, cfg.position), fx(t, cfg.step));
        let (b, k) = (fx(b, cfg.position), fx(k, cfg.step));
        let sz = fx(sz, cfg.position);
        let row = |l: usize| {
            let (wy, sy) = (fx(i64::from(wy[l]), cfg.weight), fx(sy[l], cfg.position));
            (wy, sy, kernel.row((a, t), (b, k), wy, (sy, sz)).expect("row constants"))
        };
        let taps = |l: usize| {
            let v = v[l].map(|x| x & 0xfff);
            [[v[0], v[1]], [v[2], v[3]]]
        };
        let start = |l: usize| {
            let w = |i: usize, f: Format| i64::from(acc[l][i]).min(f.max_raw());
            let (fc, fa) = (cfg.accum_color, cfg.accum_alpha);
            Acc { raw: [w(0, fc), w(1, fc), w(2, fc), w(3, fa)] }
        };

        // The column's address, once, as `Pe::sample_columns` takes it.
        let mut addressing = Tally::default();
        let ray = kernel.address(&row(0).2, m, &mut addressing).expect("address");
        let mut batch = Batch { n, wx: ray.wx, slope: ray.slope, ..Batch::default() };
        for l in 0..n {
            (batch.wy[l], batch.yz[l]) = row(l).2.lane_constants();
            let tp = taps(l);
            let words = [tp[0][0], tp[0][1], tp[1][0], tp[1][1]];
            for (w, &x) in batch.v.iter_mut().zip(&words) {
                w[l] = i64::from(x);
            }
            for (w, &x) in batch.acc.iter_mut().zip(&start(l).raw) {
                w[l] = x;
            }
        }
        batch.pad();
        // The events of the first `k` lanes: a batch counts only the
        // lanes it uses, so lane `l`'s are those of `l + 1` lanes
        // less those of `l`.
        let loaded = batch;
        let first = |k: usize| {
            let (mut part, mut t) = (loaded, Tally::default());
            part.n = k;
            kernel.sample_lanes(&mut part, &mut t);
            kernel.settle(&mut t);
            t
        };
        kernel.sample_lanes(&mut batch, &mut Tally::default());
        let mut want_first = QuantStats::default();

        for l in 0..n {
            // The general path, as `Pe::sample_datapath` runs it.
            let (wy, sy, _) = row(l);
            let mut st = QuantStats::default();
            let x = dp.position(a, t, m, &mut st).unwrap();
            let (x0, wx) = dp.address(x, &mut st);
            prop_assert_eq!((ray.x0, ray.wx), (x0, wx.raw()));
            let s = dp.bilinear(taps(l), wx, wy, &mut st).unwrap();
            let (rgb, alpha) = dp.classify(s, &mut st).unwrap();
            let mut want = start(l);
            let visible = alpha.raw() > 0;
            let mut flag = false;
            if visible {
                let sx = dp.position(b, k, m, &mut st).unwrap();
                let ds = dp.path(sx, sy, sz, &mut st).unwrap();
                let oc = dp.correct(alpha, ds, &mut st).unwrap();
                if cfg.order == Order::FrontToBack {
                    dp.composite_ftb(&mut want, rgb, oc, &mut st).unwrap();
                    flag = dp.terminated(&want);
                } else {
                    dp.composite_btf(&mut want, rgb, oc, &mut st).unwrap();
                }
            }
            let got = Acc { raw: [0, 1, 2, 3].map(|i| batch.acc[i][l]) };
            prop_assert_eq!(got, want, "lane {}", l);
            prop_assert_eq!((batch.visible >> l) & 1 != 0, visible, "lane {}", l);
            if visible {
                prop_assert_eq!((batch.done >> l) & 1 != 0, flag, "lane {}", l);
            }
            want_first.merge(&st);
            let mut tally = first(l + 1);
            tally.add_times(&addressing, l as u64 + 1);
            let mut counted = QuantStats::default();
            tally.add_to(&mut counted);
            prop_assert_eq!(counted, want_first, "lanes up to {}", l);
        }
    }
}

/// Every configuration above has a kernel, and the rows' broadcast
/// formats are the ones its proofs assume.
#[test]
fn the_test_configurations_have_kernels() {
    for cfg in configs() {
        let dp = datapath(cfg);
        let k = dp.kernel().expect("kernel");
        let z = |f: Format| f.zero();
        let row = k.row(
            (z(cfg.position), z(cfg.step)),
            (z(cfg.position), z(cfg.step)),
            z(cfg.weight),
            (z(cfg.position), z(cfg.position)),
        );
        assert!(row.is_some());
        // A word in another format leaves the row to the general path.
        let other = k.row(
            (z(cfg.step), z(cfg.step)),
            (z(cfg.position), z(cfg.step)),
            z(cfg.weight),
            (z(cfg.position), z(cfg.position)),
        );
        assert!(other.is_none());
    }
}
