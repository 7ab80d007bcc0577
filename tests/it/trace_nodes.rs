//! `ercube render --trace-nodes` against the emitted datapath: the model's
//! waveform of a few named nodes of the description (`top.pe_K.hw.<node>`)
//! and the same frame's datapath co-simulation in Icarus (`ercube cosim
//! --vcd`, every PE's emitted module replaying its captured issues) carry
//! the same word on every cycle in which a valid sample occupies the
//! node's stage (`valid_d<s>` of the module): the pipelined module's wire
//! `n_<node>` and the model's trace, cycle for cycle. A bad pattern is a
//! one-line error. Without Icarus the comparison prints one line and skips
//! (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).

use std::path::PathBuf;

use pipeline::config::PipelineConfig;
use waves::Trace;

use crate::bin::{assert_refused, describe, ercube};
use crate::tools::have;

/// The nodes compared: a declared register, an interpolation lerp, a
/// table address, the classified opacity, the corrected opacity, a
/// compositing product and an accumulator's select.
const NODES: [&str; 7] = [
    "m",
    "bilinear.top",
    "class.addr1",
    "alpha",
    "corrected",
    "comp.r.p",
    "acc_out.a",
];

#[test]
fn traced_nodes_are_the_emitted_modules_wires() {
    if !have("iverilog", "iverilog", "the traced nodes against Icarus") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The model writes back after the emitted module's depth, as a
    // cycle-for-cycle replay needs.
    std::fs::write(d.join("n.toml"), "datapath_latency = 35\npes = 3\n").unwrap();
    let frame = [
        "--scene",
        "sphere:24",
        "--size",
        "16x16",
        "--config",
        "n.toml",
    ];
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cosim-cache");
    let mut args: Vec<String> = ["render", "--method", "pipeline", "--out", "r.png"]
        .iter()
        .chain(&frame)
        .map(|s| (*s).to_owned())
        .collect();
    args.extend([
        "--vcd".into(),
        "m.vcd".into(),
        "--trace-nodes".into(),
        NODES.join(","),
    ]);
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let mut args: Vec<String> = ["cosim", "--simulator", "iverilog", "--vcd", "rtl.vcd"]
        .iter()
        .chain(&frame)
        .map(|s| (*s).to_owned())
        .collect();
    args.extend(["--cache-dir".into(), cache.display().to_string()]);
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));

    let model = Trace::read(d.join("m.vcd")).unwrap();
    let rtl = Trace::read(d.join("rtl.vcd")).unwrap();
    let cfg = PipelineConfig {
        pes: 3,
        ..PipelineConfig::default()
    };
    let g = pipeline::hw::sample::plain(&cfg);
    let sch = pipeline::cost::latency::graph_schedule(&cfg, &g);
    // Cycle `c` of the replay lasts while the top's `cyc` holds `c`: its
    // words are those just before `cyc` turns `c + 1`.
    let cyc = rtl.signal("ercube_cosim.cyc").expect("the top's cycle");
    let ends: Vec<(u64, u64)> = cyc
        .changes()
        .windows(2)
        .filter_map(|w| Some((w[0].value.as_u64()?, w[1].time - 1)))
        .collect();
    assert!(ends.len() > 500, "{} cycles", ends.len());
    let mut compared = 0u64;
    let mut nonzero = 0u64;
    for pe in 0..3 {
        for name in NODES {
            let id = g.find(name).unwrap();
            let s = sch.stage[id.0];
            let v = pipeline::hw::pipeline_rtl::verilog_name(name);
            let mine = model
                .signal(&format!("top.pe_{pe}.hw.{v}"))
                .unwrap_or_else(|| panic!("model: {v}"));
            let wire = rtl
                .signal(&format!("ercube_cosim.pe{pe}.dut.n_{v}"))
                .unwrap_or_else(|| panic!("rtl: n_{v}"));
            let valid = match s {
                0 => "in_valid".to_owned(),
                s => format!("valid_d{s}"),
            };
            let valid = rtl
                .signal(&format!("ercube_cosim.pe{pe}.dut.{valid}"))
                .unwrap_or_else(|| panic!("rtl: {valid}"));
            for &(c, t) in &ends {
                if valid.value_at_time(t).and_then(|x| x.as_u64()) != Some(1) {
                    continue;
                }
                let have = wire.value_at_time(t).and_then(|x| x.as_u64());
                let want = mine.u64_at_cycle(c);
                assert_eq!(
                    have, want,
                    "PE {pe}, {name} (stage {s}) in cycle {c}: RTL against the model"
                );
                compared += 1;
                nonzero += u64::from(want != Some(0));
            }
        }
    }
    assert!(compared > 1000, "{compared} words compared");
    assert!(nonzero > compared / 4, "{nonzero} of {compared} non-zero");
}

#[test]
fn an_unknown_node_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let args: Vec<String> = "render --scene sphere:16 --size 12x12 --method pipeline --pes 2 --vcd w.vcd --trace-nodes comp.*,no.such --out p.png"
        .split_whitespace()
        .map(String::from)
        .collect();
    let out = ercube(dir.path(), &args);
    assert_refused(&args, &out, "\"no.such\"");
}
