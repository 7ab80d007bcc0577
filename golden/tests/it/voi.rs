//! The volume of interest in the mip-map caster (pre- and post-classified),
//! in shear-warp and with pre-integration: the slice-order methods'
//! properties (`shading.rs`'s `volume_of_interest_scales_opacity`) hold
//! there too.

use glam::DVec3;
use golden::camera::Camera;
use golden::image::Image;
use golden::methods::Method;
use golden::metrics::compare;
use golden::mipmap::Classify;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::voi::{Shape, Voi};

use crate::scenes::{scene, up_for};

/// Every float of an image, as bits.
fn bits(i: &Image) -> Vec<[u32; 4]> {
    i.data.iter().map(|p| p.map(f32::to_bits)).collect()
}

#[test]
fn the_mipmap_shear_warp_and_preintegration_take_the_volume_of_interest() {
    let vol = scene("ml:24");
    let translucent =
        crate::scenes::tf(&[(0.0, [1.0, 0.8, 0.6, 0.01]), (255.0, [1.0, 1.0, 1.0, 0.06])]);
    let lut = lut_for(vol.kind(), &translucent);
    let c = DVec3::from_array(vol.center_world());
    let eye = c + DVec3::new(5.0, -4.0, -40.0);
    let camera = Camera::new(eye, c, up_for(c - eye), 60.0, 40, 40).unwrap();
    let prep = Prepared::new(&vol, &camera).unwrap();
    let sphere = Voi {
        shape: Shape::Sphere {
            centre: c.to_array(),
            radius: 6.0,
        },
        scale: 4.0,
        outside: false,
        ramp: 2.0,
    };
    let boxed = Voi {
        shape: Shape::Box {
            lo: [4.3, 6.2, 5.4],
            hi: [17.6, 15.3, 19.7],
        },
        scale: 0.0,
        outside: true,
        ramp: 0.0,
    };
    let run = |tech, (classify, pre): (Classify, bool), voi: Option<Voi>, skip: bool| {
        let mut o = RenderOptions {
            mip_classify: classify,
            ..RenderOptions::default()
        };
        o.slice.preintegrate = pre;
        o.slice.voi = voi;
        o.reference.voi = voi;
        o.slice.skips.empty = skip;
        render(&prep, &lut, tech, &o).unwrap().image
    };
    let alpha = |i: &Image| i.data.iter().map(|p| f64::from(p[3])).sum::<f64>();
    let post = (Classify::Post, false);
    let reference = run(Technique::Reference, post, Some(sphere), true);
    let plain_ref = run(Technique::Reference, post, None, true);
    for (name, tech, classify) in [
        ("mipmap post", Technique::MipMap, post),
        ("mipmap pre", Technique::MipMap, (Classify::Pre, false)),
        ("shear-warp", Technique::ShearWarp, post),
        (
            "er preintegrated",
            Technique::Slice(Method::Er),
            (Classify::Post, true),
        ),
        (
            "er-ftb preintegrated",
            Technique::Slice(Method::ErFtb),
            (Classify::Post, true),
        ),
    ] {
        let plain = run(tech, classify, None, true);
        let one = Voi {
            scale: 1.0,
            ..sphere
        };
        assert_eq!(
            bits(&run(tech, classify, Some(one), true)),
            bits(&plain),
            "{name}: scale 1 renders as no VOI"
        );
        let boosted = run(tech, classify, Some(sphere), true);
        assert_ne!(bits(&boosted), bits(&plain), "{name}: the sphere shows");
        for voi in [sphere, boxed] {
            assert_eq!(
                bits(&run(tech, classify, Some(voi), false)),
                bits(&run(tech, classify, Some(voi), true)),
                "{name}: skipping stays exact with {voi:?}"
            );
        }
        let hidden = run(tech, classify, Some(boxed), true);
        assert!(
            alpha(&hidden) < 0.99 * alpha(&plain),
            "{name}: {} vs {}",
            alpha(&hidden),
            alpha(&plain)
        );
        let with = compare(&boosted, &reference).unwrap().rmse;
        let without = compare(&plain, &plain_ref).unwrap().rmse;
        eprintln!("{name}: VOI against the reference RMSE {with:.5} (without: {without:.5})");
        assert!(with < 2.0 * without + 0.005, "{name}: {with} vs {without}");
    }
}
