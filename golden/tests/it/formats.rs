//! Every fixture of `tests/data` (written by pynrrd, SimpleITK, tifffile,
//! nibabel and pydicom; see `make_fixtures.py` and `make_dicom.py`) loads to the same volume as the others
//! of its type, and to the voxels the script's formulas give, computed
//! here again.

use std::path::{Path, PathBuf};

use golden::load::{load_auto, read_dicom_dir, read_dicom_file, read_meta, read_nrrd};
use golden::volume::{Volume, VoxelType, DEFAULT_MEMORY_LIMIT};

const DIMS: [usize; 3] = [12, 10, 7];
const SPACING: [f64; 3] = [0.5, 0.75, 1.25];
const ORIGIN: [f64; 3] = [-3.0, 2.5, 10.0];
const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The script's formulas, x fastest.
fn formula(kind: &str) -> Vec<f64> {
    let mut out = Vec::new();
    for z in 0..DIMS[2] as i64 {
        for y in 0..DIMS[1] as i64 {
            for x in 0..DIMS[0] as i64 {
                let u16v = (1000 * x + 300 * y + 5000 * z + 17 * x * y * z) % 65536;
                out.push(match kind {
                    "u8" => ((7 * x + 13 * y + 29 * z + x * y) % 256) as f64,
                    "u16" => u16v as f64,
                    "i16" => (u16v / 2 - 16000) as f64,
                    "f32" => (x - 2 * y) as f64 * 0.25 + z as f64 * 0.125,
                    _ => unreachable!(),
                });
            }
        }
    }
    out
}

/// The voxels the shared mapping rule gives for `kind`: unsigned kept,
/// signed offset by minus the minimum, float mapped onto 0..=65535.
fn expected(kind: &str) -> (VoxelType, Vec<u16>) {
    let vals = formula(kind);
    let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let data = match kind {
        "u8" | "u16" => vals.iter().map(|&v| v as u16).collect(),
        "i16" => vals.iter().map(|&v| (v - lo.min(0.0)) as u16).collect(),
        _ => vals
            .iter()
            .map(|&v| ((v - lo) * (65535.0 / (hi - lo))).round() as u16)
            .collect(),
    };
    let kind = if kind == "u8" {
        VoxelType::U8
    } else {
        VoxelType::U16
    };
    (kind, data)
}

/// The fixtures of one type, and whether each carries the spacing.
fn fixtures(kind: &str) -> Vec<(String, bool)> {
    let mut names: Vec<(String, bool)> = [
        ".nrrd",
        "_gz.nrrd",
        "_be.nrrd",
        "_det.nhdr",
        "_detgz.nhdr",
        ".mha",
        ".mhd",
        "_z.mhd",
        ".nii",
    ]
    .iter()
    .map(|s| (format!("vol_{kind}{s}"), true))
    .collect();
    // A folder of DICOM slices (pydicom), with the spacing.
    names.push((format!("dicom_{kind}"), true));
    // One multi-frame object (pydicom): Enhanced CT with per-frame
    // positions, frames shuffled (i16); plain multi-frame, RLE (u8).
    if kind == "u8" || kind == "i16" {
        names.push((format!("dicom_mf_{kind}.dcm"), true));
    }
    if kind == "u8" || kind == "u16" {
        names.push((format!("vol_{kind}.tif"), false));
        names.push((format!("vol_{kind}_pages"), false));
    }
    names
}

