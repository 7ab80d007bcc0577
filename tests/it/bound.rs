//! A pipeline frame's derived error bound through the program: the stats'
//! `bound` says whether the measured difference from golden stayed within
//! it, and a view whose path lengths saturate the `path` format gets no
//! bound, a warning and the format that holds it, with which the frame
//! comes back within 1/255 of golden in both orders. The stats'
//! `quantization` counts per format, and name the path as the format
//! whose overflows are no designed clamp.

use serde_json::Value;

use crate::bin::{describe, ercube};

/// Renders `args` with `--stats`, returning the stats and the program's
/// stderr followed by its stdout (the summary and its notes).
fn stats(dir: &std::path::Path, args: &[&str]) -> (Value, String) {
    let mut all: Vec<&str> = args.to_vec();
    all.extend(["--out", "b.png", "--stats", "b.json"]);
    let out = ercube(dir, &all);
    assert!(out.status.success(), "{}", describe(&all, &out));
    let text = std::fs::read_to_string(dir.join("b.json")).expect("stats written");
    let v: Value = serde_json::from_str(&text).expect("stats are JSON");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
    );
    (v, text)
}

/// An ordinary view: a finite bound, the measured float difference under
/// it, and `held` agreeing with the two numbers.
#[test]
fn an_ordinary_frame_reports_its_bound_as_held() {
    let dir = tempfile::tempdir().unwrap();
    for method in ["pipeline", "pipeline-ftb"] {
        let args = [
            "render",
            "--scene",
            "ml:24",
            "--size",
            "32x32",
            "--method",
            method,
            "--terminate",
            "1",
        ];
        let (v, err) = stats(dir.path(), &args);
        let b = &v["bound"];
        let value = b["value"]
            .as_f64()
            .unwrap_or_else(|| panic!("{method}: no bound: {b}"));
        let measured = b["measured"].as_f64().unwrap();
        assert!(value > 0.0 && value.is_finite(), "{method}: {b}");
        assert_eq!(b["held"], Value::Bool(measured <= value), "{method}: {b}");
        assert_eq!(b["held"], Value::Bool(true), "{method}: {b}");
        assert_eq!(b["path_saturates"], Value::Bool(false), "{method}: {b}");
        // The 8-bit difference the stats report is the float one rounded.
        let vs = v["error_vs_golden"]["max_abs_255"].as_f64().unwrap();
        assert!(
            vs <= (measured * 255.0).ceil() + 1.0,
            "{method}: {vs} vs {measured}"
        );
        assert!(!err.contains("warning"), "{method}: {err}");
        let q = &v["quantization"];
        assert_eq!(q["harmful_overflows"], 0, "{method}: {q}");
        assert_formats_sum_to_totals(q);
    }
}

/// The per-format counts of a stats' `quantization` add up to its totals,
/// and every format says whether its overflow is a clamp.
fn assert_formats_sum_to_totals(q: &Value) {
    let by = q["by_format"].as_object().expect("by_format");
    for key in ["assignments", "inexact", "overflows"] {
        let sum: u64 = by.values().map(|c| c[key].as_u64().unwrap()).sum();
        assert_eq!(Some(sum), q[key].as_u64(), "{key}: {q}");
    }
    assert!(by.values().all(|c| c["clamp"].is_boolean()), "{q}");
    let harmful: u64 = by
        .values()
        .filter(|c| c["clamp"] == false)
        .map(|c| c["overflows"].as_u64().unwrap())
        .sum();
    assert_eq!(Some(harmful), q["harmful_overflows"].as_u64(), "{q}");
}

/// Front to back with early ray termination is not what the bound is
/// derived for: no bound, and the stats say why.
#[test]
fn a_terminating_frame_says_why_it_has_no_bound() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "render",
        "--scene",
        "ml:24",
        "--size",
        "32x32",
        "--method",
        "pipeline-ftb",
    ];
    let (v, _) = stats(dir.path(), &args);
    assert_eq!(v["bound"]["value"], Value::Null, "{}", v["bound"]);
    assert_eq!(v["bound"]["held"], Value::Null);
    let why = v["bound"]["why_none"].as_str().unwrap();
    assert!(why.contains("termination"), "{why}");
}

