//! Gradient shading (`golden::shading`): the gradient is the exact slope
//! of a linear volume with spacing applied, lights move highlights where
//! they should, ER's shaded image agrees with the shaded reference far
//! better than with the unshaded one, and gradient opacity clears
//! homogeneous regions.
//!
//! `cargo test --release -p golden --test it -- --nocapture shading`
//! prints the measured errors.

use glam::DVec3;
use golden::camera::Camera;
use golden::image::Image;
use golden::methods::Method;
use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;
use golden::shading::{GradientMode, Shade, Shader};

use crate::scenes::{scene, up_for, volume_u8};

fn cam(vol: &golden::volume::Volume, eye: DVec3, size: u32) -> Camera {
    let c = DVec3::from_array(vol.center_world());
    Camera::new(eye, c, up_for(c - eye), 60.0, size, size).expect("camera")
}

fn image(prep: &Prepared, lut: &golden::tf::Lut, tech: Technique, shade: Option<Shade>) -> Image {
    let mut o = RenderOptions::default();
    o.slice.shade = shade;
    o.reference.shade = shade;
    render(prep, lut, tech, &o).expect("render").image
}

/// Central differences of `f = 2x + 3y + 4z` with spacing (1, 2, 0.5) are
/// the world slope (2, 1.5, 8) at every interior voxel, and interpolating
/// them anywhere inside keeps it.
#[test]
fn gradient_is_the_world_slope() {
    let vol = volume_u8([8, 7, 6], |x, y, z| (2 * x + 3 * y + 4 * z) as u16)
        .with_spacing([1.0, 2.0, 0.5])
        .unwrap();
    let c = DVec3::from_array(vol.center_world());
    let eye = c - DVec3::Z * 40.0;
    let prep = Prepared::new(&vol, &Camera::new(eye, c, DVec3::Y, 30.0, 8, 8).unwrap()).unwrap();
    let sh = Shader::new(&prep.view, &prep.stack, &Shade::default()).unwrap();
    assert_eq!(prep.view.axes.perm, [0, 1, 2], "the view keeps the axes");
    let want = [2.0, 1.5, 8.0];
    for &(x, y, z) in &[(1.0, 1.0, 1.0), (3.25, 2.5, 2.75), (5.9, 4.1, 3.0)] {
        let g = sh.gradient_trilinear(&prep.stack, x, y, z);
        let sign = if prep.view.axes.flip_z { -1.0 } else { 1.0 };
        let got = [g[0], g[1], g[2] * sign];
        for k in 0..3 {
            assert!((got[k] - want[k]).abs() < 1e-4, "({x}, {y}, {z}): {got:?}");
        }
        let b = sh.gradient_bilinear(&prep.stack, z as usize, x as f32, y as f32);
        assert!((f64::from(b[0]) - 2.0).abs() < 1e-4, "{b:?}");
    }
}

/// A sphere lit from the camera's left is brighter on the left half of
/// the image, and from the right on the right: the lights are where the
/// world says, in ER and in the reference.
#[test]
fn lights_light_their_side() {
    let vol = scene("sphere:32");
    let lut = lut_for(vol.kind(), &tf_preset("sphere").expect("preset"));
    let c = DVec3::from_array(vol.center_world());
    let eye = c - DVec3::Z * 50.0;
    let camera = Camera::new(eye, c, DVec3::Y, 50.0, 48, 48).unwrap();
    let prep = Prepared::new(&vol, &camera).unwrap();
    let (forward, right, _) = camera.basis();
    let halves = |img: &Image| {
        let (mut l, mut r) = (0.0, 0.0);
        for y in 0..img.height {
            for x in 0..img.width {
                let p = img.data[y * img.width + x];
                let v = f64::from(p[0] + p[1] + p[2]);
                if x < img.width / 2 {
                    l += v
                } else {
                    r += v
                }
            }
        }
        (l, r)
    };
    for tech in [Technique::Slice(Method::Er), Technique::Reference] {
        let lit = |dir: DVec3| {
            let mut sh = Shade::default();
            sh.add_light(dir).unwrap();
            halves(&image(&prep, &lut, tech, Some(sh)))
        };
        let (l1, r1) = lit(right - forward);
        let (l2, r2) = lit(-right - forward);
        assert!(
            r1 > 1.2 * l1,
            "{}: light on the right: {l1} | {r1}",
            tech.name()
        );
        assert!(
            l2 > 1.2 * r2,
            "{}: light on the left: {l2} | {r2}",
            tech.name()
        );
    }
}

