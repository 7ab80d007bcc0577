//! `ercube cosim --preintegrate`: pre-integrated frames run in the model
//! and, replayed from its capture, in the emitted sample composed with the
//! pre-integration unit (`hw::compose`), every output of every cycle
//! compared, in both orders and both simulators; back to front slice 0's
//! second step (its half step after its whole one) through each PE's
//! second datapath; a mutated operator of the unit caught. The
//! configurations take a 64-entry classification table (65 x 65 words a
//! channel), so the host port loads the unit's banks in 17,927 clocks
//! instead of the default 257 x 257 table's 265,223. Without the
//! simulators the tests print one line and skip (`ERCUBE_REQUIRE_TOOLS=1`
//! makes that a failure).
//!
//! `cargo test --release --test it -- cosim_preint::`

use std::path::Path;

use serde_json::Value;

use crate::bin::{assert_refused, describe, ercube};
use crate::cosim::{cache, passes, run};
use crate::tools::have;

/// A configuration with a 64-entry table, in `dir`.
fn small_table(dir: &Path) -> &'static str {
    std::fs::write(dir.join("t64.toml"), "table_entries = 64\n").unwrap();
    "t64.toml"
}

/// A passing pre-integrated cosim of `frame`: every sample and, back to
/// front, every second step compared, the model's latency the module's
/// depth, every cycle simulated; the cycles and samples those of `ercube
/// render` for the same frame. Returns the stats.
#[track_caller]
fn preint_passes(d: &Path, frame: &str, sim: &str, btf: bool) -> Value {
    let cfg = small_table(d);
    let frame = format!("{frame} --preintegrate --config {cfg}");
    let order = if btf { "" } else { " --order ftb" };
    let s = passes(d, &format!("{frame}{order} {sim}"));
    assert_eq!(s["model_latency"], s["rtl_depth"], "{frame}");
    assert_eq!(
        s["cycles"], s["frame_cycles"],
        "{frame}: every cycle simulated"
    );
    let second = s["second_steps_compared"].as_u64().unwrap();
    if btf {
        // Slice 0's rays take their half step after their whole one.
        assert!(second > 0, "{frame}: no second step compared");
        let lanes = s["per_pe"].as_array().unwrap();
        assert_eq!(lanes.len(), 2 * s["pes"].as_u64().unwrap() as usize);
    } else {
        assert_eq!(second, 0, "{frame}");
    }
    let (a, out) = run(
        d,
        &format!(
            "render {frame} --method {} --no-golden-twin --out r.png --stats r.json",
            if btf { "pipeline" } else { "pipeline-ftb" }
        ),
    );
    assert!(out.status.success(), "{}", describe(&a, &out));
    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(s["frame_cycles"], r["cycles"], "{frame}");
    assert_eq!(s["samples"], r["samples_total"], "{frame}");
    s
}

/// Both orders in Icarus on 2 PEs (front to back with termination): 0
/// mismatches.
#[test]
fn preintegrated_frames_match_the_model_in_icarus() {
    if !have("iverilog", "iverilog", "the pre-integrated cosim in Icarus") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let frame = "--scene ml:16 --size 12x12 --pes 2";
    for btf in [true, false] {
        preint_passes(d, frame, "--simulator iverilog", btf);
    }
}

/// Both orders in Verilator on 3 PEs, another scene and eye: 0
/// mismatches.
#[test]
fn preintegrated_frames_match_the_model_in_verilator() {
    if !have(
        "verilator",
        "verilator",
        "the pre-integrated cosim in Verilator",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let frame = "--scene sphere:16 --size 12x12 --pes 3 --eye 30,20,-40";
    for btf in [true, false] {
        preint_passes(d, frame, "", btf);
    }
}

/// One operator of the pre-integration unit inside the composed sample
/// (the even bank's table address `base + j`, `n_pre_even_a0`, as `ercube
/// rtl --preint` writes the module) turned from `+` into `-`: cosim exits
/// 1 naming the first differing cycle, PE and accumulator with both words.
#[test]
fn a_mutated_preint_operator_is_caught() {
    if !have(
        "iverilog",
        "iverilog",
        "the pre-integrated cosim mutation test",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cfg = small_table(d);
    let (a, out) = run(d, &format!("rtl --out-dir r --preint --config {cfg}"));
    assert!(out.status.success(), "{}", describe(&a, &out));
    let v = std::fs::read_to_string(d.join("r/ercube_sample_preint.v")).unwrap();
    let v = v.replace("module ercube_sample_preint", "module ercube_sample");
    let (broken, line) = crate::mutate::break_sum(&v, "n_pre_even_a0").expect("the address sum");
    std::fs::write(d.join("broken.v"), broken).unwrap();
    let args = format!(
        "cosim --scene ml:16 --size 12x12 --pes 2 --preintegrate --config {cfg} --simulator iverilog --verilog broken.v --cache-dir {}",
        cache().display()
    );
    crate::cosim::assert_caught_at_an_output(d, &args, &line);
}

/// The exact colouring's depth layers are not described: refused in one
/// line before any simulator runs.
#[test]
fn the_exact_colouring_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let args: Vec<String> =
        "cosim --simulator iverilog --scene ml:16 --size 8x8 --preintegrate --pre-colouring exact"
            .split_whitespace()
            .map(String::from)
            .collect();
    if !have("iverilog", "iverilog", "a cosim refusal") {
        return;
    }
    assert_refused(&args, &ercube(dir.path(), &args), "fast colouring only");
}
