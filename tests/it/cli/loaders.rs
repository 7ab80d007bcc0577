//! `render`'s volume loaders: raw, VolPack `.den` and NIfTI-1 `.nii`
//! files through the command line.

use std::path::Path;

use serde_json::Value;

use super::{ercube, ercube_args, read_json, read_rgba_npy, tempdir, volume_dims};

/// A small u8 test volume: a bright ball (200) in a faint gradient, so the
/// default grey-ramp transfer function shows structure and a mis-read
/// layout (wrong axis order, byte order or offset) changes the image.
fn ball(dims: [usize; 3]) -> Vec<u8> {
    let c = dims.map(|n| (n as f64 - 1.0) / 2.0);
    let mut v = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let d = ((x as f64 - c[0]).powi(2)
                    + (y as f64 - c[1]).powi(2)
                    + (z as f64 - c[2]).powi(2))
                .sqrt();
                v.push(if d < 3.5 { 200 } else { (x * 3 + y * 2) as u8 });
            }
        }
    }
    v
}

/// A VolPack `.den` file: the 62-byte little-endian header, then the voxels.
fn den_file(dims: [usize; 3], voxels: &[u8]) -> Vec<u8> {
    let d = dims.map(|n| n as i16);
    let mut b = Vec::new();
    b.extend(1i16.to_le_bytes()); // version
                                  // orig_min, orig_max, orig_len, extr_min, extr_max, extr_len,
                                  // map_min, map_max, map_len.
    let zero = [0i16; 3];
    let max = d.map(|n| n - 1);
    for triple in [zero, max, d, zero, max, d, zero, max, d] {
        for v in triple {
            b.extend(v.to_le_bytes());
        }
    }
    b.extend(0i16.to_le_bytes()); // map_warps
    b.extend((voxels.len() as i32).to_le_bytes()); // map_length
    assert_eq!(b.len(), 62);
    b.extend_from_slice(voxels);
    b
}

/// A single-file NIfTI-1 `.nii` of uint8 voxels with unit spacing: the
/// 348-byte header, the 4-byte extension flag, then the voxels at 352.
fn nifti_u8(dims: [usize; 3], voxels: &[u8]) -> Vec<u8> {
    let mut h = vec![0u8; 348];
    h[0..4].copy_from_slice(&348i32.to_le_bytes()); // sizeof_hdr
    let dim = [
        3,
        dims[0] as i16,
        dims[1] as i16,
        dims[2] as i16,
        1,
        1,
        1,
        1,
    ];
    for (k, d) in dim.iter().enumerate() {
        h[40 + 2 * k..42 + 2 * k].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&2i16.to_le_bytes()); // datatype: uint8
    h[72..74].copy_from_slice(&8i16.to_le_bytes()); // bitpix
    for k in 0..8 {
        h[76 + 4 * k..80 + 4 * k].copy_from_slice(&1.0f32.to_le_bytes()); // pixdim
    }
    h[108..112].copy_from_slice(&352.0f32.to_le_bytes()); // vox_offset
    h[112..116].copy_from_slice(&1.0f32.to_le_bytes()); // scl_slope
    h[344..348].copy_from_slice(b"n+1\0");
    h.extend([0u8; 4]);
    h.extend_from_slice(voxels);
    h
}

/// Renders `volume_args` with stats and an `.npy`, returning both.
#[track_caller]
fn render_file(dir: &Path, volume_args: &str, tag: &str) -> (Value, Vec<u8>) {
    ercube(
        dir,
        &format!(
            "render {volume_args} --size 24x24 --stats {tag}.json --npy {tag}.npy --out {tag}.png"
        ),
    )
    .ok();
    (
        read_json(&dir.join(format!("{tag}.json"))),
        std::fs::read(dir.join(format!("{tag}.npy"))).unwrap(),
    )
}

