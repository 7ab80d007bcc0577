//! The cocotb testbench of one PE's sample stage (`python/cocotb/test_pe.py`,
//! `run.py --pe-vectors`) in Icarus: the files of `ercube vectors --stage
//! pe` (the middle PE of three, front to back with termination) drive the
//! emitted `ercube_pe_sample` with every output equal to the model's and
//! every issued sample's write-back equal to `ercube.Datapath.eval`'s; a
//! copy whose control clears two bits of the row plan a clock fails at its
//! first differing issue, naming the cycle and `iss_m` or `iss_valid`.
//! Skips with one line without `iverilog` or cocotb unless
//! `ERCUBE_REQUIRE_TOOLS=1`.

use std::process::ExitCode;

use super::cocotb::{run_in, text, with_cocotb};
use super::tools;

#[test]
fn the_cocotb_testbench_drives_a_pe_sample_stage_and_fails_a_broken_copy() {
    if !tools::have(
        "iverilog",
        "iverilog",
        "the cocotb testbench of the PE's sample stage",
    ) {
        return;
    }
    let Some(py) = with_cocotb() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vec = d.join("vec");
    let v = vec.to_str().unwrap();
    let argv = [
        "ercube",
        "vectors",
        "--stage",
        "pe",
        "--pe",
        "1",
        "--scene",
        "ml:16",
        "--pes",
        "3",
        "--size",
        "12x12",
        "--order",
        "ftb",
        "--out-dir",
        v,
    ];
    assert_eq!(ercube::cli::run_with(argv), ExitCode::SUCCESS);
    let man: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(vec.join("manifest.json")).unwrap()).unwrap();
    let samples = man["samples"].as_u64().unwrap();
    assert!(samples > 100, "{man}");
    let args = ["--pe-vectors", v, "--order", "ftb"];
    let o = run_in(&py, &d.join("pass"), "icarus", &args);
    let t = text(&o);
    assert!(o.status.success(), "the PE's vectors:\n{t}");
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
    let o = run_in(&py, &d.join("broken"), "icarus", &args);
    let t = text(&o);
    assert!(!o.status.success(), "the broken copy passed:\n{t}");
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
}