/// 170 degrees with the eye 2 voxels before checker:64's face: path
/// lengths reach 23 voxels, beyond the default `path` (ds < 8). The frame
/// runs, reports no bound and warns with the format that holds it; with
/// that format both orders are within 1/255 of golden and within the
/// bound.
#[test]
fn a_saturating_path_is_reported_and_the_named_format_fixes_it() {
    let dir = tempfile::tempdir().unwrap();
    let view = [
        "render",
        "--scene",
        "checker:64",
        "--eye",
        "32,32,-2",
        "--fov",
        "170",
        "--size",
        "64x64",
    ];
    for method in ["pipeline", "pipeline-ftb"] {
        let mut args = view.to_vec();
        args.extend(["--method", method, "--terminate", "1"]);
        let (v, err) = stats(dir.path(), &args);
        let b = &v["bound"];
        assert_eq!(b["path_saturates"], Value::Bool(true), "{method}: {b}");
        assert_eq!(b["value"], Value::Null, "{method}: {b}");
        assert!(b["ds_max"].as_f64().unwrap() > 16.0, "{method}: {b}");
        // The counts name the path as the one format overflowing beyond a
        // designed clamp, and why_none names it by its count.
        let q = &v["quantization"];
        assert_formats_sum_to_totals(q);
        let path = &q["by_format"]["path"];
        let n = path["overflows"].as_u64().unwrap();
        assert!(n > 0, "{method}: {q}");
        assert_eq!(path["clamp"], false, "{method}: {q}");
        assert_eq!(q["harmful_overflows"].as_u64(), Some(n), "{method}: {q}");
        assert_eq!(
            b["harmful_overflows"]["path"].as_u64(),
            Some(n),
            "{method}: {b}"
        );
        let why = b["why_none"].as_str().unwrap();
        assert!(
            why.contains(&format!("path overflowed {n} times")),
            "{method}: {why}"
        );
        assert!(
            err.contains(&format!("path {n} (range)")),
            "{method}: {err}"
        );
        let warn: Vec<&str> = err.lines().filter(|l| l.starts_with("warning")).collect();
        assert_eq!(warn.len(), 1, "{method}: {err}");
        // The warning's TOML line, written as a configuration, is accepted
        // and holds the view.
        let toml = warn[0]
            .split('`')
            .find(|s| s.starts_with("path = "))
            .unwrap_or_else(|| panic!("{method}: no TOML in {}", warn[0]));
        std::fs::write(dir.path().join("path.toml"), format!("{toml}\n")).unwrap();
        args.extend(["--config", "path.toml"]);
        let (v, err) = stats(dir.path(), &args);
        let b = &v["bound"];
        assert_eq!(b["path_saturates"], Value::Bool(false), "{method}: {b}");
        assert_eq!(b["held"], Value::Bool(true), "{method}: {b}");
        assert!(!err.contains("warning"), "{method}: {err}");
        assert_eq!(v["quantization"]["harmful_overflows"], 0, "{method}");
        assert_eq!(v["quantization"]["by_format"]["path"]["overflows"], 0);
        let vs = v["error_vs_golden"]["max_abs_255"].as_f64().unwrap();
        assert!(
            vs <= 1.0,
            "{method}: {vs}/255 from golden with the wider path"
        );
    }
}

/// `--no-golden-twin` skips the golden render and the bound: the stats
/// say so with nulls, and the chip's image, raw words and cycles are the
/// same as with the twin.
#[test]
fn skipping_the_golden_twin_changes_nothing_of_the_chip() {
    let dir = tempfile::tempdir().unwrap();
    let base = [
        "render",
        "--scene",
        "ml:24",
        "--size",
        "32x32",
        "--method",
        "pipeline",
        "--pes",
        "3",
        "--raw-npy",
        "raw.npy",
    ];
    let (with, _) = stats(dir.path(), &base);
    let raw_with = std::fs::read(dir.path().join("raw.npy")).unwrap();
    let png_with = std::fs::read(dir.path().join("b.png")).unwrap();
    let mut args = base.to_vec();
    args.push("--no-golden-twin");
    let (without, _) = stats(dir.path(), &args);
    assert!(with["bound"].is_object(), "{}", with["bound"]);
    assert!(with["error_vs_golden"].is_object());
    assert!(without["bound"].is_null(), "{}", without["bound"]);
    assert!(without["error_vs_golden"].is_null());
    assert!(without["error_vs_golden_er"].is_null());
    for k in ["cycles", "samples_total", "stages", "quantization"] {
        assert_eq!(with[k], without[k], "{k}");
    }
    assert_eq!(raw_with, std::fs::read(dir.path().join("raw.npy")).unwrap());
    assert_eq!(png_with, std::fs::read(dir.path().join("b.png")).unwrap());
}
