//! Transfer functions over the data's range: a preset keeps its meaning on
//! 8-bit data and spans the value range of 16-bit data (or the window), so
//! a 16-bit twin of an 8-bit volume renders like it; a table that shows
//! none or all of a volume draws a one-line warning.

use std::path::Path;

use super::{ercube, read_npy, tempdir};

/// brainsmall's voxels stretched to span 0..=255 (an 8-bit MR head whose
/// values use the whole byte), and its dimensions.
fn mr_twin() -> Option<(Vec<u8>, [usize; 3])> {
    let path = crate::scenes::brainsmall()?;
    let bytes = std::fs::read(path).expect("brainsmall reads");
    let v = &bytes[62..];
    let hi = f64::from(*v.iter().max().unwrap());
    let twin = v
        .iter()
        .map(|&x| (f64::from(x) * 255.0 / hi).round() as u8)
        .collect();
    Some((twin, [128, 128, 84]))
}

/// A CT-like phantom in 8 bits: air 0, a soft-tissue ball 90 in a bone
/// shell 255, with a partial-volume ramp, spanning 0..=255.
fn ct_twin() -> (Vec<u8>, [usize; 3]) {
    let n = 40usize;
    let c = (n as f64 - 1.0) / 2.0;
    let mut v = Vec::with_capacity(n * n * n);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let d = ((x as f64 - c).powi(2) + (y as f64 - c).powi(2) + (z as f64 - c).powi(2))
                    .sqrt();
                v.push(match d {
                    d if d < 12.0 => 90,
                    d if d < 15.0 => 255,
                    d if d < 16.0 => ((16.0 - d) * 255.0).round() as u8,
                    _ => 0,
                });
            }
        }
    }
    (v, [n, n, n])
}

