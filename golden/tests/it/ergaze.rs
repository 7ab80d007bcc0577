//! Gaze-directed variable resolution for ER (`golden::ergaze`): one ER
//! frame per level, blended by the profile. The frame against its levels
//! rendered whole (the window culling exact, the blend the profile's), the
//! sweet spot bit for bit the full frame, pixels and windows per level
//! against the profile, the coarse levels' rays and samples against the
//! `4^-l` and `2^-l` the profile asks for, determinism, bad levels.
//!
//! `cargo test --release -p golden --test it -- --nocapture ergaze`
//! prints the measured counts and errors.

use glam::DVec3;
use golden::camera::Camera;
use golden::ergaze::{coarse_volume, ErGazeStats};
use golden::gaze::Gaze;
use golden::image::Image;
use golden::methods::{self, Method, Options};
use golden::metrics::compare_where;
use golden::render::{lut_for, render, PrepareOptions, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::Volume;
use golden::warp::warp;

use crate::scenes::{scene, up_for};

const W: u32 = 96;
const H: u32 = 80;

fn camera(vol: &Volume, off: DVec3, fov: f64) -> Camera {
    let c = DVec3::from_array(vol.center_world());
    let eye = c + off;
    Camera::new(eye, c, up_for(c - eye), fov, W, H).unwrap()
}

fn setup(levels: u32) -> (Volume, Prepared, Lut) {
    let vol = scene("ml:32");
    let lut = lut_for(vol.kind(), &tf_preset("ml").unwrap());
    let cam = camera(&vol, DVec3::new(6.0, -5.0, -48.0), 45.0);
    let prep = Prepared::new(&vol, &cam)
        .unwrap()
        .with_gaze_levels(&vol, &cam, &PrepareOptions::default(), levels)
        .unwrap();
    (vol, prep, lut)
}

fn gaze_frame(prep: &Prepared, lut: &Lut, m: Method, g: Gaze) -> (Image, ErGazeStats) {
    let mut o = RenderOptions::default();
    o.reference.gaze = Some(g);
    let f = render(prep, lut, Technique::Slice(m), &o).expect("frame");
    (f.image, f.er_gaze.expect("ER gaze stats"))
}

/// Level `l`'s whole frame, no window.
fn level_frame(prep: &Prepared, lut: &Lut, m: Method, l: usize, opts: &Options) -> Image {
    let p = if l == 0 {
        prep
    } else {
        &prep.gaze_levels()[l - 1]
    };
    warp(
        &p.view,
        &methods::render(m, p, lut, opts).unwrap().baseplane,
    )
}

fn first_difference(a: &Image, b: &Image) -> Option<usize> {
    a.data
        .iter()
        .zip(&b.data)
        .position(|(p, q)| p.map(f32::to_bits) != q.map(f32::to_bits))
}

#[test]
fn ergaze_frame_is_the_profile_blend_of_whole_level_frames() {
    let (_, prep, lut) = setup(2);
    for m in [Method::Er, Method::ErFtb] {
        for g in [
            Gaze::around([40.0, 36.0], W, H),
            Gaze::around([5.0, 70.0], W, H),
            Gaze {
                inner: 6.0,
                outer: 30.0,
                ..Gaze::around([70.0, 20.0], W, H)
            },
        ] {
            let (img, _) = gaze_frame(&prep, &lut, m, g);
            let o = Options::default();
            let whole: Vec<Image> = (0..=2)
                .map(|l| level_frame(&prep, &lut, m, l, &o))
                .collect();
            // The blend from the profile's definition, in f64 like the
            // renderer's.
            let mut want = Image::new(W as usize, H as usize);
            for (p, out) in want.data.iter_mut().enumerate() {
                let (x, y) = ((p % W as usize) as f64 + 0.5, (p / W as usize) as f64 + 0.5);
                let lev = g.level(x, y);
                let (l0, t) = (lev.floor() as usize, lev.fract());
                let a = whole[l0].data[p];
                *out = if t > 0.0 {
                    let b = whole[l0 + 1].data[p];
                    std::array::from_fn(|c| {
                        (f64::from(a[c]) + t * (f64::from(b[c]) - f64::from(a[c]))) as f32
                    })
                } else {
                    a
                };
            }
            assert_eq!(
                first_difference(&img, &want),
                None,
                "{m:?} {g:?}: first pixel differing from the blend of whole level frames"
            );
            // The sweet spot is the full frame.
            let (inside, n) = compare_where(&img, &whole[0], |x, y| {
                g.level(x as f64 + 0.5, y as f64 + 0.5) == 0.0
            })
            .unwrap();
            assert!(n > 0);
            assert_eq!(
                inside.rmse, 0.0,
                "{m:?}: sweet spot differs from the full frame"
            );
            let (outside, _) = compare_where(&img, &whole[0], |x, y| {
                g.level(x as f64 + 0.5, y as f64 + 0.5) > 0.0
            })
            .unwrap();
            println!(
                "ergaze {m:?} at {:?}: sweet spot {n} px rmse 0, outside rmse {:.4} max {}",
                g.at, outside.rmse, outside.max_abs_255
            );
        }
    }
}

#[test]
fn ergaze_pixels_and_windows_per_level_follow_the_profile() {
    let (_, prep, lut) = setup(3);
    let g = Gaze {
        levels: 3,
        ..Gaze::around([30.0, 50.0], W, H)
    };
    let (_, st) = gaze_frame(&prep, &lut, Method::Er, g);
    assert_eq!(st.levels.len(), 4);
    for lv in &st.levels {
        let l = f64::from(lv.level);
        // Pixels reading level l: floor(lev) = l, or the next one up with
        // a non-zero blend weight.
        let reads = |i: u32, j: u32| {
            let lev = g.level(f64::from(i) + 0.5, f64::from(j) + 0.5);
            lev.floor() == l || (lev.floor() + 1.0 == l && lev.fract() > 0.0)
        };
        let mut n = 0u64;
        let mut bbox: Option<[u32; 4]> = None;
        for j in 0..H {
            for i in 0..W {
                if reads(i, j) {
                    n += 1;
                    let b = bbox.get_or_insert([i, i, j, j]);
                    *b = [b[0].min(i), b[1].max(i), b[2].min(j), b[3].max(j)];
                }
            }
        }
        assert_eq!(lv.pixels, n, "level {l}");
        assert_eq!(
            lv.window.map(|w| [w.x[0], w.x[1], w.y[0], w.y[1]]),
            bbox,
            "level {l}"
        );
        // A window culls: never more samples than the level's whole frame.
        let p = if lv.level == 0 {
            &prep
        } else {
            &prep.gaze_levels()[lv.level as usize - 1]
        };
        let whole = methods::render(Method::Er, p, &lut, &Options::default()).unwrap();
        assert!(lv.samples <= whole.stats.samples_total, "level {l}");
        println!(
            "ergaze level {l}: {} px, window {:?}, {} of the whole level frame's {} samples",
            lv.pixels, lv.window, lv.samples, whole.stats.samples_total
        );
    }
    assert_eq!(
        st.samples_total,
        st.levels.iter().map(|l| l.samples).sum::<u64>()
    );
    // With the whole image at the periphery only the coarsest level runs.
    let far = Gaze {
        inner: 0.0,
        outer: 1e-3,
        ..g
    };
    let (_, st) = gaze_frame(&prep, &lut, Method::Er, far);
    for lv in &st.levels[..3] {
        assert_eq!((lv.pixels, lv.samples, lv.window), (0, 0, None));
    }
    assert_eq!(st.levels[3].pixels, u64::from(W * H));
}

/// Level `l` samples its rays `2^l` times further apart on every plane and
/// its slices `2^l` apart. Unculled and unskipped, ER's samples on a slice
/// are the rays of its region's grid, `(N / t)^2` up to one ray per axis
/// (docs/benchmarks.md, eq. 12), so level `l`, whose `N_l` voxels per axis
/// span `2^l N_l` base voxels against the base's `N`, takes
/// `r = 8^-l prod_axes (2^l N_l / N)` of the base's samples (the extents'
/// ratio is 66/64 per axis for `ml:64` at level 1: the replicated edge),
/// and region 0 casts `4^-l` of its rays times the two in-plane ratios.
/// The grids' rounding, one ray per axis, bounds both within a factor
/// `(1 +- 1/N_l)^2` of that.
#[test]
fn ergaze_coarse_levels_take_the_profiles_rays_and_samples() {
    let vol = scene("ml:64");
    let lut = lut_for(vol.kind(), &tf_preset("ml").unwrap());
    let cam = camera(&vol, DVec3::new(3.0, -2.0, -96.0), 40.0);
    let prep = Prepared::new(&vol, &cam)
        .unwrap()
        .with_gaze_levels(&vol, &cam, &PrepareOptions::default(), 2)
        .unwrap();
    let o = Options {
        skips: Skips::NONE,
        ..Options::default()
    };
    let base = methods::render(Method::Er, &prep, &lut, &o).unwrap();
    for l in 1..=2u32 {
        let p = &prep.gaze_levels()[l as usize - 1];
        let k = 1usize << l;
        let want = vol.dims().map(|n| (n - 1).div_ceil(k) + 1);
        assert_eq!(p.stack.dims, [want[0], want[1], want[2]], "level {l}");
        for a in 0..3 {
            assert_eq!(p.view.spacing[a], prep.view.spacing[a] * k as f64);
        }
        let out = methods::render(Method::Er, p, &lut, &o).unwrap();
        let s = &out.stats;
        let ratio = s.samples_total as f64 * 8f64.powi(l as i32) / base.stats.samples_total as f64;
        let ext: Vec<f64> = (0..3)
            .map(|a| (k * p.stack.dims[a]) as f64 / prep.stack.dims[a] as f64)
            .collect();
        let n = p.stack.dims[0].min(p.stack.dims[1]) as f64;
        let (lo, hi) = ((1.0 - 1.0 / n).powi(2), (1.0 + 1.0 / n).powi(2));
        let (lo_s, hi_s) = (lo * ext[0] * ext[1] * ext[2], hi * ext[0] * ext[1] * ext[2]);
        let (lo_r, hi_r) = (lo * ext[0] * ext[1], hi * ext[0] * ext[1]);
        println!(
            "ergaze level {l}: {} samples, x 8^{l} / base {} = {ratio:.3} (bounds {lo_s:.3} .. {hi_s:.3}); region 0 rays {} against {}",
            s.samples_total, base.stats.samples_total, s.rays_per_region[0], base.stats.rays_per_region[0]
        );
        assert!(
            (lo_s..=hi_s).contains(&ratio),
            "level {l}: samples x 8^l / base = {ratio}"
        );
        // Rays per unit image area: 4^-l of the base's at the baseplane.
        let rays = s.rays_per_region[0] as f64 * 4f64.powi(l as i32)
            / base.stats.rays_per_region[0] as f64;
        assert!(
            (lo_r..=hi_r).contains(&rays),
            "level {l}: region-0 rays x 4^l / base = {rays}"
        );
    }
}

#[test]
fn ergaze_bits_do_not_depend_on_the_thread_count() {
    let (_, prep, lut) = setup(2);
    let g = Gaze::around([40.0, 36.0], W, H);
    let run = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| gaze_frame(&prep, &lut, Method::ErFtb, g))
    };
    let (a, sa) = run(1);
    let (b, sb) = run(2);
    let (c, sc) = run(3);
    assert_eq!(first_difference(&a, &b), None);
    assert_eq!(first_difference(&a, &c), None);
    assert_eq!((&sa, &sa), (&sb, &sc));
}

