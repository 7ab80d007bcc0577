//! `ercube synth`: a unit synthesized and placed and routed on an iCE40
//! UltraPlus with Debian's yosys and nextpnr-ice40, its measured counts
//! checked against the estimator; and its one-line refusals.
//!
//! Without the tools the placement test prints one line and skips, unless
//! `ERCUBE_REQUIRE_TOOLS=1` (`.ci/run` installs them and sets it). The ECP5
//! runs need the PyPI tools (a venv of about 400 MB the command makes on
//! first use) and are `#[ignore]`d; docs/cost.md has their commands and
//! times.

use crate::bin::{assert_refused, describe, ercube};
use crate::tools::have;

/// The estimator's tolerance against place and route's synthesis: LUTs
/// and flip-flops within 10%, DSP blocks and block RAM exact.
const REL_TOL: f64 = 0.10;

/// The delay model's tolerance against the measured clock
/// (`pipeline::cost::fmax`, docs/cost.md).
const FMAX_TOL: f64 = 0.15;

/// Runs `ercube synth` on `unit` for `target` and returns its JSON report.
fn synth(dir: &std::path::Path, target: &str, unit: &str) -> serde_json::Value {
    synth_with(dir, target, unit, &[])
}

/// As [`synth`], with more arguments (a `--config`).
fn synth_with(
    dir: &std::path::Path,
    target: &str,
    unit: &str,
    extra: &[&str],
) -> serde_json::Value {
    let json = format!("{target}-{unit}-{}.json", extra.len());
    let mut args = vec![
        "synth", "--target", target, "--unit", unit, "--stats", &json,
    ];
    args.extend_from_slice(extra);
    report(dir, &args, &json).1
}

/// Runs `ercube args` in `dir`, which must succeed and write the report
/// `json`: its standard output and the report.
fn report(dir: &std::path::Path, args: &[&str], json: &str) -> (String, serde_json::Value) {
    let out = ercube(dir, args);
    assert!(out.status.success(), "{}", describe(args, &out));
    let r = serde_json::from_slice(&std::fs::read(dir.join(json)).expect("report written"))
        .expect("valid JSON");
    (String::from_utf8_lossy(&out.stdout).into_owned(), r)
}

/// Checks the estimate against the synthesized counts of one report.
fn check_estimate(r: &serde_json::Value) {
    let n = |v: &serde_json::Value, k: &str| v[k].as_u64().expect("count");
    let (got, est) = (&r["synthesized"], &r["estimated"]);
    for k in ["dsp", "bram"] {
        assert_eq!(n(est, k), n(got, k), "{k} of {}", r["unit"]);
    }
    for k in ["lut", "ff"] {
        let (e, g) = (n(est, k) as f64, n(got, k) as f64);
        assert!(
            (e - g).abs() <= REL_TOL * g,
            "{}: estimated {k} {e} against {g} synthesized",
            r["unit"]
        );
    }
}

/// The delay model's clock against the measured one: within
/// [`FMAX_TOL`].
fn check_fmax(r: &serde_json::Value) {
    let got = r["placed"]["fmax_mhz"].as_f64().expect("a measured clock");
    let est = r["predicted_mhz"].as_f64().expect("a predicted clock");
    assert!(
        (est - got).abs() <= FMAX_TOL * got,
        "{} ({}): predicted {est:.1} MHz against {got:.1} measured",
        r["unit"],
        r["description"]
    );
}

