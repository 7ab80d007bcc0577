//! The same synthetic head written by nibabel (RAS), pynrrd (permuted,
//! flipped), SimpleITK (permuted, flipped) and pydicom (coronal slices,
//! shuffled files; see `tests/data/make_oriented.py`) is one volume once
//! placed in LPS world space, and renders bit-identically from "anterior"
//! in every format.

use std::path::{Path, PathBuf};

use glam::DVec3;
use golden::camera::Camera;
use golden::load::load_placed;
use golden::methods::Method;
use golden::orient::to_world_grid;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::tf::{ControlPoint, TransferFunction};
use golden::volume::DEFAULT_MEMORY_LIMIT;

const HEADS: [&str; 4] = [
    "head_ras.nii",
    "head_perm.nrrd",
    "head_perm.mha",
    "head_coronal",
];

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Voxels are HU + 1000 (the air's -1000 is the minimum).
fn head_tf() -> TransferFunction {
    let p = |value, rgba| ControlPoint { value, rgba };
    TransferFunction::new(vec![
        p(0.0, [0.0, 0.0, 0.0, 0.0]),
        p(900.0, [0.0, 0.0, 0.0, 0.0]),
        p(1040.0, [0.8, 0.5, 0.4, 0.05]),
        p(1200.0, [1.0, 0.2, 0.2, 0.5]),
        p(2000.0, [1.0, 1.0, 1.0, 0.6]),
    ])
    .unwrap()
}

#[test]
fn every_format_places_the_same_head_on_the_world_axes() {
    let first = load_placed(&data(HEADS[0]), None, DEFAULT_MEMORY_LIMIT).unwrap();
    let (want, want_frame) = to_world_grid(&first).unwrap();
    assert_eq!(want.dims(), [14, 16, 12]);
    assert_eq!(want.spacing(), [1.0, 1.5, 2.0]);
    assert_eq!(want_frame.origin, DVec3::new(-6.5, -11.25, -11.0));
    assert!(!want_frame.is_oblique());
    for name in HEADS {
        let l = load_placed(&data(name), None, DEFAULT_MEMORY_LIMIT).unwrap();
        // Stored in four different index orders...
        let (v, frame) = to_world_grid(&l).unwrap();
        // ... and one volume in world space.
        assert_eq!(
            (v.dims(), v.spacing()),
            (want.dims(), want.spacing()),
            "{name}"
        );
        assert!(v.data() == want.data(), "{name}: voxels differ");
        assert_eq!(frame, want_frame, "{name}");
    }
    // The files really are stored differently.
    let dims: Vec<[usize; 3]> = HEADS
        .iter()
        .map(|n| {
            load_placed(&data(n), None, DEFAULT_MEMORY_LIMIT)
                .unwrap()
                .volume
                .dims()
        })
        .collect();
    assert_eq!(
        dims,
        [[14, 16, 12], [12, 14, 16], [16, 12, 14], [14, 12, 16]]
    );
}

#[test]
fn the_head_from_anterior_is_bit_identical_in_every_format() {
    let tf = head_tf();
    let mut images = Vec::new();
    for name in HEADS {
        let l = load_placed(&data(name), None, DEFAULT_MEMORY_LIMIT).unwrap();
        let (vol, frame) = to_world_grid(&l).unwrap();
        // In front of the face (anterior is -y in LPS), head up (+z).
        let centre = frame.point_to_world(DVec3::from_array(vol.center_world()));
        let eye = centre + DVec3::new(0.0, -60.0, 0.0);
        let cam = Camera::new(
            frame.point_to_volume(eye),
            frame.point_to_volume(centre),
            frame.dir_to_volume(DVec3::Z),
            40.0,
            48,
            48,
        )
        .unwrap();
        let prep = Prepared::new(&vol, &cam).unwrap();
        let lut = lut_for(vol.kind(), &tf);
        let mut per = Vec::new();
        for tech in [Technique::Slice(Method::Er), Technique::Reference] {
            per.push(
                render(&prep, &lut, tech, &RenderOptions::default())
                    .unwrap()
                    .image
                    .data,
            );
        }
        images.push((name, per));
    }
    for (name, per) in &images[1..] {
        assert!(
            per == &images[0].1,
            "{name} renders differently from {}",
            HEADS[0]
        );
    }
    // Looking at the face, the patient's left ear (+x) is on the image's
    // right: with only the ear's value opaque, the rest of the head (whose
    // grid is symmetric in x) gives both halves the same opacity, and the
    // ear adds its own to the right half.
    let p = |value, a| ControlPoint {
        value,
        rgba: [1.0, 1.0, 1.0, a],
    };
    let ear_tf =
        TransferFunction::new(vec![p(1170.0, 0.0), p(1200.0, 0.9), p(1230.0, 0.0)]).unwrap();
    let l = load_placed(&data(HEADS[3]), None, DEFAULT_MEMORY_LIMIT).unwrap();
    let (vol, frame) = to_world_grid(&l).unwrap();
    let centre = frame.point_to_world(DVec3::from_array(vol.center_world()));
    let eye = centre + DVec3::new(0.0, -60.0, 0.0);
    let cam = Camera::new(
        frame.point_to_volume(eye),
        frame.point_to_volume(centre),
        frame.dir_to_volume(DVec3::Z),
        40.0,
        48,
        48,
    )
    .unwrap();
    let prep = Prepared::new(&vol, &cam).unwrap();
    let img = render(
        &prep,
        &lut_for(vol.kind(), &ear_tf),
        Technique::Reference,
        &RenderOptions::default(),
    )
    .unwrap()
    .image
    .data;
    let (mut left, mut right) = (0.0f64, 0.0f64);
    for j in 0..48 {
        for i in 0..48 {
            let a = f64::from(img[j * 48 + i][3]);
            if i < 24 {
                left += a;
            } else {
                right += a;
            }
        }
    }
    assert!(right > left + 2.0, "ear side {right} vs other {left}");
}
