//! `ercube vectors --stage pe`: one PE's sample stage over a frame as
//! `$readmemh` files, replayed by the plain testbench against the emitted
//! `ercube_pe_sample` in Icarus with no mismatch, under column blocks and
//! the round-robin mappings; a copy of the module whose control skips a
//! ray, or whose column decoder misreads a tap column, fails naming the
//! cycle and the signal. Without
//! Icarus the test prints one line and skips (`ERCUBE_REQUIRE_TOOLS=1`
//! makes that a failure).
//!
//! `cargo test --release --test it -- pe_vectors::` (about 20 s).

use std::path::Path;

use serde_json::Value;

use crate::bin::{assert_refused, describe, ercube};
use crate::round_robin::{break_decoder, config, vectors_args, COLUMNS, FRAMES};
use crate::tools::have;

/// Runs `ercube` with whitespace-separated `args` in `dir`.
fn run(dir: &Path, args: &str) -> std::process::Output {
    let args: Vec<String> = args.split_whitespace().map(String::from).collect();
    let out = ercube(dir, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    out
}

/// Builds `files` (the testbench last) in `dir` with Icarus and runs
/// them; the testbench's output. Shared with the datapath's vectors
/// (`cosim.rs`).
pub(crate) fn replay(dir: &Path, files: &[&str]) -> String {
    let c = std::process::Command::new("iverilog")
        .args(["-g2005", "-o", "tb.vvp"])
        .args(files)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
    let r = std::process::Command::new("vvp")
        .args(["-n", "tb.vvp"])
        .current_dir(dir)
        .output()
        .unwrap();
    String::from_utf8_lossy(&r.stdout).into_owned()
}

/// The checks a passing replay's output counts (`vectors: 0 mismatches
/// in N ...`); fails when it reports mismatches.
pub(crate) fn passed_checks(out: &str) -> u64 {
    assert!(out.contains("vectors: 0 mismatches in "), "{out}");
    out.split("mismatches in ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap()
}

/// Manifest entry `f`'s file in `dir` has `rows` words, none wider than
/// its port. Shared with the datapath's vectors (`cosim.rs`).
pub(crate) fn assert_rows_fit(dir: &Path, f: &serde_json::Value, rows: u64) {
    let text = std::fs::read_to_string(dir.join(f["path"].as_str().unwrap())).unwrap();
    assert_eq!(text.lines().count() as u64, rows, "{f}");
    let width = f["width"].as_u64().unwrap();
    assert!(
        text.lines()
            .all(|l| u128::from_str_radix(l, 16).unwrap() >> width == 0),
        "{f}: a word wider than its port"
    );
}

/// The PE stage's files in the order Icarus builds them.
const PE_FILES: [&str; 3] = ["ercube_sample.v", "ercube_pe_sample.v", "pe_vectors_tb.v"];

/// The middle PE of three, front to back with termination and the
/// controller's empty-space skipping (the default): its broadcast, plan
/// port, held range, right neighbour's edge register, slice loads, buffer
/// words and termination bits written from outside the stage replay with
/// 0 mismatches, every issue, tap and write-back checked; the manifest
/// names every file's signal, width and rows; a control that clears two
/// bits of the row plan a clock is caught at its first differing issue.
#[test]
fn pe_vectors_replay_in_icarus() {
    if !have("iverilog", "iverilog", "the PE's vectors replay") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = run(
        d,
        "vectors --stage pe --pe 1 --scene ml:16 --pes 3 --size 12x12 --order ftb --out-dir v",
    );
    let v = d.join("v");
    let m: Value =
        serde_json::from_str(&std::fs::read_to_string(v.join("manifest.json")).unwrap()).unwrap();
    let rows = m["rows"].as_u64().unwrap();
    let samples = m["samples"].as_u64().unwrap();
    assert!(samples > 100 && rows > samples, "{m}");
    assert!(
        m["samples_all_pes"].as_u64().unwrap() > samples,
        "PE 1 is one of three"
    );
    let files = m["files"].as_array().unwrap();
    let signal = |n: &str| files.iter().find(|f| f["signal"] == n);
    for n in [
        "bc_go",
        "bc_a",
        "pl_valid",
        "pl_lo",
        "map_we",
        "edge_in",
        "iss_valid",
        "iss_m",
        "tap_v01",
        "wb_valid",
        "wb_data",
    ] {
        assert!(signal(n).is_some(), "{n} in the manifest");
    }
    for f in files {
        assert_rows_fit(&v, f, rows);
    }
    let ones = |n: &str| {
        std::fs::read_to_string(v.join(format!("pe1_{n}.hex")))
            .unwrap()
            .lines()
            .filter(|l| *l == "1")
            .count() as u64
    };
    assert_eq!(ones("iss_valid"), samples);
    assert_eq!(ones("wb_valid"), samples);
    assert!(ones("pl_valid") > 0, "runs on the plan port");
    let edge = std::fs::read_to_string(v.join("pe1_edge_in.hex")).unwrap();
    assert!(
        edge.lines().any(|l| l != "0"),
        "the right neighbour's edge words"
    );
    // The writes: slice loads, buffer words and termination bits.
    let writes = std::fs::read_to_string(v.join("pe1_writes.hex")).unwrap();
    for mem in ['0', '2', '4', '6'] {
        assert!(
            writes.lines().any(|l| l.chars().nth(8) == Some(mem)),
            "a write into memory {mem}"
        );
    }
    let good = replay(&v, &PE_FILES);
    let checks = passed_checks(&good);
    assert!(checks > 3 * samples + 2 * rows, "{good}");
    println!("{}{good}", String::from_utf8_lossy(&out.stdout));
    // Each clock clears the issued bit and the one above it.
    let path = v.join("ercube_pe_sample.v");
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("rem <= row_bits & ~one;"));
    std::fs::write(
        &path,
        text.replace(
            "rem <= row_bits & ~one;",
            "rem <= row_bits & ~one & ~(one << 1);",
        ),
    )
    .unwrap();
    let bad = replay(&v, &PE_FILES);
    let line = bad
        .lines()
        .find(|l| l.starts_with("MISMATCH cycle "))
        .unwrap_or_else(|| panic!("the broken copy fails: {bad}"));
    let cycle: u64 = line["MISMATCH cycle ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(cycle < rows, "{line}");
    assert!(
        line.contains(" pe 1 iss_m expected ") || line.contains(" pe 1 iss_valid expected "),
        "{line}"
    );
    assert!(!bad.contains(" 0 mismatches"), "{bad}");
    println!("broken copy: {line}");
}

/// The middle PE of three under the interleave (overlapped migration,
/// two lanes) and the cyclic mapping: the column map's entries and the
/// column decoder are memory writes (`cm_mx`, `cm_sl`, `loc`) beside the
/// slice loads and buffer words, and the files replay with 0 mismatches,
/// every issue of the PE checked; a copy whose column decoder reads the
/// right tap column at the left one's index is caught at a tap.
#[test]
fn pe_vectors_replay_round_robin_mappings_in_icarus() {
    if !have("iverilog", "iverilog", "the PE's vectors replay") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, toml, frame) in FRAMES {
        let v = d.join(name);
        let args = vectors_args(frame, &config(d, name, toml), &v);
        let out = ercube(d, &args);
        assert!(out.status.success(), "{}", describe(&args, &out));
        let m: Value =
            serde_json::from_str(&std::fs::read_to_string(v.join("manifest.json")).unwrap())
                .unwrap();
        assert_eq!(m["mapping"], name);
        let mems = m["writes"]["mem"].as_array().unwrap();
        let code = |n: &str| mems.iter().position(|m| m == n).unwrap();
        let writes = std::fs::read_to_string(v.join("pe1_writes.hex")).unwrap();
        let count = |n: &str| {
            let c = format!("{:x}", code(n));
            writes.lines().filter(|l| l[8..9] == c).count()
        };
        // The decoder: one entry a volume column.
        assert_eq!(count("loc"), COLUMNS, "{name}");
        assert!(count("cm_mx") > 0, "{name}: the column map's entries");
        assert_eq!(count("cm_mx"), count("cm_sl"), "{name}");
        let rows = m["rows"].as_u64().unwrap();
        for f in m["files"].as_array().unwrap() {
            assert_rows_fit(&v, f, rows);
        }
        let samples = m["samples"].as_u64().unwrap();
        assert!(samples > 100, "{name}: {m}");
        let good = replay(&v, &PE_FILES);
        let checks = passed_checks(&good);
        assert!(checks > 3 * samples + 2 * rows, "{name}: {good}");
        println!("{name}: {good}");
        let path = v.join("ercube_pe_sample.v");
        let text = std::fs::read_to_string(&path).unwrap();
        let broken = break_decoder(&text).expect("the column decoder");
        std::fs::write(&path, broken).unwrap();
        let bad = replay(&v, &PE_FILES);
        let line = bad
            .lines()
            .find(|l| l.starts_with("MISMATCH cycle "))
            .unwrap_or_else(|| panic!("{name}: the broken copy fails: {bad}"));
        assert!(line.contains(" pe 1 tap_v"), "{name}: {line}");
        println!("{name}, broken decoder: {line}");
    }
}

/// Refused in one line: a PE the frame lacks, `--cycles` with the PE's
/// stage, `--pe` without it.
#[test]
fn pe_vectors_refusals() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (args, needle) in [
        (
            "vectors --stage pe --pe 2 --scene ml:16 --pes 2 --size 8x8 --out-dir v",
            "--pe 2",
        ),
        (
            "vectors --stage pe --cycles 1-10 --scene ml:16 --pes 2 --size 8x8 --out-dir v",
            "--cycles",
        ),
        (
            "vectors --pe 1 --scene ml:16 --pes 2 --size 8x8 --out-dir v",
            "--stage pe",
        ),
    ] {
        let args: Vec<String> = args.split_whitespace().map(String::from).collect();
        assert_refused(&args, &ercube(d, &args), needle);
    }
    assert!(!d.join("v").exists(), "a refused run leaves nothing");
}
