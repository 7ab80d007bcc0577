//! The DPI-C scoreboard testbench in Verilator (`ffi/sv/`): the emitted
//! `composite` and `bilinear` units match the model through DPI-C on
//! random stimulus; a copy of `composite` with one sum made a difference
//! stops at its first differing cycle, naming the signal; `composite`
//! behind `rst`, `in_valid` and `out_valid` passes too. Needs
//! `verilator` (and `cc`); skips with one line without it unless
//! `ERCUBE_REQUIRE_TOOLS=1`.

#[path = "../../../tests/support/mutate.rs"]
pub(super) mod mutate;

use std::path::Path;
use std::process::{Command, Output};

use ercube_ffi::testbench::{testbench, WAIVER};
use pipeline::hw::unit::Unit;

use super::{tools, verilate_dpi};

const SAMPLES: u32 = 5000;

/// Builds the testbench of `verilog` (module `module`, unit `unit`) in
/// `dir` with Verilator and runs it.
fn verilate(dir: &Path, unit: &Unit, module: &str, verilog: &str) -> Output {
    let tb = testbench(unit, verilog, module, ("", "btf", "grey-ramp"), SAMPLES).unwrap();
    let exe = verilate_dpi(dir, &tb, &[("unit.vlt", WAIVER), ("unit.v", verilog)], &[]);
    Command::new(exe).output().unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

#[test]
fn the_dpi_testbench_passes_the_units_and_fails_a_broken_copy() {
    if !tools::have("verilator", "verilator", "the DPI-C testbench")
        || !tools::have("cc", "gcc", "the DPI-C testbench")
    {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for name in ["composite", "bilinear"] {
        let unit = Unit::from_toml(None, Some("btf"), name).unwrap();
        let module = format!("ercube_{name}");
        let v = unit.verilog(&module).unwrap();
        let out = verilate(&d.join(name), &unit, &module, &v);
        let t = text(&out);
        assert!(out.status.success(), "{name}:\n{t}");
        assert!(
            t.contains(&format!("ercube: {SAMPLES} samples match the model")),
            "{t}"
        );
        if name == "composite" {
            let (broken, line) = mutate::break_one_sum(&v).expect("a sum to break");
            let out = verilate(&d.join("broken"), &unit, &module, &broken);
            let t = text(&out);
            assert!(
                !out.status.success(),
                "the broken copy ({line}) passed:\n{t}"
            );
            assert!(
                t.contains("first mismatch at cycle") && t.contains("y_r: model"),
                "the broken sum is y_r's ({line}):\n{t}"
            );
            // The same unit behind rst, in_valid and out_valid.
            let ports: Vec<_> = unit
                .inputs()
                .iter()
                .map(|p| (p, true))
                .chain(unit.outputs().iter().map(|p| (p, false)))
                .map(|(p, i)| (p.name.clone(), p.word.bits, p.word.signed, i))
                .collect();
            let hs = mutate::with_handshake(&v, &module, "hs", &ports, unit.latency());
            let out = verilate(&d.join("handshake"), &unit, "hs", &hs);
            let t = text(&out);
            assert!(out.status.success(), "handshake:\n{t}");
            assert!(
                t.contains(&format!("ercube: {SAMPLES} samples match the model")),
                "{t}"
            );
        }
    }
}

#[test]
fn the_testbench_refuses_a_module_whose_ports_are_not_the_units() {
    let unit = Unit::from_toml(None, None, "composite").unwrap();
    let v = unit.verilog("m").unwrap();
    let cfg = ("", "", "grey-ramp");
    let renamed = v.replace("input [15:0] acc_r", "input [15:0] acc_x");
    let e = testbench(&unit, &renamed, "m", cfg, 10).unwrap_err();
    assert!(e.contains("no port acc_r"), "{e}");
    let narrow = v.replace("input [15:0] acc_r", "input [14:0] acc_r");
    let e = testbench(&unit, &narrow, "m", cfg, 10).unwrap_err();
    assert!(e.contains("acc_r is 15 bits"), "{e}");
    assert!(testbench(&unit, &v, "other", cfg, 10).is_err());
    let tb = testbench(&unit, &v, "m", cfg, 10).unwrap();
    assert!(tb.contains("m dut (.clk(clk), .acc_r(acc_r)"), "{tb}");
}