/// ER shades what the reference shades: shaded against shaded is several
/// times closer than shaded ER against the unshaded reference, on the
/// smooth Marschner-Lobb signal and on brainsmall-like data.
#[test]
fn er_agrees_with_the_shaded_reference() {
    for (spec, preset, dist) in [("ml:32", "ml", 48.0), ("sphere:32", "sphere", 40.0)] {
        let vol = scene(spec);
        let lut = lut_for(vol.kind(), &tf_preset(preset).expect("preset"));
        let c = DVec3::from_array(vol.center_world());
        let prep = Prepared::new(&vol, &cam(&vol, c + DVec3::new(9.0, 7.0, -dist), 64)).unwrap();
        let sh = Some(Shade::default());
        let reference = image(&prep, &lut, Technique::Reference, sh);
        let er = image(&prep, &lut, Technique::Slice(Method::Er), sh);
        let flat = image(&prep, &lut, Technique::Slice(Method::Er), None);
        let shaded = compare(&er, &reference).unwrap().rmse;
        let unshaded = compare(&flat, &reference).unwrap().rmse;
        eprintln!(
            "{spec}: shaded ER vs shaded reference RMSE {shaded:.5}, unshaded ER {unshaded:.5}"
        );
        assert!(shaded * 3.0 < unshaded, "{spec}: {shaded} vs {unshaded}");
        assert!(shaded < 0.02, "{spec}: {shaded}");
    }
}

/// Gradient opacity clears a solid block's homogeneous inside: seen
/// through it, the block lets through more of the backdrop of its own
/// back face, so less opacity accumulates; a vanishing scale changes
/// nothing but zero-gradient samples.
#[test]
fn gradient_opacity_clears_homogeneous_regions() {
    let vol = volume_u8([24, 24, 24], |x, y, z| {
        if (4..20).contains(&x) && (4..20).contains(&y) && (4..20).contains(&z) {
            200
        } else {
            0
        }
    });
    let lut = lut_for(
        vol.kind(),
        &crate::scenes::tf(&[(0.0, [1.0, 1.0, 1.0, 0.0]), (255.0, [1.0, 1.0, 1.0, 0.08])]),
    );
    let prep = Prepared::new(&vol, &cam(&vol, DVec3::new(11.5, 11.5, -30.0), 32)).unwrap();
    let alpha = |g: f64| {
        let mut sh = Shade::default();
        sh.gradient_opacity = g;
        let img = image(&prep, &lut, Technique::Slice(Method::Er), Some(sh));
        img.data.iter().map(|p| f64::from(p[3])).sum::<f64>()
    };
    let (plain, cleared) = (alpha(0.0), alpha(50.0));
    eprintln!("summed opacity: {plain:.2} plain, {cleared:.2} with gradient opacity 50");
    assert!(cleared < 0.6 * plain, "{cleared} vs {plain}");
    assert!(cleared > 0.0);
}

/// Shading refuses what it cannot do: bad materials, zero lights.
#[test]
fn shading_refuses_bad_input() {
    let vol = scene("sphere:16");
    let lut = lut_for(vol.kind(), &tf_preset("sphere").unwrap());
    let prep = Prepared::new(&vol, &cam(&vol, DVec3::new(7.5, 7.5, -20.0), 16)).unwrap();
    let mut o = RenderOptions::default();
    let mut bad = Shade::default();
    bad.material.shininess = 0.0;
    o.slice.shade = Some(bad);
    let e = render(&prep, &lut, Technique::Slice(Method::Er), &o)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("shininess"), "{e}");
}