#[test]
fn ergaze_coarse_volume_filters_and_refuses_too_many_levels() {
    // A constant volume stays constant; a linear ramp stays on its line
    // (the tent is symmetric), except where the edge is replicated.
    let ramp = Volume::from_fn(
        [9, 6, 5],
        golden::volume::VoxelType::U8,
        u64::MAX,
        |x, _, _| (10 * x) as u16,
    )
    .unwrap();
    let c = coarse_volume(&ramp, 1).unwrap();
    assert_eq!(c.dims(), [5, 4, 3]);
    assert_eq!(c.spacing(), [2.0; 3]);
    for x in 1..4 {
        assert_eq!(c.get(x, 1, 1), (20 * x) as u16, "x = {x}");
    }
    // The edge: (3 * 0 + 1 * 10) / 4 at x = 0 rounds to 3 (0 and 10 replicated as 0, 0, 10).
    assert_eq!(c.get(0, 0, 0), 3);
    let err = coarse_volume(&ramp, 3).unwrap_err().to_string();
    assert!(
        err.contains("fewer --gaze-levels") && !err.contains('\n'),
        "{err}"
    );
    let (vol, prep, _) = setup(0);
    let cam = camera(&vol, DVec3::new(6.0, -5.0, -48.0), 45.0);
    let err = prep
        .with_gaze_levels(&vol, &cam, &PrepareOptions::default(), 5)
        .unwrap_err()
        .to_string();
    assert!(err.contains("fewer --gaze-levels"), "{err}");
    // A profile with more levels than prepared is refused, not rendered.
    let (_, prep, lut) = setup(1);
    let mut o = RenderOptions::default();
    o.reference.gaze = Some(Gaze::around([4.0, 4.0], W, H));
    let err = render(&prep, &lut, Technique::Slice(Method::Er), &o)
        .unwrap_err()
        .to_string();
    assert!(err.contains("coarse volumes"), "{err}");
    let err = render(&prep, &lut, Technique::Slice(Method::Box), &o)
        .unwrap_err()
        .to_string();
    assert!(err.contains("er and er-ftb"), "{err}");
}

