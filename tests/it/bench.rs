//! Integration tests of `ercube bench` and `ercube sweep-widths`: the real
//! binary on tiny scenes, checking the CSV's rows and columns, that the
//! plots are valid PNGs, determinism (the same arguments and any thread
//! count give the same CSV except its time column), and the one-line
//! error rule for bad arguments. Everything is small enough to run in a
//! few seconds in release.

use std::path::Path;
use std::process::Output;

/// Runs `ercube` in the current directory (the outputs go to temporary
/// directories named in `args`).
fn ercube(args: &[&str]) -> Output {
    crate::bin::ercube(Path::new("."), args)
}

#[track_caller]
fn ok(args: &[&str]) -> Output {
    let out = ercube(args);
    assert!(
        out.status.success(),
        "ercube {} failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Asserts a one-line error with exit status 2 that mentions `needle`.
#[track_caller]
fn fails(args: &[&str], needle: &str) {
    let out = ercube(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "ercube {}: {err}",
        args.join(" ")
    );
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
    assert!(err.starts_with("ercube: error: "), "{err}");
    assert!(err.contains(needle), "'{err}' lacks '{needle}'");
}

/// Reads a CSV into its header and rows of fields.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).expect("csv");
    let mut lines = text.lines();
    let header = lines
        .next()
        .expect("header")
        .split(',')
        .map(String::from)
        .collect::<Vec<_>>();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect::<Vec<_>>())
        .collect::<Vec<_>>();
    for r in &rows {
        assert_eq!(r.len(), header.len(), "ragged row {r:?}");
    }
    (header, rows)
}

/// Asserts `path` is a decodable PNG of a plausible plot size.
#[track_caller]
fn assert_png(path: &Path) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        img.width() >= 400 && img.height() >= 300,
        "{}",
        path.display()
    );
    // Not blank: a plot has axes, text and lines on its white ground.
    let rgb = img.to_rgb8();
    let dark = rgb
        .pixels()
        .filter(|p| p.0.iter().all(|&c| c < 100))
        .count();
    assert!(dark > 500, "{} looks blank", path.display());
}

/// The CSV without its timing column, for determinism checks.
fn without_time(path: &Path) -> Vec<Vec<String>> {
    let (header, rows) = read_csv(path);
    let t = header.iter().position(|h| h == "time_s").expect("time_s");
    rows.into_iter()
        .map(|mut r| {
            r.remove(t);
            r
        })
        .collect()
}

#[test]
fn bench_writes_csv_plots_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let o = out.to_str().unwrap();
    let args = [
        "bench",
        "--scene",
        "sphere:16",
        "--size",
        "16x16",
        "--distances",
        "4,16",
        "--frames",
        "2",
        "--methods",
        "er,under,over,reference,pipeline",
        "--out-dir",
        o,
    ];
    ok(&args);
    let (header, rows) = read_csv(&out.join("bench.csv"));
    for col in [
        "method",
        "D",
        "run",
        "status",
        "time_s",
        "samples",
        "cycles",
        "max_abs_255",
        "rmse",
        "psnr",
        "vs_er_max_abs_255",
    ] {
        assert!(header.iter().any(|h| h == col), "no column {col}");
    }
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    // Per distance: 2 frames of er, under, over and pipeline, 1 reference.
    assert_eq!(rows.len(), 2 * (4 * 2 + 1));
    for d in ["4", "16"] {
        let at: Vec<_> = rows.iter().filter(|r| r[col("D")] == d).collect();
        assert_eq!(at.len(), 9, "D = {d}");
        let er = at.iter().find(|r| r[col("method")] == "er").unwrap();
        let pipe = at.iter().find(|r| r[col("method")] == "pipeline").unwrap();
        // Same geometry; golden's 4-voxel empty-space blocks nest in the
        // pipeline's 16-voxel ones, so the pipeline skips a subset of what
        // golden skips: at least golden's samples. The pipeline has
        // cycles, er none.
        let samples = |r: &Vec<String>| r[col("samples")].parse::<u64>().unwrap();
        assert!(samples(pipe) >= samples(er), "D = {d}");
        assert!(pipe[col("cycles")].parse::<u64>().unwrap() > 0);
        assert!(er[col("cycles")].is_empty());
        assert!(pipe[col("vs_er_max_abs_255")].parse::<f64>().unwrap() <= 1.0);
        for r in &at {
            assert_eq!(r[col("status")], "ok");
            assert!(r[col("time_s")].parse::<f64>().unwrap() > 0.0);
        }
    }
    // Over samples more than ER when the eye is close.
    let samples = |m: &str| -> u64 {
        rows.iter()
            .find(|r| r[col("D")] == "4" && r[col("method")] == m)
            .unwrap()[col("samples")]
        .parse()
        .unwrap()
    };
    assert!(samples("over") > samples("er"));
    assert!(samples("under") < samples("er"));
    for png in [
        "time_vs_distance.png",
        "error_vs_time.png",
        "samples_per_slice.png",
        "samples_vs_distance.png",
    ] {
        assert_png(&out.join(png));
    }
    let (sh, srows) = read_csv(&out.join("samples_per_slice.csv"));
    assert_eq!(srows.len(), 16);
    assert!(sh.iter().any(|h| h == "model_er"));
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("eq. 12") && md.contains("over/er"), "{md}");

    // Same arguments, another thread count and seed: same CSV but times.
    let out2 = dir.path().join("b2");
    let mut args2 = args.to_vec();
    let o2 = out2.to_str().unwrap();
    *args2.last_mut().unwrap() = o2;
    args2.extend(["--threads", "1", "--seed", "9"]);
    ok(&args2);
    assert_eq!(
        without_time(&out.join("bench.csv")),
        without_time(&out2.join("bench.csv"))
    );
}

