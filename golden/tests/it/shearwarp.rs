//! Perspective shear-warp (`golden::shearwarp`): the factorisation's
//! geometry against an independent projection of voxel centres, the three
//! eye cases, the runs' contents, exact skipping (runs, opaque pixels,
//! culling), determinism across thread counts, and the error against the
//! reference as the intermediate image grows.
//!
//! `cargo test --release -p golden --test it -- --nocapture shearwarp`
//! prints the measured errors.

use glam::DVec3;
use golden::camera::{Camera, ImagePlane};
use golden::clip::ClipPlane;
use golden::geometry::View;
use golden::metrics::compare;
use golden::render::{lut_for, render, PrepareOptions, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;
use golden::shearwarp::{Classified, EyeCase, Factor};
use golden::volume::VoxelType;

use crate::scenes::{scene, sparse, table, volume_u8};

fn camera(eye: DVec3, look: DVec3, fov: f64, w: u32, h: u32) -> Camera {
    let f = (look - eye).normalize();
    let up = if f.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    Camera::new(eye, look, up, fov, w, h).expect("camera")
}

fn bits(v: &[[f32; 4]]) -> Vec<[u32; 4]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

fn sw(scale: f64, skip: bool, cull: bool) -> RenderOptions {
    let mut o = RenderOptions {
        sw_scale: scale,
        ..RenderOptions::default()
    };
    o.slice.skips.empty = skip;
    o.slice.skips.cull = cull;
    o
}

/// The continuous pixel position of world point `w` from the camera's own
/// definition (README: pixel `(i, j)` looks along `f + sx r + sy u`),
/// without `golden::geometry`.
fn project(cam: &Camera, w: DVec3) -> Option<[f64; 2]> {
    let f = (cam.look_at - cam.eye).normalize();
    let r = f.cross(cam.up).normalize();
    let u = r.cross(f);
    let p = w - cam.eye;
    let depth = p.dot(f);
    if depth <= 1e-9 {
        return None;
    }
    let (sx, sy) = (p.dot(r) / depth, p.dot(u) / depth);
    let t = (cam.fov_deg.to_radians() * 0.5).tan();
    let (wd, ht) = (f64::from(cam.width), f64::from(cam.height));
    Some([
        (sx / (t * wd / ht) + 1.0) * 0.5 * wd,
        (1.0 - sy / t) * 0.5 * ht,
    ])
}

/// Shear (voxel centre to intermediate image) then warp (intermediate to
/// final pixel) lands every voxel centre in front of the eye where the
/// camera itself projects it, for eyes on all six sides, off axis, with
/// anisotropic spacing and several intermediate scales.
#[test]
fn shear_then_warp_projects_voxel_centres_where_the_camera_does() {
    let dims = [11, 7, 9];
    let spacing = [1.0, 1.5, 0.75];
    let centre = DVec3::new(5.0 * 1.0, 3.0 * 1.5, 4.0 * 0.75);
    let eyes = [
        DVec3::new(3.0, 2.0, -20.0),
        DVec3::new(9.0, 14.0, 30.0),
        DVec3::new(-25.0, 1.0, 4.0),
        DVec3::new(40.0, 8.0, -3.0),
        DVec3::new(4.0, -30.0, 2.0),
        DVec3::new(6.0, 35.0, 10.0),
        // Inside the volume: the near plane clips it.
        DVec3::new(5.0, 4.0, 2.0),
    ];
    let mut checked = 0;
    for (n, eye) in eyes.into_iter().enumerate() {
        let look = if n == 6 {
            eye + DVec3::new(0.3, 0.2, 1.0)
        } else {
            centre + DVec3::new(0.7, -0.4, 0.3)
        };
        let cam = camera(eye, look, 50.0, 37, 23);
        let view = View::new(dims, spacing, &cam, 1.0).expect("view");
        for scale in [0.5, 1.0, 3.0] {
            let f = Factor::new(&view, scale, false).expect("factor");
            for z in 0..dims[2] {
                for y in 0..dims[1] {
                    for x in 0..dims[0] {
                        let idx = DVec3::new(x as f64, y as f64, z as f64);
                        let v = view.axes.to_view(idx);
                        if v.z < 0.0 {
                            continue; // in front of the near plane
                        }
                        let world = idx * DVec3::from_array(spacing);
                        let Some(want) = project(&cam, world) else {
                            assert!(
                                f.warp(&view, f.shear(v)).is_none(),
                                "voxel {idx} behind the eye warps to a pixel"
                            );
                            continue;
                        };
                        let got = f.warp(&view, f.shear(v)).expect("in front of the eye");
                        let err = (got[0] - want[0]).abs().max((got[1] - want[1]).abs());
                        let tol = 1e-9 * (1.0 + want[0].abs().max(want[1].abs()));
                        assert!(
                            err < tol,
                            "eye {eye}, scale {scale}, voxel {idx}: {got:?} vs {want:?}"
                        );
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 10_000, "{checked} voxel centres checked");
}

/// A slice's voxel at `(x, y)` shears to intermediate pixel
/// `S (e + (x - e) D / (z + D))` (the paper's `M^sd`, scaled): slice 0
/// lands 1:1 at scale 1 and slice z shrinks by `D / (z + D)` about the eye.
#[test]
fn slices_shrink_about_the_eye_by_d_over_z_plus_d() {
    let cam = camera(
        DVec3::new(4.0, 2.5, -6.0),
        DVec3::new(4.0, 2.5, 5.0),
        60.0,
        16,
        16,
    );
    let view = View::new([9, 6, 12], [1.0; 3], &cam, 1.0).expect("view");
    assert_eq!(view.d, 6.0);
    let f = Factor::new(&view, 1.0, false).expect("factor");
    let origin = f.shear(DVec3::new(0.0, 0.0, 0.0));
    let one = f.shear(DVec3::new(1.0, 1.0, 0.0));
    assert!((one[0] - origin[0] - 1.0).abs() < 1e-12 && (one[1] - origin[1] - 1.0).abs() < 1e-12);
    for z in [1.0, 5.0, 11.0] {
        let a = f.shear(DVec3::new(2.0, 1.0, z));
        let b = f.shear(DVec3::new(7.0, 5.0, z));
        let s = 6.0 / (z + 6.0);
        assert!(((b[0] - a[0]) - 5.0 * s).abs() < 1e-12, "z {z}");
        assert!(((b[1] - a[1]) - 4.0 * s).abs() < 1e-12, "z {z}");
        // The eye's foot is the fixed point.
        let e = f.shear(DVec3::new(4.0, 2.5, z));
        let e0 = f.shear(DVec3::new(4.0, 2.5, 0.0));
        assert!((e[0] - e0[0]).abs() < 1e-12 && (e[1] - e0[1]).abs() < 1e-12);
    }
}

#[test]
fn the_runs_hold_exactly_the_visible_voxels() {
    let vol = sparse([23, 17, 13], 5, 7);
    let lut = table(&[
        (0.0, [0.0; 4]),
        (60.0, [0.0; 4]),
        (255.0, [1.0, 0.5, 0.2, 0.7]),
    ]);
    let cam = camera(
        DVec3::new(11.0, 8.0, -30.0),
        DVec3::new(11.0, 8.0, 6.0),
        40.0,
        8,
        8,
    );
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    let c = Classified::build(&prep.stack, &lut).expect("classify");
    let [nx, ny, nz] = c.dims;
    let mut visible = 0;
    for z in 0..nz {
        for y in 0..ny {
            let mut from_runs = vec![false; nx];
            let mut last = 0;
            for r in c.runs(z, y) {
                assert!(r[0] < r[1] && r[0] >= last, "runs sorted and disjoint");
                last = r[1];
                for x in r[0]..r[1] {
                    from_runs[x as usize] = true;
                }
            }
            for (x, &seen) in from_runs.iter().enumerate() {
                let want = c.row(z, y)[x][3] > 0.0;
                assert_eq!(seen, want, "voxel {x},{y},{z}");
                visible += usize::from(want);
            }
        }
    }
    assert!(
        visible > 0 && visible < nx * ny * nz,
        "{visible} visible voxels"
    );
}

/// Looking away from the volume draws nothing and composites nothing,
/// as the reference sees nothing.
#[test]
fn a_volume_behind_the_eye_draws_nothing() {
    let vol = scene("sphere:24");
    let lut = lut_for(VoxelType::U8, &tf_preset("sphere").expect("preset"));
    let eye = DVec3::new(11.5, 11.5, -20.0);
    let cam = camera(eye, eye - DVec3::new(0.1, 0.2, 1.0), 60.0, 24, 24);
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    let f = render(&prep, &lut, Technique::ShearWarp, &sw(1.0, true, true)).unwrap();
    let st = f.sw.expect("stats");
    assert_eq!(st.eye_case, Some(EyeCase::Behind));
    assert_eq!(st.samples_total, 0);
    assert!(f.image.data.iter().all(|p| *p == [0.0; 4]));
    let r = render(&prep, &lut, Technique::Reference, &RenderOptions::default()).unwrap();
    assert!(
        r.image.data.iter().all(|p| p[3] == 0.0),
        "the reference agrees"
    );
}

/// An eye inside the volume: the near plane drops the slices beside the
/// eye, the rest renders finite and close to the reference, which clips
/// at the same plane.
#[test]
fn an_eye_inside_the_volume_renders_through_the_near_plane() {
    let vol = scene("ml:32");
    let lut = lut_for(VoxelType::U8, &tf_preset("ml").expect("preset"));
    let eye = DVec3::new(15.5, 14.0, 9.0);
    let cam = camera(eye, eye + DVec3::new(0.2, 0.1, 1.0), 70.0, 32, 32);
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    assert!(prep.view.axes.z_first > 0, "the near plane clips");
    let f = render(&prep, &lut, Technique::ShearWarp, &sw(1.0, true, true)).unwrap();
    let st = f.sw.expect("stats");
    assert_eq!(st.eye_case, Some(EyeCase::Around));
    assert!(f.image.data.iter().flatten().all(|v| v.is_finite()));
    let lit = f.image.data.iter().filter(|p| p[3] > 0.05).count();
    assert!(lit > 32 * 32 / 2, "{lit} pixels lit");
    let r = render(&prep, &lut, Technique::Reference, &RenderOptions::default()).unwrap();
    let e = compare(&f.image, &r.image).unwrap();
    eprintln!("shear-warp inside ml:32: rmse {:.4}", e.rmse);
    assert!(e.rmse < 0.08, "rmse {}", e.rmse);
}

/// Skipping transparent voxels through the runs, skipping opaque pixels
/// and culling the intermediate image change no bit, while the runs do
/// cut the samples resampled; also with clip planes and an eye inside.
#[test]
fn runs_and_culling_change_no_bit() {
    let vol = sparse([30, 26, 22], 6, 3);
    let lut = table(&[
        (0.0, [0.0; 4]),
        (90.0, [0.0; 4]),
        (255.0, [0.9, 0.6, 0.3, 0.9]),
    ]);
    let views = [
        (
            DVec3::new(14.0, 12.0, -25.0),
            DVec3::new(14.5, 12.5, 10.5),
            vec![],
        ),
        (
            DVec3::new(50.0, -10.0, 40.0),
            DVec3::new(14.5, 12.5, 10.5),
            vec![],
        ),
        (
            DVec3::new(10.0, 30.0, -15.0),
            DVec3::new(14.5, 12.5, 10.5),
            vec![ClipPlane::new(DVec3::new(1.0, 0.2, 0.0), -12.0).unwrap()],
        ),
        (
            DVec3::new(15.0, 13.0, 6.0),
            DVec3::new(14.0, 12.0, 20.0),
            vec![],
        ),
    ];
    let mut cases = Vec::new();
    for (eye, look, clip) in views {
        let cam = camera(eye, look, 100.0, 40, 30);
        let popts = PrepareOptions {
            clip,
            ..PrepareOptions::default()
        };
        let prep = Prepared::with(&vol, &cam, &popts).expect("prepare");
        for scale in [0.5, 1.0, 2.5] {
            let full = render(&prep, &lut, Technique::ShearWarp, &sw(scale, false, false)).unwrap();
            let s_full = full.sw.clone().unwrap();
            cases.push(s_full.eye_case);
            assert!(
                full.image.data.iter().any(|p| p[3] > 0.0),
                "eye {eye}: something drawn"
            );
            for (skip, cull) in [(true, false), (false, true), (true, true)] {
                let f = render(&prep, &lut, Technique::ShearWarp, &sw(scale, skip, cull)).unwrap();
                assert!(
                    bits(&f.image.data) == bits(&full.image.data),
                    "eye {eye}, scale {scale}, runs {skip}, cull {cull}: the image changed"
                );
                let s = f.sw.unwrap();
                assert!(s.samples_composited <= s_full.samples_composited);
                if skip && !cull {
                    assert!(
                        s.samples_total < s_full.samples_total,
                        "eye {eye}: runs cut {} of {} samples only",
                        s_full.samples_total - s.samples_total,
                        s_full.samples_total
                    );
                    assert_eq!(s.samples_composited, s_full.samples_composited);
                }
            }
        }
    }
    assert!(cases.contains(&Some(EyeCase::Around)) && cases.contains(&Some(EyeCase::Front)));
}

/// Early termination stops pixels once opaque: fewer samples, an image
/// within the termination threshold of the unterminated one.
#[test]
fn early_termination_skips_opaque_pixels_within_its_threshold() {
    let vol = scene("ml:32");
    let lut = lut_for(VoxelType::U8, &tf_preset("ml").expect("preset"));
    let cam = camera(
        DVec3::new(15.5, 15.5, -40.0),
        DVec3::splat(15.5),
        45.0,
        32,
        32,
    );
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    let mut all = sw(1.0, true, true);
    all.slice.terminate = 1.0;
    let a = render(&prep, &lut, Technique::ShearWarp, &all).unwrap();
    let t = render(&prep, &lut, Technique::ShearWarp, &sw(1.0, true, true)).unwrap();
    let (sa, st) = (a.sw.unwrap(), t.sw.unwrap());
    assert!(st.rays_terminated > 0);
    assert!(
        st.samples_total < sa.samples_total,
        "{} vs {}",
        st.samples_total,
        sa.samples_total
    );
    let worst = a
        .image
        .data
        .iter()
        .zip(&t.image.data)
        .flat_map(|(p, q)| (0..4).map(move |c| (p[c] - q[c]).abs()))
        .fold(0f32, f32::max);
    assert!(worst <= 0.0101, "terminated image differs by {worst}");
}

#[test]
fn the_same_bits_for_any_thread_count() {
    let vol = sparse([29, 25, 33], 6, 11);
    let lut = table(&[
        (0.0, [0.0; 4]),
        (80.0, [0.0; 4]),
        (255.0, [1.0, 0.6, 0.3, 0.5]),
    ]);
    let cam = camera(
        DVec3::new(40.0, -9.0, -25.0),
        DVec3::new(14.5, 12.5, 16.5),
        70.0,
        40,
        36,
    );
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                [0.5, 1.0, 2.0].map(|s| {
                    let f = render(&prep, &lut, Technique::ShearWarp, &sw(s, true, true)).unwrap();
                    (bits(&f.image.data), f.sw)
                })
            })
    };
    let one = run(1);
    assert!(
        one[1].0.iter().any(|p| p[3] != 0),
        "the view shows something"
    );
    for threads in [2, 3] {
        assert!(
            run(threads) == one,
            "shear-warp differs with {threads} threads"
        );
    }
}

/// RMSE against the reference on smooth Marschner-Lobb as the
/// intermediate image grows from a quarter to twice the front slice's
/// resolution, near (the final image magnifies the front slice) and far.
fn errors(dist: f64, fov: f64) -> Vec<f64> {
    let vol = scene("ml:48");
    let lut = lut_for(VoxelType::U8, &tf_preset("ml").expect("preset"));
    let c = DVec3::splat(23.5);
    let cam = camera(DVec3::new(23.5, 23.5, -dist), c, fov, 64, 64);
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    let reference = render(&prep, &lut, Technique::Reference, &RenderOptions::default()).unwrap();
    let e: Vec<f64> = [0.25, 0.5, 1.0, 2.0]
        .iter()
        .map(|&s| {
            let f = render(&prep, &lut, Technique::ShearWarp, &sw(s, true, true)).unwrap();
            compare(&f.image, &reference.image).unwrap().rmse
        })
        .collect();
    eprintln!("shear-warp ml:48 at {dist} ({fov} deg): rmse at scales 1/4, 1/2, 1, 2: {e:.4?}");
    e
}

#[test]
fn error_against_the_reference_falls_as_the_intermediate_image_grows() {
    for (dist, fov, bound) in [(24.0, 90.0, 0.03), (150.0, 20.0, 0.03)] {
        let e = errors(dist, fov);
        for w in e.windows(2) {
            assert!(w[1] < w[0], "error grew with the scale: {e:?}");
        }
        assert!(e[2] < bound, "at scale 1: {e:?}");
    }
}

#[test]
fn bad_options_are_refused() {
    let vol = volume_u8([8, 8, 8], |x, _, _| (x * 30) as u16);
    let lut = table(&[(0.0, [0.0; 4]), (255.0, [1.0; 4])]);
    let cam = camera(DVec3::new(3.5, 3.5, -12.0), DVec3::splat(3.5), 40.0, 8, 8);
    let prep = Prepared::new(&vol, &cam).expect("prepare");
    for s in [0.0, -1.0, 0.1, 9.0, f64::NAN] {
        let e = render(&prep, &lut, Technique::ShearWarp, &sw(s, true, true))
            .err()
            .unwrap_or_else(|| panic!("scale {s} accepted"))
            .to_string();
        assert!(e.contains("intermediate scale"), "{e}");
    }
    let mut o = sw(1.0, true, true);
    o.slice.substeps = 2;
    let e = render(&prep, &lut, Technique::ShearWarp, &o)
        .unwrap_err()
        .to_string();
    assert!(e.contains("substeps"), "{e}");
    let _ = ImagePlane::Camera;
}