/// `--rays footprint`'s level: halving the image doubles each pixel's
/// footprint, so the level rises by exactly one (until the coarsest);
/// a near, fine view keeps the voxels' rays (level 0); the level's rays
/// give every pixel at least `RAYS_PER_PIXEL` across, and one level
/// coarser would not.
#[test]
fn footprint_level_follows_the_pixel_size() {
    use golden::ergaze::{footprint_level, RAYS_PER_PIXEL};
    use golden::geometry::View;
    let vol = scene("ml:32");
    let c = DVec3::from_array(vol.center_world());
    let level = |off: DVec3, fov: f64, side: u32| {
        let eye = c + off;
        let cam = Camera::new(eye, c, up_for(c - eye), fov, side, side).unwrap();
        let view = View::new(vol.dims(), vol.spacing(), &cam, 1.0).unwrap();
        (footprint_level(&view), view)
    };
    assert_eq!(level(DVec3::new(0.0, 0.0, -40.0), 60.0, 256).0, 0);
    for off in [
        DVec3::new(0.0, 0.0, -400.0),
        DVec3::new(300.0, -200.0, -500.0),
    ] {
        let (l64, view) = level(off, 20.0, 64);
        let (l32, _) = level(off, 20.0, 32);
        assert!(l64 >= 1, "a far 64-pixel view keeps level {l64}");
        assert_eq!(l32, (l64 + 1).min(golden::gaze::MAX_LEVEL), "{off}");
        // The centre pixel's footprint on region 0's back plane, from two
        // neighbouring pixel rays (independent of the level's formula).
        let hit = |px: f64, py: f64| {
            let d = view.rays.dir(px, py);
            let s = 2.0 * view.d / d.z;
            DVec3::new(view.eye.x + s * d.x, view.eye.y + s * d.y, 0.0)
        };
        let [w, h] = view.size.map(f64::from);
        let f = hit(w / 2.0, h / 2.0).distance(hit(w / 2.0 + 1.0, h / 2.0));
        let across = f / 2f64.powi(l64 as i32);
        assert!(across >= RAYS_PER_PIXEL, "{across} rays per pixel");
        assert!(
            across < 2.0 * RAYS_PER_PIXEL * 1.5,
            "{across}: a coarser level fits"
        );
    }
}
