//! Helpers shared by the boundary passes' command tests
//! ([`crate::cosim_split`], [`crate::cosim_merge`], [`crate::cosim_fold`]): a pass's
//! co-simulation in both simulators and `ercube rtl` writing its module in
//! one order only.

use std::path::Path;

use serde_json::Value;

use crate::bin::{describe, ercube};
use crate::tools::have;

/// `s`'s words as arguments.
pub fn args(s: &str) -> Vec<String> {
    s.split_whitespace().map(String::from).collect()
}

/// `ercube cosim --stage <stage>` on `frame` in Icarus and Verilator
/// (each skipped when missing): 0 mismatches, at least one pass, the
/// clocks equal to the frame's cycles of the stage, child words compared,
/// no problem.
pub fn assert_matches_in_both_simulators(stage: &str, frame: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cache = d.join("cache");
    for (sim, tool) in [("iverilog", "iverilog"), ("verilator", "verilator")] {
        if !have(tool, tool, &format!("the {stage} cosim")) {
            continue;
        }
        let a = args(&format!(
            "cosim --stage {stage} {frame} --simulator {sim} --stats s.json --cache-dir {}",
            cache.display()
        ));
        let out = ercube(d, &a);
        let text = describe(&a, &out);
        assert!(out.status.success(), "{text}");
        let s: Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("s.json")).unwrap()).unwrap();
        assert_eq!(s["mismatches"], 0, "{text}");
        assert!(s["passes"].as_u64().unwrap() > 0, "{text}");
        assert_eq!(s["clocks"], s[format!("frame_{stage}_cycles")], "{text}");
        assert!(s["compared"]["child_words"].as_u64().unwrap() > 0, "{text}");
        assert!(s["problems"].as_array().unwrap().is_empty(), "{text}");
    }
}

/// `ercube rtl` in `d` writes `module` in order `yes` (listed and
/// declared) and not in order `no`, saying `refusal` in one line.
pub fn assert_rtl_writes_in_one_order(d: &Path, module: &str, yes: &str, no: &str, refusal: &str) {
    let a = args(&format!(
        "rtl --order {yes} --dims 16,16,16 --pes 2 --out-dir {yes}"
    ));
    let out = ercube(d, &a);
    assert!(out.status.success(), "{}", describe(&a, &out));
    let list = std::fs::read_to_string(d.join(format!("{yes}/filelist.f"))).unwrap();
    assert!(list.contains(&format!("{module}.v")), "{list}");
    let v = std::fs::read_to_string(d.join(format!("{yes}/{module}.v"))).unwrap();
    assert!(v.contains(&format!("module {module} (")), "{v}");
    let a = args(&format!(
        "rtl --order {no} --dims 16,16,16 --pes 2 --out-dir {no}"
    ));
    let out = ercube(d, &a);
    assert!(out.status.success(), "{}", describe(&a, &out));
    assert!(!d.join(format!("{no}/{module}.v")).exists());
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        said.contains(&format!("{module} not written: {refusal}")),
        "{said}"
    );
}
