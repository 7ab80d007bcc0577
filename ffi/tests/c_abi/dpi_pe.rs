//! The DPI-C scoreboard testbench of one PE's sample stage,
//! `ercube_pe_sample`, in Verilator (`ercube_ffi::pe_testbench`): the
//! files of `ercube vectors --stage pe` (the middle PE of three, front to
//! back with termination) drive the emitted module, whose issue, tap and
//! write-back stream equals the files' every clock and whose every
//! write-back equals the model's datapath through DPI-C on the bundle the
//! module issued. A copy whose control clears two bits of the row plan a
//! clock stops at its first differing issue; a copy whose datapath's red
//! compositing sum is a difference stops at its first write-back, named
//! by the DPI-C scoreboard (`acc_out_r`, the issue cycle plus the depth).
//! Under the round-robin mappings the column map and decoder are memory
//! writes among the files, and a copy with a broken column decoder stops
//! at its first differing tap.
//! Needs `verilator` (and `cc`); skips with one line without it unless
//! `ERCUBE_REQUIRE_TOOLS=1`.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use ercube_ffi::pe_testbench::pe_testbench;
use pipeline::hw::unit::Unit;
use serde_json::Value;

use super::dpi::mutate;
use super::{round_robin, tools, verilate_dpi, UNOPTIMISED};

/// The frame: PE 1 of 3, `ml:16`, 12x12, front to back.
fn vectors(dir: &Path) -> Value {
    let v = dir.to_str().unwrap();
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
    serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap()
}

/// Builds the testbench around `datapath` and `pe` (the two modules'
/// texts) in `dir` with Verilator, unoptimised (the runs are short).
fn verilate(dir: &Path, tb: &str, datapath: &str, pe: &str) -> PathBuf {
    verilate_dpi(
        dir,
        tb,
        &[("ercube_sample.v", datapath), ("ercube_pe_sample.v", pe)],
        &UNOPTIMISED,
    )
}

/// Runs the testbench on the files in `vec`: (passed, output).
fn run(exe: &Path, vec: &Path) -> (bool, String) {
    let o = Command::new(exe)
        .arg(format!("+vectors={}", vec.display()))
        .output()
        .unwrap();
    let t = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), t)
}

/// The checks the files call for: every row of an output checked every
/// clock, the rows of the rest where their valid is 1.
fn checks(vec: &Path, man: &Value) -> u64 {
    let rows = |name: &str| -> Vec<u64> {
        let p = vec.join(format!("pe1_{name}.hex"));
        std::fs::read_to_string(p)
            .unwrap()
            .split_whitespace()
            .map(|w| u64::from_str_radix(w, 16).unwrap())
            .collect()
    };
    let mut n = 0;
    for f in man["files"].as_array().unwrap() {
        if f["direction"] != "out" {
            continue;
        }
        let checked = f["checked"].as_str().unwrap();
        n += match checked
            .strip_prefix("where ")
            .and_then(|s| s.strip_suffix(" is 1"))
        {
            Some(valid) => rows(valid).iter().filter(|&&v| v == 1).count() as u64,
            None => f["rows"].as_u64().unwrap(),
        };
    }
    n
}

