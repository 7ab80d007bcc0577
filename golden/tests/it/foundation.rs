//! The foundation's contracts: camera convention, warp, principal axis,
//! reference renderer on an analytic case.

use glam::DVec3;
use golden::camera::{Camera, ImagePlane};
use golden::geometry::{Layout, Merge, View};
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::tf::{ControlPoint, TransferFunction};
use golden::volume::{Volume, VoxelType, DEFAULT_MEMORY_LIMIT};
use golden::warp::pixel_to_base;

fn impulse(dims: [usize; 3], p: [usize; 3]) -> Volume {
    Volume::from_fn(dims, VoxelType::U8, DEFAULT_MEMORY_LIMIT, |x, y, z| {
        if [x, y, z] == p {
            255
        } else {
            0
        }
    })
    .unwrap()
}

fn emissive(alpha: f64) -> TransferFunction {
    TransferFunction::new(vec![
        ControlPoint {
            value: 0.0,
            rgba: [1.0, 1.0, 1.0, 0.0],
        },
        ControlPoint {
            value: 255.0,
            rgba: [1.0, 1.0, 1.0, alpha],
        },
    ])
    .unwrap()
}

/// The README's convention, written out independently of the library:
/// the continuous pixel position a world point projects to.
fn convention_pixel(cam: &Camera, p: DVec3) -> (f64, f64) {
    let f = (cam.look_at - cam.eye).normalize();
    let r = f.cross(cam.up).normalize();
    let u = r.cross(f);
    let d = p - cam.eye;
    let (sx, sy) = (d.dot(r) / d.dot(f), d.dot(u) / d.dot(f));
    let t = (cam.fov_deg.to_radians() / 2.0).tan();
    let (w, h) = (cam.width as f64, cam.height as f64);
    // sx = (2 px / W - 1) t W / H, sy = (1 - 2 py / H) t, with px = i + 1/2.
    ((sx / (t * w / h) + 1.0) * w / 2.0, (1.0 - sy / t) * h / 2.0)
}

fn brightest(img: &golden::image::Image) -> (usize, usize) {
    let mut best = (0, 0, -1.0f32);
    for j in 0..img.height {
        for i in 0..img.width {
            let v = img.get(i, j)[0];
            if v > best.2 {
                best = (i, j, v);
            }
        }
    }
    (best.0, best.1)
}