/// Both gradient definitions against the Marschner-Lobb signal's own
/// gradient (its formula differenced at 1e-6): the mean angle between the
/// model's gradient and the true one at pseudo-random points, skipping
/// points where the signal is nearly flat.
#[test]
fn gradient_modes_against_the_analytic_signal() {
    for n in [64usize, 128] {
        let vol = scene(&format!("ml:{n}"));
        let c = DVec3::from_array(vol.center_world());
        let camera = Camera::new(c - DVec3::Z * 200.0, c, DVec3::Y, 20.0, 8, 8).unwrap();
        let prep = Prepared::new(&vol, &camera).unwrap();
        assert_eq!(prep.view.axes.perm, [0, 1, 2]);
        let flip = if prep.view.axes.flip_z { -1.0 } else { 1.0 };
        let scale = 2.0 / (n - 1) as f64;
        let truth = |p: [f64; 3]| {
            let u = p.map(|v| -1.0 + scale * v);
            let h = 1e-6;
            let f = golden::scenes::marschner_lobb;
            let d = [
                f(u[0] + h, u[1], u[2]) - f(u[0] - h, u[1], u[2]),
                f(u[0], u[1] + h, u[2]) - f(u[0], u[1] - h, u[2]),
                f(u[0], u[1], u[2] + h) - f(u[0], u[1], u[2] - h),
            ];
            d.map(|v| v / (2.0 * h) * scale * 255.0)
        };
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let points: Vec<[f64; 3]> = (0..4000)
            .map(|_| [0; 3].map(|_| 2.0 + rnd() * (n as f64 - 5.0)))
            .collect();
        let mut means = Vec::new();
        for mode in [GradientMode::Voxels, GradientMode::Samples] {
            let mut shade = Shade::default();
            shade.gradient = mode;
            let sh = Shader::new(&prep.view, &prep.stack, &shade).unwrap();
            let (mut sum, mut count) = (0.0, 0);
            for &p in &points {
                let t = truth(p);
                let tl = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
                // Flat where |grad f| < 0.6 per unit of the signal's domain.
                if tl / (scale * 255.0) < 0.6 {
                    continue;
                }
                let mut g = sh.gradient_trilinear(&prep.stack, p[0], p[1], p[2]);
                g[2] *= flip;
                let gl = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                let cos = (g[0] * t[0] + g[1] * t[1] + g[2] * t[2]) / (gl * tl);
                sum += cos.clamp(-1.0, 1.0).acos().to_degrees();
                count += 1;
            }
            assert!(count > 1000, "{n}: {count} points");
            means.push(sum / count as f64);
        }
        eprintln!(
            "ml:{n}: mean gradient angle error {:.2} deg on voxels, {:.2} deg from samples",
            means[0], means[1]
        );
        for m in &means {
            assert!(*m < if n == 128 { 3.0 } else { 15.0 }, "ml:{n}: {means:?}");
        }
    }
}