/// The number after `key` in `t`.
fn after(t: &str, key: &str) -> u64 {
    let at = t.find(key).unwrap_or_else(|| panic!("no '{key}' in:\n{t}"));
    t[at + key.len()..]
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn the_dpi_testbench_scores_a_pe_sample_stage_and_fails_broken_copies() {
    let what = "the DPI-C testbench of the PE's sample stage";
    if !tools::have("verilator", "verilator", what) || !tools::have("cc", "gcc", what) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vec = d.join("vec");
    let man = vectors(&vec);
    let (samples, rows) = (
        man["samples"].as_u64().unwrap(),
        man["rows"].as_u64().unwrap(),
    );
    let depth = man["depth"].as_u64().unwrap();
    assert!(samples > 100, "{man}");
    let unit = Unit::from_toml(None, Some("ftb"), "sample").unwrap();
    let manifest = std::fs::read_to_string(vec.join("manifest.json")).unwrap();
    let pe = std::fs::read_to_string(vec.join("ercube_pe_sample.v")).unwrap();
    let datapath = std::fs::read_to_string(vec.join("ercube_sample.v")).unwrap();
    let tb = pe_testbench(&unit, &manifest, &pe, ("", "ftb")).unwrap();

    let exe = verilate(&d.join("pass"), &tb, &datapath, &pe);
    let (ok, t) = run(&exe, &vec);
    assert!(ok, "the PE's vectors:\n{t}");
    let n = checks(&vec, &man);
    assert!(
        t.contains(&format!(
            "ercube: PE 1: {samples} samples' write-backs match the model through DPI-C; {n} checks of the issue, tap and write-back stream over {rows} cycles"
        )),
        "{samples} samples, {n} checks:\n{t}"
    );

    // The control: the row plan's bit cleared as two.
    assert!(pe.contains("rem <= row_bits & ~one;"));
    let broken = pe.replace(
        "rem <= row_bits & ~one;",
        "rem <= row_bits & ~one & ~(one << 1);",
    );
    let exe = verilate(&d.join("control"), &tb, &datapath, &broken);
    let (ok, t) = run(&exe, &vec);
    assert!(!ok, "the broken control passed:\n{t}");
    let cycle = after(&t, "ercube: first mismatch at cycle ");
    assert!(cycle < rows, "{t}");
    assert!(
        t.contains(&format!("{cycle} (PE 1): iss_m: model"))
            || t.contains(&format!("{cycle} (PE 1): iss_valid: model")),
        "{t}"
    );

    // The datapath: its red compositing sum a difference, caught by the
    // model through DPI-C at the first write-back.
    let (broken, line) = mutate::break_sum(&datapath, "n_comp_r_s").expect("the red sum");
    let exe = verilate(&d.join("datapath"), &tb, &broken, &pe);
    let (ok, t) = run(&exe, &vec);
    assert!(!ok, "the broken datapath ({line}) passed:\n{t}");
    assert!(t.contains("(acc_out_r): model"), "{line}:\n{t}");
    let (cycle, from) = (
        after(&t, "ercube: first mismatch at cycle "),
        after(&t, "sample issued at cycle "),
    );
    assert_eq!(cycle, from + depth, "{t}");
}

/// The round-robin mappings (`tests/support/round_robin.rs`): the
/// column map's entries and the column decoder reach the module as memory
/// writes (`cm_mx`, `cm_sl`, `loc`), and the emitted PE passes the
/// scoreboard under the interleave and the cyclic mapping, every issue,
/// tap and write-back checked; a copy whose column decoder reads the right
/// tap column at the left one's index stops at its first differing tap.
#[test]
fn the_dpi_testbench_scores_the_round_robin_mappings_and_fails_a_broken_decoder() {
    let what = "the DPI-C testbench of the PE's sample stage";
    if !tools::have("verilator", "verilator", what) || !tools::have("cc", "gcc", what) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, toml, frame) in round_robin::FRAMES {
        let vec = d.join(name).join("vec");
        std::fs::create_dir_all(d.join(name)).unwrap();
        let args = round_robin::vectors_args(frame, &round_robin::config(d, name, toml), &vec);
        let argv = std::iter::once("ercube").chain(args.iter().map(String::as_str));
        assert_eq!(ercube::cli::run_with(argv), ExitCode::SUCCESS, "{name}");
        let man: Value =
            serde_json::from_str(&std::fs::read_to_string(vec.join("manifest.json")).unwrap())
                .unwrap();
        assert_eq!(man["mapping"], name);
        let (samples, rows) = (
            man["samples"].as_u64().unwrap(),
            man["rows"].as_u64().unwrap(),
        );
        assert!(samples > 100, "{name}: {man}");
        let unit = Unit::from_toml(Some(toml), None, "sample").unwrap();
        let manifest = std::fs::read_to_string(vec.join("manifest.json")).unwrap();
        let pe = std::fs::read_to_string(vec.join("ercube_pe_sample.v")).unwrap();
        let datapath = std::fs::read_to_string(vec.join("ercube_sample.v")).unwrap();
        let tb = pe_testbench(&unit, &manifest, &pe, (toml, "")).unwrap();
        let exe = verilate(&d.join(name).join("pass"), &tb, &datapath, &pe);
        let (ok, t) = run(&exe, &vec);
        assert!(ok, "{name}:\n{t}");
        let n = checks(&vec, &man);
        assert!(
            t.contains(&format!(
                "ercube: PE 1: {samples} samples' write-backs match the model through DPI-C; {n} checks of the issue, tap and write-back stream over {rows} cycles"
            )),
            "{name}: {samples} samples, {n} checks:\n{t}"
        );
        let broken = round_robin::break_decoder(&pe).expect("the column decoder");
        let exe = verilate(&d.join(name).join("decoder"), &tb, &datapath, &broken);
        let (ok, t) = run(&exe, &vec);
        assert!(!ok, "{name}: the broken decoder passed:\n{t}");
        let cycle = after(&t, "ercube: first mismatch at cycle ");
        assert!(cycle < rows, "{name}: {t}");
        assert!(t.contains(&format!("{cycle} (PE 1): tap_v")), "{name}: {t}");
    }
}

#[test]
fn the_pe_testbench_refuses_what_does_not_match_the_vectors() {
    let dir = tempfile::tempdir().unwrap();
    let vec = dir.path().join("vec");
    vectors(&vec);
    let manifest = std::fs::read_to_string(vec.join("manifest.json")).unwrap();
    let pe = std::fs::read_to_string(vec.join("ercube_pe_sample.v")).unwrap();
    let ftb = Unit::from_toml(None, Some("ftb"), "sample").unwrap();
    let tb = |unit: &Unit, man: &str, v: &str| pe_testbench(unit, man, v, ("", "ftb"));
    assert!(tb(&ftb, &manifest, &pe).is_ok());
    let btf = Unit::from_toml(None, Some("btf"), "sample").unwrap();
    let e = tb(&btf, &manifest, &pe).unwrap_err();
    assert!(e.contains("depth") && e.contains("--order"), "{e}");
    let e = tb(&ftb, "{\"stage\": \"datapath\"}", &pe).unwrap_err();
    assert!(e.contains("--stage pe"), "{e}");
    let e = tb(&ftb, "not json", &pe).unwrap_err();
    assert!(e.starts_with("manifest.json: "), "{e}");
    let renamed = pe.replace(
        "output wire signed [15:0] iss_m",
        "output wire signed [15:0] iss_x",
    );
    assert_ne!(renamed, pe);
    let e = tb(&ftb, &manifest, &renamed).unwrap_err();
    assert!(e.contains("no port iss_m"), "{e}");
    let narrow = pe.replace(
        "output wire signed [15:0] iss_m",
        "output wire signed [14:0] iss_m",
    );
    let e = tb(&ftb, &manifest, &narrow).unwrap_err();
    assert!(e.contains("port iss_m is 15 bits"), "{e}");
    let e = tb(&ftb, &manifest, "module other(input clk); endmodule").unwrap_err();
    assert!(e.contains("no module ercube_pe_sample"), "{e}");
    let cut = Unit::from_toml(None, Some("ftb"), "composite").unwrap();
    assert!(tb(&cut, &manifest, &pe).is_err());
}
