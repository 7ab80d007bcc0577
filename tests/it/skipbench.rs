//! `ercube skip-bench` through the binary: the pipeline rows on a given
//! configuration, with their utilisation, and a bad configuration refused.

use crate::bin::{assert_refused, describe, ercube};

/// With `--config`, the pipeline rows run that configuration: with 4 PEs
/// in it every row's utilisation is its samples over 4 PEs' worth of its
/// cycles, and the section names the architecture; a configuration that
/// does not validate is refused in one line before anything runs.
#[test]
fn skip_bench_runs_the_pipeline_rows_on_a_config() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    std::fs::write(
        d.join("arch.toml"),
        "pes = 4\nmapping = \"interleave\"\nmigration = \"overlapped\"\npass_skip_empty = true\nlink_lanes = 2\n",
    )
    .expect("config");
    let args = [
        "skip-bench",
        "--n",
        "16",
        "--frames",
        "1",
        "--brainsmall",
        "missing.den",
        "--config",
        "arch.toml",
        "--report",
        "out",
        "--threads",
        "2",
    ];
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let csv = std::fs::read_to_string(d.join("out/bench/skip/skip.csv")).expect("csv");
    let head: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).expect(name);
    let mut pipeline_rows = 0;
    for line in csv.lines().skip(1) {
        let r: Vec<&str> = line.split(',').collect();
        if !r[col("configuration")].starts_with("pipeline") {
            assert!(r[col("utilization")].is_empty(), "{line}");
            continue;
        }
        pipeline_rows += 1;
        let num = |name: &str| -> f64 { r[col(name)].parse().expect(name) };
        let (c, u, s) = (num("cycles"), num("utilization"), num("samples"));
        assert!(u > 0.0 && u <= 1.0, "{line}");
        assert!((u * 4.0 * c - s).abs() <= 1e-4 * 4.0 * c + 1.0, "{line}");
    }
    // Three synthetic scenes (brainsmall is missing) of six rows each.
    assert_eq!(pipeline_rows, 18);
    let md = std::fs::read_to_string(d.join("out/benchmarks.md")).expect("markdown");
    assert!(md.contains("--config arch.toml"), "{md}");
    assert!(
        md.contains("interleave/overlapped:2/on-chip, 4 PEs"),
        "{md}"
    );
    assert!(md.contains("brainsmall left out"), "{md}");

    std::fs::write(d.join("bad.toml"), "link_lanes = 2\n").expect("config");
    let bad = [
        "skip-bench",
        "--n",
        "16",
        "--frames",
        "1",
        "--config",
        "bad.toml",
        "--report",
        "never",
    ];
    let out = ercube(d, &bad);
    assert_refused(&bad, &out, "link_lanes");
    assert!(
        !d.join("never").exists(),
        "nothing written for a bad config"
    );
}
