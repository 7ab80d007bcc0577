//! `ercube cosim --stage merge`: a back-to-front frame near the volume
//! (several regions) co-simulated in Icarus and Verilator with 0
//! mismatches, its stats naming the clocks and the writes compared (the
//! clocks are the frame's merge cycles); front to back, one region and the
//! sparse merge are refused in one line each. `ercube rtl` writes the
//! module back to front only. Without the simulators the tests print one
//! line and skip (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).

use crate::bin::{assert_refused, ercube};
use crate::cosim_pass::{args, assert_matches_in_both_simulators, assert_rtl_writes_in_one_order};
use crate::tools::have;

const FRAME: &str = "--scene ml:24 --eye=-6,12.2,10.2 --size 24x24 --pes 3";

#[test]
fn cosim_merge_matches_in_both_simulators() {
    assert_matches_in_both_simulators("merge", FRAME);
}

#[test]
fn cosim_merge_refuses_what_does_not_merge() {
    if !have("iverilog", "iverilog", "a merge cosim refusal") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = args("cosim --stage merge --scene ml:16 --size 8x8 --order ftb --simulator iverilog");
    assert_refused(&a, &ercube(d, &a), "front to back has no merge");
    let a = args("cosim --stage merge --scene ml:16 --size 8x8 --simulator iverilog");
    assert_refused(&a, &ercube(d, &a), "the frame has no merge");
    std::fs::write(d.join("sparse.toml"), "pass_skip_empty = true\n").unwrap();
    let a = args(&format!(
        "cosim --stage merge {FRAME} --config sparse.toml --simulator iverilog"
    ));
    assert_refused(&a, &ercube(d, &a), "the sparse merge");
}

#[test]
fn rtl_writes_the_merge_back_to_front_only() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    assert_rtl_writes_in_one_order(
        d,
        "ercube_pe_merge",
        "btf",
        "ftb",
        "front to back has no merge",
    );
    let readme = std::fs::read_to_string(d.join("btf/README.md")).unwrap();
    assert!(
        readme.contains("## ercube_pe_merge: the PE's dense merge"),
        "{readme}"
    );
}