#[test]
fn bench_records_oversampling_too_large_as_skipped() {
    // An eye 0.01 voxel in front of a 16^3 volume gives oversampling
    // (16 * 15.01 / 0.01)^2, about 5.8e8, rays at the front slice, over its
    // limit of 2^28; the bench records that and goes on.
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("s");
    ok(&[
        "bench",
        "--scene",
        "sphere:16",
        "--size",
        "4x4",
        "--distances",
        "0.01",
        "--frames",
        "1",
        "--methods",
        "over,under",
        "--out-dir",
        o.to_str().unwrap(),
    ]);
    let (header, rows) = read_csv(&o.join("bench.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let over = rows.iter().find(|r| r[col("method")] == "over").unwrap();
    assert_eq!(over[col("status")], "skipped");
    assert!(!over[col("note")].is_empty());
    let under = rows.iter().find(|r| r[col("method")] == "under").unwrap();
    assert_eq!(under[col("status")], "ok");
}

#[test]
fn sweep_widths_writes_its_csv_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("w");
    let out = ok(&[
        "sweep-widths",
        "--scene",
        "sphere:12",
        "--size",
        "16x16",
        "--eye",
        "5.5,5.5,-10",
        "--alpha-bits",
        "8,12",
        "--accum-bits",
        "12-13",
        "--position-frac",
        "none",
        "--weight-bits",
        "none",
        "--color-frac",
        "none",
        "--sample-frac",
        "2",
        "--out-dir",
        o.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("narrowest"));
    let (header, rows) = read_csv(&o.join("widths.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    // Base, two alpha, two accumulator and one sample width.
    assert_eq!(rows.len(), 6);
    assert_eq!(rows[0][col("knob")], "base");
    assert_eq!(rows[0][col("total_bits")], "218");
    // The defaults stay within one grey level of golden er (README).
    assert!(rows[0][col("vs_er_max_abs_255")].parse::<f64>().unwrap() <= 1.0);
    let alpha8 = rows
        .iter()
        .find(|r| r[col("knob")] == "alpha bits" && r[col("value")] == "8")
        .unwrap();
    assert_eq!(alpha8[col("total_bits")], "214");
    for r in &rows {
        assert_eq!(r[col("status")], "ok", "{r:?}");
        assert!(r[col("vs_ref_rmse")].parse::<f64>().unwrap() >= 0.0);
    }
    assert_png(&o.join("widths.png"));
    assert!(o.join("widths.md").exists());
}

#[test]
fn bad_arguments_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    // Leaked so that argument lists can be built from static pieces.
    let o: &'static str = Box::leak(
        dir.path()
            .join("x")
            .to_string_lossy()
            .into_owned()
            .into_boxed_str(),
    );
    let base = [
        "bench",
        "--scene",
        "sphere:8",
        "--size",
        "8x8",
        "--out-dir",
        o,
    ];
    let with = |extra: &[&'static str]| {
        let mut v = base.to_vec();
        v.extend_from_slice(extra);
        v
    };
    fails(&with(&["--methods", "er,warp"]), "unknown method 'warp'");
    fails(&with(&["--methods", "er,er"]), "listed twice");
    fails(&with(&["--distances", "4,-1"]), "--distances");
    fails(&with(&["--distances", "4,x"]), "not a number");
    fails(
        &with(&["--distances", "4,8", "--fov", "90,80,70"]),
        "3 angles for 2 distances",
    );
    fails(&with(&["--fov", "200"]), "between 0 and 180");
    fails(&with(&["--frames", "0"]), "--frames");
    fails(
        &with(&["--distances", "4", "--slices-at", "5"]),
        "--slices-at",
    );
    fails(
        &with(&["--methods", "pipeline:/nonexistent.toml"]),
        "cannot read",
    );
    fails(&with(&["--report", o]), "--report");
    fails(&["bench", "--out-dir", o], "no volume");
    fails(
        &[
            "sweep-widths",
            "--scene",
            "sphere:8",
            "--alpha-bits",
            "12-8",
            "--out-dir",
            o,
        ],
        "runs backwards",
    );
    fails(
        &[
            "sweep-widths",
            "--scene",
            "sphere:8",
            "--weight-bits",
            "99",
            "--out-dir",
            o,
        ],
        "--weight-bits",
    );
}
