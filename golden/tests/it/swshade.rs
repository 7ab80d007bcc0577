//! Shear-warp shading (`golden::shearwarp::render_shaded`): the same
//! Blinn-Phong shader as the slice-order methods, each sample's colour its
//! filtered colour over its filtered opacity and its gradient the voxel
//! gradients filtered with the same taps. Against the shaded reference, an
//! ambient-only material against the unshaded frame, gradient opacity,
//! determinism.
//!
//! `cargo test --release -p golden --test it -- --nocapture swshade`
//! prints the measured errors.

use glam::DVec3;
use golden::camera::Camera;
use golden::image::Image;
use golden::methods::Method;
use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;
use golden::shading::{GradientMode, Material, Shade};

use crate::scenes::{scene, up_for, volume_u8};

fn cam(vol: &golden::volume::Volume, eye: DVec3, size: u32) -> Camera {
    let c = DVec3::from_array(vol.center_world());
    Camera::new(eye, c, up_for(c - eye), 60.0, size, size).expect("camera")
}

fn image(
    prep: &Prepared,
    lut: &golden::tf::Lut,
    tech: Technique,
    shade: Option<Shade>,
    scale: f64,
) -> Image {
    let mut o = RenderOptions {
        sw_scale: scale,
        ..RenderOptions::default()
    };
    o.slice.shade = shade;
    o.reference.shade = shade;
    render(prep, lut, tech, &o).expect("render").image
}

/// Shaded shear-warp against the shaded reference is several times closer
/// than unshaded shear-warp (it shades what the reference shades), and
/// within a stated tolerance of what it and ER measure: at most its own
/// unshaded error against the unshaded reference (the resampling's) plus
/// shaded ER's against the shaded reference (the shading's, from
/// interpolated voxel gradients, which both take); the triangle
/// inequality's form, not a proof, as the two terms interact.
#[test]
fn swshade_agrees_with_the_shaded_reference() {
    for (spec, preset, dist) in [("ml:32", "ml", 48.0), ("sphere:32", "sphere", 40.0)] {
        let vol = scene(spec);
        let lut = lut_for(vol.kind(), &tf_preset(preset).expect("preset"));
        let c = DVec3::from_array(vol.center_world());
        let prep = Prepared::new(&vol, &cam(&vol, c + DVec3::new(9.0, 7.0, -dist), 64)).unwrap();
        let sh = Some(Shade::default());
        let reference = image(&prep, &lut, Technique::Reference, sh, 1.0);
        let flat_reference = image(&prep, &lut, Technique::Reference, None, 1.0);
        let er = image(&prep, &lut, Technique::Slice(Method::Er), sh, 1.0);
        let er_err = compare(&er, &reference).unwrap().rmse;
        for scale in [1.0, 2.0] {
            let sw = image(&prep, &lut, Technique::ShearWarp, sh, scale);
            let flat = image(&prep, &lut, Technique::ShearWarp, None, scale);
            let shaded = compare(&sw, &reference).unwrap().rmse;
            let unshaded = compare(&flat, &reference).unwrap().rmse;
            let resampling = compare(&flat, &flat_reference).unwrap().rmse;
            let bound = resampling + er_err;
            eprintln!(
                "swshade {spec} S = {scale}: shaded shear-warp vs shaded reference RMSE {shaded:.5}, unshaded {unshaded:.5}; unshaded vs unshaded {resampling:.5}, shaded ER {er_err:.5}, bound {bound:.5}"
            );
            assert!(shaded * 3.0 < unshaded, "{spec}: {shaded} vs {unshaded}");
            assert!(shaded <= bound, "{spec} S = {scale}: {shaded} > {bound}");
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap();
            let again = one.install(|| image(&prep, &lut, Technique::ShearWarp, sh, scale));
            assert_eq!(again.data, sw.data, "{spec}: thread count changed the bits");
        }
    }
}

/// With only ambient light (`ka = 1`, `kd = ks = 0`) a shaded colour is the
/// sample's own: the shaded frame is the unshaded one up to the `f32`
/// rounding of dividing by the opacity before rather than after; samples
/// mode shades too and stays near voxels mode.
#[test]
fn swshade_ambient_only_is_the_unshaded_frame() {
    let vol = scene("ml:32");
    let lut = lut_for(vol.kind(), &tf_preset("ml").unwrap());
    let c = DVec3::from_array(vol.center_world());
    let prep = Prepared::new(&vol, &cam(&vol, c + DVec3::new(-5.0, 4.0, -40.0), 48)).unwrap();
    let mut ambient = Shade::default();
    ambient.material = Material {
        ambient: 1.0,
        diffuse: 0.0,
        specular: 0.0,
        shininess: 10.0,
    };
    let flat = image(&prep, &lut, Technique::ShearWarp, None, 1.0);
    let amb = image(&prep, &lut, Technique::ShearWarp, Some(ambient), 1.0);
    let worst = flat
        .data
        .iter()
        .zip(&amb.data)
        .flat_map(|(p, q)| (0..4).map(move |k| (p[k] - q[k]).abs()))
        .fold(0f32, f32::max);
    assert!(
        worst < 1e-5,
        "ambient-only differs from unshaded by {worst}"
    );
    let lit = image(
        &prep,
        &lut,
        Technique::ShearWarp,
        Some(Shade::default()),
        1.0,
    );
    assert!(
        compare(&lit, &flat).unwrap().rmse > 0.01,
        "shading changed nothing"
    );
    let mut samples = Shade::default();
    samples.gradient = GradientMode::Samples;
    let diff = image(&prep, &lut, Technique::ShearWarp, Some(samples), 1.0);
    let e = compare(&diff, &lit).unwrap().rmse;
    eprintln!("swshade: samples mode vs voxels mode RMSE {e:.5}");
    assert!(e > 0.0 && e < 0.02, "samples against voxels mode: {e}");
}

/// Gradient opacity clears a solid block's homogeneous inside in
/// shear-warp too.
#[test]
fn swshade_gradient_opacity_clears_homogeneous_regions() {
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
        let img = image(&prep, &lut, Technique::ShearWarp, Some(sh), 1.0);
        img.data.iter().map(|p| f64::from(p[3])).sum::<f64>()
    };
    let (plain, cleared) = (alpha(0.0), alpha(50.0));
    eprintln!("swshade: summed opacity {plain:.2} plain, {cleared:.2} with gradient opacity 50");
    assert!(cleared < 0.6 * plain, "{cleared} vs {plain}");
    assert!(cleared > 0.0);
}
