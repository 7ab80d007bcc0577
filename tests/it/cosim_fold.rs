//! `ercube cosim --stage fold`: a front-to-back frame near the volume
//! (several regions) co-simulated in Icarus and Verilator with 0
//! mismatches, its stats naming the clocks and the writes compared (the
//! clocks are the frame's fold cycles); back to front, one region and the
//! sparse fold are refused in one line each. `ercube rtl` writes the
//! module front to back only. Without the simulators the tests print one
//! line and skip (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).

use crate::bin::{assert_refused, ercube};
use crate::cosim_pass::{args, assert_matches_in_both_simulators, assert_rtl_writes_in_one_order};
use crate::tools::have;

const FRAME: &str = "--scene ml:24 --eye=-6,12.2,10.2 --size 24x24 --pes 3 --order ftb";

#[test]
fn cosim_fold_matches_in_both_simulators() {
    assert_matches_in_both_simulators("fold", FRAME);
}

#[test]
fn cosim_fold_refuses_what_does_not_fold() {
    if !have("iverilog", "iverilog", "a fold cosim refusal") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = args("cosim --stage fold --scene ml:16 --size 8x8 --order btf --simulator iverilog");
    assert_refused(&a, &ercube(d, &a), "back to front has no fold");
    let a = args("cosim --stage fold --scene ml:16 --size 8x8 --order ftb --simulator iverilog");
    assert_refused(&a, &ercube(d, &a), "the frame has no fold");
    std::fs::write(d.join("sparse.toml"), "pass_skip_empty = true\n").unwrap();
    let a = args(&format!(
        "cosim --stage fold {FRAME} --config sparse.toml --simulator iverilog"
    ));
    assert_refused(&a, &ercube(d, &a), "the sparse fold");
}

#[test]
fn rtl_writes_the_fold_front_to_back_only() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    assert_rtl_writes_in_one_order(
        d,
        "ercube_pe_fold",
        "ftb",
        "btf",
        "back to front has no fold",
    );
    let readme = std::fs::read_to_string(d.join("ftb/README.md")).unwrap();
    assert!(
        readme.contains("## ercube_pe_fold: the PE's dense fold"),
        "{readme}"
    );
}
