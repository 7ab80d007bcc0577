//! `ercube cosim --stage merge`: a back-to-front frame near the volume
//! (several regions) co-simulated in Icarus and Verilator with 0
//! mismatches, its stats naming the clocks and the writes compared (the
//! clocks are the frame's merge cycles); front to back, one region and the
//! sparse merge are refused in one line each. `ercube rtl` writes the
//! module back to front only. Without the simulators the tests print one
//! line and skip (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).

use serde_json::Value;

use crate::bin::{assert_refused, describe, ercube};
use crate::tools::have;

const FRAME: &str = "--scene ml:24 --eye=-6,12.2,10.2 --size 24x24 --pes 3";

fn args(s: &str) -> Vec<String> {
    s.split_whitespace().map(String::from).collect()
}

#[test]
fn cosim_merge_matches_in_both_simulators() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cache = d.join("cache");
    for (sim, tool) in [("iverilog", "iverilog"), ("verilator", "verilator")] {
        if !have(tool, tool, "the merge cosim") {
            continue;
        }
        let a = args(&format!(
            "cosim --stage merge {FRAME} --simulator {sim} --stats s.json --cache-dir {}",
            cache.display()
        ));
        let out = ercube(d, &a);
        let text = describe(&a, &out);
        assert!(out.status.success(), "{text}");
        let s: Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("s.json")).unwrap()).unwrap();
        assert_eq!(s["mismatches"], 0, "{text}");
        assert!(s["passes"].as_u64().unwrap() > 0, "{text}");
        assert_eq!(s["clocks"], s["frame_merge_cycles"], "{text}");
        assert!(s["compared"]["child_words"].as_u64().unwrap() > 0, "{text}");
        assert!(s["problems"].as_array().unwrap().is_empty(), "{text}");
    }
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
    let a = args("rtl --dims 16,16,16 --pes 2 --out-dir btf");
    let out = ercube(d, &a);
    assert!(out.status.success(), "{}", describe(&a, &out));
    let list = std::fs::read_to_string(d.join("btf/filelist.f")).unwrap();
    assert!(list.contains("ercube_pe_merge.v"), "{list}");
    let v = std::fs::read_to_string(d.join("btf/ercube_pe_merge.v")).unwrap();
    assert!(v.contains("module ercube_pe_merge ("), "{v}");
    let readme = std::fs::read_to_string(d.join("btf/README.md")).unwrap();
    assert!(
        readme.contains("## ercube_pe_merge: the PE's dense merge"),
        "{readme}"
    );
    let a = args("rtl --order ftb --dims 16,16,16 --pes 2 --out-dir ftb");
    let out = ercube(d, &a);
    assert!(out.status.success(), "{}", describe(&a, &out));
    assert!(!d.join("ftb/ercube_pe_merge.v").exists());
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        said.contains("ercube_pe_merge not written: front to back has no merge"),
        "{said}"
    );
}
