//! `ercube explore`: the architecture sweep through the binary, its table
//! (CSV and Markdown) and plot, and its refusals.

use crate::bin::{assert_refused, describe, ercube};

/// The cycles of one frame of `checker:32` from `(16, 16, -16)` at `pes`
/// PEs with skipping, run directly.
fn direct_cycles(pes: u16) -> u64 {
    use golden::camera::Camera;
    use golden::render::Prepared;
    use golden::scenes::Scene;
    use golden::tf::Lut;
    use pipeline::config::PipelineConfig;
    let scene: Scene = "checker:32".parse().expect("scene");
    let vol = scene.build(1 << 30).expect("volume");
    let cfg = PipelineConfig {
        pes,
        ..PipelineConfig::default()
    };
    let lut = Lut::for_bits(
        &scene.preset(),
        cfg.table_entries as usize,
        vol.kind().bits(),
    );
    let cam = Camera::new(
        glam::DVec3::new(16.0, 16.0, -16.0),
        glam::DVec3::from_array(vol.center_world()),
        glam::DVec3::Y,
        60.0,
        256,
        256,
    )
    .expect("camera");
    let prep = Prepared::new(&vol, &cam).expect("view");
    pipeline::FrameRun::prepared(&cfg, &lut, &prep, pipeline::Voxels::Volume(&vol))
        .skips(golden::skip::Skips::default())
        .run()
        .expect("frame")
        .cycles
}

/// A tiny sweep (checker:32, two mappings, two placements, two PE counts)
/// writes one row per configuration in sweep order, the blocks/on-chip
/// rows with the cycles of a direct run, traffic only where the rays are
/// external, and the same table whatever the thread count.
#[test]
fn explore_runs_a_tiny_sweep() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let args = |threads: &str, out: &str| -> Vec<String> {
        [
            "explore",
            "--scene",
            "checker:32",
            "--eye",
            "16,16,-16",
            "--sweep-pes",
            "2,4",
            "--mappings",
            "blocks,cyclic",
            "--cyclic-widths",
            "4",
            "--migrations",
            "between-slices",
            "--threads",
            threads,
            "--out-dir",
            out,
        ]
        .iter()
        .map(|s| s.to_string())
        .collect()
    };
    let a = args("2", "one");
    let out = ercube(d, &a);
    assert!(out.status.success(), "{}", describe(&a, &out));
    let csv = std::fs::read_to_string(d.join("one/explore.csv")).expect("csv");
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let keys: Vec<(&str, &str, &str)> = rows.iter().map(|r| (r[0], r[2], r[3])).collect();
    assert_eq!(
        keys,
        vec![
            ("blocks", "on-chip", "2"),
            ("blocks", "on-chip", "4"),
            ("blocks", "external", "2"),
            ("blocks", "external", "4"),
            ("cyclic:4", "on-chip", "2"),
            ("cyclic:4", "on-chip", "4"),
            ("cyclic:4", "external", "2"),
            ("cyclic:4", "external", "4"),
        ]
    );
    let head: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).expect(name);
    let num = |r: &[&str], name: &str| -> f64 { r[col(name)].parse().expect(name) };
    assert_eq!(num(&rows[0], "cycles") as u64, direct_cycles(2));
    assert_eq!(num(&rows[1], "cycles") as u64, direct_cycles(4));
    for r in &rows {
        assert_eq!(r[1], "between-slices");
        let external = r[2] == "external";
        assert_eq!(num(r, "ray_bytes") > 0.0, external, "{r:?}");
        // The volume once per frame: 32^3 voxels of 12 bits.
        assert_eq!(num(r, "voxel_bytes"), 32.0 * 32.0 * 32.0 * 1.5);
        let fps = num(r, "fps");
        assert!((fps - 200e6 / num(r, "cycles")).abs() < 1e-3 * fps);
    }
    // The external placement trades the compositing buffer's memory for
    // the row buffers and the DDR4 interface's LUTs and flip-flops (at
    // 32^3 the interface's own block RAM outweighs the buffer's). The
    // on-chip row also carries the emitted sample stage's control
    // statements, which the external placement (not emitted) prices as
    // the described address step, some two thousand LUTs fewer at this
    // size: so its LUTs exceed the on-chip row's by more than half the
    // interface's, its flip-flops by at least the interface's.
    use pipeline::cost::arch::{MEMORY_CONTROLLER_FFS, MEMORY_CONTROLLER_LUTS};
    assert!(num(&rows[2], "on_chip_bits") < num(&rows[0], "on_chip_bits"));
    let more = |what: &str| num(&rows[2], what) - num(&rows[0], what);
    assert!(
        more("lut") > f64::from(MEMORY_CONTROLLER_LUTS) / 2.0,
        "{}",
        more("lut")
    );
    assert!(
        more("ff") >= f64::from(MEMORY_CONTROLLER_FFS),
        "{}",
        more("ff")
    );
    let md = std::fs::read_to_string(d.join("one/explore.md")).expect("markdown");
    assert_eq!(md.lines().filter(|l| l.starts_with("| blocks")).count(), 4);
    assert_eq!(
        md.lines().filter(|l| l.starts_with("| cyclic:4")).count(),
        4
    );
    // A summary line per part: the design of most frames/s among those
    // that fit it (the largest parts hold every design of this sweep).
    let summary = md.split("Best design per part").nth(1).expect("a summary");
    let lines: Vec<&str> = summary.lines().filter(|l| l.starts_with("- ")).collect();
    assert!(lines.len() >= 2, "{summary}");
    assert!(
        lines
            .iter()
            .any(|l| l.contains(" at P = ") && l.contains("frames/s")),
        "{summary}"
    );
    let png = std::fs::read(d.join("one/explore.png")).expect("plot");
    assert_eq!(&png[1..4], b"PNG");
    let b = args("1", "two");
    let out = ercube(d, &b);
    assert!(out.status.success(), "{}", describe(&b, &out));
    let again = std::fs::read_to_string(d.join("two/explore.csv")).expect("csv");
    assert_eq!(csv, again, "the table does not depend on the thread count");
}

