//! Gaze-directed variable resolution of the mip-map method
//! (`golden::mipcast::render_gaze` through `golden::gaze::render_with`):
//! ray counts per level against the profile, the sweet spot bit for bit
//! the full-resolution mip-map image, coarser rays taking fewer samples,
//! and determinism across thread counts.
//!
//! `cargo test --release -p golden --test it -- --nocapture mipgaze`
//! prints the measured savings and errors.

use glam::DVec3;
use golden::camera::Camera;
use golden::gaze::Gaze;
use golden::metrics::compare;
use golden::render::{lut_for, render, Frame, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;
use golden::tf::Lut;

use crate::scenes::{scene, up_for};

const W: u32 = 96;
const H: u32 = 80;

fn setup() -> (Prepared, Lut) {
    let vol = scene("ml:32");
    let lut = lut_for(vol.kind(), &tf_preset("ml").unwrap());
    let c = DVec3::from_array(vol.center_world());
    let eye = c + DVec3::new(6.0, -5.0, -48.0);
    let cam = Camera::new(eye, c, up_for(c - eye), 45.0, W, H).unwrap();
    (Prepared::new(&vol, &cam).unwrap(), lut)
}

fn frame(prep: &Prepared, lut: &Lut, tech: Technique, gaze: Option<Gaze>) -> Frame {
    let mut o = RenderOptions::default();
    o.reference.gaze = gaze;
    render(prep, lut, tech, &o).expect("frame")
}

/// The rays level `l` must cast for the profile, from its definition: a
/// ray is cast when it has non-zero bilinear weight at the centre of a
/// pixel whose level brackets `l` (ray `a` at pixel position
/// `(a + 1/2) 2^l`, the pixel's position clamped to the grid).
fn expected_rays(g: &Gaze, l: u32) -> u64 {
    let s = f64::from(1u32 << l);
    let (nx, ny) = (
        (W as usize).div_ceil(1 << l) + 1,
        (H as usize).div_ceil(1 << l) + 1,
    );
    let mut need = vec![false; nx * ny];
    for j in 0..H {
        for i in 0..W {
            let (x, y) = (f64::from(i) + 0.5, f64::from(j) + 0.5);
            let lev = g.level(x, y);
            if !(lev.floor() == f64::from(l) || (lev.ceil() == f64::from(l) && lev.fract() > 0.0)) {
                continue;
            }
            let fx = (x / s - 0.5).clamp(0.0, (nx - 1) as f64);
            let fy = (y / s - 0.5).clamp(0.0, (ny - 1) as f64);
            for b in 0..ny {
                for a in 0..nx {
                    if (fx - a as f64).abs() < 1.0 && (fy - b as f64).abs() < 1.0 {
                        need[b * nx + a] = true;
                    }
                }
            }
        }
    }
    need.iter().filter(|&&n| n).count() as u64
}

#[test]
fn ray_counts_per_level_follow_the_profile() {
    let (prep, lut) = setup();
    for g in [
        Gaze::around([40.0, 36.0], W, H),
        Gaze::around([5.0, 70.0], W, H),
        Gaze {
            levels: 3,
            ..Gaze::around([60.0, 20.0], W, H)
        },
    ] {
        let f = frame(&prep, &lut, Technique::MipMap, Some(g));
        let st = f.gaze.expect("gaze stats");
        let sweet = (0..H)
            .flat_map(|j| (0..W).map(move |i| (i, j)))
            .filter(|&(i, j)| g.level(f64::from(i) + 0.5, f64::from(j) + 0.5) < 1.0)
            .count() as u64;
        assert_eq!(
            st.rays_per_level[0], sweet,
            "one ray per pixel below level 1"
        );
        for l in 0..=g.levels {
            assert_eq!(
                st.rays_per_level[l as usize],
                expected_rays(&g, l),
                "level {l} of {g:?}"
            );
        }
        // The reference under the same profile casts the same rays.
        let r = frame(&prep, &lut, Technique::Reference, Some(g));
        assert_eq!(r.gaze.unwrap(), st);
    }
    // The periphery everywhere: one ray per 16 pixels (plus the grid's
    // closing row and column) and far fewer samples.
    let far = Gaze {
        at: [-1e4, -1e4],
        ..Gaze::around([0.0, 0.0], W, H)
    };
    let f = frame(&prep, &lut, Technique::MipMap, Some(far));
    let st = f.gaze.unwrap();
    assert_eq!(st.rays, u64::from((W / 4 + 1) * (H / 4 + 1)), "{st:?}");
    let full = frame(&prep, &lut, Technique::MipMap, None);
    let (s_far, s_full) = (
        f.mip.unwrap().samples_total,
        full.mip.unwrap().samples_total,
    );
    eprintln!(
        "mipgaze periphery: {} rays for {} pixels, {s_far} samples against {s_full}",
        st.rays, st.pixels
    );
    assert!(s_far * 16 < s_full, "{s_far} samples against {s_full}");
}

#[test]
fn the_sweet_spot_is_the_full_mipmap_and_the_periphery_is_coarser() {
    let (prep, lut) = setup();
    let full = frame(&prep, &lut, Technique::MipMap, None);
    let g = Gaze::around([40.0, 36.0], W, H);
    let f = frame(&prep, &lut, Technique::MipMap, Some(g));
    let (mut inner, mut exact, mut mid, mut n_mid, mut out, mut n_out) = (0, 0, 0.0, 0, 0.0, 0);
    for j in 0..H as usize {
        for i in 0..W as usize {
            let k = j * W as usize + i;
            let (a, b) = (f.image.data[k], full.image.data[k]);
            let lev = g.level(i as f64 + 0.5, j as f64 + 0.5);
            let d: f64 = (0..4).map(|c| f64::from((a[c] - b[c]).abs())).sum();
            if lev == 0.0 {
                inner += 1;
                exact += usize::from(a == b);
            } else if lev < f64::from(g.levels) {
                mid += d;
                n_mid += 1;
            } else {
                out += d;
                n_out += 1;
            }
        }
    }
    let st = f.gaze.as_ref().unwrap();
    let rmse = compare(&f.image, &full.image).unwrap().rmse;
    eprintln!(
        "mipgaze: {} rays for {} pixels ({:.1}%), samples {} against {}; RMSE {rmse:.4} against \
         the full mip-map; mean |error| {:.4} in the ramp, {:.4} at the periphery",
        st.rays,
        st.pixels,
        100.0 * st.rays as f64 / st.pixels as f64,
        f.mip.as_ref().unwrap().samples_total,
        full.mip.as_ref().unwrap().samples_total,
        mid / n_mid as f64,
        out / n_out as f64
    );
    assert!(inner > 100, "{inner} sweet-spot pixels");
    assert_eq!(exact, inner, "the sweet spot is the full mip-map's pixels");
    assert!(mid / (n_mid as f64) < out / (n_out as f64));
    assert!(f.mip.unwrap().samples_total * 2 < full.mip.unwrap().samples_total);
}

#[test]
fn mipmap_gaze_is_deterministic_across_threads() {
    let (prep, lut) = setup();
    let g = Gaze::around([10.0, 70.0], W, H);
    let run = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| {
                let f = frame(&prep, &lut, Technique::MipMap, Some(g));
                let bits: Vec<[u32; 4]> =
                    f.image.data.iter().map(|p| p.map(f32::to_bits)).collect();
                (bits, f.mip, f.gaze)
            })
    };
    let one = run(1);
    assert!(run(2) == one, "mipmap gaze differs with 2 threads");
}