#[test]
fn a_voxel_lands_on_the_pixel_the_convention_predicts() {
    let p = [21usize, 9, 14];
    let vol = impulse([32, 24, 28], p);
    let lut = lut_for(VoxelType::U8, &emissive(0.2));
    let cases = [
        (
            DVec3::new(5.0, 30.0, -40.0),
            DVec3::new(16.0, 12.0, 14.0),
            DVec3::Y,
            50.0,
            [64u32, 48u32],
        ),
        (
            DVec3::new(70.0, 10.0, 20.0),
            DVec3::new(16.0, 12.0, 14.0),
            DVec3::Z,
            70.0,
            [40, 60],
        ),
        (
            DVec3::new(10.0, -50.0, 9.0),
            DVec3::new(15.0, 12.0, 13.0),
            DVec3::X,
            40.0,
            [50, 50],
        ),
    ];
    for (eye, look, up, fov, [w, h]) in cases {
        let cam = Camera::new(eye, look, up, fov, w, h).unwrap();
        let (px, py) = convention_pixel(&cam, DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
        let want = (px.floor() as usize, py.floor() as usize);
        let prep = Prepared::new(&vol, &cam).unwrap();
        for tech in [Technique::Reference, "er".parse().unwrap()] {
            let img = render(&prep, &lut, tech, &RenderOptions::default())
                .unwrap()
                .image;
            let got = brightest(&img);
            assert_eq!(
                got,
                want,
                "{} eye {eye}: predicted ({px:.2}, {py:.2})",
                tech.name()
            );
        }
    }
}

#[test]
fn warp_matrix_agrees_with_direct_projection() {
    let cams = [
        Camera::new(
            DVec3::new(12.0, 40.0, -30.0),
            DVec3::new(20.0, 10.0, 30.0),
            DVec3::Y,
            80.0,
            90,
            70,
        )
        .unwrap(),
        Camera::new(
            DVec3::new(100.0, 17.0, 3.0),
            DVec3::new(10.0, 20.0, 25.0),
            DVec3::new(0.2, 1.0, 0.1),
            45.0,
            64,
            64,
        )
        .unwrap(),
    ];
    for mut cam in cams {
        for plane in [ImagePlane::Camera, ImagePlane::Front] {
            cam.image_plane = plane;
            let view = View::new([40, 30, 50], [1.0, 1.0, 1.0], &cam, 1.0).unwrap();
            let layout = Layout::exponential(&view, Merge::Bartlett).unwrap();
            let grid = layout.baseplane();
            let m = pixel_to_base(&view, &grid);
            let inv = m.inverse();
            for &(u, v) in &[(0.0, 0.0), (10.5, 3.25), (30.0, 40.0), (-5.0, 12.0)] {
                // Baseplane sample (u, v) is view point (origin + s (u, v), 0).
                let q = DVec3::new(
                    grid.origin[0] + grid.spacing * u,
                    grid.origin[1] + grid.spacing * v,
                    0.0,
                );
                let world = view.axes.to_index(q);
                let (px, py) = match plane {
                    ImagePlane::Camera => convention_pixel(&cam, world),
                    ImagePlane::Front => cam_front_pixel(&view, q),
                };
                let h = inv * DVec3::new(u, v, 1.0);
                let (wx, wy) = (h.x / h.z, h.y / h.z);
                assert!(
                    (wx - px).abs() < 1e-6 && (wy - py).abs() < 1e-6,
                    "{plane:?} ({u},{v}): warp ({wx},{wy}) direct ({px},{py})"
                );
                let f = m * DVec3::new(px, py, 1.0);
                assert!((f.x / f.z - u).abs() < 1e-6 && (f.y / f.z - v).abs() < 1e-6);
            }
        }
    }
}

/// Front mode: the pixel whose view-space ray passes through `q`.
fn cam_front_pixel(view: &View, q: DVec3) -> (f64, f64) {
    view.rays.project(q).unwrap()
}

#[test]
fn principal_axis_on_all_six_sides() {
    let dims = [40usize, 30, 50];
    let c = DVec3::new(19.5, 14.5, 24.5);
    let cases = [
        (DVec3::new(-20.0, 14.5, 24.5), "+x", 20.0),
        (DVec3::new(70.0, 14.5, 24.5), "-x", 31.0),
        (DVec3::new(19.5, -10.0, 24.5), "+y", 10.0),
        (DVec3::new(19.5, 44.0, 24.5), "-y", 15.0),
        (DVec3::new(19.5, 14.5, -7.5), "+z", 7.5),
        (DVec3::new(19.5, 14.5, 60.0), "-z", 11.0),
        // Off-axis: largest component decides.
        (DVec3::new(-30.0, 20.0, 10.0), "+x", 30.0),
    ];
    for (eye, label, d) in cases {
        let up = if label.ends_with('y') {
            DVec3::Z
        } else {
            DVec3::Y
        };
        let cam = Camera::new(eye, c, up, 60.0, 16, 16).unwrap();
        let view = View::new(dims, [1.0; 3], &cam, 1.0).unwrap();
        assert_eq!(view.axes.label(), label, "eye {eye}");
        assert!(
            (view.d - d).abs() < 1e-12,
            "eye {eye}: D {} want {d}",
            view.d
        );
        assert_eq!(view.eye.z, -view.d);
    }
}

#[test]
fn eye_inside_the_slab_is_clipped_not_hung() {
    let dims = [20usize, 20, 20];
    let cam = Camera::new(
        DVec3::new(9.5, 9.5, 5.2),
        DVec3::new(9.5, 9.5, 19.0),
        DVec3::Y,
        60.0,
        8,
        8,
    )
    .unwrap();
    let view = View::new(dims, [1.0; 3], &cam, 1.0).unwrap();
    // The first slice at least 1 voxel in front of z = 5.2 is 7.
    assert_eq!(view.axes.z_first, 7);
    assert!((view.d - 1.8).abs() < 1e-9);
    assert_eq!(view.dims[2], 13);
}

#[test]
fn reference_slab_matches_the_closed_form() {
    // A uniform slab 16 voxels thick, seen head-on through a narrow field of
    // view: opacity 1 - (1 - a)^16, colour premultiplied by it.
    let n = 16usize;
    let vol = Volume::from_fn([n, n, n], VoxelType::U8, DEFAULT_MEMORY_LIMIT, |_, _, _| {
        200
    })
    .unwrap();
    for a in [0.01, 0.1, 0.3] {
        // Constant opacity for every scalar the central ray meets (100..=200).
        let tf = TransferFunction::new(vec![
            ControlPoint {
                value: 0.0,
                rgba: [0.5, 0.5, 0.5, 0.0],
            },
            ControlPoint {
                value: 90.0,
                rgba: [0.5, 0.5, 0.5, a],
            },
            ControlPoint {
                value: 255.0,
                rgba: [0.5, 0.5, 0.5, a],
            },
        ])
        .unwrap();
        let lut = lut_for(VoxelType::U8, &tf);
        let cam = Camera::new(
            DVec3::new(7.5, 7.5, -1000.0),
            DVec3::new(7.5, 7.5, 7.5),
            DVec3::Y,
            0.01,
            3,
            3,
        )
        .unwrap();
        let prep = Prepared::new(&vol, &cam).unwrap();
        let img = render(&prep, &lut, Technique::Reference, &RenderOptions::default())
            .unwrap()
            .image;
        let want = 1.0 - (1.0 - a).powf(n as f64);
        let px = img.get(1, 1);
        assert!(
            (px[3] as f64 - want).abs() < 1e-6,
            "a {a}: opacity {} want {want}",
            px[3]
        );
        assert!((px[0] as f64 - 0.5 * want).abs() < 1e-6);
    }
}
