//! The exact pre-integrated colouring (`golden::preint::Colouring::Exact`):
//! its step colour follows a fine march of the self-attenuated segment at
//! every depth, and on thin, opaque, high-frequency volumes (thin
//! spherical shells, a lattice of thin plates, the folded `ribbon`
//! scene) at several thicknesses, opacities and views its image is never
//! further from the reference than plain sampling's.
//!
//! `cargo test --release -p golden --test it -- preexact`

use glam::DVec3;
use golden::camera::{Camera, ImagePlane};
use golden::methods::Method;
use golden::metrics::compare;
use golden::opacity::correct_opacity;
use golden::preint::{segment_exact, segment_opacity, Colouring, PreTable};
use golden::render::{render, Prepared, RenderOptions, Technique};
use golden::tf::Lut;
use golden::volume::Volume;

use crate::scenes::{table, volume_u8};

/// March a linear scalar from `sf` to `sb` over length `ds` in `n` fine
/// post-classified steps, front to back: the self-attenuated segment.
fn march(lut: &Lut, sf: f32, sb: f32, ds: f32, n: usize) -> [f64; 4] {
    let mut acc = [0f64; 4];
    for k in 0..n {
        let s = sf + (sb - sf) * (k as f32 + 0.5) / n as f32;
        let c = lut.lookup(s);
        let a = f64::from(correct_opacity(c[3], ds / n as f32));
        let w = (1.0 - acc[3]) * a;
        for ch in 0..3 {
            acc[ch] += w * f64::from(c[ch]);
        }
        acc[3] += w;
    }
    acc
}

/// A colour that changes where the opacity is high, so that the order of
/// colours inside a step matters.
fn ribbon_lut() -> Lut {
    table(&[
        (0.0, [0.0; 4]),
        (40.0, [0.5, 0.0, 0.1, 0.0]),
        (100.0, [0.9, 0.2, 0.1, 0.6]),
        (160.0, [1.0, 0.9, 0.2, 0.95]),
        (255.0, [0.1, 1.0, 0.6, 0.95]),
    ])
}

/// On a grid of front and back scalars and step lengths from thin to
/// opaque, the exact colouring's premultiplied colour is within 0.012 of
/// the 4000-step march (the depth axis's interpolation bound, module
/// notes of `golden::preint`), its opacity bits are the fast table's, and
/// it is at least five times closer than the fast colouring at worst.
#[test]
fn preexact_colour_follows_the_march_at_every_depth() {
    let lut = ribbon_lut();
    let (fast, exact) = (
        PreTable::new(&lut),
        PreTable::with_colouring(&lut, Colouring::Exact),
    );
    let (mut worst_fast, mut worst_exact) = (0f64, 0f64);
    for sf in (0..=255).step_by(15) {
        for sb in (0..=255).step_by(15) {
            for ds in [0.25f32, 0.5, 1.0, 1.7, 3.0, 8.0] {
                let (sf, sb) = (sf as f32, sb as f32);
                let e = exact.lookup(sf, sb);
                if e[3] <= 0.0 {
                    continue;
                }
                let m = march(&lut, sf, sb, ds, 4_000);
                let (a, at) = segment_exact(e[3], ds);
                assert_eq!(a.to_bits(), segment_opacity(e[3], ds).to_bits());
                let cx = exact.layered_colour(sf, sb, &e, at);
                let cf = fast.step_colour(&fast.lookup(sf, sb), &[0.0; 4], 0.0);
                for ch in 0..3 {
                    worst_exact = worst_exact.max((f64::from(cx[ch] * a) - m[ch]).abs());
                    worst_fast = worst_fast.max((f64::from(cf[ch] * a) - m[ch]).abs());
                }
            }
        }
    }
    println!("premultiplied colour against the march: fast worst {worst_fast:.4}, exact worst {worst_exact:.4}");
    assert!(worst_exact < 0.012, "exact off the march by {worst_exact}");
    assert!(
        worst_exact * 5.0 < worst_fast,
        "{worst_exact} against {worst_fast}"
    );
}

/// Thin spherical shells of `thickness` voxels (a Gaussian cross-section)
/// about the centre of an `n`^3 volume.
fn shells(n: usize, thickness: f64) -> Volume {
    let c = (n as f64 - 1.0) / 2.0;
    let radii = [0.2 * n as f64, 0.32 * n as f64, 0.44 * n as f64];
    volume_u8([n, n, n], move |x, y, z| {
        let d = ((x as f64 - c).powi(2) + (y as f64 - c).powi(2) + (z as f64 - c).powi(2)).sqrt();
        let u = radii
            .iter()
            .map(|r| ((d - r) / (thickness / 2.0)).abs())
            .fold(f64::INFINITY, f64::min);
        (220.0 * (-u * u).exp()).round() as u16
    })
}

/// A lattice of thin plates: planes `thickness` voxels thick every 6
/// voxels along x, y and z, alternately (a 3D checker of plates), with a
/// soft cross-section.
fn plates(n: usize, thickness: f64) -> Volume {
    volume_u8([n, n, n], move |x, y, z| {
        let cell = (x / 6 + y / 6 + z / 6) % 3;
        let coord = [x, y, z][cell] as f64;
        let u = (coord - 6.0 * (coord / 6.0).round()) / (thickness / 2.0);
        (220.0 * (-u * u).exp()).round() as u16
    })
}