/// The position adder (a carry chain) and the slope square (four
/// SB_MAC16s and their partial-sum adders), placed and routed on an
/// iCE40UP5K: the estimate within the tolerances, the delay model's clock
/// within 15% of the measured one, a measured clock with its critical
/// path, and the placed logic cells covering the unit's LUTs; then the
/// square-root stage at the default widths and the position adder at the
/// holdout `mid` widths (pipeline/data/widths/mid.toml, which the delay
/// model's fit does not use), clocks only. About 15 s.
#[test]
fn synth_places_units_on_ice40_and_checks_the_estimator() {
    if !have("yosys", "yosys", "the iCE40 synthesis")
        || !have(
            "nextpnr-ice40",
            "nextpnr-ice40",
            "the iCE40 place and route",
        )
    {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    for unit in ["add_position", "mul_square"] {
        let r = synth(dir.path(), "ice40-up5k", unit);
        check_estimate(&r);
        assert_eq!(r["latch_free"], true, "{r}");
        let placed = &r["placed"];
        let fmax = placed["fmax_mhz"].as_f64().expect("a measured clock");
        // An iCE40UP5K's fabric runs below 300 MHz; a figure outside
        // means the report was misread.
        assert!(fmax > 5.0 && fmax < 300.0, "{unit}: {fmax} MHz");
        let path = &placed["critical_path"];
        assert!(path["cells"].as_u64().expect("path cells") >= 2, "{path}");
        let lc = placed["utilization"]
            .as_array()
            .expect("utilization")
            .iter()
            .find(|u| u["name"] == "ICESTORM_LC")
            .and_then(|u| u["used"].as_u64())
            .expect("logic cells used");
        let luts = r["synthesized"]["lut"].as_u64().unwrap();
        let (bits_in, bits_out) = (
            r["wrapper_bits"][0].as_u64().unwrap(),
            r["wrapper_bits"][1].as_u64().unwrap(),
        );
        // The wrapper's shift registers are placed too: nothing removed.
        assert!(lc >= luts.max(bits_in + bits_out), "{unit}: {lc} cells");
        check_fmax(&r);
    }
    check_fmax(&synth(dir.path(), "ice40-up5k", "sqrt_norm"));
    let mid = concat!(env!("CARGO_MANIFEST_DIR"), "/pipeline/data/widths/mid.toml");
    let r = synth_with(dir.path(), "ice40-up5k", "add_position", &["--config", mid]);
    assert!(
        r["description"].as_str().unwrap_or("").contains("24"),
        "the mid widths' 24-bit positions: {r}"
    );
    check_fmax(&r);
}

/// The PE's readout stage (`ercube_pe_readout` for a 16^3 volume over 2
/// PEs: two 416 x 64 buffer banks, a 26 x 17 column map and the readout's
/// state machine) synthesized and placed on an iCE40UP5K: its estimate
/// (`pipeline::cost::readout`, from the shape the Verilog is written
/// from) within 10% on LUTs and flip-flops and exact on block RAM, and a
/// measured clock. About 50 s on a loaded two-core machine.
#[test]
fn synth_readout_on_ice40_against_its_estimate() {
    if !have("yosys", "yosys", "the iCE40 synthesis")
        || !have(
            "nextpnr-ice40",
            "nextpnr-ice40",
            "the iCE40 place and route",
        )
    {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let args = [
        "synth",
        "--target",
        "ice40-up5k",
        "--readout",
        "--dims",
        "16,16,16",
        "--pes",
        "2",
        "--stats",
        "readout.json",
    ];
    let (text, r) = report(dir.path(), &args, "readout.json");
    assert!(text.contains("estimated (pipeline::cost, ice40)"), "{text}");
    assert_eq!(r["unit"], "readout", "{r}");
    assert!(r["synthesized"]["bram"].as_u64().unwrap() > 0, "{r}");
    check_estimate(&r);
    let fmax = r["placed"]["fmax_mhz"].as_f64().expect("a measured clock");
    assert!(fmax > 5.0 && fmax < 300.0, "readout: {fmax} MHz");
}

/// The ECP5 flow on every unit at the default widths (about 5 minutes on
/// two cores, the first call installing the tools): counts against the
/// estimate as on iCE40.
#[test]
#[ignore = "ECP5 tools from PyPI (about 400 MB); cargo test --release --test it -- --ignored synth_ecp5"]
fn synth_ecp5_units_against_the_estimator() {
    let dir = tempfile::tempdir().expect("temp dir");
    for unit in [
        "add_position",
        "mul_ray",
        "mul_square",
        "bilinear",
        "composite",
        "class_table",
        "sqrt_norm",
        "divider",
    ] {
        let r = synth(dir.path(), "ecp5-25k", unit);
        check_estimate(&r);
        check_fmax(&r);
    }
}

/// The whole emitted sample datapath (`ercube rtl`'s `ercube_sample`) on
/// an LFE5U-85F: no latch, the datapath named as such (not the PE), a
/// measured clock and the schedule's predicted one. It does not fit an
/// iCE40UP5K or an LFE5U-25F (docs/cost.md). Tens of minutes on two
/// shared cores.
#[test]
#[ignore = "ECP5 tools, tens of minutes: cargo test --release --test it -- --ignored synth_datapath"]
fn synth_datapath_on_ecp5_85k() {
    let dir = tempfile::tempdir().expect("temp dir");
    let args = [
        "synth",
        "--target",
        "ecp5-85k",
        "--datapath",
        "--stats",
        "dp.json",
    ];
    let (_, r) = report(dir.path(), &args, "dp.json");
    assert_eq!(r["module"], "ercube_sample");
    assert_eq!(r["latch_free"], true);
    assert!(
        r["description"]
            .as_str()
            .unwrap_or("")
            .contains("not the PE"),
        "{r}"
    );
    let fmax = r["placed"]["fmax_mhz"].as_f64().expect("a measured clock");
    assert!(fmax > 5.0 && fmax < 400.0, "{fmax}");
    assert!(r["predicted_mhz"].as_f64().expect("a prediction") > 0.0);
}

/// The PE's emitted sample stage for a 64^3 volume on two PEs, placed on
/// an LFE5U-85F (docs/cost.md, "The PE's sample stage placed"): the
/// estimator's LUTs and flip-flops within 10% of yosys's, its multiplier
/// blocks and block RAMs exact, the measured clock within 15% of the
/// prediction that includes the control's issue path. About 12 minutes
/// on two quiet cores (33 on two loaded ones).
#[test]
#[ignore = "ECP5 tools, about 12 minutes: cargo test --release --test it -- --ignored synth_pe_stage"]
fn synth_pe_stage_on_ecp5_85k_against_its_estimate() {
    let dir = tempfile::tempdir().expect("temp dir");
    let args = [
        "synth", "--target", "ecp5-85k", "--pe", "--dims", "64,64,64", "--pes", "2", "--json",
        "pe.json",
    ];
    let (_, r) = report(dir.path(), &args, "pe.json");
    assert_eq!(r["module"], "ercube_pe_sample");
    assert_eq!(r["latch_free"], true);
    check_estimate(&r);
    check_fmax(&r);
}

/// The PE's sample stage (16^3 over 2 PEs) synthesized for a 7-series
/// part with Debian's yosys, flattened: its LUTs and flip-flops within
/// 10% of the estimate, its DSP48E1s and RAMB18s exact. Counts only (no
/// open timing for Xilinx parts). About 30 s.
#[test]
fn synth_pe_stage_on_xc7_against_its_estimate() {
    if !have("yosys", "yosys", "the xc7 synthesis") {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let args = [
        "synth", "--target", "xc7", "--pe", "--dims", "16,16,16", "--pes", "2", "--stats",
        "pe.json",
    ];
    let (text, r) = report(dir.path(), &args, "pe.json");
    assert!(text.contains("synthesis counts only"), "{text}");
    assert_eq!(r["module"], "ercube_pe_sample", "{r}");
    assert!(r["synthesized"]["bram"].as_u64().unwrap() > 0, "{r}");
    check_estimate(&r);
}

/// Bad targets, units, the array and misplaced options are one line and
/// status 2, before any tool runs.
#[test]
fn synth_refuses_bad_input() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let cases: [(&[&str], &str); 7] = [
        (&["--target", "zynq", "--unit", "composite"], "zynq"),
        (&["--target", "ice40-up5k", "--unit", "nope"], "nope"),
        (
            &[
                "--target",
                "ice40-up5k",
                "--unit",
                "composite",
                "--dims",
                "8,8,8",
            ],
            "--dims",
        ),
        (&["--target", "ecp5-85k", "--array"], "not emitted"),
        (&["--target", "xc7"], "--unit"),
        (
            &["--target", "xc7", "--unit", "composite", "--datapath"],
            "--datapath",
        ),
        (
            &[
                "--target",
                "ice40-up5k",
                "--unit",
                "composite",
                "--clock-mhz",
                "0",
            ],
            "clock",
        ),
    ];
    for (extra, needle) in cases {
        let mut args = vec!["synth"];
        args.extend_from_slice(extra);
        assert_refused(&args, &ercube(d, &args), needle);
    }
}

/// The clock of a design whose PE sample stage was placed is the
/// measured one by default: each ECP5 stage of
/// `pipeline/data/measured/stages.csv`, its volume's edge and PEs costed,
/// is quoted at its measured clock, labelled measured.
#[test]
fn cost_quotes_a_placed_stages_measured_clock() {
    let dir = tempfile::tempdir().expect("temp dir");
    let stages = pipeline::cost::fmax::stages::stages();
    assert!(!stages.is_empty());
    for s in stages
        .iter()
        .filter(|s| s.target == pipeline::cost::Target::Ecp5)
    {
        let (scene, pes) = (format!("checker:{}", s.dims), s.pes.to_string());
        let args = [
            "cost",
            "--scene",
            &scene,
            "--pes",
            &pes,
            "--target",
            "ecp5",
            "--archs",
            "none",
            "--sweep-pes",
            "none",
        ];
        let out = ercube(dir.path(), &args);
        assert!(out.status.success(), "{}", describe(&args, &out));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains(&format!("at {} MHz (measured clock)", s.mhz)),
            "{}: {text}",
            s.dims
        );
    }
}

/// `ercube cost --clock predicted` quotes the frame at the clock the
/// schedule is predicted to reach (`pipeline::cost::fmax`), labelled so,
/// and prints the predicted clocks beside the assumed one by default;
/// `--target-mhz` reports a pipelining that reaches the clock or refuses
/// in one line; xc7 has no prediction. No external tool: about 2 s.
#[test]
fn cost_quotes_the_predicted_clock_and_pipelines_to_a_target() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let base = [
        "cost",
        "--scene",
        "checker:16",
        "--archs",
        "none",
        "--sweep-pes",
        "none",
    ];
    let run = |extra: &[&str]| {
        let mut args: Vec<&str> = base.to_vec();
        args.extend_from_slice(extra);
        let out = ercube(d, &args);
        assert!(out.status.success(), "{}", describe(&args, &out));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let assumed = run(&["--target", "ecp5", "--clock", "assumed"]);
    assert!(assumed.contains("at 150 MHz (assumed clock)"), "{assumed}");
    let line = assumed
        .lines()
        .find(|l| l.contains("predicted clock"))
        .expect("the predicted clocks are printed");
    let mhz: f64 = line
        .split("ecp5 ")
        .nth(1)
        .and_then(|r| r.split(" MHz").next())
        .and_then(|x| x.parse().ok())
        .expect("an ECP5 figure");
    // The sample stage's clock: never above its datapath's (whose slowest
    // stage this view's issue path may or may not undercut), and well
    // above the 13.7 MHz of a control written without the pick's carry
    // chain (docs/cost.md).
    let datapath = pipeline::cost::fmax::pe_prediction(
        &pipeline::config::PipelineConfig::default(),
        pipeline::cost::Target::Ecp5,
    )
    .expect("an ECP5 prediction")
    .mhz;
    assert!(mhz > 13.7 && mhz <= datapath + 0.05, "{line}");
    let predicted = run(&["--target", "ecp5", "--clock", "predicted"]);
    assert!(
        predicted.contains(&format!("at {mhz} MHz (predicted clock)")),
        "{predicted}"
    );
    // By default the clock is the first of measured, predicted and assumed
    // there is: predicted here (no 16^3 stage was placed), assumed on xc7.
    let auto = run(&["--target", "ecp5"]);
    assert!(
        auto.contains(&format!("at {mhz} MHz (predicted clock)")),
        "{auto}"
    );
    assert!(
        run(&["--target", "xc7"]).contains("at 200 MHz (assumed clock)"),
        "xc7 has no timing flow"
    );
    let slow = run(&["--target", "ecp5", "--target-mhz", "40"]);
    let pipelined = slow
        .lines()
        .find(|l| l.starts_with("pipelined for 40 MHz on ecp5"))
        .expect("the pipelining line");
    let stages: u32 = pipelined
        .split(": ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|x| x.parse().ok())
        .expect("a stage count");
    assert!(stages > 1 && stages < 35, "{pipelined}");
    // The option sets the configuration's target_mhz: the PE's pipeline
    // and the frame's drain follow the packed schedule.
    assert!(
        slow.contains(&format!("pipeline {stages} clocks")),
        "{slow}"
    );
    assert!(assumed.contains("pipeline 35 clocks"), "{assumed}");
    let drain = |text: &str| -> u64 {
        text.split("drain ")
            .nth(1)
            .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).next())
            .and_then(|x| x.parse().ok())
            .expect("the run's drain cycles")
    };
    assert!(drain(&slow) < drain(&assumed), "{slow}\n{assumed}");
    let refusals: [(&[&str], &str); 6] = [
        (&["--target", "xc7", "--clock", "predicted"], "xc7"),
        (
            &["--target", "ecp5", "--target-mhz", "900"],
            "no schedule reaches",
        ),
        (
            &["--target", "ecp5", "--target-mhz", "2000"],
            "outside 0..=1000",
        ),
        (&["--target", "xc7", "--target-mhz", "50"], "delay model"),
        (
            &["--target", "ecp5", "--clock", "measured"],
            "--clock measured",
        ),
        (
            &[
                "--target",
                "ecp5",
                "--clock",
                "predicted",
                "--clock-mhz",
                "50",
            ],
            "--clock-mhz",
        ),
    ];
    for (extra, needle) in refusals {
        let mut args: Vec<&str> = base.to_vec();
        args.extend_from_slice(extra);
        assert_refused(&args, &ercube(d, &args), needle);
    }
}
