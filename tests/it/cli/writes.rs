//! Atomic writes: a failed run leaves nothing behind, a successful one
//! replaces its outputs whole.

use super::{assert_one_line_error, entries, ercube, read_json, read_png, read_rgba_npy, tempdir};

/// Failed writes leave nothing behind: no output, no temporary file, no
/// created directory; an existing output survives a failed run untouched.
#[test]
fn failed_writes_leave_no_partial_files() {
    let dir = tempdir();
    let d = dir.path();

    // Output into a directory that does not exist.
    let run = ercube(
        d,
        "render --scene checker:16 --size 16x16 --out nodir/o.png",
    );
    assert_one_line_error(&run, "nodir");
    assert!(entries(d).is_empty(), "left behind: {:?}", entries(d));

    // Output path that is a directory: it stays an empty directory.
    std::fs::create_dir(d.join("adir")).unwrap();
    let run = ercube(d, "render --scene checker:16 --size 16x16 --out adir");
    assert_one_line_error(&run, "adir");
    assert!(d.join("adir").is_dir());
    assert!(entries(&d.join("adir")).is_empty());
    assert_eq!(entries(d), ["adir"], "stray files");

    // The same for the stats and npy writers, which run after the PNG.
    for flag in ["--stats", "--npy"] {
        let run = ercube(
            d,
            &format!("render --scene checker:16 --size 16x16 --out ok.png {flag} adir"),
        );
        assert_one_line_error(&run, "adir");
        assert!(entries(&d.join("adir")).is_empty());
        assert!(
            entries(d).iter().all(|n| n == "adir" || n == "ok.png"),
            "{flag}: stray files {:?}",
            entries(d)
        );
    }

    // An existing output is not truncated by a run that fails.
    std::fs::write(d.join("keep.png"), b"precious").unwrap();
    let run = ercube(
        d,
        "render --scene checker:16 --size 16x16 --fov 0 --out keep.png",
    );
    assert_one_line_error(&run, "field of view");
    assert_eq!(std::fs::read(d.join("keep.png")).unwrap(), b"precious");
}

/// A successful run replaces an existing output whole and leaves no
/// temporary files.
#[test]
fn successful_writes_replace_outputs_cleanly() {
    let dir = tempdir();
    let d = dir.path();
    std::fs::write(d.join("o.png"), vec![b'x'; 100_000]).unwrap();
    ercube(
        d,
        "render --scene sphere:16 --size 16x16 --out o.png --npy o.npy --stats o.json",
    )
    .ok();
    // A truncating in-place write of a shorter file would leave x's or fail
    // to decode.
    assert_eq!(read_png(&d.join("o.png")).dimensions(), (16, 16));
    read_rgba_npy(&d.join("o.npy"), 16, 16);
    read_json(&d.join("o.json"));
    assert_eq!(entries(d), ["o.json", "o.npy", "o.png"]);
}

/// Outputs are ordinary files: their permissions follow the umask like any
/// other file the user creates, rather than the 0600 of a temporary file.
#[cfg(unix)]
#[test]
fn outputs_have_ordinary_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempdir();
    let d = dir.path();
    ercube(
        d,
        "render --scene sphere:16 --size 16x16 --out o.png --stats o.json",
    )
    .ok();
    // What this process's umask gives a newly created file.
    std::fs::write(d.join("plain"), b"").unwrap();
    let mode = |n: &str| std::fs::metadata(d.join(n)).unwrap().permissions().mode() & 0o777;
    for name in ["o.png", "o.json"] {
        assert_eq!(
            format!("{:o}", mode(name)),
            format!("{:o}", mode("plain")),
            "{name}: permissions differ from a plainly created file"
        );
    }
}
