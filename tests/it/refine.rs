//! Adaptive and progressive refinement through the program: bad
//! thresholds, level and step counts refused in one line, and `ercube
//! refine` writing each step, the CSV and the plot, its last step equal to
//! one ray per pixel.

use crate::bin::{assert_refused, describe, ercube};

#[test]
fn bad_refinements_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let base = "--scene sphere:16 --size 24x20";
    for (args, needle) in [
        (
            format!("render {base} --method reference --refine complexity:-0.5 --out o.png"),
            "refine threshold -0.5",
        ),
        (
            format!("render {base} --method reference --refine complexity:1.5 --out o.png"),
            "refine threshold 1.5",
        ),
        (
            format!("render {base} --method reference --refine complexity:abc --out o.png"),
            "is not a number",
        ),
        (
            format!("render {base} --method reference --refine complexity:NaN --out o.png"),
            "refine threshold NaN",
        ),
        (
            format!("render {base} --method reference --refine colour --out o.png"),
            "unknown refinement 'colour'",
        ),
        (
            format!(
                "render {base} --method mipmap --refine complexity --refine-levels 0 --out o.png"
            ),
            "refine levels 0",
        ),
        (
            format!(
                "render {base} --method mipmap --refine complexity --refine-levels 7 --out o.png"
            ),
            "refine levels 7",
        ),
        (
            format!("render {base} --method reference --refine-levels 2 --out o.png"),
            "--refine-levels needs --refine",
        ),
        (
            format!("render {base} --method er --refine complexity --out o.png"),
            "--refine applies to --method reference or mipmap",
        ),
        (
            format!("refine {base} --steps 1 --out-dir out"),
            "--steps 1 must be 2 to 1000",
        ),
        (
            format!("refine {base} --refine-levels 9 --out-dir out"),
            "refine levels 9",
        ),
        (
            format!("refine {base} --method er --out-dir out"),
            "takes --method reference or mipmap",
        ),
        (
            format!("refine {base} --refine complexity:-1 --out-dir out"),
            "refine threshold -1",
        ),
    ] {
        let args: Vec<&str> = args.split_whitespace().collect();
        let out = ercube(dir.path(), &args);
        assert_refused(&args, &out, needle);
    }
    assert!(!dir.path().join("o.png").exists());
    assert!(!dir.path().join("out").exists());
}

#[test]
fn refine_writes_each_step_and_ends_on_one_ray_per_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "refine",
        "--scene",
        "sphere:16",
        "--size",
        "40x32",
        "--steps",
        "4",
        "--gaze",
        "10,10",
        "--out-dir",
        "out",
    ];
    let out = ercube(dir.path(), &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("1280 rays in all, equal to one ray per pixel"),
        "{stdout}"
    );
    let o = dir.path().join("out");
    for f in ["step_01.png", "step_04.png", "progress.png", "stats.json"] {
        assert!(o.join(f).exists(), "{f}");
    }
    let csv = std::fs::read_to_string(o.join("progress.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 4);
    let new: u64 = rows.iter().map(|r| r[1].parse::<u64>().unwrap()).sum();
    assert_eq!(new, 1280, "{csv}");
    assert_eq!(rows[3][5], "0.000000", "{csv}");
}
