//! The datapath description's nodes traced by name
//! (`FrameRun::trace_nodes`, `ercube render --trace-nodes`): in a traced
//! frame, captured at the same time, every sample a PE issued in cycle `t`
//! shows in `top.pe_K.hw.<node>` at cycle `t + s` (`s` the node's stage in
//! the model's schedule) the word `hw::eval` gives for the captured
//! inputs, for the plain sample and the sample composed with the shading
//! unit and the volume of interest; the traced frame is the untraced one.
//! `tests/it/cosim.rs`'s `traced_nodes_are_the_emitted_modules_wires`
//! compares the same signals with the emitted module's wires in Icarus.

use std::sync::{Arc, Mutex};

use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::capture::Recorded;
use pipeline::cosim::replay::word_of;
use pipeline::hw::compose::{sample, Units};
use pipeline::hw::pipeline_rtl::verilog_name;
use pipeline::FrameRun;
use waves::{Trace, TraceConfig, Tracer};

use crate::chip::{signature, subject, view_from};

/// `v`'s low `bits` bits.
fn masked(v: i128, bits: u32) -> u128 {
    if bits >= 128 {
        v as u128
    } else {
        (v as u128) & ((1u128 << bits) - 1)
    }
}

fn check(order: Order, shading: bool, with_voi: bool, patterns: &[&str]) {
    use golden::shading::Shade;
    use golden::voi::{Shape, Voi};
    let s = subject("ml:24");
    let prep = view_from(&s.vol, [30.0, 20.0, -40.0], 16);
    let shade = Shade::default();
    let voi = Voi {
        shape: Shape::Sphere {
            centre: s.vol.center_world(),
            radius: 7.0,
        },
        scale: 3.0,
        outside: false,
        ramp: 2.0,
    };
    let cfg = PipelineConfig {
        pes: 3,
        order,
        ..PipelineConfig::default()
    };
    let frame = || {
        FrameRun::new(&cfg, &s.lut, &s.vol, &prep.view)
            .unit(shading.then_some(&shade))
            .unit(with_voi.then_some(&voi))
    };
    let plain = frame().run().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let vcd = dir.path().join("n.vcd");
    let rec = Arc::new(Mutex::new(Recorded::new()));
    let pats: Vec<String> = patterns.iter().map(|p| (*p).to_owned()).collect();
    let traced = frame()
        // Only the nodes (they are outside the groups), so the file stays
        // small.
        .trace(Tracer::new(TraceConfig::new(&vcd).with_groups(Vec::<String>::new())).unwrap())
        .trace_nodes(pats)
        .capture(rec.clone())
        .run()
        .unwrap();
    assert_eq!(
        signature(&traced),
        signature(&plain),
        "tracing nodes changed the frame"
    );
    let rec = rec.lock().unwrap();
    let trace = Trace::read(&vcd).unwrap();
    let units = Units {
        lights: shading.then_some(1),
        voi: with_voi,
        ..Units::default()
    };
    let g = sample(&cfg, units);
    let sch = pipeline::cost::latency::graph_schedule(&cfg, &g);
    let glob = |p: &str, n: &str| match p.strip_suffix('*') {
        Some(pre) => n.starts_with(pre),
        None => p == n,
    };
    let chosen: Vec<usize> = (0..g.nodes.len())
        .filter(|&i| patterns.iter().any(|p| glob(p, &g.nodes[i].name)))
        .collect();
    assert!(chosen.len() >= patterns.len(), "{patterns:?}");
    // Every traced node is in the waveform, as wide as its word; no other
    // signal is in the `hw` scopes.
    let hw: Vec<&str> = trace.names().filter(|n| n.contains(".hw.")).collect();
    assert_eq!(hw.len(), chosen.len() * usize::from(cfg.pes), "{hw:?}");
    let tables = rec.tables.clone();
    let frame_words = rec.frame.clone();
    let mut compared = 0u64;
    let mut changed = 0u64;
    for i in &rec.issues {
        let word = |name: &str| -> Option<i64> {
            let v = verilog_name(name);
            word_of(i, &v).or_else(|| frame_words.iter().find(|f| f.0 == v).map(|f| f.1))
        };
        let read = |node: &str, m: pipeline::hw::MemId, addr: i128| -> Option<i64> {
            let mem = &g.mems[m.0];
            if mem.depth == 0 {
                let k = ["v00", "v01", "v10", "v11"]
                    .iter()
                    .position(|t| *t == node)?;
                return Some(i64::from(i.input.taps[k]));
            }
            let words = &tables.iter().find(|t| t.0 == mem.name)?.1;
            words.get(usize::try_from(addr).ok()?).copied()
        };
        let v = pipeline::hw::eval::eval(
            &g,
            &word,
            &read,
            &mut pipeline::fixed::QuantStats::default(),
        )
        .unwrap();
        for &n in &chosen {
            let node = &g.nodes[n];
            let name = format!("top.pe_{}.hw.{}", i.pe, verilog_name(&node.name));
            let sig = trace.signal(&name).unwrap_or_else(|| panic!("{name}"));
            assert_eq!(sig.width(), node.word.bits, "{name}");
            let at = i.cycle + u64::from(sch.stage[n]);
            let bits = sig
                .value_at_cycle(at)
                .and_then(|w| w.to_bitvec())
                .unwrap_or_else(|| panic!("{name} at cycle {at}"));
            let got: u128 = bits
                .iter()
                .by_vals()
                .enumerate()
                .map(|(b, x)| u128::from(x) << b)
                .sum();
            assert_eq!(
                got,
                masked(v[n], node.word.bits),
                "{units:?} {order:?}: {name} at cycle {at} (issued {})",
                i.cycle
            );
            compared += 1;
            changed += u64::from(v[n] != 0);
        }
    }
    assert!(rec.issues.len() > 1000, "{}", rec.issues.len());
    assert!(
        changed > compared / 4,
        "{changed} of {compared} words non-zero"
    );
}

#[test]
fn traced_nodes_are_the_description_on_the_issued_samples() {
    check(Order::BackToFront, false, false, &["*"]);
    check(
        Order::FrontToBack,
        false,
        false,
        &["sample", "class.addr1", "comp.*", "m", "corrected"],
    );
}

#[test]
fn traced_unit_nodes_are_the_composed_description() {
    check(
        Order::BackToFront,
        true,
        true,
        &[
            "shade.norm*",
            "shade.gop*",
            "shade.fade*",
            "voi.*",
            "alpha",
            "acc_out.a",
        ],
    );
}

/// A pattern naming no node, and a pre-integrated frame, are refused in
/// one line before the frame runs.
#[test]
fn unknown_nodes_are_refused() {
    let s = subject("ml:24");
    let prep = view_from(&s.vol, [30.0, 20.0, -40.0], 8);
    let cfg = PipelineConfig {
        pes: 2,
        ..PipelineConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let Err(e) = FrameRun::new(&cfg, &s.lut, &s.vol, &prep.view)
        .trace(Tracer::new(TraceConfig::new(dir.path().join("x.vcd"))).unwrap())
        .trace_nodes(vec!["comp.*".into(), "no.such".into()])
        .run()
    else {
        panic!("an unknown node was not refused");
    };
    let e = e.to_string();
    assert!(e.contains("\"no.such\"") && !e.contains('\n'), "{e}");
}
