//! The cocotb testbench (`python/cocotb`, cocotb 2.x in `target/pyvenv`)
//! in Icarus: the emitted `composite` (both orders) and `bilinear` units
//! match `ercube.Datapath` on 2000 random samples each; a copy of
//! `composite` with one sum made a difference fails at its first cycle,
//! naming the signal; `composite` behind `rst`, `in_valid` and
//! `out_valid` passes too. The whole pipelined datapath, `ercube_sample`
//! (`test_sample.py`), matches the model on 1000 random bundles with
//! bubbles in both orders, and a copy whose red compositing sum is made a
//! difference fails at its first differing cycle, naming `acc_out_r`.
//! In captured-frame mode (`test_frame.py`), two PEs' issue streams of a
//! window of a brainsmall frame (`ercube vectors`) replay into it with
//! every write-back equal to the model's, and the broken copy fails at the
//! first write-back it changes, naming the frame's cycle, the PE and
//! `acc_out_r`. Needs `iverilog` and cocotb (installed into the
//! environment when PyPI is reachable); skips with one line without them
//! unless `ERCUBE_REQUIRE_TOOLS=1`.

#[path = "../../../tests/support/mutate.rs"]
pub(super) mod mutate;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use pipeline::hw::unit::Unit;

use super::window::{self, FIRST};
use super::{installed, ok, root, skip, tools, with_bin, BRAIN};

/// The captured window's last cycle (`tests/support/window.rs`: the DPI-C
/// testbench's frame, `ffi/tests/c_abi/dpi_sample.rs`).
pub(super) const LAST: u64 = 302_000;

/// `run.py ARGS` in `dir`, in Icarus.
fn run(py: &Path, dir: &Path, args: &[&str]) -> Output {
    run_in(py, dir, "icarus", args)
}

/// `run.py ARGS --simulator SIM` in `dir`.
pub(super) fn run_in(py: &Path, dir: &Path, sim: &str, args: &[&str]) -> Output {
    Command::new(py)
        .env("PATH", with_bin(py.parent().unwrap()))
        .arg(root().join("python/cocotb/run.py"))
        .args(args)
        .args(["--simulator", sim, "--build-dir"])
        .arg(dir)
        .output()
        .unwrap()
}

pub(super) fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The environment's Python with the module and cocotb, or `None`
/// (skipped) without `iverilog` or cocotb.
fn cocotb_python(what: &str) -> Option<PathBuf> {
    if !tools::have("iverilog", "iverilog", what) {
        return None;
    }
    with_cocotb()
}

/// The environment's Python with the module and cocotb (installed into
/// it when PyPI is reachable), or `None` (skipped).
pub(super) fn with_cocotb() -> Option<PathBuf> {
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

#[test]
fn the_cocotb_testbench_replays_a_brainsmall_frame_and_fails_a_broken_copy() {
    let Some(py) = cocotb_python("the cocotb testbench of a captured frame") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vec = d.join("vec");
    window::capture(&root().join(BRAIN), LAST, &vec);
    let (n0, n3) = (window::issued(&vec, 0), window::issued(&vec, 3));
    assert!(n0 > 500 && n3 > 500, "PEs 0 and 3 issued {n0} and {n3}");
    let v = vec.to_str().unwrap();
    let o = run(&py, &d.join("pass"), &["--vectors", v, "--pes", "0,3"]);
    let t = text(&o);
    assert!(o.status.success(), "the frame's streams:\n{t}");
    assert!(
        t.contains(&format!("PE 0: {n0} samples match the model"))
            && t.contains(&format!("PE 3: {n3} samples match the model")),
        "PEs 0 and 3 issued {n0} and {n3}:\n{t}"
    );

    let verilog = std::fs::read_to_string(vec.join("ercube_sample.v")).unwrap();
    let (broken, line) = mutate::break_sum(&verilog, "n_comp_r_s").expect("the red sum");
    let file = d.join("broken.v");
    std::fs::write(&file, broken).unwrap();
    let args = [
        "--vectors",
        v,
        "--pes",
        "0,3",
        "--verilog",
        file.to_str().unwrap(),
        "--top",
        "ercube_sample",
    ];
    let o = run(&py, &d.join("broken"), &args);
    let t = text(&o);
    assert!(!o.status.success(), "the broken copy ({line}) passed:\n{t}");
    frame_mismatch_at_a_write_back(&t);
}

/// `t` (a run of the broken copy on the window's PEs 0 and 3) names its
/// first mismatch at a write-back of PE 0's inside the window: `acc_out_r`
/// at the issue cycle plus the depth.
pub(super) fn frame_mismatch_at_a_write_back(t: &str) {
    let key = "first mismatch at cycle ";
    let at = t
        .find(key)
        .unwrap_or_else(|| panic!("no mismatch named:\n{t}"));
    let rest = &t[at + key.len()..];
    let num = |s: &str| -> u64 {
        s.split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let cycle = num(rest);
    let from = num(&rest[rest.find("issued at cycle ").unwrap() + 16..]);
    assert!(
        rest.contains("(PE 0,") && rest.contains("acc_out_r: model"),
        "{t}"
    );
    assert!((FIRST..=LAST).contains(&from), "{t}");
    let depth = Unit::from_toml(None, None, "sample")
        .unwrap()
        .pipelined("ercube_sample")
        .unwrap()
        .depth;
    assert_eq!(cycle, from + u64::from(depth), "{t}");
}
