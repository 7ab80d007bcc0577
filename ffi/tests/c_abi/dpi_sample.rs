//! The DPI-C scoreboard testbench of the whole pipelined datapath,
//! `ercube_sample` as `ercube rtl` emits it, in Verilator
//! (`ercube_ffi::sample_testbench`): random bundles with bubbles, and two
//! PEs' captured issue streams of a brainsmall frame (`ercube vectors`),
//! match the model through DPI-C, every sample issued and checked; a copy
//! whose red compositing sum (`n_comp_r_s`) is made a difference stops at
//! its first differing cycle naming `acc_out_r`, on both stimuli. Needs
//! `verilator` (and `cc`); skips with one line without it unless
//! `ERCUBE_REQUIRE_TOOLS=1`.

use std::path::Path;
use std::process::{Command, Output};

use ercube_ffi::sample_testbench::sample_testbench;
use pipeline::hw::unit::Unit;

use super::dpi::mutate;
use super::window::{self, FIRST};
use super::{root, tools, verilate_dpi, BRAIN, UNOPTIMISED};

/// The captured window's last cycle (`tests/support/window.rs`).
const LAST: u64 = 306_000;

/// Builds the testbench of `verilog` (module `ercube_sample`) in `dir`
/// with Verilator, unoptimised (the runs are short; the C++ compile of the
/// 1700-line module dominates).
fn verilate(dir: &Path, tb: &str, verilog: &str) -> std::path::PathBuf {
    verilate_dpi(dir, tb, &[("unit.v", verilog)], &UNOPTIMISED)
}

fn run(exe: &Path, args: &[String]) -> (bool, String) {
    let o: Output = Command::new(exe).args(args).output().unwrap();
    let t = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), t)
}

#[test]
fn the_dpi_testbench_passes_ercube_sample_on_a_frame_and_fails_a_broken_copy() {
    if !tools::have(
        "verilator",
        "verilator",
        "the DPI-C testbench of ercube_sample",
    ) || !tools::have("cc", "gcc", "the DPI-C testbench of ercube_sample")
    {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vec = d.join("vec");
    window::capture(&root().join(BRAIN), LAST, &vec);

    let unit = Unit::from_toml(None, None, "sample").unwrap();
    let m = unit.pipelined("ercube_sample").unwrap();
    let cfg = ("", "", "grey-ramp");
    let tb = sample_testbench(&unit, &m, (&m.verilog, "ercube_sample"), cfg).unwrap();
    let random = vec!["+samples=5000".to_owned(), "+bubbles=30".to_owned()];
    let frame = |pe: usize| {
        vec![
            format!("+vectors={}", vec.display()),
            format!("+pe={pe}"),
            format!("+first={FIRST}"),
        ]
    };

    let exe = verilate(&d.join("pass"), &tb, &m.verilog);
    let (ok, t) = run(&exe, &random);
    assert!(ok, "random:\n{t}");
    assert!(t.contains("ercube: 5000 samples match the model"), "{t}");
    for pe in [0, 3] {
        let n = window::issued(&vec, pe);
        assert!(n > 1000, "pe {pe} issued {n} samples in the window");
        let (ok, t) = run(&exe, &frame(pe));
        assert!(ok, "pe {pe}:\n{t}");
        assert!(
            t.contains(&format!("ercube: {n} samples match the model")),
            "pe {pe} issued {n}:\n{t}"
        );
    }

    let (broken, line) = mutate::break_sum(&m.verilog, "n_comp_r_s").expect("the red sum");
    let exe = verilate(&d.join("broken"), &tb, &broken);
    for args in [random, frame(0)] {
        let (ok, t) = run(&exe, &args);
        assert!(!ok, "the broken copy ({line}) passed {args:?}:\n{t}");
        assert!(
            t.contains("ercube: first mismatch at cycle") && t.contains("acc_out_r: model"),
            "the broken sum is acc_out_r's ({line}), {args:?}:\n{t}"
        );
    }
    // The frame's first mismatch is inside the window, at a sample's
    // write-back: its issue cycle plus the depth.
    let (_, t) = run(&exe, &frame(0));
    let at = |key: &str| -> u64 {
        let s = &t[t.find(key).unwrap() + key.len()..];
        s.split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let (cycle, from) = (at("mismatch at cycle "), at("issued at cycle "));
    assert!((FIRST..=LAST).contains(&from), "{t}");
    assert_eq!(cycle, from + u64::from(m.depth), "{t}");
}

#[test]
fn the_sample_testbench_refuses_a_module_whose_ports_are_not_ercube_samples() {
    let unit = Unit::from_toml(None, None, "sample").unwrap();
    let m = unit.pipelined("ercube_sample").unwrap();
    let v = &m.verilog;
    let cfg = ("", "", "grey-ramp");
    let tb = |text: &str| sample_testbench(&unit, &m, (text, "ercube_sample"), cfg);
    let renamed = v.replace("input wire [15:0] acc_r", "input wire [15:0] acc_x");
    assert_ne!(&renamed, v);
    assert!(tb(&renamed).unwrap_err().contains("no port acc_r"));
    let narrow = v.replace("input wire [15:0] acc_r", "input wire [14:0] acc_r");
    assert!(tb(&narrow).unwrap_err().contains("acc_r is 15 bits"));
    assert!(sample_testbench(&unit, &m, (v, "other"), cfg).is_err());
    let cut = Unit::from_toml(None, None, "composite").unwrap();
    assert!(sample_testbench(&cut, &m, (v, "ercube_sample"), cfg).is_err());
    assert!(cut.pipelined("m").is_err(), "a cut has no pipelined module");
    let t = tb(v).unwrap();
    assert!(t.contains("ercube_sample dut (.clk(clk), .rst(rst)"), "{t}");
    assert!(t.contains(&format!("localparam int DEPTH = {};", m.depth)));
}
