//! One datapath sample through the C ABI against the model: random
//! inputs per unit and order, the words `tests/c/datapath.c` prints equal
//! to [`Datapath`]'s methods applied step by step (the whole sample as a
//! PE's sampling cycle computes it, `bilinear` and `composite` alone).

use std::collections::HashMap;
use std::io::Write;
use std::process::{Command, Stdio};

use pipeline::config::{Order, PipelineConfig};
use pipeline::datapath::{Acc, Datapath};
use pipeline::fixed::{Format, Fx, QuantStats};
use pipeline::tables::Tables;

use super::{compile, tools};

/// A deterministic stream of words (splitmix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> i64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as i64
    }

    /// A raw word of `f`.
    fn word(&mut self, f: Format) -> i64 {
        let span = i128::from(f.max_raw()) - i128::from(f.min_raw()) + 1;
        (i128::from(self.next()).rem_euclid(span) + i128::from(f.min_raw())) as i64
    }
}

/// One sample's input words by port name and the model's output words by
/// output name.
type Case = (HashMap<&'static str, i64>, HashMap<&'static str, i64>);

/// The model's words for a random sample of `unit`.
fn case(unit: &str, cfg: &PipelineConfig, dp: &Datapath, r: &mut Rng) -> Case {
    let st = &mut QuantStats::default();
    let fx = |w: i64, f: Format| Fx::from_raw(w, f).unwrap();
    let (fc, fa) = (cfg.accum_color, cfg.accum_alpha);
    let acc = [r.word(fc), r.word(fc), r.word(fc), r.word(fa)];
    let taps = [0; 4].map(|_| r.word(cfg.voxel));
    let v = [
        [taps[0] as u16, taps[1] as u16],
        [taps[2] as u16, taps[3] as u16],
    ];
    let mut i = HashMap::new();
    let mut o = HashMap::new();
    let accs = [
        ("acc_r", acc[0]),
        ("acc_g", acc[1]),
        ("acc_b", acc[2]),
        ("acc_a", acc[3]),
    ];
    let composite = |out: &mut Acc, c: [Fx; 3], a: Fx, st: &mut QuantStats| match cfg.order {
        Order::BackToFront => dp.composite_btf(out, c, a, st).unwrap(),
        Order::FrontToBack => dp.composite_ftb(out, c, a, st).unwrap(),
    };
    match unit {
        "bilinear" => {
            let (wx, wy) = (r.word(cfg.weight), r.word(cfg.weight));
            let y = dp
                .bilinear(v, fx(wx, cfg.weight), fx(wy, cfg.weight), st)
                .unwrap();
            i.extend([
                ("v00", taps[0]),
                ("v01", taps[1]),
                ("v10", taps[2]),
                ("v11", taps[3]),
            ]);
            i.extend([("wx", wx), ("wy", wy)]);
            o.insert("y", y.raw());
        }
        "composite" => {
            let c = [0; 3].map(|_| r.word(cfg.color));
            let a = r.word(cfg.opacity_corr);
            let mut out = Acc { raw: acc };
            composite(
                &mut out,
                c.map(|w| fx(w, cfg.color)),
                fx(a, cfg.opacity_corr),
                st,
            );
            i.extend(accs);
            i.extend([("c_r", c[0]), ("c_g", c[1]), ("c_b", c[2]), ("a", a)]);
            o.extend(["y_r", "y_g", "y_b", "y_a"].into_iter().zip(out.raw));
        }
        _ => {
            // A ray index and positions as a frame has them (hw::tests).
            let m = r.next().rem_euclid(800) - 400;
            let (a, t) = (r.word(cfg.position) >> 8, r.word(cfg.step));
            let (b, k) = (r.word(cfg.position) >> 20, r.word(cfg.step) >> 30);
            let wy = r.word(cfg.weight);
            let (sy, sz) = (r.word(cfg.position) >> 24, r.word(cfg.position) >> 24);
            let x = dp
                .position(fx(a, cfg.position), fx(t, cfg.step), m, st)
                .unwrap();
            let (x0, wx) = dp.address(x, st);
            let s = dp.bilinear(v, wx, fx(wy, cfg.weight), st).unwrap();
            let (rgb, alpha) = dp.classify(s, st).unwrap();
            let sx = dp
                .position(fx(b, cfg.position), fx(k, cfg.step), m, st)
                .unwrap();
            let p = cfg.position;
            let ds = dp.path(sx, fx(sy, p), fx(sz, p), st).unwrap();
            let oc = dp.correct(alpha, ds, st).unwrap();
            let mut out = Acc { raw: acc };
            if alpha.raw() > 0 {
                composite(&mut out, rgb, oc, st);
            }
            i.extend([("slot_m", m), ("a", a), ("t", t), ("b", b), ("k", k)]);
            i.extend([("row_wy", wy), ("sy", sy), ("sz", sz)]);
            i.extend([
                ("v00", taps[0]),
                ("v01", taps[1]),
                ("v10", taps[2]),
                ("v11", taps[3]),
            ]);
            i.extend(accs);
            let names = ["acc_out_r", "acc_out_g", "acc_out_b", "acc_out_a"];
            o.extend(names.into_iter().zip(out.raw));
            o.insert("x0", x0);
        }
    }
    (i, o)
}

