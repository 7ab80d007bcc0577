//! `ercube peer vtk` (docs/peers.md): VTK renders the same view as ercube.
//! The tests that need VTK run when a Python with `vtk` and `numpy` can be
//! found (the script's venv `bench/peers/.venv`, else `python3`); otherwise
//! they print one line and pass, whatever `ERCUBE_REQUIRE_TOOLS` says (CI
//! has no VTK venv), unless `ERCUBE_REQUIRE_VTK=1`, which makes a missing
//! VTK a failure.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::bin::{describe, ercube, read_npy};

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/peers/vtk.py")
}

/// Writes the 24^3 volume holding one bright voxel at high x, low y
/// (left of centre, low in the image) as `dir/v.raw`; returns the
/// arguments that read it and the camera that sees it.
fn one_voxel_view(dir: &Path) -> [&'static str; 10] {
    let n = 24;
    let mut vox = vec![0u8; n * n * n];
    vox[(12 * n + 7) * n + 17] = 255;
    std::fs::write(dir.join("v.raw"), &vox).unwrap();
    [
        "peer",
        "vtk",
        "--volume",
        "v.raw",
        "--raw-dims",
        "24,24,24",
        "--eye",
        "11.5,11.5,-24",
        "--fov",
        "60",
    ]
}

/// `ercube` arguments `head`, then the peer's Python `py` and this
/// repository's script.
fn peer_args(head: &[&str], py: &Path) -> Vec<String> {
    let mut args: Vec<String> = head.iter().map(|s| s.to_string()).collect();
    args.push("--python".into());
    args.push(py.to_string_lossy().into_owned());
    args.push("--script".into());
    args.push(script().to_string_lossy().into_owned());
    args
}

/// A Python that imports vtk and numpy, or `None` (said on stderr) to skip.
fn vtk_python(what: &str) -> Option<PathBuf> {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/peers/.venv/bin/python");
    for py in [venv, PathBuf::from("python3")] {
        let ok = Command::new(&py)
            .args(["-c", "import vtkmodules.vtkRenderingVolume, numpy"])
            .output()
            .is_ok_and(|o| o.status.success());
        if ok {
            return Some(py);
        }
    }
    if std::env::var("ERCUBE_REQUIRE_VTK").as_deref() == Ok("1") {
        panic!("no Python with vtk and numpy and ERCUBE_REQUIRE_VTK=1: run python3 bench/peers/vtk.py --self-test once (it makes bench/peers/.venv)");
    }
    let _ = writeln!(
        std::io::stderr(),
        "skipped {what}: no Python with vtk and numpy (python3 bench/peers/vtk.py --self-test makes bench/peers/.venv; ERCUBE_REQUIRE_VTK=1 makes this a failure)"
    );
    None
}

/// Brightness-weighted centre (column, row) of an image.
fn centroid(h: usize, w: usize, v: &[f32]) -> (f64, f64) {
    let (mut s, mut si, mut sj) = (0.0, 0.0, 0.0);
    for j in 0..h {
        for i in 0..w {
            let p = &v[(j * w + i) * 4..(j * w + i) * 4 + 3];
            let l = f64::from(p[0] + p[1] + p[2]);
            s += l;
            si += l * i as f64;
            sj += l * j as f64;
        }
    }
    assert!(s > 0.0, "the image is black");
    (si / s, sj / s)
}

