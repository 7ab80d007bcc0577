//! One vocabulary across commands: the same option names, meanings and
//! defaults, help grouped under headings, every subcommand listed, sample
//! data in the repository and no default that writes into its own files.

use super::{entries, ercube, tempdir};

/// The top-level help names every subcommand, in its list and its about
/// line.
#[test]
fn the_top_level_help_lists_every_subcommand() {
    let dir = tempdir();
    let help = ercube(dir.path(), "--help").ok().stdout();
    let (about, list) = help.split_once("Commands:").expect("a command list");
    for cmd in [
        "render",
        "compare",
        "demo",
        "animate",
        "bench",
        "merge-results",
        "sweep-widths",
        "cost",
        "explore",
        "peer",
        "skip-bench",
    ] {
        assert!(
            list.lines()
                .any(|l| l.trim_start().starts_with(&format!("{cmd} "))),
            "{cmd} listed:\n{help}"
        );
        assert!(about.contains(cmd), "{cmd} in the about line:\n{help}");
    }
}

/// `render -h` groups its options under headings.
#[test]
fn render_help_is_grouped_under_headings() {
    let dir = tempdir();
    let help = ercube(dir.path(), "render --help").ok().stdout();
    let headings: Vec<&str> = help
        .lines()
        .filter(|l| l.ends_with(':') && !l.starts_with(' '))
        .collect();
    for h in [
        "Volume:",
        "Camera:",
        "Transfer function:",
        "Rendering:",
        "Pipeline:",
        "Waveforms:",
    ] {
        assert!(headings.contains(&h), "{h} in {headings:?}");
    }
    let waves = help.split("Waveforms:").nth(1).unwrap();
    assert!(
        waves.contains("--trace-pes") && waves.contains("regs"),
        "{waves}"
    );
}

/// `cost` writes its report with --stats as every command does (--json
/// is kept as an older spelling), and refuses to run without a source as
/// `render` does.
#[test]
fn cost_speaks_as_the_other_commands() {
    let dir = tempdir();
    let d = dir.path();
    let base = "cost --scene checker:16 --eye 8,8,-8 --pes 2 --sweep-pes none --archs none";
    ercube(d, &format!("{base} --stats a.json")).ok();
    ercube(d, &format!("{base} --json b.json")).ok();
    let (a, b) = (
        super::read_json(&d.join("a.json")),
        super::read_json(&d.join("b.json")),
    );
    assert_eq!(a["cycles"], b["cycles"], "one report either way");
    for (cmd, needle) in [
        ("cost", "--scene"),
        ("render", "--scene"),
        ("explore", "--scene"),
    ] {
        let run = ercube(d, cmd);
        crate::bin::assert_refused(&run.args, &run.out, needle);
    }
}

/// `bench` draws on the camera's image plane by default, as every other
/// command; its report's brainsmall default is the repository's copy.
#[test]
fn defaults_agree_across_commands() {
    let dir = tempdir();
    let d = dir.path();
    for cmd in ["render", "compare", "bench", "animate", "explore", "cost"] {
        let help = ercube(d, &format!("{cmd} --help")).ok().stdout();
        let plane = help
            .split("--image-plane")
            .nth(1)
            .unwrap_or_else(|| panic!("{cmd} has --image-plane"));
        let plane = &plane[..plane.find("\n      --").unwrap_or(plane.len())];
        assert!(plane.contains("[default: camera]"), "{cmd}: {plane}");
    }
    for cmd in ["bench", "skip-bench"] {
        let help = ercube(d, &format!("{cmd} --help")).ok().stdout();
        assert!(
            help.contains("[default: data/brainsmall.den]"),
            "{cmd}: {help}"
        );
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let den = root.join("data/brainsmall.den");
    assert_eq!(
        std::fs::metadata(&den).map(|m| m.len()).ok(),
        Some(62 + 128 * 128 * 84)
    );
    let readme = std::fs::read_to_string(root.join("data/README.md")).unwrap();
    assert!(readme.contains("VolPack"), "the sample's provenance");
}

/// `skip-bench` run from a folder writes its report under ./skip-bench,
/// never ./docs, so a run from a clone's root leaves the project's report
/// alone.
#[test]
fn skip_bench_writes_nothing_into_docs_by_default() {
    let dir = tempdir();
    let d = dir.path();
    ercube(d, "skip-bench --n 16 --frames 1 --no-pipeline --threads 1").ok();
    assert_eq!(entries(d), ["skip-bench"]);
    assert!(d.join("skip-bench/benchmarks.md").is_file());
}

/// The demo's and compare's table says what its error figure is.
#[test]
fn compare_names_its_error_metric() {
    let dir = tempdir();
    let out = ercube(
        dir.path(),
        "compare --scene checker:16 --size 16x16 --methods er,reference --out-dir c",
    )
    .ok()
    .stdout();
    assert!(
        out.contains("rmse: root-mean-square error against the reference"),
        "{out}"
    );
    let ignore =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/.gitignore")).unwrap();
    for d in [
        "/ercube-demo/",
        "/compare/",
        "/explore/",
        "/skip-bench/",
        "/bench-results/",
    ] {
        assert!(ignore.lines().any(|l| l == d), "{d} ignored");
    }
}
