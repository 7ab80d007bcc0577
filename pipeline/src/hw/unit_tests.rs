//! The units against the whole description: a cut evaluated on the words
//! the whole sample's evaluation holds at its ports gives the words the
//! whole sample holds at its outputs; latencies; refusals.

use super::unit::{Unit, NAMES};
use crate::config::{Order, PipelineConfig};
use proptest::prelude::*;

/// A raw word of `bits` (signed or not) from any `r`.
fn fit(r: i64, w: super::Word) -> i64 {
    let span = 1i128 << w.bits;
    let lo = if w.signed { -(span / 2) } else { 0 };
    (i128::from(r).rem_euclid(span) + lo) as i64
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// Random words at the whole sample's ports (position inputs kept
    /// small enough for the model's 128-bit products): every cut's
    /// outputs equal the whole sample's nodes they are cut at.
    #[test]
    fn cuts_agree_with_the_whole_sample(r in any::<[i64; 16]>(), ftb in any::<bool>(), tf in 0usize..3) {
        let order = if ftb { Order::FrontToBack } else { Order::BackToFront };
        let cfg = PipelineConfig { order, ..PipelineConfig::default() };
        let mut whole = Unit::new(&cfg, "sample").unwrap();
        whole.fill_tables(["grey-ramp", "ml", "brain"][tf]).unwrap();
        let words: Vec<i64> = whole
            .inputs()
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let w = fit(r[i], p.word);
                // The ray index and positions as a frame has them.
                match p.name.as_str() {
                    "slot_m" => w % 512,
                    "a" | "b" | "sy" | "sz" => w >> 20,
                    _ => w,
                }
            })
            .collect();
        let Ok(_) = whole.eval(&words) else {
            return Ok(());
        };
        let values = whole.node_values(&words).unwrap();
        for name in ["bilinear", "composite"] {
            let cut = Unit::new(&cfg, name).unwrap();
            let spec = super::unit::spec(&super::sample::plain(&cfg), name).unwrap();
            let at = |node: &str| values.iter().find(|v| v.0 == node).unwrap().1;
            let ins: Vec<i64> = spec.ports.iter().map(|p| at(p.1)).collect();
            let want: Vec<i64> = spec.outputs.iter().map(|o| at(o.1)).collect();
            prop_assert_eq!(cut.eval(&ins).unwrap(), want, "{}", name);
        }
    }
}

#[test]
fn latencies_ports_and_refusals() {
    let cfg = PipelineConfig::default();
    let lat = |name: &str, order| {
        Unit::new(&PipelineConfig { order, ..cfg }, name)
            .unwrap()
            .latency()
    };
    assert_eq!(lat("bilinear", Order::BackToFront), 2);
    assert_eq!(lat("composite", Order::BackToFront), 1);
    assert_eq!(lat("composite", Order::FrontToBack), 1);
    assert_eq!(lat("sample", Order::BackToFront), 35);
    assert_eq!(lat("sample", Order::FrontToBack), 36);
    for name in NAMES {
        let u = Unit::new(&cfg, name).unwrap();
        assert!(!u.inputs().is_empty() && !u.outputs().is_empty(), "{name}");
    }
    let s = Unit::new(&cfg, "sample").unwrap();
    let names: Vec<&str> = s.inputs().iter().map(|p| p.name.as_str()).collect();
    assert!(
        names.contains(&"row_wy") && names.contains(&"v11"),
        "{names:?}"
    );
    assert_eq!(s.tables().count(), 6);
    assert_eq!(Unit::new(&cfg, "composite").unwrap().tables().count(), 0);
    let e = Unit::new(&cfg, "nope").unwrap_err().to_string();
    assert!(e.contains("sample, bilinear, composite"), "{e}");
    let e = Unit::from_toml(Some("pes = 0"), None, "sample")
        .unwrap_err()
        .to_string();
    assert!(e.contains("pes"), "{e}");
    let e = Unit::from_toml(None, Some("sideways"), "sample")
        .unwrap_err()
        .to_string();
    assert!(e.contains("btf"), "{e}");
    let mut c = Unit::new(&cfg, "composite").unwrap();
    let n = c.inputs().len();
    assert!(c.eval(&vec![0; n - 1]).is_err());
    let mut big = vec![0; n];
    big[0] = 1 << 40;
    let e = c.eval(&big).unwrap_err().to_string();
    assert!(e.contains("acc_r"), "{e}");
    assert!(c
        .load_table("class_r", &[0])
        .unwrap_err()
        .to_string()
        .contains("no table"));
    assert!(
        c.fill_tables("no-such-tf").is_err(),
        "a misspelt preset is refused without tables too"
    );
    assert!(c.fill_tables("grey-ramp").is_ok());
    let mut s = s;
    assert!(s
        .load_table("class_r", &[0])
        .unwrap_err()
        .to_string()
        .contains("holds"));
    assert!(s.fill_tables("no-such-tf").is_err());
    assert!(s.verilog("m").is_err(), "the whole sample has reads inside");
}

#[test]
fn the_whole_sample_is_the_emitted_module_and_its_tables_take_single_words() {
    for cfg in [
        PipelineConfig::default(),
        PipelineConfig {
            target_mhz: 100,
            ..PipelineConfig::default()
        },
    ] {
        let mut s = Unit::new(&cfg, "sample").unwrap();
        let m = s.pipelined("ercube_sample").unwrap();
        // The module `ercube rtl` writes, whose depth the model's latency is.
        let sch = crate::cost::latency::sample_schedule(&cfg);
        let rtl =
            super::pipeline_rtl::emit_scheduled(&super::sample::plain(&cfg), &sch, "ercube_sample")
                .unwrap();
        assert_eq!(m.verilog, rtl.verilog);
        assert_eq!(s.latency(), m.depth);
        assert_eq!(m.depth, crate::cost::latency::plain_depth(&cfg));
        let w = s.table_word("class_a", 100).unwrap();
        assert_eq!(Some(w), s.table("class_a").map(|t| t[100]));
        s.set_table_word("class_a", 100, w ^ 1).unwrap();
        assert_eq!(s.table("class_a").unwrap()[100], w ^ 1);
        assert!(s
            .table_word("class_a", 1 << 30)
            .unwrap_err()
            .to_string()
            .contains("past"));
        assert!(s
            .set_table_word("class_a", 0, -1)
            .unwrap_err()
            .to_string()
            .contains("outside"));
        assert!(s
            .set_table_word("nope", 0, 0)
            .unwrap_err()
            .to_string()
            .contains("expected class_r"));
    }
    let c = Unit::new(&PipelineConfig::default(), "composite").unwrap();
    assert!(c.pipelined("m").unwrap_err().to_string().contains("cut"));
    assert!(c
        .table_word("class_r", 0)
        .unwrap_err()
        .to_string()
        .contains("reads no table"));
}
