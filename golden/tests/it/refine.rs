//! Adaptive and progressive refinement (`golden::refine`): a flat image
//! stays at the first grid, an edge is refined to one ray per pixel along
//! its length, the last progressive step is the one-ray-per-pixel frame
//! bit for bit with every ray cast once, and the bits do not depend on
//! the thread count.
//!
//! `cargo test --release -p golden --test it -- --nocapture refine`
//! prints the counts.

use glam::DVec3;
use golden::camera::Camera;
use golden::gaze::Gaze;
use golden::image::Image;
use golden::refine::frame::{self, Refined};
use golden::refine::Refine;
use golden::render::{lut_for, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;
use golden::tf::Lut;

use crate::scenes::{scene, up_for, volume_u8};

const W: u32 = 64;
const H: u32 = 45;

/// A 32^3 volume, `f` per voxel, seen through its front face (the face
/// fills the image: every ray enters through it) with `grey-ramp`.
fn setup(f: impl Fn(usize, usize, usize) -> u16 + Sync) -> (Prepared, Lut) {
    let vol = volume_u8([32, 32, 32], f);
    let lut = lut_for(vol.kind(), &tf_preset("grey-ramp").unwrap());
    let c = DVec3::from_array(vol.center_world());
    let eye = c + DVec3::new(0.0, 0.0, -56.0);
    let cam = Camera::new(eye, c, up_for(c - eye), 24.0, W, H).unwrap();
    (Prepared::new(&vol, &cam).unwrap(), lut)
}

fn refined(prep: &Prepared, lut: &Lut, tech: Technique, r: Refine, g: Option<Gaze>) -> Refined {
    let mut o = RenderOptions::default();
    o.reference.gaze = g;
    frame::render(prep, lut, tech, &o, &r).expect("refined frame")
}

fn full(prep: &Prepared, lut: &Lut, tech: Technique) -> Image {
    frame::full(prep, lut, tech, &RenderOptions::default()).expect("full frame")
}

fn bits(img: &Image) -> Vec<[u32; 4]> {
    img.data.iter().map(|p| p.map(f32::to_bits)).collect()
}

const R: Refine = Refine {
    threshold: 0.02,
    levels: 3,
};

/// The first grid's rays: `ceil((n - 1) / 2^L) + 1` per axis.
fn grid_rays(l: u32) -> u64 {
    let s = 1u32 << l;
    u64::from(((W - 1).div_ceil(s) + 1) * ((H - 1).div_ceil(s) + 1))
}

#[test]
fn a_flat_image_refines_to_the_coarsest_level_only() {
    // Uniform and opaque: every ray saturates on the front face.
    let (prep, lut) = setup(|_, _, _| 200);
    for tech in [Technique::Reference, Technique::MipMap] {
        let f = full(&prep, &lut, tech);
        let first = f.data[0];
        assert!(first[3] > 0.99, "{tech:?}: the face is opaque: {first:?}");
        let out = refined(&prep, &lut, tech, R, None);
        let s = &out.stats;
        println!("{tech:?} flat: {s:?}");
        assert_eq!(s.rays, grid_rays(3), "{tech:?}");
        assert_eq!(s.rays_per_level, vec![0, 0, 0, grid_rays(3)], "{tech:?}");
        assert_eq!(s.leaves_per_level[..3], [0, 0, 0], "{tech:?}");
        assert!(out.leaf_level.iter().all(|&l| l == 3), "{tech:?}");
        let err = golden::metrics::compare(&out.image, &f).unwrap();
        assert!(err.max_abs_255 <= 1.0, "{tech:?}: {err:?}");
    }
}

#[test]
fn an_edge_refines_to_one_ray_per_pixel_along_it() {
    // One edge of a checkerboard: opaque for x < 13, empty beyond (13 is
    // off the coarse grid's columns, so the edge crosses cells).
    let (prep, lut) = setup(|x, _, _| if x < 13 { 255 } else { 0 });
    for tech in [Technique::Reference, Technique::MipMap] {
        let f = full(&prep, &lut, tech);
        let out = refined(&prep, &lut, tech, R, None);
        println!("{tech:?} edge: {:?}", out.stats);
        let w = W as usize;
        let (a, b) = (bits(&out.image), bits(&f));
        let mut edge_rows = 0;
        for y in 0..H as usize {
            let mut on_edge = false;
            for x in 0..w - 1 {
                let (p, q) = (y * w + x, y * w + x + 1);
                let jump = (0..4)
                    .map(|c| (f.data[p][c] - f.data[q][c]).abs())
                    .fold(0.0f32, f32::max);
                if f64::from(jump) > R.threshold {
                    on_edge = true;
                    assert_eq!(
                        out.leaf_level[p], 0,
                        "{tech:?}: pixel {x},{y} before the edge"
                    );
                    assert_eq!(a[p], b[p], "{tech:?}: pixel {x},{y} is its own ray");
                    assert_eq!(a[q], b[q], "{tech:?}: pixel {},{y} is its own ray", x + 1);
                }
            }
            edge_rows += usize::from(on_edge);
        }
        assert_eq!(
            edge_rows, H as usize,
            "{tech:?}: the edge crosses every row"
        );
        // Away from the edge the first grid holds.
        let coarse = out.leaf_level.iter().filter(|&&l| l == 3).count();
        assert!(
            coarse > w * H as usize / 2,
            "{tech:?}: {coarse} coarse pixels"
        );
        assert!(
            out.stats.rays < out.stats.pixels / 3,
            "{tech:?}: {:?}",
            out.stats
        );
        assert!(out.stats.rays_per_level[0] > 0, "{tech:?}: level 0 reached");
    }
}

/// Every step's counts and the last step's bits, on a scene with detail.
fn progressive(
    prep: &Prepared,
    lut: &Lut,
    tech: Technique,
    g: Option<Gaze>,
    steps: usize,
) -> (Vec<(u64, u64)>, Image) {
    let mut o = RenderOptions::default();
    o.reference.gaze = g;
    let mut rows = Vec::new();
    let mut last = None;
    frame::progressive(prep, lut, tech, &o, &R, steps, |s| {
        rows.push((s.rays_new, s.rays));
        assert_eq!(s.stats.rays, s.rays);
        last = Some(s.image.clone());
        Ok(())
    })
    .expect("progressive");
    (rows, last.expect("steps"))
}

/// A built-in scene with its preset, 96x80, seen from in front.
fn view(spec: &str, tf: &str) -> (Prepared, Lut) {
    let vol = scene(spec);
    let lut = lut_for(vol.kind(), &tf_preset(tf).unwrap());
    let c = DVec3::from_array(vol.center_world());
    let eye = c + DVec3::new(6.0, -5.0, -48.0);
    let cam = Camera::new(eye, c, up_for(c - eye), 45.0, 96, 80).unwrap();
    (Prepared::new(&vol, &cam).unwrap(), lut)
}

#[test]
fn the_last_progressive_step_is_one_ray_per_pixel_bit_for_bit() {
    let pixels = 96 * 80;
    // The smooth sphere starts sparse; Marschner-Lobb is detail almost
    // everywhere.
    for (spec, tf, sparse) in [("sphere:32", "sphere", true), ("ml:32", "ml", false)] {
        let (prep, lut) = view(spec, tf);
        for tech in [Technique::Reference, Technique::MipMap] {
            let f = full(&prep, &lut, tech);
            for g in [None, Some(Gaze::around([20.0, 60.0], 96, 80))] {
                let (rows, last) = progressive(&prep, &lut, tech, g, 5);
                println!("{spec} {tech:?} gaze {}: {rows:?}", g.is_some());
                assert_eq!(rows.len(), 5);
                // No ray twice: the new rays add up to one per pixel.
                assert_eq!(rows.iter().map(|r| r.0).sum::<u64>(), pixels);
                assert_eq!(rows.last().unwrap().1, pixels);
                assert!(!sparse || rows[0].1 < pixels / 2, "{rows:?}");
                assert!(rows.windows(2).all(|w| w[1].1 > w[0].1), "{rows:?}");
                assert_eq!(bits(&last), bits(&f), "{tech:?}");
            }
        }
    }
}

#[test]
fn refinement_is_the_same_on_any_thread_count() {
    let (prep, lut) = view("ml:32", "ml");
    let g = Some(Gaze::around([30.0, 30.0], 96, 80));
    for tech in [Technique::Reference, Technique::MipMap] {
        let run = || {
            let a = refined(&prep, &lut, tech, R, g);
            let (rows, last) = progressive(&prep, &lut, tech, None, 3);
            (
                bits(&a.image),
                a.stats,
                a.mip,
                a.leaf_level,
                rows,
                bits(&last),
            )
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(run);
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap()
            .install(run);
        assert!(one == three, "{tech:?}: 1 and 3 threads differ");
    }
}

#[test]
fn refinement_refuses_what_it_does_not_take() {
    let (prep, lut) = view("ml:32", "ml");
    let o = RenderOptions::default();
    let er = Technique::Slice(golden::methods::Method::Er);
    let e = frame::render(&prep, &lut, er, &o, &R)
        .unwrap_err()
        .to_string();
    assert!(e.contains("reference and the mip-map"), "{e}");
    for bad in [
        Refine {
            threshold: -0.1,
            ..R
        },
        Refine {
            threshold: f64::NAN,
            ..R
        },
        Refine { levels: 0, ..R },
        Refine { levels: 7, ..R },
    ] {
        let e = frame::render(&prep, &lut, Technique::Reference, &o, &bad)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("refine "), "{e}");
    }
    for steps in [0, 1, frame::MAX_STEPS + 1] {
        assert!(
            frame::progressive(&prep, &lut, Technique::Reference, &o, &R, steps, |_| Ok(()))
                .is_err()
        );
    }
}
