//! Gaze-directed variable resolution (`golden::gaze`): the sweet spot is
//! the one-ray-per-pixel caster bit for bit, the periphery casts far fewer
//! rays at a bounded error, and the result does not depend on the thread
//! count.
//!
//! `cargo test --release -p golden --test it -- --nocapture gaze` prints
//! the measured savings and errors.

use glam::DVec3;
use golden::camera::Camera;
use golden::gaze::Gaze;
use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;

use crate::scenes::{scene, up_for};

fn frame(prep: &Prepared, lut: &golden::tf::Lut, gaze: Gaze) -> golden::render::Frame {
    let mut o = RenderOptions::default();
    o.reference.gaze = Some(gaze);
    render(prep, lut, Technique::Reference, &o).expect("gaze frame")
}

fn setup() -> (Prepared, golden::tf::Lut) {
    let vol = scene("ml:32");
    let lut = lut_for(vol.kind(), &tf_preset("ml").unwrap());
    let c = DVec3::from_array(vol.center_world());
    let eye = c + DVec3::new(6.0, -5.0, -48.0);
    let cam = Camera::new(eye, c, up_for(c - eye), 45.0, 96, 80).unwrap();
    (Prepared::new(&vol, &cam).unwrap(), lut)
}

#[test]
fn sweet_spot_is_exact_and_periphery_is_cheap() {
    let (prep, lut) = setup();
    let (w, h) = (96u32, 80u32);
    let full = frame(&prep, &lut, Gaze::full(w, h));
    let fs = full.gaze.as_ref().unwrap();
    assert_eq!(fs.rays, fs.pixels, "the full profile casts a ray per pixel");
    let g = Gaze::around([40.0, 36.0], w, h);
    let f = frame(&prep, &lut, g);
    let st = f.gaze.as_ref().unwrap();
    let (mut exact, mut inner, mut err_mid, mut n_mid, mut err_out, mut n_out) =
        (0, 0, 0.0, 0, 0.0, 0);
    for j in 0..h as usize {
        for i in 0..w as usize {
            let k = j * w as usize + i;
            let (a, b) = (f.image.data[k], full.image.data[k]);
            let lev = g.level(i as f64 + 0.5, j as f64 + 0.5);
            let d: f64 = (0..4).map(|c| f64::from((a[c] - b[c]).abs())).sum();
            if lev == 0.0 {
                inner += 1;
                exact += usize::from(a == b);
            } else if lev < f64::from(g.levels) {
                err_mid += d;
                n_mid += 1;
            } else {
                err_out += d;
                n_out += 1;
            }
        }
    }
    let rmse = compare(&f.image, &full.image).unwrap().rmse;
    eprintln!(
        "gaze: {} rays for {} pixels ({:.1}%, per level {:?}); RMSE {rmse:.4} against one ray \
         per pixel; mean |error| {:.4} in the ramp, {:.4} at the periphery",
        st.rays,
        st.pixels,
        100.0 * st.rays as f64 / st.pixels as f64,
        st.rays_per_level,
        err_mid / n_mid.max(1) as f64,
        err_out / n_out.max(1) as f64
    );
    assert!(inner > 100, "{inner} sweet-spot pixels");
    assert_eq!(exact, inner, "the sweet spot is its own rays");
    assert!(n_mid > 0 && n_out > 0);
    assert!(st.rays * 2 < st.pixels, "{st:?}");
    // Error grows with distance from the gaze: none in the sweet spot,
    // less in the ramp than where the coarsest level holds.
    let (mid, out) = (err_mid / n_mid as f64, err_out / n_out as f64);
    assert!(out > 0.0, "the periphery is coarser");
    assert!(mid < out, "ramp {mid} against periphery {out}");
}

#[test]
fn gaze_is_deterministic_and_checks_its_profile() {
    let (prep, lut) = setup();
    let g = Gaze::around([10.0, 70.0], 96, 80);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| frame(&prep, &lut, g));
    let two = frame(&prep, &lut, g);
    let bits = |f: &golden::render::Frame| {
        f.image
            .data
            .iter()
            .map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&one), bits(&two));
    assert_eq!(one.gaze, two.gaze);
    for bad in [
        Gaze {
            inner: 20.0,
            outer: 10.0,
            ..g
        },
        Gaze { levels: 9, ..g },
        Gaze {
            at: [f64::NAN, 0.0],
            ..g
        },
    ] {
        let mut o = RenderOptions::default();
        o.reference.gaze = Some(bad);
        let e = render(&prep, &lut, Technique::Reference, &o)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("gaze"), "{e}");
    }
}
