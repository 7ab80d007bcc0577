//! Shear-warp through the program: `render --method shear-warp` writes its
//! counts in the stats, the intermediate scale changes the image and the
//! work, `compare` and `bench` run it, and the options it cannot honour
//! are refused in one line each.

use crate::bin::{assert_refused, describe, ercube};

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("stats written")).expect("json")
}

#[test]
fn render_writes_the_shear_warp_counts() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let stats = |scale: &str, name: &str| {
        let args = [
            "render",
            "--scene",
            "ml:24",
            "--size",
            "32x32",
            "--method",
            "shear-warp",
            "--intermediate-scale",
            scale,
            "--compare-reference",
            "--out",
            "i.png",
            "--stats",
            name,
        ];
        let out = ercube(d, &args);
        assert!(out.status.success(), "{}", describe(&args, &out));
        json(&d.join(name))
    };
    let one = stats("1", "one.json");
    let two = stats("2", "two.json");
    assert_eq!(one["method"], "shear-warp");
    let sw = &one["shear_warp"];
    assert_eq!(sw["eye_case"], "front");
    assert_eq!(sw["scale"], 1.0);
    assert!(sw["samples_total"].as_u64().unwrap() > 0);
    assert_eq!(one["samples_total"], sw["samples_total"]);
    assert!(one["error_vs_reference"]["rmse"].as_f64().unwrap() < 0.05);
    let size = |v: &serde_json::Value| v["shear_warp"]["intermediate"][0].as_u64().unwrap();
    assert!(
        size(&two) > size(&one) * 3 / 2,
        "scale 2's intermediate image is about twice as wide: {} vs {}",
        size(&two),
        size(&one)
    );
}

#[test]
fn a_volume_behind_the_eye_renders_black() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let args = [
        "render",
        "--scene",
        "sphere:16",
        "--size",
        "16x16",
        "--method",
        "shear-warp",
        "--eye",
        "7.5,7.5,-20",
        "--look-at",
        "7.5,7.5,-40",
        "--out",
        "i.png",
        "--stats",
        "s.json",
    ];
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let v = json(&d.join("s.json"));
    assert_eq!(v["shear_warp"]["eye_case"], "behind");
    assert_eq!(v["shear_warp"]["samples_total"], 0);
}

#[test]
fn compare_and_bench_run_shear_warp() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let args = [
        "compare",
        "--scene",
        "sphere:16",
        "--size",
        "16x16",
        "--methods",
        "shear-warp,under",
        "--out-dir",
        "c",
    ];
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    assert!(d.join("c/shear-warp.png").exists());
    let args = [
        "bench",
        "--scene",
        "sphere:16",
        "--size",
        "16x16",
        "--distances",
        "4,16",
        "--frames",
        "1",
        "--methods",
        "reference,shear-warp",
        "--out-dir",
        "b",
    ];
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let csv = std::fs::read_to_string(d.join("b/bench.csv")).expect("csv");
    assert_eq!(
        csv.lines().filter(|l| l.contains("shear-warp")).count(),
        2,
        "{csv}"
    );
}

#[test]
fn options_shear_warp_cannot_honour_are_one_line_errors() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let s = "render --scene checker:16 --size 16x16 --method shear-warp";
    let cases: Vec<(String, &str)> = vec![
        (format!("{s} --intermediate-scale 0"), "intermediate scale"),
        (format!("{s} --intermediate-scale 20"), "intermediate scale"),
        (
            format!("{s} --intermediate-scale nan"),
            "intermediate scale",
        ),
        (format!("{s} --voi sphere:4,4,4,3 --voi-scale 200"), "scale"),
        (format!("{s} --gaze 3,3"), "gaze"),
        (format!("{s} --substeps 2"), "substeps"),
        (format!("{s} --baseplane-npy b.npy"), "baseplane"),
        (format!("{s} --terminate 0"), "termination"),
    ];
    for (line, needle) in &cases {
        let args: Vec<&str> = line.split_whitespace().collect();
        assert_refused(&args, &ercube(dir.path(), &args), needle);
    }
}

/// `--shade` works with shear-warp, close to the shaded reference.
#[test]
fn render_shades_shear_warp() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let args = [
        "render",
        "--scene",
        "ml:24",
        "--size",
        "32x32",
        "--method",
        "shear-warp",
        "--compare-reference",
        "--shade",
        "--out",
        "i.png",
        "--stats",
        "s.json",
    ];
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let rmse = json(&d.join("s.json"))["error_vs_reference"]["rmse"]
        .as_f64()
        .expect("rmse");
    assert!(rmse < 0.05, "shaded shear-warp vs shaded reference: {rmse}");
}
