//! The cocotb testbench (`python/cocotb`, cocotb 2.x in `target/pyvenv`)
//! in Icarus: the emitted `composite` (both orders) and `bilinear` units
//! match `ercube.Datapath` on 2000 random samples each; a copy of
//! `composite` with one sum made a difference fails at its first cycle,
//! naming the signal; `composite` behind `rst`, `in_valid` and
//! `out_valid` passes too. The whole pipelined datapath, `ercube_sample`
//! (`test_sample.py`), matches the model on 1000 random bundles with
//! bubbles in both orders, and a copy whose red compositing sum is made a
//! difference fails at its first differing cycle, naming `acc_out_r`. Needs `iverilog` and cocotb (installed into the
//! environment when PyPI is reachable); skips with one line without them
//! unless `ERCUBE_REQUIRE_TOOLS=1`.

#[path = "../../../tests/support/mutate.rs"]
mod mutate;

use std::path::Path;
use std::process::{Command, Output};

use pipeline::hw::unit::Unit;

use super::{installed, ok, root, skip, tools, with_bin};

/// `run.py ARGS` in `dir`.
fn run(py: &Path, dir: &Path, args: &[&str]) -> Output {
    Command::new(py)
        .env("PATH", with_bin(py.parent().unwrap()))
        .arg(root().join("python/cocotb/run.py"))
        .args(args)
        .arg("--build-dir")
        .arg(dir)
        .output()
        .unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The environment's Python with the module and cocotb, or `None`
/// (skipped) without `iverilog` or cocotb.
fn cocotb_python(what: &str) -> Option<std::path::PathBuf> {
    if !tools::have("iverilog", "iverilog", what) {
        return None;
    }
    let py = installed()?;
    let has = |py: &Path| ok(Command::new(py).args(["-c", "import cocotb_tools.runner"]));
    if !has(&py) {
        let pip = py.parent().unwrap().join("pip");
        if !ok(Command::new(pip).args(["install", "-q", "cocotb>=2,<3"])) || !has(&py) {
            skip("cocotb cannot be installed into target/pyvenv");
            return None;
        }
    }
    Some(py)
}

#[test]
fn the_cocotb_testbench_passes_ercube_sample_and_fails_a_broken_copy() {
    let Some(py) = cocotb_python("the cocotb testbench of ercube_sample") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for order in ["btf", "ftb"] {
        let o = run(
            &py,
            &d.join(order),
            &["--unit", "sample", "--order", order, "--samples", "1000"],
        );
        let t = text(&o);
        assert!(o.status.success(), "sample {order}:\n{t}");
        assert!(t.contains("ercube: 1000 samples match the model"), "{t}");
    }
    let unit = Unit::from_toml(None, Some("btf"), "sample").unwrap();
    let m = unit.pipelined("ercube_sample").unwrap();
    let (broken, line) = mutate::break_sum(&m.verilog, "n_comp_r_s").expect("the red sum");
    let file = d.join("broken.v");
    std::fs::write(&file, broken).unwrap();
    let o = run(
        &py,
        &d.join("broken"),
        &[
            "--unit",
            "sample",
            "--samples",
            "1000",
            "--verilog",
            file.to_str().unwrap(),
            "--top",
            "ercube_sample",
        ],
    );
    let t = text(&o);
    assert!(!o.status.success(), "the broken copy ({line}) passed:\n{t}");
    assert!(
        t.contains("first mismatch at cycle") && t.contains("acc_out_r: model"),
        "the broken sum is acc_out_r's ({line}):\n{t}"
    );
}

#[test]
fn the_cocotb_testbench_passes_the_units_and_fails_a_broken_copy() {
    let Some(py) = cocotb_python("the cocotb testbench") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (i, (unit, order)) in [
        ("composite", "btf"),
        ("composite", "ftb"),
        ("bilinear", "btf"),
    ]
    .into_iter()
    .enumerate()
    {
        let o = run(
            &py,
            &d.join(format!("pass{i}")),
            &["--unit", unit, "--order", order],
        );
        let t = text(&o);
        assert!(o.status.success(), "{unit} {order}:\n{t}");
        assert!(t.contains("2000 samples match the model"), "{t}");
    }

    let unit = Unit::from_toml(None, Some("btf"), "composite").unwrap();
    let v = unit.verilog("ercube_composite").unwrap();
    // The unit behind rst, in_valid and out_valid.
    let ports: Vec<_> = unit
        .inputs()
        .iter()
        .map(|p| (p, true))
        .chain(unit.outputs().iter().map(|p| (p, false)))
        .map(|(p, i)| (p.name.clone(), p.word.bits, p.word.signed, i))
        .collect();
    let hs = mutate::with_handshake(&v, "ercube_composite", "hs", &ports, unit.latency());
    let file = d.join("hs.v");
    std::fs::write(&file, hs).unwrap();
    let o = run(
        &py,
        &d.join("handshake"),
        &[
            "--unit",
            "composite",
            "--verilog",
            file.to_str().unwrap(),
            "--top",
            "hs",
        ],
    );
    let t = text(&o);
    assert!(o.status.success(), "handshake:\n{t}");
    assert!(t.contains("2000 samples match the model"), "{t}");

    let (broken, line) = mutate::break_one_sum(&v).expect("a sum to break");
    let file = d.join("broken.v");
    std::fs::write(&file, broken).unwrap();
    let o = run(
        &py,
        &d.join("broken"),
        &[
            "--unit",
            "composite",
            "--verilog",
            file.to_str().unwrap(),
            "--top",
            "ercube_composite",
        ],
    );
    let t = text(&o);
    assert!(!o.status.success(), "the broken copy ({line}) passed:\n{t}");
    assert!(t.contains("first mismatch at cycle"), "{t}");
    assert!(
        t.contains("y_r: model"),
        "the broken sum is y_r's ({line}):\n{t}"
    );
}
