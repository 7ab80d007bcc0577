//! `ercube cosim --stage split`: a front-to-back frame near the volume
//! (several regions) co-simulated in Icarus and Verilator with 0
//! mismatches, its stats naming the clocks and the writes compared (the
//! clocks are the frame's split cycles); back to front and one region are
//! refused in one line. `ercube rtl --order ftb` writes the module. Without
//! the simulators the tests print one line and skip
//! (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).

use crate::bin::{assert_refused, ercube};
use crate::cosim_pass::{args, assert_matches_in_both_simulators, assert_rtl_writes_in_one_order};
use crate::tools::have;

const FRAME: &str = "--scene ml:24 --eye=-6,12.2,10.2 --size 24x24 --pes 3 --order ftb";

#[test]
fn cosim_split_matches_in_both_simulators() {
    assert_matches_in_both_simulators("split", FRAME);
}

#[test]
fn cosim_split_refuses_what_does_not_split() {
    if !have("iverilog", "iverilog", "a split cosim refusal") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = args("cosim --stage split --scene ml:16 --size 8x8 --simulator iverilog");
    assert_refused(&a, &ercube(d, &a), "back to front has no split");
    let a = args("cosim --stage split --scene ml:16 --size 8x8 --order ftb --simulator iverilog");
    assert_refused(&a, &ercube(d, &a), "the frame has no split");
}

#[test]
fn rtl_writes_the_split_front_to_back_only() {
    let dir = tempfile::tempdir().unwrap();
    assert_rtl_writes_in_one_order(
        dir.path(),
        "ercube_pe_split",
        "ftb",
        "btf",
        "back to front has no split",
    );
}