/// Bad sweep options are one line naming the problem, before any run.
#[test]
fn explore_refuses_bad_options() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let cases: [(&[&str], &str); 12] = [
        (&["--sweep-pes", "0"], "--sweep-pes"),
        (&["--sweep-pes", "300"], "--sweep-pes"),
        // The older spelling is still accepted.
        (&["--pes", "4,,8"], "--sweep-pes"),
        (&["--sweep-pes", "64"], "64"),
        (&["--mappings", "stripes"], "stripes"),
        (&["--placements", "dram"], "dram"),
        (&["--migrations", "later"], "later"),
        (&["--widths", "0"], "--cyclic-widths"),
        (&["--lanes", "5"], "--lanes"),
        (&["--lanes", "1,,2"], "--lanes"),
        (&["--clock-mhz", "0"], "clock"),
        (&["--threads", "0"], "threads"),
    ];
    for (extra, needle) in cases {
        let mut args = vec!["explore", "--scene", "checker:32", "--out-dir", "x"];
        args.extend_from_slice(extra);
        if !extra.contains(&"--pes") && !extra.contains(&"--sweep-pes") {
            // The default sweep's 64 PEs are more than checker:32 has columns.
            args.extend_from_slice(&["--pes", "4"]);
        }
        let out = ercube(d, &args);
        assert_refused(&args, &out, needle);
    }
    assert!(!d.join("x").exists(), "nothing written for bad options");
}

/// Lanes sweep with the overlapped migration only: a between-slices row
/// runs one lane, each overlapped row its own (named `overlapped:2`), and
/// a second lane never adds cycles on this view.
#[test]
fn explore_sweeps_lanes_with_the_overlapped_migration() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let a: Vec<String> = [
        "explore",
        "--scene",
        "checker:32",
        "--eye",
        "16,16,-16",
        "--pes",
        "4",
        "--mappings",
        "interleave",
        "--migrations",
        "between-slices,overlapped",
        "--lanes",
        "1,2",
        "--placements",
        "on-chip",
        "--out-dir",
        "lanes",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let out = ercube(d, &a);
    assert!(out.status.success(), "{}", describe(&a, &out));
    let csv = std::fs::read_to_string(d.join("lanes/explore.csv")).expect("csv");
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let migrations: Vec<&str> = rows.iter().map(|r| r[1]).collect();
    assert_eq!(
        migrations,
        vec!["between-slices", "overlapped", "overlapped:2"]
    );
    let cycles: Vec<u64> = rows.iter().map(|r| r[4].parse().expect("cycles")).collect();
    assert!(cycles[2] <= cycles[1], "{cycles:?}");
}
