//! `compare` and `demo`: their images and tables.

use std::path::Path;

use super::{entries, ercube, num, read_json, read_png, tempdir};

/// One parsed row of `compare.csv`.
struct CsvRow {
    method: String,
    time_s: f64,
    samples: Option<u64>,
    max_abs_255: f64,
    rmse: f64,
    psnr: f64,
}

#[track_caller]
fn read_compare_csv(path: &Path) -> Vec<CsvRow> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("method,time_s,samples,max_abs_255,rmse,psnr"),
        "CSV header"
    );
    lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f.len(), 6, "CSV row {line:?}");
            let n = |s: &str| -> f64 { s.parse().unwrap_or_else(|_| panic!("{s:?} in {line:?}")) };
            CsvRow {
                method: f[0].to_string(),
                time_s: n(f[1]),
                samples: (f[2] != "-").then(|| f[2].parse().expect("sample count")),
                max_abs_255: n(f[3]),
                rmse: n(f[4]),
                psnr: n(f[5]),
            }
        })
        .collect()
}

/// `compare` writes each method's image, the montage, the CSV and JSON
/// tables and prints a row per method; its numbers agree with `render`.
#[test]
fn compare_writes_images_and_tables() {
    let dir = tempdir();
    let d = dir.path();
    let run = ercube(
        d,
        "compare --scene sphere:16 --size 32x32 --methods er,under,reference --out-dir D",
    )
    .ok();
    let out = d.join("D");
    for name in ["er", "under", "reference"] {
        assert_eq!(
            read_png(&out.join(format!("{name}.png"))).dimensions(),
            (32, 32),
            "{name}.png"
        );
        assert!(
            run.stdout()
                .lines()
                .any(|l| l.trim_start().starts_with(name)),
            "no table row for {name}:\n{}",
            run.stdout()
        );
    }
    // Three labelled panels side by side.
    let montage = read_png(&out.join("montage.png"));
    assert!(montage.width() > 3 * 32 && montage.width() > montage.height());

    let rows = read_compare_csv(&out.join("compare.csv"));
    let names: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    assert_eq!(names, ["er", "under", "reference"]);
    for r in &rows {
        assert!(r.time_s >= 0.0, "{}: time {}", r.method, r.time_s);
        assert!((0.0..=255.0).contains(&r.max_abs_255), "{}", r.method);
        assert!(
            (0.0..=1.0).contains(&r.rmse),
            "{}: rmse {}",
            r.method,
            r.rmse
        );
        // Slice-order methods count samples; the reference does not.
        assert_eq!(r.samples.is_some(), r.method != "reference", "{}", r.method);
    }
    let reference = &rows[2];
    assert_eq!((reference.max_abs_255, reference.rmse), (0.0, 0.0));
    assert!(reference.psnr.is_infinite());
    for r in &rows[..2] {
        assert!(
            r.rmse > 0.0 && r.psnr.is_finite(),
            "{}: rmse {}",
            r.method,
            r.rmse
        );
        assert!(r.samples.unwrap() > 0);
    }

    let json = read_json(&out.join("compare.json"));
    let arr = json.as_array().expect("compare.json is an array");
    let jnames: Vec<&str> = arr.iter().map(|o| o["method"].as_str().unwrap()).collect();
    assert_eq!(jnames, names);
    for (o, r) in arr.iter().zip(&rows) {
        let e = &o["error_vs_reference"];
        assert!((num(e, "rmse") - r.rmse).abs() < 1e-6, "{}", r.method);
        assert_eq!(o["samples"].as_u64(), r.samples, "{}", r.method);
    }

    // The same view through `render` counts the same samples and finds the
    // same error.
    ercube(
        d,
        "render --scene sphere:16 --size 32x32 --method er --compare-reference --stats er.json \
         --out er.png",
    )
    .ok();
    let s = read_json(&d.join("er.json"));
    assert_eq!(s["samples_total"].as_u64(), rows[0].samples);
    assert!((num(&s["error_vs_reference"], "rmse") - rows[0].rmse).abs() < 1e-5);
}

/// `demo` needs no input files and writes its montage and table into the
/// directory given, nowhere else.
#[test]
fn demo_runs_without_inputs() {
    let dir = tempdir();
    let d = dir.path();
    let run = ercube(d, "demo --out-dir D").ok();
    assert_eq!(entries(d), ["D"], "demo wrote outside its directory");
    let montage = read_png(&d.join("D/montage.png"));
    assert!(montage.width() > montage.height());
    let rows = read_compare_csv(&d.join("D/compare.csv"));
    let names: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    for m in ["er", "reference"] {
        assert!(names.contains(&m), "no {m} row in {names:?}");
        assert!(run.stdout().contains(m), "no {m} in the printed table");
    }
    // The demo's image is the checkerboard room, not an empty frame.
    let er = read_png(&d.join("D/er.png"));
    assert!(er.pixels().filter(|p| p.0 != [0, 0, 0]).count() > 1000);
}
