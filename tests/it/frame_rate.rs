//! One frame rate everywhere: `ercube cost`, `ercube explore` and `ercube
//! render --method pipeline` run the same frame (the same skipping) and
//! quote it at the same clock, so they print the same cycles and frames
//! per second for the same design, view and part.

use crate::bin::{describe, ercube};

const VIEW: [&str; 6] = ["--scene", "checker:32", "--eye", "16,16,-16", "--pes", "4"];

/// The `frame: ...` line a command printed.
fn frame_line(args: &[&str], out: &std::process::Output) -> String {
    assert!(out.status.success(), "{}", describe(args, out));
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .map(str::trim)
        .find_map(|l| l.strip_prefix("frame: "))
        .unwrap_or_else(|| panic!("no frame line: {}", describe(args, out)))
        .to_owned()
}

/// Explore's line for its one design, in the same words, from its CSV.
fn explore_line(dir: &std::path::Path, view: &[&str], extra: &[&str]) -> String {
    let mut args = vec!["explore"];
    args.extend_from_slice(view);
    args.extend_from_slice(&[
        "--mappings",
        "blocks",
        "--placements",
        "on-chip",
        "--migrations",
        "between-slices",
        "--out-dir",
        "ex",
    ]);
    args.extend_from_slice(extra);
    let out = ercube(dir, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let md = String::from_utf8_lossy(&out.stdout);
    assert!(md.contains("at 200 MHz (assumed clock)"), "{md}");
    let csv = std::fs::read_to_string(dir.join("ex/explore.csv")).expect("csv");
    let mut rows = csv.lines();
    let head: Vec<&str> = rows.next().expect("header").split(',').collect();
    let row: Vec<&str> = rows.next().expect("one design").split(',').collect();
    let col = |name: &str| row[head.iter().position(|h| *h == name).expect(name)];
    let cycles: u64 = col("cycles").parse().expect("cycles");
    let fps: f64 = col("fps").parse().expect("fps");
    format!("{cycles} cycles/frame, {fps:.1} frames/s at 200 MHz (assumed clock)")
}

/// The three commands' frame lines for `view`, with `skipping` options.
fn three_lines(d: &std::path::Path, view: &[&str], skipping: &[&str]) -> [String; 3] {
    let mut render = vec!["render", "--method", "pipeline", "--out", "r.png"];
    render.extend_from_slice(view);
    render.extend_from_slice(skipping);
    let r = frame_line(&render, &ercube(d, &render));
    let mut cost = vec!["cost", "--sweep-pes", "none", "--archs", "none"];
    cost.extend_from_slice(view);
    cost.extend_from_slice(skipping);
    let c = frame_line(&cost, &ercube(d, &cost));
    [r, c, explore_line(d, view, skipping)]
}

#[test]
fn cost_explore_and_render_agree_on_a_frame() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    for skipping in [&[][..], &["--no-skip-empty", "--no-cull"][..]] {
        let [r, c, e] = three_lines(d, &VIEW, skipping);
        assert_eq!(c, r, "cost against render, skipping {skipping:?}");
        assert_eq!(e, r, "explore against render, skipping {skipping:?}");
        assert!(r.ends_with("at 200 MHz (assumed clock)"), "{r}");
    }
    // Skipping changes the frame, so the comparison above is not vacuous.
    let mut a = vec!["cost", "--sweep-pes", "none", "--archs", "none"];
    a.extend_from_slice(&VIEW);
    let skipped = frame_line(&a, &ercube(d, &a));
    a.push("--no-skip-empty");
    let full = frame_line(&a, &ercube(d, &a));
    assert_ne!(skipped, full);
}

/// The case: brainsmall, 16 PEs, the default eye, skipping as
/// render does; the three commands print the same line (195,456 cycles,
/// 1,023.2 frames/s at 200 MHz). About 3 s.
#[test]
fn cost_explore_and_render_agree_on_brainsmall() {
    let Some(path) = crate::scenes::brainsmall() else {
        eprintln!("skipped: data/brainsmall.den is absent");
        return;
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let vol = path.to_string_lossy().into_owned();
    let view = ["--volume", vol.as_str(), "--pes", "16"];
    let [r, c, e] = three_lines(dir.path(), &view, &[]);
    assert_eq!(c, r, "cost against render");
    assert_eq!(e, r, "explore against render");
    assert!(r.ends_with("at 200 MHz (assumed clock)"), "{r}");
}