#[test]
fn a_c_program_evaluates_the_models_datapath_samples() {
    if !tools::have("cc", "gcc", "the C ABI datapath test") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let prog = compile(dir.path(), "datapath");
    let mut seen_error_lines = false;
    for (unit, order, tf) in [
        ("sample", Order::BackToFront, "brain"),
        ("sample", Order::FrontToBack, "ml"),
        ("bilinear", Order::BackToFront, "grey-ramp"),
        ("composite", Order::BackToFront, "grey-ramp"),
        ("composite", Order::FrontToBack, "grey-ramp"),
    ] {
        let cfg = PipelineConfig {
            order,
            ..PipelineConfig::default()
        };
        let lut = golden::tf::Lut::for_bits(
            &golden::scenes::tf_preset(tf).unwrap(),
            cfg.table_entries as usize,
            u32::from(cfg.voxel.bits()),
        );
        let dp = Datapath::new(cfg, Tables::new(&cfg, &lut).unwrap()).without_kernel();
        let mut rng = Rng(0x5eed ^ unit.len() as u64 ^ (order as u64) << 8);
        let cases: Vec<Case> = (0..300).map(|_| case(unit, &cfg, &dp, &mut rng)).collect();
        // Ports as the C program lists them, then one line per sample.
        let listing = Command::new(&prog)
            .args([unit, ["btf", "ftb"][order as usize], tf])
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&listing.stdout).into_owned();
        assert!(
            listing.status.success(),
            "{text}\n{}",
            String::from_utf8_lossy(&listing.stderr)
        );
        let port = |side: &str| -> Vec<String> {
            text.lines()
                .filter_map(|l| l.strip_prefix(side))
                .map(|l| l.split(' ').next().unwrap().to_owned())
                .collect()
        };
        let (ins, outs) = (port("in "), port("out "));
        let mut input = String::new();
        for (i, _) in &cases {
            let words: Vec<String> = ins.iter().map(|n| i[n.as_str()].to_string()).collect();
            input.push_str(&words.join(" "));
            input.push('\n');
        }
        let mut child = Command::new(&prog)
            .args([unit, ["btf", "ftb"][order as usize], tf])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        child
            .stdin
            .take()
            .unwrap()
            .write_all(input.as_bytes())
            .unwrap();
        let out = child.wait_with_output().unwrap();
        let got = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{unit}: {got}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let rows: Vec<&str> = got.lines().skip(text.lines().count()).collect();
        assert_eq!(rows.len(), cases.len(), "{unit}: {got}");
        let mut visible = 0;
        for (k, ((i, o), row)) in cases.iter().zip(&rows).enumerate() {
            let words: Vec<i64> = row.split(' ').map(|w| w.parse().unwrap()).collect();
            let want: Vec<i64> = outs.iter().map(|n| o[n.as_str()]).collect();
            assert_eq!(words, want, "{unit} {order:?} sample {k}: inputs {i:?}");
            visible += usize::from(unit != "sample" || o["acc_out_a"] != i["acc_a"]);
        }
        // Enough samples composited to prove the arithmetic, not the mux.
        assert!(
            visible > 30,
            "{unit}: only {visible} samples changed the accumulators"
        );
        let lat: u32 = text
            .lines()
            .find_map(|l| l.strip_prefix("latency "))
            .unwrap()
            .parse()
            .unwrap();
        let want_lat = match (unit, order) {
            ("sample", Order::BackToFront) => 35,
            ("sample", Order::FrontToBack) => 36,
            ("bilinear", _) => 2,
            _ => 1,
        };
        assert_eq!(lat, want_lat, "{unit}");
        if !seen_error_lines {
            for (line, says) in [
                ("unknown unit:", "sample, bilinear, composite"),
                ("bad order:", "btf"),
                ("bad config:", "pes"),
                ("few inputs:", "8 input words, 7 given"),
                ("wide input:", "acc_r"),
                ("no table:", "reads no table"),
                ("no port:", "acc_x"),
                ("null datapath:", "null"),
                ("no table word:", "reads no table"),
                ("table address:", "past its"),
                ("table word:", "outside"),
            ] {
                let l = text.lines().find(|l| l.starts_with(line)).unwrap();
                assert!(l.contains(says), "{l}");
            }
            seen_error_lines = true;
        }
    }
}