/// A volume of interest: scale 1 renders as none, bit for bit; a box
/// outside which opacity is zeroed renders as the same box clipped away
/// (six clip planes), bit for bit; a boosted sphere adds opacity; ER and
/// the reference agree with it as without it.
#[test]
fn volume_of_interest_scales_opacity() {
    use golden::clip::ClipPlane;
    use golden::render::PrepareOptions;
    use golden::voi::{Shape, Voi};
    let vol = scene("ml:24");
    // Translucent throughout, so what happens inside shows.
    let translucent =
        crate::scenes::tf(&[(0.0, [1.0, 0.8, 0.6, 0.01]), (255.0, [1.0, 1.0, 1.0, 0.06])]);
    let lut = lut_for(vol.kind(), &translucent);
    let c = DVec3::from_array(vol.center_world());
    let camera = cam(&vol, c + DVec3::new(5.0, -4.0, -40.0), 40);
    let prep = Prepared::new(&vol, &camera).unwrap();
    let er = Technique::Slice(Method::Er);
    let run = |prep: &Prepared, tech, voi: Option<Voi>| {
        let mut o = RenderOptions::default();
        o.slice.voi = voi;
        o.reference.voi = voi;
        render(prep, &lut, tech, &o).unwrap().image
    };
    let bits = |i: &Image| {
        i.data
            .iter()
            .map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    let (lo, hi) = ([4.3, 6.2, 5.4], [17.6, 15.3, 19.7]);
    let boxed = |scale, outside| Voi {
        shape: Shape::Box { lo, hi },
        scale,
        outside,
        ramp: 0.0,
    };
    let plain = run(&prep, er, None);
    assert_eq!(bits(&run(&prep, er, Some(boxed(1.0, false)))), bits(&plain));
    // Zero outside the box = the box's six clip planes.
    let planes: Vec<ClipPlane> = (0..3)
        .flat_map(|k| {
            let e = DVec3::from_array(std::array::from_fn(|i| f64::from(u8::from(i == k))));
            [
                ClipPlane::new(e, -lo[k]).unwrap(),
                ClipPlane::new(-e, hi[k]).unwrap(),
            ]
        })
        .collect();
    let clipped = Prepared::with(
        &vol,
        &camera,
        &PrepareOptions {
            clip: planes,
            ..PrepareOptions::default()
        },
    )
    .unwrap();
    assert_eq!(
        bits(&run(&prep, er, Some(boxed(0.0, true)))),
        bits(&run(&clipped, er, None)),
        "zero opacity outside the box is the box's clipping"
    );
    // A boosted sphere, with a ramp.
    let sphere = Voi {
        shape: Shape::Sphere {
            centre: c.to_array(),
            radius: 6.0,
        },
        scale: 4.0,
        outside: false,
        ramp: 2.0,
    };
    let alpha = |i: &Image| i.data.iter().map(|p| f64::from(p[3])).sum::<f64>();
    let boosted = run(&prep, er, Some(sphere));
    assert_ne!(
        bits(&boosted),
        bits(&plain),
        "a boosted sphere changes the image"
    );
    let hidden = run(
        &prep,
        er,
        Some(Voi {
            scale: 0.0,
            ..sphere
        }),
    );
    assert!(
        alpha(&hidden) < 0.99 * alpha(&plain),
        "{} vs {}",
        alpha(&hidden),
        alpha(&plain)
    );
    let reference = run(&prep, Technique::Reference, Some(sphere));
    let plain_ref = run(&prep, Technique::Reference, None);
    let with = compare(&boosted, &reference).unwrap().rmse;
    let without = compare(&plain, &plain_ref).unwrap().rmse;
    eprintln!("volume of interest: ER vs reference RMSE {with:.5} (without: {without:.5})");
    assert!(with < 2.0 * without + 0.005, "{with} vs {without}");
    // The factor's ramp: 1 far outside, the scale deep inside, between on
    // the boundary.
    let v = golden::voi::ViewVoi::new(&prep.view, &sphere).unwrap();
    let centre = prep.view.axes.to_view(c);
    assert_eq!(v.factor(centre), 4.0);
    assert_eq!(v.factor(centre + DVec3::X * 20.0), 1.0);
    let edge = v.factor(centre + DVec3::X * 6.0);
    assert!((edge - 2.5).abs() < 1e-9, "{edge}");
}

/// The normal fade makes shading continuous at a vanishing gradient: two
/// opposite-ish tiny gradients shade within `3 (kd + ks) n_L |dg| / F` of
/// each other, where without the fade (`F = 0`) they differ by a whole
/// diffuse term; and above `F` the fade changes nothing.
#[test]
fn normal_fade_bounds_the_shading_of_tiny_gradients() {
    let vol = volume_u8([8, 8, 8], |x, _, _| (10 * x) as u16);
    let c = DVec3::from_array(vol.center_world());
    let prep = Prepared::new(
        &vol,
        &Camera::new(c - DVec3::Z * 30.0, c, DVec3::Y, 30.0, 8, 8).unwrap(),
    )
    .unwrap();
    let colour = [0.8, 0.6, 0.4, 0.5];
    let mut abrupt = Shade::default();
    abrupt.normal_fade = 0.0;
    let faded = Shade::default();
    let shade = |s: &Shade, g: [f64; 3]| {
        Shader::new(&prep.view, &prep.stack, s)
            .unwrap()
            .shade(colour, g)
    };
    // Facing the headlight (view z) and facing sideways, both tiny.
    let (a, b) = ([0.0, 0.0, 1e-3], [1e-3, 0.0, 0.0]);
    let dg = 2f64.sqrt() * 1e-3;
    let m = faded.material;
    let lip = 3.0 * (m.diffuse + m.specular) * dg / faded.normal_fade;
    let (fa, fb) = (shade(&faded, a), shade(&faded, b));
    let (aa, ab) = (shade(&abrupt, a), shade(&abrupt, b));
    for ch in 0..3 {
        assert!(
            (fa[ch] - fb[ch]).abs() <= lip,
            "faded channel {ch}: {fa:?} {fb:?}"
        );
        assert!(
            (aa[ch] - ab[ch]).abs() > 0.5 * m.diffuse * colour[ch],
            "abrupt channel {ch}: {aa:?} {ab:?}"
        );
    }
    // Above the fade both rules agree exactly.
    let big = [0.0, 30.0, 40.0];
    assert_eq!(shade(&faded, big), shade(&abrupt, big));
}

/// The mip-map method shades too (post-classified: gradients of the
/// level-blended scalar at the level's own resolution): against the shaded
/// reference it is several times closer than unshaded, and the same bits
/// whatever the thread count.
#[test]
fn the_mipmap_shades_like_the_reference() {
    for (spec, preset, dist) in [("ml:32", "ml", 48.0), ("sphere:32", "sphere", 40.0)] {
        let vol = scene(spec);
        let lut = lut_for(vol.kind(), &tf_preset(preset).expect("preset"));
        let c = DVec3::from_array(vol.center_world());
        let prep = Prepared::new(&vol, &cam(&vol, c + DVec3::new(9.0, 7.0, -dist), 64)).unwrap();
        let sh = Some(Shade::default());
        let reference = image(&prep, &lut, Technique::Reference, sh);
        let mip = image(&prep, &lut, Technique::MipMap, sh);
        let flat = image(&prep, &lut, Technique::MipMap, None);
        let er = image(&prep, &lut, Technique::Slice(Method::Er), sh);
        let shaded = compare(&mip, &reference).unwrap().rmse;
        let unshaded = compare(&flat, &reference).unwrap().rmse;
        let er_err = compare(&er, &reference).unwrap().rmse;
        eprintln!(
            "{spec}: shaded mipmap vs shaded reference RMSE {shaded:.5}, unshaded {unshaded:.5}, shaded ER {er_err:.5}"
        );
        assert!(shaded * 3.0 < unshaded, "{spec}: {shaded} vs {unshaded}");
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let again = one.install(|| image(&prep, &lut, Technique::MipMap, sh));
        assert_eq!(
            again.data, mip.data,
            "{spec}: thread count changed the bits"
        );
    }
}

/// A pre-classified mip-map frame (`--mip-classify pre`), shaded or not.
fn pre_mip(prep: &Prepared, lut: &golden::tf::Lut, shade: Option<Shade>) -> Image {
    let mut o = RenderOptions::default();
    o.slice.shade = shade;
    o.reference.shade = shade;
    o.mip_classify = golden::mipmap::Classify::Pre;
    render(prep, lut, Technique::MipMap, &o)
        .expect("render")
        .image
}

/// The pre-classified mip-map stores the shading in its level 0
/// (`MipMap::build_shaded`): ambient-only shading (ka 1, kd = ks = 0)
/// gives the unshaded pre-classified frame to 1e-6; with the default
/// material it is closer to the shaded reference than the unshaded
/// pre-classified frame; and a new light rebuilds the cached pyramid
/// (the frame equals a fresh preparation's and differs from the old
/// light's).
#[test]
fn the_pre_classified_mipmap_stores_the_shading() {
    for (spec, preset, dist) in [("ml:32", "ml", 48.0), ("sphere:32", "sphere", 40.0)] {
        let vol = scene(spec);
        let lut = lut_for(vol.kind(), &tf_preset(preset).expect("preset"));
        let c = DVec3::from_array(vol.center_world());
        let eye = c + DVec3::new(9.0, 7.0, -dist);
        let prep = Prepared::new(&vol, &cam(&vol, eye, 64)).unwrap();
        let flat = pre_mip(&prep, &lut, None);
        let mut ambient = Shade::default();
        ambient.material = golden::shading::Material::parse("1,0,0,10").unwrap();
        let amb = pre_mip(&prep, &lut, Some(ambient));
        let worst = amb
            .data
            .iter()
            .flatten()
            .zip(flat.data.iter().flatten())
            .map(|(a, b)| (a - b).abs())
            .fold(0f32, f32::max);
        assert!(worst <= 1e-6, "{spec}: ambient-only differs by {worst}");
        let sh = Some(Shade::default());
        let reference = image(&prep, &lut, Technique::Reference, sh);
        let shaded = compare(&pre_mip(&prep, &lut, sh), &reference).unwrap().rmse;
        let unshaded = compare(&flat, &reference).unwrap().rmse;
        eprintln!(
            "{spec}: pre-classified mipmap vs shaded reference RMSE {shaded:.5} shaded, {unshaded:.5} unshaded"
        );
        assert!(shaded < unshaded, "{spec}: {shaded} vs {unshaded}");
        // Another light: the cached pyramid must not be reused.
        let mut side = Shade::default();
        side.add_light(glam::DVec3::new(1.0, 0.0, 0.0)).unwrap();
        let lit = pre_mip(&prep, &lut, Some(side));
        let fresh = Prepared::new(&vol, &cam(&vol, eye, 64)).unwrap();
        assert_eq!(lit.data, pre_mip(&fresh, &lut, Some(side)).data, "{spec}");
        assert_ne!(lit.data, pre_mip(&prep, &lut, sh).data, "{spec}");
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// The slice-order methods' `f32` shader agrees with the `f64` one to
    /// its stated tolerance, for any material, lights, fade, gradient
    /// opacity and gradient (tiny, fading and steep).
    #[test]
    fn shade_f32_agrees_with_shade(
        m in (0.0..2.0f64, 0.0..3.0f64, 0.0..3.0f64, 1.0..300.0f64, proptest::bool::ANY),
        lights in proptest::collection::vec((-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64), 0..4),
        fade in proptest::prop_oneof![proptest::strategy::Just(0.0), 0.1..20.0f64],
        g_ref in proptest::prop_oneof![proptest::strategy::Just(0.0), 0.1..50.0f64],
        samples in proptest::collection::vec(
            ((0.0..1.0f32, 0.0..1.0f32, 0.0..1.0f32, 0.0..1.0f32), (-3.0..3.0f32, -3.0..3.0f32, -3.0..3.0f32), -6..3i32),
            200,
        ),
    ) {
        let vol = volume_u8([6, 6, 6], |x, y, z| (x + y + z) as u16);
        let c = DVec3::from_array(vol.center_world());
        let prep = Prepared::new(&vol, &cam(&vol, c + DVec3::new(3.0, -5.0, -30.0), 8)).unwrap();
        let mut shade = Shade::default();
        let (ka, kd, ks, p, integral) = m;
        shade.material.ambient = ka;
        shade.material.diffuse = kd;
        shade.material.specular = ks;
        shade.material.shininess = if integral { p.round() } else { p };
        for (x, y, z) in lights {
            if DVec3::new(x, y, z).length() > 1e-3 {
                shade.add_light(DVec3::new(x, y, z)).unwrap();
            }
        }
        shade.normal_fade = fade;
        shade.gradient_opacity = g_ref;
        let sh = Shader::new(&prep.view, &prep.stack, &shade).unwrap();
        let tol = sh.f32_tolerance();
        for ((r, gr, b, a), (gx, gy, gz), e) in samples {
            // Gradient magnitudes from 1e-6 to 3e3, across the fade.
            let k = 10f32.powi(e);
            let g = [gx * k, gy * k, gz * k];
            let want = sh.shade([r, gr, b, a].map(f64::from), g.map(f64::from));
            let got = sh.shade_f32([r, gr, b, a], g);
            for ch in 0..4 {
                let d = (f64::from(got[ch]) - want[ch]).abs();
                proptest::prop_assert!(d <= tol, "channel {ch}: {} against {} (tolerance {tol}), g {g:?}", got[ch], want[ch]);
            }
        }
    }
}