/// Views of an `n`^3 volume: front, oblique, near (wide angle) and far.
fn views(n: usize) -> Vec<(&'static str, Camera)> {
    let c = (n as f64 - 1.0) / 2.0;
    let centre = DVec3::splat(c);
    let mut out = Vec::new();
    for (name, eye, fov) in [
        ("front", DVec3::new(c, c, -1.5 * n as f64), 40.0),
        (
            "oblique",
            centre + DVec3::new(-1.1, 0.7, -1.6) * n as f64,
            35.0,
        ),
        ("near", DVec3::new(c + 3.0, c - 2.0, -0.3 * n as f64), 90.0),
        ("far", centre + DVec3::new(0.8, -0.5, -4.0) * n as f64, 15.0),
    ] {
        let up = crate::scenes::up_for(centre - eye);
        let mut cam = Camera::new(eye, centre, up, fov, 40, 40).expect("camera");
        cam.image_plane = ImagePlane::Camera;
        out.push((name, cam));
    }
    out
}

/// The RMSE against a fine reference of plain sampling and of each
/// pre-integrated colouring, for `method`.
fn errors(prep: &Prepared, lut: &Lut, reference: &golden::image::Image, m: Method) -> [f64; 4] {
    let mut out = [0f64; 4];
    let mut opts = RenderOptions::default();
    let img = |opts: &RenderOptions| {
        render(prep, lut, Technique::Slice(m), opts)
            .expect("render")
            .image
    };
    out[0] = compare(&img(&opts), reference).expect("sizes").rmse;
    opts.slice.preintegrate = true;
    for (k, c) in [Colouring::Fast, Colouring::Attenuated, Colouring::Exact]
        .into_iter()
        .enumerate()
    {
        opts.slice.pre_colouring = c;
        out[k + 1] = compare(&img(&opts), reference).expect("sizes").rmse;
    }
    out
}

/// Thin shells and plates at two thicknesses and two opacities, and the
/// folded ribbon, from four views each: exact pre-integration's RMSE
/// against the reference (a 1/20-voxel step) is at or below plain
/// sampling's in every case, for er and er-ftb.
#[test]
fn preexact_is_never_worse_than_plain_sampling_on_thin_shells() {
    let n = 32;
    let opaque = ribbon_lut();
    let faint = table(&[
        (0.0, [0.0; 4]),
        (40.0, [0.5, 0.0, 0.1, 0.0]),
        (100.0, [0.9, 0.2, 0.1, 0.2]),
        (160.0, [1.0, 0.9, 0.2, 0.4]),
        (255.0, [0.1, 1.0, 0.6, 0.4]),
    ]);
    let ribbon = golden::scenes::Scene::Ribbon { n }
        .build(golden::volume::DEFAULT_MEMORY_LIMIT)
        .expect("ribbon");
    let mut cases: Vec<(String, Volume)> = Vec::new();
    for t in [1.0, 2.0] {
        cases.push((format!("shells {t}"), shells(n, t)));
        cases.push((format!("plates {t}"), plates(n, t)));
    }
    cases.push(("ribbon".into(), ribbon));
    let mut fine = RenderOptions::default();
    fine.reference.step = 0.05;
    let mut worst_ratio = 0f64;
    // One table at a time outermost, so that its three pre-integrated
    // tables are built once and shared by every view.
    for (lname, lut) in [("opaque", &opaque), ("faint", &faint)] {
        for (name, vol) in &cases {
            for (view, cam) in views(n) {
                let prep = Prepared::new(vol, &cam).expect("view");
                let reference = render(&prep, lut, Technique::Reference, &fine)
                    .expect("reference")
                    .image;
                for m in [Method::Er, Method::ErFtb] {
                    let [plain, fast, att, exact] = errors(&prep, lut, &reference, m);
                    println!(
                        "{name:10} {view:8} {lname:6} {:6}: plain {plain:.4} fast {fast:.4} attenuated {att:.4} exact {exact:.4}",
                        m.name()
                    );
                    assert!(
                        exact <= plain,
                        "{name}, {view}, {lname}, {}: exact {exact} above plain {plain}",
                        m.name()
                    );
                    worst_ratio = worst_ratio.max(exact / plain);
                }
            }
        }
    }
    println!("largest exact / plain RMSE: {worst_ratio:.3}");
}

/// The exact colouring's eight-ray path (`sampling::lanes`) gives the
/// one-ray path's bits, for every slice-order method, on the ribbon from
/// two views.
#[test]
fn preexact_lanes_match_the_one_ray_path() {
    let n = 32;
    let vol = golden::scenes::Scene::Ribbon { n }
        .build(golden::volume::DEFAULT_MEMORY_LIMIT)
        .expect("ribbon");
    let lut = ribbon_lut();
    for (view, cam) in views(n).into_iter().take(2) {
        let prep = Prepared::new(&vol, &cam).expect("view");
        for m in Method::ALL {
            let image = |lanes: bool| {
                let mut opts = RenderOptions::default();
                opts.slice.preintegrate = true;
                opts.slice.pre_colouring = Colouring::Exact;
                opts.slice.lanes = lanes;
                let img = render(&prep, &lut, Technique::Slice(m), &opts)
                    .expect("render")
                    .image;
                img.data
                    .iter()
                    .map(|p| p.map(f32::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(image(true), image(false), "{view}, {}", m.name());
        }
    }
}