fn load(name: &str) -> Volume {
    load_auto(&data(name), None, DEFAULT_MEMORY_LIMIT).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn every_fixture_loads_to_the_formula() {
    let mut loaded = 0;
    for kind in ["u8", "u16", "i16", "f32"] {
        let (want_kind, want) = expected(kind);
        let list = fixtures(kind);
        let first = load(&list[0].0);
        for (name, spaced) in &list {
            let v = load(name);
            assert_eq!(v.dims(), DIMS, "{name}");
            assert_eq!(v.kind(), want_kind, "{name}");
            assert!(
                v.data() == &want[..],
                "{name}: voxels differ from the formula"
            );
            let spacing = if *spaced { SPACING } else { [1.0; 3] };
            assert_eq!(v.spacing(), spacing, "{name}");
            // Bit-identical to the first fixture of its type.
            assert_eq!(
                (v.dims(), v.kind(), v.data()),
                (first.dims(), first.kind(), first.data()),
                "{name}"
            );
            loaded += 1;
        }
    }
    assert_eq!(loaded, 4 * 10 + 2 * 2 + 2);
}

#[test]
fn nrrd_and_metaimage_placement_is_kept() {
    for name in ["vol_u8.nrrd", "vol_i16_detgz.nhdr", "vol_f32_gz.nrrd"] {
        let l = read_nrrd(&data(name), DEFAULT_MEMORY_LIMIT).unwrap();
        assert_eq!((l.origin, l.axes), (Some(ORIGIN), Some(IDENTITY)), "{name}");
    }
    // Per-axis spacings carry no placement.
    let l = read_nrrd(&data("vol_u16_be.nrrd"), DEFAULT_MEMORY_LIMIT).unwrap();
    assert_eq!((l.origin, l.axes), (None, None));
    for name in ["vol_u16.mha", "vol_f32.mhd", "vol_u8_z.mhd"] {
        let l = read_meta(&data(name), DEFAULT_MEMORY_LIMIT).unwrap();
        assert_eq!((l.origin, l.axes), (Some(ORIGIN), Some(IDENTITY)), "{name}");
        assert_eq!(l.volume.spacing(), SPACING);
    }
    // DICOM: the first slice along the normal, whatever the file order.
    for name in ["dicom_u16", "dicom_i16", "dicom_u8", "dicom_f32"] {
        let l = read_dicom_dir(&data(name), DEFAULT_MEMORY_LIMIT).unwrap();
        assert_eq!((l.origin, l.axes), (Some(ORIGIN), Some(IDENTITY)), "{name}");
        assert_eq!(l.volume.spacing(), SPACING, "{name}");
    }
    // A multi-frame object: placed like its series, from its functional
    // groups (Enhanced CT) or top-level attributes (plain).
    for (name, series) in [
        ("dicom_mf_i16.dcm", "dicom_i16"),
        ("dicom_mf_u8.dcm", "dicom_u8"),
    ] {
        let l = read_dicom_file(&data(name), DEFAULT_MEMORY_LIMIT).unwrap();
        let s = read_dicom_dir(&data(series), DEFAULT_MEMORY_LIMIT).unwrap();
        assert_eq!((l.origin, l.axes), (Some(ORIGIN), Some(IDENTITY)), "{name}");
        assert_eq!((l.origin, l.axes), (s.origin, s.axes), "{name}");
        assert_eq!(l.volume.spacing(), SPACING, "{name}");
        assert_eq!(l.volume.units(), s.volume.units(), "{name}");
    }
}

/// A multi-frame object renders bit-identically to the series of
/// single-frame slices of the same data (the frames sorted by position,
/// the spacing from the functional groups).
#[test]
fn multi_frame_dicom_renders_like_its_series() {
    use golden::camera::Camera;
    use golden::methods::Method;
    use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
    use golden::tf::{ControlPoint, TransferFunction};
    for (name, series) in [
        ("dicom_mf_i16.dcm", "dicom_i16"),
        ("dicom_mf_u8.dcm", "dicom_u8"),
    ] {
        let mut images = Vec::new();
        for n in [name, series] {
            let v = load(n);
            let cam = Camera::new(
                glam::DVec3::new(2.0, 1.5, -9.0),
                glam::DVec3::from_array(v.center_world()),
                glam::DVec3::Y,
                50.0,
                24,
                20,
            )
            .unwrap();
            let prep = Prepared::new(&v, &cam).unwrap();
            // A ramp over the data's values: every voxel counts.
            let hi = f64::from(*v.data().iter().max().unwrap());
            let p = |value: f64, a: f64| ControlPoint {
                value,
                rgba: [1.0, 0.8, 0.6, a],
            };
            let tf = TransferFunction::new(vec![p(0.0, 0.0), p(hi, 0.6)]).unwrap();
            let lut = lut_for(v.kind(), &tf);
            let img = render(
                &prep,
                &lut,
                Technique::Slice(Method::Er),
                &RenderOptions::default(),
            )
            .unwrap()
            .image;
            images.push(img.data);
        }
        let first = images[0].iter().zip(&images[1]).position(|(a, b)| a != b);
        assert_eq!(first, None, "{name} vs {series}: first differing value");
        assert!(
            images[0].iter().any(|p| p[3] > 0.0),
            "{name}: an empty image proves nothing"
        );
    }
}

#[test]
fn fixtures_are_small() {
    for entry in walk(&data("")) {
        let size = std::fs::metadata(&entry).unwrap().len();
        assert!(size < 20_000, "{} is {size} bytes", entry.display());
    }
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}
