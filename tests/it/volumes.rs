//! Real volumes through the program: a DICOM series folder, `--window` in
//! the file's units, and `--space world` rendering the same head written
//! in four orientations by four tools (golden/tests/data/make_oriented.py)
//! to the same bytes.

use std::path::{Path, PathBuf};

use crate::bin::{assert_refused, describe, ercube};

fn data(name: &str) -> String {
    let p: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("golden/tests/data")
        .join(name);
    p.to_string_lossy().into_owned()
}

/// Voxels of the head are HU + 1000.
const HEAD_TF: &str = "[[point]]\nvalue = 900\nrgba = [0, 0, 0, 0]\n\n\
                       [[point]]\nvalue = 1040\nrgba = [0.8, 0.5, 0.4, 0.05]\n\n\
                       [[point]]\nvalue = 2000\nrgba = [1, 1, 1, 0.6]\n";

fn render_npy(dir: &Path, extra: &[&str]) -> Vec<u8> {
    let mut args = vec![
        "render", "--size", "32x32", "--out", "i.png", "--npy", "i.npy",
    ];
    args.extend_from_slice(extra);
    let out = ercube(dir, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    std::fs::read(dir.join("i.npy")).expect("npy written")
}

#[test]
fn the_head_from_anterior_is_the_same_image_in_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("head.toml"), HEAD_TF).unwrap();
    let mut images = Vec::new();
    for name in [
        "head_ras.nii",
        "head_perm.nrrd",
        "head_perm.mha",
        "head_coronal",
    ] {
        let vol = data(name);
        // The default world camera looks from anterior, head up.
        let img = render_npy(
            d,
            &[
                "--volume",
                &vol,
                "--space",
                "world",
                "--tf-file",
                "head.toml",
                "--method",
                "er",
            ],
        );
        images.push((name, img));
    }
    for (name, img) in &images[1..] {
        assert!(img == &images[0].1, "{name} differs from head_ras.nii");
    }
    // An explicit anterior eye in LPS (-y), head up (+z), is the default.
    let vol = data("head_perm.mha");
    let explicit = render_npy(
        d,
        &[
            "--volume",
            &vol,
            "--space",
            "world",
            "--tf-file",
            "head.toml",
            "--method",
            "er",
            "--look-at",
            "0,0,0",
            "--eye",
            "0,-48,0",
            "--up",
            "0,0,1",
        ],
    );
    // The default looks at the volume's centre from 2x its largest extent;
    // the head's centre is the world origin and 2 * 24 mm = 48 mm.
    assert!(explicit == images[0].1, "the explicit anterior eye differs");
    // In voxel space the files differ (they are stored differently).
    let a = render_npy(
        d,
        &["--volume", &data("head_ras.nii"), "--tf-file", "head.toml"],
    );
    let b = render_npy(
        d,
        &[
            "--volume",
            &data("head_perm.nrrd"),
            "--tf-file",
            "head.toml",
        ],
    );
    assert!(a != b);
}

#[test]
fn a_window_in_hounsfield_units_spreads_the_range() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A ramp over the 16-bit range: grey and opacity grow with the value.
    std::fs::write(
        d.join("ramp.toml"),
        "[[point]]\nvalue = 0\nrgba = [0, 0, 0, 0]\n\n\
         [[point]]\nvalue = 65535\nrgba = [1, 1, 1, 0.5]\n",
    )
    .unwrap();
    let vol = data("head_coronal");
    let plain = render_npy(d, &["--volume", &vol, "--tf-file", "ramp.toml"]);
    let narrow = render_npy(
        d,
        &[
            "--volume",
            &vol,
            "--tf-file",
            "ramp.toml",
            "--window",
            "0,100",
        ],
    );
    // Without a window the head spans 0..2000 of 65535 (HU + 1000): nearly
    // clear. Under 0,100 HU air is 0, brain (40 HU) 0.4 of the ramp and
    // the skull the top: far brighter.
    assert!(plain != narrow);
    let mean = |b: &[u8]| -> f64 {
        // .npy v1: magic, version, a little-endian u16 header length.
        let start = 10 + u16::from_le_bytes([b[8], b[9]]) as usize;
        let f: Vec<f32> = b[start..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        f.iter().map(|&v| v as f64).sum::<f64>() / f.len() as f64
    };
    assert!(
        mean(&narrow) > 5.0 * mean(&plain),
        "{} vs {}",
        mean(&narrow),
        mean(&plain)
    );
}

#[test]
fn bad_volumes_and_spaces_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let head = data("head_ras.nii");
    let j2k = data("dicom_j2k");
    let slice = data("dicom_u16/IM4416");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["--scene", "sphere:8", "--space", "world"],
            "--space world needs",
        ),
        (vec!["--volume", &j2k], "(JPEG 2000) is not supported"),
        (vec!["--volume", &slice], "give the folder"),
        (vec!["--volume", &head, "--window", "5,1"], "lo < hi"),
        (vec!["--volume", &head, "--window", "x"], "lo,hi"),
    ];
    for (extra, needle) in cases {
        let mut args = vec!["render", "--size", "8x8", "--out", "i.png"];
        args.extend_from_slice(&extra);
        assert_refused(&args, &ercube(d, &args), needle);
    }
}
