//! Bad input: one line on stderr, a non-zero exit, no panic.

use super::{assert_one_line_error, entries, ercube, error_problems, tempdir};

/// Every malformed input of the contract exits non-zero with one line on
/// stderr naming the problem, and writes no image. All cases run before the
/// test fails, so one report lists every offender.
#[test]
fn bad_input_gives_one_line_errors() {
    let dir = tempdir();
    let d = dir.path();
    // Files for the loader and transfer-function cases.
    std::fs::write(d.join("short.raw"), [7u8; 100]).unwrap();
    std::fs::write(d.join("bad.toml"), "[[point]]\nvalue = \"x\"\n").unwrap();
    std::fs::write(d.join("junk.toml"), "garbage [[[").unwrap();
    std::fs::write(
        d.join("range.toml"),
        "[[point]]\nvalue = 0\nrgba = [1, 1, 1, 2]\n",
    )
    .unwrap();
    std::fs::write(d.join("bad.den"), [0xffu8; 62]).unwrap();
    std::fs::write(d.join("vol.xyz"), [0u8; 8]).unwrap();
    let before = entries(d);

    let s = "render --scene checker:16 --size 16x16";
    // (arguments after `ercube`, keyword the message must contain)
    let cases: Vec<(String, &str)> = vec![
        ("render --scene foo --size 16x16".into(), "scene"),
        ("render --scene sphere:x --size 16x16".into(), "scene"),
        ("render --scene checker:1 --size 16x16".into(), "size"),
        ("render --scene checker:16:0 --size 16x16".into(), "cube"),
        ("render --size 16x16".into(), "volume"),
        (format!("{s} --eye 1,2"), "eye"),
        (format!("{s} --eye a,b,c"), "eye"),
        (format!("{s} --fov abc"), "fov"),
        ("render --scene checker:16 --size 0x10".into(), "size"),
        (
            "render --scene checker:16 --size 100000x100000".into(),
            "size",
        ),
        ("render --scene checker:16 --size 10".into(), "size"),
        (format!("{s} --eye nan,0,0"), "finite"),
        (format!("{s} --fov NaN"), "field of view"),
        (format!("{s} --fov 0"), "field of view"),
        (format!("{s} --fov 180"), "field of view"),
        (format!("{s} --fov -5"), "field of view"),
        (format!("{s} --fov 200"), "field of view"),
        (
            format!("{s} --method pipeline --pes 4 --vcd w.vcd --trace-signals ctrl,bogus"),
            "signal group",
        ),
        (format!("{s} --block 3"), "block size"),
        (format!("{s} --block 128"), "block size"),
        (format!("{s} --clip 1,2,3"), "clip plane"),
        (format!("{s} --clip 0,0,0,1"), "clip plane"),
        (format!("{s} --clip 0,0,1,inf"), "clip plane"),
        (format!("{s} {}", "--clip 0,0,1,0 ".repeat(7)), "at most 6"),
        (format!("{s} --near 0"), "near"),
        (format!("{s} --near nan"), "near"),
        (format!("{s} --eye 3,4,-20 --look-at 3,4,-20"), "look-at"),
        // The default eye is straight in front of the volume along z.
        (format!("{s} --up 0,0,1"), "parallel"),
        (format!("{s} --up 0,0,0"), "up"),
        (
            "render --volume /nonexistent.den --size 16x16".into(),
            "nonexistent.den",
        ),
        (
            "render --volume short.raw --raw-dims 16,12,10 --size 16x16".into(),
            "truncated",
        ),
        (
            "render --volume short.raw --raw-dims 10,10,1 --raw-type f32 --size 16x16".into(),
            "raw",
        ),
        (
            "render --volume short.raw --raw-dims 0,10,10 --size 16x16".into(),
            "zero",
        ),
        ("render --volume bad.den --size 16x16".into(), "den"),
        ("render --volume vol.xyz --size 16x16".into(), "raw-dims"),
        (format!("{s} --tf-file bad.toml"), "transfer function"),
        (format!("{s} --tf-file junk.toml"), "transfer function"),
        (format!("{s} --tf-file range.toml"), "rgba"),
        (format!("{s} --tf-file missing.toml"), "missing.toml"),
        (format!("{s} --tf nope"), "preset"),
        (format!("{s} --method nope"), "method"),
        (format!("{s} --threads 0"), "threads"),
        (format!("{s} --terminate 2"), "terminat"),
        (format!("{s} --substeps 0"), "substeps"),
        (format!("{s} --image-plane sideways"), "image-plane"),
        (
            "compare --scene checker:16 --size 16x16 --methods er,nope --out-dir cmp".into(),
            "method",
        ),
        (
            "compare --scene checker:16 --size 16x16 --fov 0 --out-dir cmp".into(),
            "field of view",
        ),
    ];
    let mut failures = Vec::new();
    for (args, keyword) in &cases {
        // `render` gets an explicit output, which must not appear.
        let args = if args.starts_with("render") {
            format!("{args} --out o.png")
        } else {
            args.clone()
        };
        let run = ercube(d, &args);
        let mut problems = error_problems(&run, keyword);
        if entries(d) != before {
            problems.push(format!("left files behind: {:?}", entries(d)));
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{}\n    => {}",
                run.describe(),
                problems.join("; ")
            ));
        }
        // Start the next case from the same directory contents.
        for name in entries(d) {
            if !before.contains(&name) {
                let p = d.join(&name);
                if p.is_dir() {
                    std::fs::remove_dir_all(p).unwrap();
                } else {
                    std::fs::remove_file(p).unwrap();
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} bad inputs broke the error contract:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// A missing required argument is bad input like any other: the one line
/// must say which argument is missing. (`--raw-type` requires `--raw-dims`.)
#[test]
fn missing_required_argument_is_named() {
    let dir = tempdir();
    std::fs::write(dir.path().join("v.raw"), [0u8; 64]).unwrap();
    let run = ercube(
        dir.path(),
        "render --volume v.raw --raw-type u16le --size 16x16 --out o.png",
    );
    assert_one_line_error(&run, "raw-dims");
}

/// `--raw-dims` describes a `--volume` file; given with `--scene` it can
/// only be a mistake, and silently ignoring it hides the mistake.
#[test]
fn raw_flags_with_a_scene_are_refused() {
    let dir = tempdir();
    let run = ercube(
        dir.path(),
        "render --scene checker:16 --raw-dims 4,4,4 --size 16x16 --out o.png",
    );
    assert_one_line_error(&run, "raw-dims");
    assert!(!dir.path().join("o.png").exists());
}

/// File errors state the OS error once and name the user's path, not the
/// temporary file used for the atomic write. All three cases are checked
/// before the test fails.
#[test]
fn file_errors_are_stated_once() {
    let dir = tempdir();
    std::fs::create_dir(dir.path().join("adir")).unwrap();
    let cases = [
        (
            "render --volume /nonexistent.den --size 16x16 --out o.png",
            "/nonexistent.den",
            "No such file or directory",
        ),
        // Output paths are checked before any work, in the program's
        // words rather than the OS error's.
        (
            "render --scene checker:16 --size 16x16 --out nodir/o.png",
            "nodir/o.png",
            "does not exist",
        ),
        (
            "render --scene checker:16 --size 16x16 --out adir",
            "adir",
            "is a folder",
        ),
    ];
    let mut failures = Vec::new();
    for (args, path, os_error) in cases {
        let run = ercube(dir.path(), args);
        let mut problems = error_problems(&run, path);
        let err = run.stderr();
        if err.matches(os_error).count() != 1 {
            problems.push(format!("'{os_error}' is not stated exactly once"));
        }
        if err.contains(".tmp") {
            problems.push("names a temporary file".into());
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{}\n    => {}",
                run.describe(),
                problems.join("; ")
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