/// A single-file NIfTI-1 of int16 voxels (datatype 4) with unit spacing.
fn nifti_i16(dims: [usize; 3], voxels: &[i16]) -> Vec<u8> {
    let mut h = vec![0u8; 348];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
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
    h[70..72].copy_from_slice(&4i16.to_le_bytes()); // int16
    h[72..74].copy_from_slice(&16i16.to_le_bytes()); // bitpix
    for k in 0..8 {
        h[76 + 4 * k..80 + 4 * k].copy_from_slice(&1.0f32.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352.0f32.to_le_bytes()); // vox_offset
    h[112..116].copy_from_slice(&1.0f32.to_le_bytes()); // scl_slope
    h[344..348].copy_from_slice(b"n+1\0");
    h.extend([0u8; 4]);
    h.extend(voxels.iter().flat_map(|v| v.to_le_bytes()));
    h
}

/// Renders with `args` into `tag.npy` and returns its RGBA values.
#[track_caller]
fn render(dir: &Path, args: &str, tag: &str) -> Vec<f32> {
    ercube(
        dir,
        &format!("render {args} --size 64x64 --npy {tag}.npy --out {tag}.png"),
    )
    .ok();
    read_npy(&dir.join(format!("{tag}.npy"))).values
}

fn rmse(a: &[f32], b: &[f32]) -> f64 {
    let s: f64 = a.iter().zip(b).map(|(x, y)| f64::from(x - y).powi(2)).sum();
    (s / a.len() as f64).sqrt()
}

fn mean_alpha(v: &[f32]) -> f64 {
    v.chunks(4).map(|p| f64::from(p[3])).sum::<f64>() / (v.len() / 4) as f64
}

/// An MR head written as u16 (values x 200 + 1000, the file's own range)
/// renders with every preset like its 8-bit twin, and so does a window
/// onto that range; before, every voxel above the preset's raw 8-bit
/// values was opaque and the image a solid block.
#[test]
fn a_16_bit_mr_head_renders_like_its_8_bit_twin() {
    let Some((twin, d)) = mr_twin() else {
        eprintln!("skipped: data/brainsmall.den is absent");
        return;
    };
    let dir = tempdir();
    let p = dir.path();
    std::fs::write(p.join("mr8.raw"), &twin).unwrap();
    let wide: Vec<u8> = twin
        .iter()
        .flat_map(|&v| (u16::from(v) * 200 + 1000).to_le_bytes())
        .collect();
    std::fs::write(p.join("mr16.raw"), wide).unwrap();
    let dims = format!("--raw-dims {},{},{}", d[0], d[1], d[2]);
    let view = "--eye 64,64,-64 --fov 90";
    for tf in ["grey-ramp", "brain", "brain-shaded"] {
        let a = render(p, &format!("--volume mr8.raw {dims} {view} --tf {tf}"), "a");
        let b = render(
            p,
            &format!("--volume mr16.raw {dims} --raw-type u16le {view} --tf {tf}"),
            "b",
        );
        assert!(mean_alpha(&a) > 0.05, "{tf}: the 8-bit head shows");
        let e = rmse(&a, &b);
        assert!(e < 2e-3, "{tf}: 16-bit twin differs by rmse {e}");
        let w = render(
            p,
            &format!(
                "--volume mr16.raw {dims} --raw-type u16le {view} --tf {tf} --window 1000,52000"
            ),
            "w",
        );
        let e = rmse(&a, &w);
        assert!(
            e < 2e-3,
            "{tf}: the window onto the data's range differs by rmse {e}"
        );
    }
}

/// A CT-like volume in Hounsfield units (NIfTI int16, -1024 and up, which
/// the loader offsets to 0) renders like its 8-bit twin.
#[test]
fn a_16_bit_ct_volume_renders_like_its_8_bit_twin() {
    let (twin, d) = ct_twin();
    let dir = tempdir();
    let p = dir.path();
    std::fs::write(p.join("ct8.raw"), &twin).unwrap();
    let hu: Vec<i16> = twin.iter().map(|&v| i16::from(v) * 12 - 1024).collect();
    std::fs::write(p.join("ct16.nii"), nifti_i16(d, &hu)).unwrap();
    let view = "--eye 19.5,19.5,-40 --fov 60";
    for tf in ["grey-ramp", "impulse", "sphere"] {
        let a = render(
            p,
            &format!("--volume ct8.raw --raw-dims 40,40,40 {view} --tf {tf}"),
            "a",
        );
        let b = render(p, &format!("--volume ct16.nii {view} --tf {tf}"), "b");
        assert!(mean_alpha(&a) > 0.05, "{tf}: the 8-bit phantom shows");
        let e = rmse(&a, &b);
        assert!(e < 2e-3, "{tf}: 16-bit twin differs by rmse {e}");
    }
}

/// On 8-bit data a preset is exactly its raw table: a TOML file of the
/// same points without `fit` renders the same bits; with `fit = [0, 1]`
/// and the values divided by 255, too.
#[test]
fn presets_keep_their_meaning_on_8_bit_data() {
    let dir = tempdir();
    let p = dir.path();
    let raw = "[[point]]\nvalue = 0\nrgba = [0, 0, 0, 0]\n\
               [[point]]\nvalue = 30\nrgba = [0.11764705882352941, 0.11764705882352941, 0.11764705882352941, 0]\n\
               [[point]]\nvalue = 150\nrgba = [0.5882352941176471, 0.5882352941176471, 0.5882352941176471, 1]\n\
               [[point]]\nvalue = 255\nrgba = [1, 1, 1, 1]\n";
    std::fs::write(p.join("raw.toml"), raw).unwrap();
    let view = "--scene ml:32";
    let a = render(p, &format!("{view} --tf grey-ramp"), "a");
    let b = render(p, &format!("{view} --tf-file raw.toml"), "b");
    assert_eq!(a, b, "the preset is its raw table on 8-bit data");
}

/// A table that makes none or all of the volume visible warns in one
/// line on stderr; the render still succeeds.
#[test]
fn a_table_that_shows_none_or_all_of_the_volume_warns() {
    let dir = tempdir();
    let p = dir.path();
    // Raw units above every value of an 8-bit volume: nothing shows.
    std::fs::write(
        p.join("high.toml"),
        "[[point]]\nvalue = 300\nrgba = [1, 1, 1, 0]\n[[point]]\nvalue = 400\nrgba = [1, 1, 1, 1]\n",
    )
    .unwrap();
    // Opaque everywhere: a solid block.
    std::fs::write(
        p.join("solid.toml"),
        "[[point]]\nvalue = 0\nrgba = [1, 1, 1, 0.5]\n",
    )
    .unwrap();
    for (file, needle) in [
        ("high.toml", "none of the volume"),
        ("solid.toml", "all of the volume"),
    ] {
        let run = ercube(
            p,
            &format!("render --scene ml:16 --size 16x16 --tf-file {file} --out x.png"),
        )
        .ok();
        let err = run.stderr();
        let lines: Vec<&str> = err.lines().collect();
        assert_eq!(lines.len(), 1, "{}", run.describe());
        assert!(
            lines[0].starts_with("ercube: warning: ") && lines[0].contains(needle),
            "{}",
            run.describe()
        );
    }
    let run = ercube(p, "render --scene ml:16 --size 16x16 --out x.png").ok();
    assert_eq!(
        run.stderr(),
        "",
        "a preset that shows part of the scene is quiet"
    );
}