#[test]
fn the_script_puts_a_bright_voxel_where_ercubes_camera_does() {
    let Some(py) = vtk_python("the VTK convention self-test") else {
        return;
    };
    let out = Command::new(&py)
        .arg(script())
        .arg("--self-test")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("\"self_test\": \"pass\""),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn peer_vtk_renders_the_same_view_on_a_tiny_volume() {
    let Some(py) = vtk_python("ercube peer vtk") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let view = one_voxel_view(dir.path());
    let args = peer_args(
        &[
            &view[..],
            &[
                "--size",
                "64x64",
                "--methods",
                "reference,er,er-ftb:2",
                "--frames",
                "1",
                "--threads",
                "2",
                "--out-dir",
                "out",
            ],
        ]
        .concat(),
        &py,
    );
    let out = ercube(dir.path(), &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let o = dir.path().join("out");
    for f in [
        "peer.csv",
        "peer.json",
        "summary.md",
        "error_vs_time.png",
        "montage.png",
        "vtk.png",
    ] {
        assert!(o.join(f).is_file(), "no {f}");
    }
    let csv = std::fs::read_to_string(o.join("peer.csv")).unwrap();
    let methods: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(methods, ["er", "er-ftb:2", "vtk", "reference"], "{csv}");
    let vtk_rmse: f64 = csv
        .lines()
        .find(|l| l.starts_with("vtk,"))
        .and_then(|l| l.split(',').nth(5))
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        vtk_rmse < 0.02,
        "VTK is {vtk_rmse} RMSE from the reference\n{csv}"
    );
    let (h, w, r) = read_npy(&o.join("reference.npy"));
    let (h2, w2, v) = read_npy(&o.join("vtk.npy"));
    assert_eq!((h, w), (h2, w2));
    let (cr, cv) = (centroid(h, w, &r), centroid(h, w, &v));
    assert!(
        cr.0 < w as f64 / 2.0 && cr.1 > h as f64 / 2.0,
        "reference at {cr:?}"
    );
    assert!(
        (cr.0 - cv.0).abs() < 0.5 && (cr.1 - cv.1).abs() < 0.5,
        "the bright voxel is at {cr:?} in ercube's reference, {cv:?} in VTK's image"
    );
}

/// `--views all`: every view in its folder and one table of all, VTK
/// near ercube's reference on each (the oblique view's eye has negative
/// coordinates, which reach the script as `--eye=...`).
#[test]
fn peer_vtk_renders_every_view() {
    let Some(py) = vtk_python("ercube peer vtk --views all") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let view = one_voxel_view(dir.path());
    let args = peer_args(
        &[
            &view[..],
            &[
                "--size",
                "48x48",
                "--methods",
                "reference,er-ftb",
                "--views",
                "all",
                "--frames",
                "1",
                "--threads",
                "2",
                "--out-dir",
                "out",
            ],
        ]
        .concat(),
        &py,
    );
    let out = ercube(dir.path(), &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let o = dir.path().join("out");
    for v in ["front", "oblique", "near", "far"] {
        assert!(o.join(v).join("peer.csv").is_file(), "no {v}/peer.csv");
    }
    assert!(o.join("views.md").is_file());
    let csv = std::fs::read_to_string(o.join("views.csv")).unwrap();
    let vtk: Vec<(&str, f64)> = csv
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(1) == Some("vtk"))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0], f[6].parse().unwrap())
        })
        .collect();
    assert_eq!(vtk.len(), 4, "{csv}");
    for (view, rmse) in vtk {
        assert!(
            rmse < 0.02,
            "{view}: VTK is {rmse} RMSE from the reference\n{csv}"
        );
    }
}

/// `--shade`: VTK shades with ercube's material and headlight, and its
/// image is an independent check of ercube's shading: much nearer
/// ercube's shaded reference than its unshaded one (on ml:32 about 0.06
/// against 0.44 RMSE), and the report says the run was shaded.
#[test]
fn peer_vtk_shades_like_ercube() {
    let Some(py) = vtk_python("ercube peer vtk --shade") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let run = |out: &str, shade: bool| {
        let mut args = peer_args(
            &[
                "peer",
                "vtk",
                "--scene",
                "ml:32",
                "--size",
                "64x64",
                "--methods",
                "reference,er-ftb",
                "--frames",
                "1",
                "--threads",
                "2",
                "--out-dir",
                out,
            ],
            &py,
        );
        if shade {
            args.push("--shade".into());
        }
        let o = ercube(dir.path(), &args);
        assert!(o.status.success(), "{}", describe(&args, &o));
        dir.path().join(out)
    };
    let (shaded, flat) = (run("shaded", true), run("flat", false));
    let json = std::fs::read_to_string(shaded.join("peer.json")).unwrap();
    assert!(json.contains("shaded alike: Blinn-Phong"), "{json}");
    let rgb_rmse = |a: &[f32], b: &[f32]| {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for (pa, pb) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
            for c in 0..3 {
                sum += f64::from(pa[c] - pb[c]).powi(2);
                n += 1;
            }
        }
        (sum / n as f64).sqrt()
    };
    let vtk = read_npy(&shaded.join("vtk.npy")).2;
    let ours = read_npy(&shaded.join("reference.npy")).2;
    let unshaded = read_npy(&flat.join("reference.npy")).2;
    let (near, far) = (rgb_rmse(&vtk, &ours), rgb_rmse(&vtk, &unshaded));
    assert!(
        near < 0.5 * far,
        "VTK's shaded image is {near} RMSE from ercube's shaded reference and {far} from its unshaded one"
    );
}

#[test]
fn a_missing_python_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "peer",
        "vtk",
        "--scene",
        "impulse:8",
        "--size",
        "8x8",
        "--methods",
        "er",
        "--frames",
        "1",
        "--out-dir",
        "out",
        "--python",
        "/nonexistent/python3",
    ];
    let out = ercube(dir.path(), &args);
    assert_eq!(out.status.code(), Some(2), "{}", describe(&args, &out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("peer vtk: cannot run /nonexistent/python3"),
        "{err}"
    );
}
