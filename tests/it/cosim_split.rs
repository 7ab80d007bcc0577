//! `ercube cosim --stage split`: a front-to-back frame near the volume
//! (several regions) co-simulated in Icarus and Verilator with 0
//! mismatches, its stats naming the clocks and the writes compared (the
//! clocks are the frame's split cycles); back to front and one region are
//! refused in one line. `ercube rtl --order ftb` writes the module. Without
//! the simulators the tests print one line and skip
//! (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).

use serde_json::Value;

use crate::bin::{assert_refused, describe, ercube};
use crate::tools::have;

const FRAME: &str = "--scene ml:24 --eye=-6,12.2,10.2 --size 24x24 --pes 3 --order ftb";

fn args(s: &str) -> Vec<String> {
    s.split_whitespace().map(String::from).collect()
}

#[test]
fn cosim_split_matches_in_both_simulators() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cache = d.join("cache");
    for (sim, tool) in [("iverilog", "iverilog"), ("verilator", "verilator")] {
        if !have(tool, tool, "the split cosim") {
            continue;
        }
        let a = args(&format!(
            "cosim --stage split {FRAME} --simulator {sim} --stats s.json --cache-dir {}",
            cache.display()
        ));
        let out = ercube(d, &a);
        let text = describe(&a, &out);
        assert!(out.status.success(), "{text}");
        let s: Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("s.json")).unwrap()).unwrap();
        assert_eq!(s["mismatches"], 0, "{text}");
        assert!(s["passes"].as_u64().unwrap() > 0, "{text}");
        assert_eq!(s["clocks"], s["frame_split_cycles"], "{text}");
        assert!(s["compared"]["child_words"].as_u64().unwrap() > 0, "{text}");
        assert!(s["problems"].as_array().unwrap().is_empty(), "{text}");
    }
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
    let d = dir.path();
    let a = args("rtl --order ftb --dims 16,16,16 --pes 2 --out-dir ftb");
    let out = ercube(d, &a);
    assert!(out.status.success(), "{}", describe(&a, &out));
    let list = std::fs::read_to_string(d.join("ftb/filelist.f")).unwrap();
    assert!(list.contains("ercube_pe_split.v"), "{list}");
    let v = std::fs::read_to_string(d.join("ftb/ercube_pe_split.v")).unwrap();
    assert!(v.contains("module ercube_pe_split ("), "{v}");
    let a = args("rtl --order btf --dims 16,16,16 --pes 2 --out-dir btf");
    let out = ercube(d, &a);
    assert!(out.status.success(), "{}", describe(&a, &out));
    assert!(!d.join("btf/ercube_pe_split.v").exists());
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        said.contains("ercube_pe_split not written: back to front has no split"),
        "{said}"
    );
}
