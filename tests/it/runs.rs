//! Runs are all or nothing, and bad files and values are refused in one
//! line through the program: output paths checked before any work, files
//! outside a header's folder refused unless allowed, sizes and PE lists
//! checked against what exists.

use crate::bin::{assert_refused, ercube};

fn run(dir: &std::path::Path, args: &str) -> (Vec<String>, std::process::Output) {
    let argv: Vec<String> = args.split_whitespace().map(String::from).collect();
    let out = ercube(dir, &argv);
    (argv, out)
}

#[test]
fn a_run_with_an_unwritable_output_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("DIR")).unwrap();
    for (args, needle) in [
        (
            "render --scene checker:16 --size 16x16 --out a.png --stats DIR",
            "output DIR is a folder",
        ),
        (
            "render --scene checker:16 --size 16x16 --out b.png --npy missing/x.npy",
            "the folder missing does not exist",
        ),
        (
            "render --scene checker:16 --size 16x16 --method pipeline --out c.png --vcd no/t.vcd",
            "the folder no does not exist",
        ),
    ] {
        let (argv, out) = run(dir.path(), args);
        assert_refused(&argv, &out, needle);
    }
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["DIR"], "a refused run left files");
    // A good run writes all its outputs.
    let (_, out) = run(
        dir.path(),
        "render --scene checker:16 --size 16x16 --out a.png --npy a.npy --stats a.json --threads 1",
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in ["a.png", "a.npy", "a.json"] {
        assert!(dir.path().join(f).is_file(), "{f} missing");
    }
}

#[test]
fn a_header_naming_data_outside_its_folder_needs_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    std::fs::write(dir.path().join("v.raw"), vec![200u8; 8 * 8 * 8]).unwrap();
    let nhdr = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n\
                data file: ../v.raw\n";
    std::fs::write(sub.join("v.nhdr"), nhdr).unwrap();
    let args = "render --volume sub/v.nhdr --size 16x16 --out o.png";
    let (argv, out) = run(dir.path(), args);
    assert_refused(&argv, &out, "steps out with '..'");
    assert!(!dir.path().join("o.png").exists());
    let (_, out) = run(dir.path(), &format!("{args} --allow-outside-data"));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn sizes_spacings_and_pe_lists_beyond_range_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (args, needle) in [
        (
            "render --scene checker:16 --size 4294967297x16 --out o.png",
            "each side must be 1 to",
        ),
        (
            "render --scene checker:16 --size 16x16 --spacing 1e-30,1,1 --out o.png",
            "must be numbers from 1e-6 to 1e6",
        ),
        (
            "render --scene checker:16 --size 16x16 --method pipeline --pes 16 --vcd t.vcd --trace-pes 300 --out o.png",
            "--trace-pes 300: PE 300 outside the array of 16 PEs",
        ),
    ] {
        let (argv, out) = run(dir.path(), args);
        assert_refused(&argv, &out, needle);
        assert!(!dir.path().join("o.png").exists(), "{args}");
        assert!(!dir.path().join("t.vcd").exists(), "{args}");
    }
}

/// `animate` whose path fails part-way (the third eye sits on the look-at
/// point) leaves no frame behind and no output folder it made; an output
/// folder that was there keeps what it held and gains nothing.
#[test]
fn an_animation_that_fails_part_way_leaves_no_frames() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("eyes.txt"),
        "8,8,-30\n8,8,-28\n7.5,7.5,7.5\n8,8,-26\n",
    )
    .unwrap();
    let args = "animate --scene checker:16 --size 16x16 --path eyes.txt --look-at 7.5,7.5,7.5";
    let (argv, out) = run(dir.path(), &format!("{args} --out-dir fresh"));
    assert_refused(&argv, &out, "frame 2: look-at point equals the eye");
    assert!(
        !dir.path().join("fresh").exists(),
        "the failed run left its output folder"
    );
    std::fs::create_dir(dir.path().join("kept")).unwrap();
    std::fs::write(dir.path().join("kept/notes.txt"), "mine").unwrap();
    let (argv, out) = run(dir.path(), &format!("{args} --out-dir kept"));
    assert_refused(&argv, &out, "frame 2");
    let left: Vec<_> = std::fs::read_dir(dir.path().join("kept"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["notes.txt"], "the failed run left frames");
}