/// Raw u8 with a header offset, VolPack `.den` and NIfTI-1 `.nii` holding
/// the same voxels load to the same dimensions and render the same bits;
/// raw u16 in either byte order renders the same as the other.
#[test]
fn loaders_through_the_cli() {
    let dir = tempdir();
    let d = dir.path();
    let dims = [16, 12, 10];
    let vox = ball(dims);

    // Raw u8 after a 7-byte header we ask the loader to skip.
    let mut raw = b"HEADER!".to_vec();
    raw.extend_from_slice(&vox);
    std::fs::write(d.join("vol.raw"), &raw).unwrap();
    let (s_raw, img_raw) = render_file(
        d,
        "--volume vol.raw --raw-dims 16,12,10 --raw-type u8 --raw-offset 7",
        "raw",
    );
    assert_eq!(volume_dims(&s_raw), [16, 12, 10]);
    let vals = read_rgba_npy(&d.join("raw.npy"), 24, 24);
    assert!(
        vals.iter().any(|&v| v > 0.05),
        "raw u8 volume renders black"
    );

    std::fs::write(d.join("vol.den"), den_file(dims, &vox)).unwrap();
    let (s_den, img_den) = render_file(d, "--volume vol.den", "den");
    assert_eq!(volume_dims(&s_den), [16, 12, 10]);
    assert!(
        img_den == img_raw,
        ".den and raw u8 of the same voxels differ"
    );

    std::fs::write(d.join("vol.nii"), nifti_u8(dims, &vox)).unwrap();
    let (s_nii, img_nii) = render_file(d, "--volume vol.nii", "nii");
    assert_eq!(volume_dims(&s_nii), [16, 12, 10]);
    assert!(
        img_nii == img_raw,
        ".nii and raw u8 of the same voxels differ"
    );

    // 16-bit raw, both byte orders, values 0..=200 scaled to span the range.
    let wide: Vec<u16> = vox.iter().map(|&v| v as u16 * 300).collect();
    let le: Vec<u8> = wide.iter().flat_map(|v| v.to_le_bytes()).collect();
    let be: Vec<u8> = wide.iter().flat_map(|v| v.to_be_bytes()).collect();
    std::fs::write(d.join("le.raw"), le).unwrap();
    std::fs::write(d.join("be.raw"), be).unwrap();
    let (s_le, img_le) = render_file(
        d,
        "--volume le.raw --raw-dims 16,12,10 --raw-type u16le",
        "le",
    );
    let (s_be, img_be) = render_file(
        d,
        "--volume be.raw --raw-dims 16,12,10 --raw-type u16be",
        "be",
    );
    assert_eq!(volume_dims(&s_le), [16, 12, 10]);
    assert_eq!(volume_dims(&s_be), [16, 12, 10]);
    let vals = read_rgba_npy(&d.join("le.npy"), 24, 24);
    assert!(
        vals.iter().any(|&v| v > 0.05),
        "raw u16 volume renders black"
    );
    // A byte-order mix-up would read different values and change the image.
    assert!(
        img_le == img_be,
        "u16le and u16be of the same values differ"
    );
}

/// The real `brainsmall.den` loads as a `.den` and, with its header skipped,
/// as raw bytes: same dimensions, same image.
#[test]
fn brainsmall_as_den_and_as_raw() {
    let Some(path) = crate::scenes::brainsmall() else {
        eprintln!("note: data/brainsmall.den absent, skipping");
        return;
    };
    let dir = tempdir();
    let path = path.to_string_lossy().into_owned();
    let mut runs = Vec::new();
    for (tag, extra) in [
        ("den", vec![]),
        (
            "raw",
            vec!["--raw-dims", "128,128,84", "--raw-offset", "62"],
        ),
    ] {
        let mut args: Vec<String> = ["render", "--volume", &path]
            .iter()
            .map(|s| s.to_string())
            .collect();
        args.extend(extra.iter().map(|s| s.to_string()));
        for a in [
            "--size",
            "32x32",
            "--stats",
            &format!("{tag}.json"),
            "--npy",
            &format!("{tag}.npy"),
            "--out",
            &format!("{tag}.png"),
        ] {
            args.push(a.to_string());
        }
        ercube_args(dir.path(), args).ok();
        let s = read_json(&dir.path().join(format!("{tag}.json")));
        assert_eq!(volume_dims(&s), [128, 128, 84], "{tag}");
        let vals = read_rgba_npy(&dir.path().join(format!("{tag}.npy")), 32, 32);
        assert!(
            vals.iter().any(|&v| v > 0.05),
            "{tag}: the brain renders black"
        );
        runs.push(std::fs::read(dir.path().join(format!("{tag}.npy"))).unwrap());
    }
    assert!(runs[0] == runs[1], "brainsmall as .den and as raw differ");
}
