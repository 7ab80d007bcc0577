//! Skipping what the scene does not need, in golden: empty space and
//! culling leave every method's image bit for bit unchanged (proptest over
//! random sparse volumes, tables, views and block sizes); early ray
//! termination changes no channel by more than `1 - threshold`; clip
//! planes never let a sample beyond them through; the occupancy structure
//! is conservative against brute force.
//!
//! `cargo test --release -p golden --test it -- skipping`; the long proptest run:
//! `cargo test --release -p golden --test it -- --ignored skipping`.

use glam::DVec3;
use golden::camera::{Camera, ImagePlane};
use golden::clip::ClipPlane;
use golden::methods::{self, Method, Options, Output};
use golden::occupancy::{MinMax, Occupancy};
use golden::render::{render, PrepareOptions, Prepared, RenderOptions, Technique};
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::{Volume, VoxelType, DEFAULT_MEMORY_LIMIT};
use proptest::prelude::*;

use crate::scenes::{eye_and_look, hash, sparse, table};

const OFF: Skips = Skips {
    empty: false,
    cull: false,
};

fn camera(eye: DVec3, look: DVec3, fov: f64, front: bool) -> Camera {
    let f = (look - eye).normalize();
    let up = if f.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    let mut c = Camera::new(eye, look, up, fov, 40, 32).expect("camera");
    if front {
        c.image_plane = ImagePlane::Front;
    }
    c
}

fn slice(m: Method, p: &Prepared, l: &Lut, terminate: f32, substeps: u32, skips: Skips) -> Output {
    let o = Options {
        terminate,
        substeps,
        skips,
        shade: None,
        voi: None,
        preintegrate: false,
        pre_colouring: Default::default(),
        lanes: true,
    };
    methods::render(m, p, l, &o).expect("render")
}

fn image(p: &Prepared, l: &Lut, m: Method, o: Options) -> Vec<[f32; 4]> {
    let opts = RenderOptions {
        slice: o,
        ..RenderOptions::default()
    };
    render(p, l, Technique::Slice(m), &opts)
        .expect("render")
        .image
        .data
}

fn bits(v: &[[f32; 4]]) -> Vec<[u32; 4]> {
    v.iter().map(|p| p.map(f32::to_bits)).collect()
}

#[derive(Debug, Clone)]
struct Case {
    dims: [usize; 3],
    blobs: usize,
    seed: u64,
    /// Opacity starts above this scalar (air below is transparent).
    threshold: f64,
    side: usize,
    dist: f64,
    offset: [f64; 2],
    fov: f64,
    front: bool,
    block: usize,
    substeps: u32,
}

fn cases() -> impl Strategy<Value = Case> {
    (
        (
            prop::array::uniform3(6usize..28),
            1usize..5,
            any::<u64>(),
            20.0..120.0f64,
        ),
        (
            0usize..6,
            prop_oneof![0.3..4.0f64, 4.0..60.0],
            prop::array::uniform2(-0.6..0.6f64),
            prop_oneof![10.0..40.0f64, 40.0..150.0],
            any::<bool>(),
        ),
        (
            prop::sample::select(vec![2usize, 4, 8, 16]),
            prop_oneof![3 => Just(1u32), 1 => Just(2u32)],
        ),
    )
        .prop_map(
            |(
                (dims, blobs, seed, threshold),
                (side, dist, offset, fov, front),
                (block, substeps),
            )| Case {
                dims,
                blobs,
                seed,
                threshold,
                side,
                dist,
                offset,
                fov,
                front,
                block,
                substeps,
            },
        )
}

/// The eye `dist` voxels outside face `side`, looking at a point offset
/// across the volume (so that narrow views see only part of it).
fn case_camera(c: &Case) -> Camera {
    let (eye, look) = eye_and_look(c.dims, c.side, c.dist, c.offset);
    camera(eye, look, c.fov, c.front)
}

fn check_identity(c: &Case) -> Result<(), TestCaseError> {
    let vol = sparse(c.dims, c.blobs, c.seed);
    let lut = table(&[
        (0.0, [0.0; 4]),
        (c.threshold, [0.2, 0.3, 0.9, 0.0]),
        (c.threshold + 40.0, [1.0, 0.6, 0.2, 0.5]),
        (255.0, [1.0, 1.0, 1.0, 0.9]),
    ]);
    let cam = case_camera(c);
    let opts = PrepareOptions {
        block: c.block,
        ..PrepareOptions::default()
    };
    let prep =
        Prepared::with(&vol, &cam, &opts).map_err(|e| TestCaseError::reject(e.to_string()))?;
    for m in Method::ALL {
        let off = slice(m, &prep, &lut, 1.0, c.substeps, OFF);
        // Culling leaves rays the warp never reads empty, so the whole
        // baseplane is compared with empty-space skipping alone.
        let empty = Skips {
            empty: true,
            cull: false,
        };
        let on = slice(m, &prep, &lut, 1.0, c.substeps, empty);
        prop_assert_eq!(
            bits(&on.baseplane.data),
            bits(&off.baseplane.data),
            "{} baseplane changed by empty-space skipping",
            m.name()
        );
        let on = slice(m, &prep, &lut, 1.0, c.substeps, Skips::default());
        prop_assert!(on.stats.samples_total <= off.stats.samples_total);
        for z in 0..prep.view.dims[2] {
            prop_assert!(on.stats.samples_per_slice[z] <= off.stats.samples_per_slice[z]);
        }
        let o = |skips| Options {
            terminate: 1.0,
            substeps: c.substeps,
            skips,
            shade: None,
            voi: None,
            preintegrate: false,
            pre_colouring: Default::default(),
            lanes: true,
        };
        prop_assert_eq!(
            bits(&image(&prep, &lut, m, o(Skips::default()))),
            bits(&image(&prep, &lut, m, o(OFF))),
            "{} image changed by skipping",
            m.name()
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]
    /// Empty-space skipping and culling never change a bit of any
    /// method's baseplane or image, and never add a sample.
    #[test]
    fn skipping_is_bit_identical(c in cases()) {
        check_identity(&c)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2048, ..ProptestConfig::default() })]
    /// The long run of [`skipping_is_bit_identical`].
    #[test]
    #[ignore]
    fn skipping_is_bit_identical_long(c in cases()) {
        check_identity(&c)?;
    }
}

/// Skipping actually skips: on a sparse volume with transparent air the
/// samples fall by a large factor, and a narrow view culls rays.
#[test]
fn skipping_saves_samples_and_culls_rays() {
    let vol = sparse([48, 40, 44], 2, 7);
    let lut = table(&[
        (0.0, [0.0; 4]),
        (50.0, [1.0, 1.0, 1.0, 0.0]),
        (255.0, [1.0; 4]),
    ]);
    let cam = camera(
        DVec3::new(23.5, 19.5, -30.0),
        DVec3::new(23.5, 19.5, 21.5),
        60.0,
        false,
    );
    let prep = Prepared::new(&vol, &cam).expect("view");
    let off = slice(Method::Er, &prep, &lut, 1.0, 1, OFF);
    let on = slice(Method::Er, &prep, &lut, 1.0, 1, Skips::default());
    let ratio = off.stats.samples_total as f64 / on.stats.samples_total as f64;
    println!(
        "samples {} -> {} ({ratio:.1}x), occupied blocks {:.3}, slices skipped {}, beams skipped {}",
        off.stats.samples_total,
        on.stats.samples_total,
        on.stats.occupied_blocks,
        on.stats.slices_skipped,
        on.stats.beams_skipped
    );
    assert!(ratio > 2.0, "empty-space skipping saved only {ratio:.2}x");
    assert!(on.stats.occupied_blocks < 0.5);
    // A 10-degree view of one corner reaches few of the rays.
    let narrow = camera(
        DVec3::new(23.5, 19.5, -30.0),
        DVec3::new(8.0, 6.0, 0.0),
        10.0,
        false,
    );
    let prep = Prepared::new(&vol, &narrow).expect("view");
    let on = slice(
        Method::ErFtb,
        &prep,
        &lut,
        1.0,
        1,
        Skips {
            empty: false,
            cull: true,
        },
    );
    let total: u64 = on.stats.rays_per_region.iter().sum();
    println!(
        "narrow view: {} of {total} rays culled",
        on.stats.rays_culled
    );
    assert!(
        on.stats.rays_culled * 2 > total,
        "culled {} of {total}",
        on.stats.rays_culled
    );
}

/// Termination with every skip on stays within `1 - threshold` of the
/// exact image (no skipping, no termination), channel by channel.
#[test]
fn termination_error_stays_within_the_threshold() {
    let vol = sparse([40, 36, 44], 4, 11);
    let lut = table(&[
        (0.0, [0.0; 4]),
        (45.0, [0.9, 0.5, 0.2, 0.0]),
        (120.0, [0.4, 0.7, 1.0, 0.95]),
    ]);
    for (eye, fov) in [
        (DVec3::new(19.5, 17.5, -20.0), 90.0),
        (DVec3::new(-60.0, 10.0, 20.0), 40.0),
    ] {
        let cam = camera(eye, DVec3::new(19.5, 17.5, 21.5), fov, false);
        let prep = Prepared::new(&vol, &cam).expect("view");
        let exact = image(
            &prep,
            &lut,
            Method::ErFtb,
            Options {
                terminate: 1.0,
                substeps: 1,
                skips: OFF,
                shade: None,
                voi: None,
                preintegrate: false,
                pre_colouring: Default::default(),
                lanes: true,
            },
        );
        for t in [0.99f32, 0.9, 0.5] {
            let o = Options {
                terminate: t,
                substeps: 1,
                skips: Skips::default(),
                shade: None,
                voi: None,
                preintegrate: false,
                pre_colouring: Default::default(),
                lanes: true,
            };
            let got = image(&prep, &lut, Method::ErFtb, o);
            let worst = got
                .iter()
                .zip(&exact)
                .flat_map(|(a, b)| (0..4).map(move |c| (a[c] - b[c]).abs()))
                .fold(0f32, f32::max);
            println!("threshold {t}: worst channel change {worst:.5}");
            // f32 compositing of the exact image: a few ulps per slice.
            assert!(worst <= (1.0 - t) + 1e-5, "threshold {t}: {worst}");
            let s_on = slice(Method::ErFtb, &prep, &lut, t, 1, Skips::default()).stats;
            let s_off = slice(Method::ErFtb, &prep, &lut, 1.0, 1, Skips::default()).stats;
            assert!(
                s_on.samples_total < s_off.samples_total,
                "termination took no samples off"
            );
        }
    }
}

/// A plane perpendicular to the principal axis through slice `k` keeps
/// slices `z >= k` whole: the image equals that of the volume with the
/// slices in front emptied, bit for bit, in every method (a sample in
/// front of the plane would have shown the emptied voxels).
#[test]
fn a_slice_aligned_clip_plane_equals_emptying_the_slices_in_front() {
    let dims = [24, 20, 30];
    let vol = sparse(dims, 5, 3);
    let k = 11usize;
    let cut = Volume::from_fn(dims, VoxelType::U8, DEFAULT_MEMORY_LIMIT, |x, y, z| {
        if z < k {
            0
        } else {
            vol.get(x, y, z)
        }
    })
    .expect("volume");
    let lut = table(&[
        (0.0, [0.0; 4]),
        (30.0, [1.0, 0.5, 0.0, 0.0]),
        (200.0, [0.3, 0.6, 1.0, 0.8]),
    ]);
    let cam = camera(
        DVec3::new(11.5, 9.5, -25.0),
        DVec3::new(12.0, 9.0, 14.5),
        70.0,
        false,
    );
    let clip = vec!["0,0,1,-11".parse::<ClipPlane>().expect("plane")];
    let clipped = Prepared::with(
        &vol,
        &cam,
        &PrepareOptions {
            clip,
            ..PrepareOptions::default()
        },
    )
    .expect("view");
    let emptied = Prepared::new(&cut, &cam).expect("view");
    let whole = Prepared::new(&vol, &cam).expect("view");
    for m in Method::ALL {
        for skips in [OFF, Skips::default()] {
            let o = Options {
                terminate: 1.0,
                substeps: 1,
                skips,
                shade: None,
                voi: None,
                preintegrate: false,
                pre_colouring: Default::default(),
                lanes: true,
            };
            let a = image(&clipped, &lut, m, o);
            assert_eq!(bits(&a), bits(&image(&emptied, &lut, m, o)), "{}", m.name());
            assert_ne!(
                bits(&a),
                bits(&image(&whole, &lut, m, o)),
                "{}: the plane cut nothing",
                m.name()
            );
        }
    }
}

/// A bright point behind a plane more than one voxel away leaves no trace
/// with the plane (every sample that could read it lies beyond the plane),
/// in every method and the reference, and does without it.
#[test]
fn no_sample_beyond_a_clip_plane_is_taken() {
    let dims = [21, 21, 21];
    let vol = Volume::from_fn(dims, VoxelType::U8, DEFAULT_MEMORY_LIMIT, |x, y, z| {
        if (x, y, z) == (10, 10, 10) {
            255
        } else {
            0
        }
    })
    .expect("volume");
    let lut = table(&[(0.0, [0.0; 4]), (255.0, [1.0, 1.0, 1.0, 1.0])]);
    // Oblique planes: keep x + y + z <= 30 - 2.5 sqrt 3 (the point's cell
    // lies wholly beyond), and keep y <= 8.4.
    for plane in ["-1,-1,-1,25.6", "0,-1,0,8.4"] {
        let cam = camera(
            DVec3::new(-14.0, 4.0, -22.0),
            DVec3::new(10.0, 10.0, 10.0),
            60.0,
            false,
        );
        let p = PrepareOptions {
            clip: vec![plane.parse().expect("plane")],
            ..PrepareOptions::default()
        };
        let clipped = Prepared::with(&vol, &cam, &p).expect("view");
        let whole = Prepared::new(&vol, &cam).expect("view");
        let mut techs: Vec<Technique> = Method::ALL.map(Technique::Slice).to_vec();
        techs.push(Technique::Reference);
        for t in techs {
            let o = RenderOptions::default();
            let lit = |p: &Prepared| {
                render(p, &lut, t, &o)
                    .expect("render")
                    .image
                    .data
                    .iter()
                    .map(|v| v[3])
                    .fold(0f32, f32::max)
            };
            assert_eq!(lit(&clipped), 0.0, "{} through plane {plane}", t.name());
            assert!(
                lit(&whole) > 0.01,
                "{}: the point is not seen at all",
                t.name()
            );
        }
    }
}

/// Clip planes are refused when malformed or too many, with one line.
#[test]
fn bad_clip_planes_are_refused() {
    for bad in ["1,2,3", "1,2,3,4,5", "0,0,0,1", "nan,0,1,0", "a,b,c,d"] {
        let e = bad.parse::<ClipPlane>().expect_err(bad).to_string();
        assert!(!e.contains('\n') && e.contains("clip plane"), "{bad}: {e}");
    }
    let vol = sparse([8, 8, 8], 1, 1);
    let cam = camera(DVec3::new(3.5, 3.5, -10.0), DVec3::splat(3.5), 60.0, false);
    let p = PrepareOptions {
        clip: vec!["0,0,1,0".parse().expect("plane"); 7],
        ..PrepareOptions::default()
    };
    let e = Prepared::with(&vol, &cam, &p)
        .expect_err("7 planes")
        .to_string();
    assert!(e.contains("at most 6"), "{e}");
    let p = PrepareOptions {
        block: 3,
        ..PrepareOptions::default()
    };
    let e = Prepared::with(&vol, &cam, &p)
        .expect_err("block 3")
        .to_string();
    assert!(e.contains("power of two"), "{e}");
}

/// The min-max blocks against brute force, with the one-voxel overlap.
#[test]
fn min_max_blocks_match_brute_force() {
    let dims = [13, 9, 17];
    let vol = sparse(dims, 3, 5);
    for block in [2usize, 4, 8, 16] {
        let mm = MinMax::new(&vol, block).expect("blocks");
        for bz in 0..mm.counts[2] {
            for by in 0..mm.counts[1] {
                for bx in 0..mm.counts[0] {
                    let (mut lo, mut hi) = (u16::MAX, 0);
                    let b = [bx, by, bz];
                    let r = |a: usize| b[a] * block..=(b[a] * block + block).min(dims[a] - 1);
                    for z in r(2) {
                        for y in r(1) {
                            for x in r(0) {
                                lo = lo.min(vol.get(x, y, z));
                                hi = hi.max(vol.get(x, y, z));
                            }
                        }
                    }
                    let i = (bz * mm.counts[1] + by) * mm.counts[0] + bx;
                    assert_eq!(mm.range[i], (lo, hi), "block {b:?} of {block}");
                }
            }
        }
    }
}

/// A block the occupancy calls empty gives zero opacity to every scalar
/// the table can be asked about in its range (checked on a fine grid),
/// and one it calls occupied has a visible scalar (the map is tight at
/// the table's resolution).
#[test]
fn occupancy_is_conservative_and_tight() {
    let lut = table(&[
        (0.0, [0.0; 4]),
        (60.3, [1.0, 0.0, 0.0, 0.0]),
        (61.0, [1.0, 0.0, 0.0, 0.4]),
        (100.0, [1.0, 0.0, 0.0, 0.0]),
        (180.0, [1.0, 0.0, 0.0, 0.0]),
        (181.0, [1.0, 1.0, 1.0, 1.0]),
    ]);
    let visible = lut.visible_ranges();
    let mut state = 12345u64;
    for _ in 0..4000 {
        state = hash(state);
        let a = (state % 256) as u16;
        let b = ((state >> 16) % 256) as u16;
        let (lo, hi) = (a.min(b), a.max(b));
        let seen = (0..=((hi - lo) as usize * 16))
            .map(|k| f32::from(lo) + k as f32 / 16.0)
            .any(|s| lut.lookup(s)[3] > 0.0);
        if !visible.any(lo, hi) {
            assert!(!seen, "[{lo}, {hi}] called empty but a sample is visible");
        } else {
            // Tight to one table entry: the entries a range looks up reach
            // one scalar past its top.
            let top = (hi + 1).min(255);
            assert!(
                (lo..=top).any(|s| lut.lookup(f32::from(s))[3] > 0.0),
                "[{lo}, {hi}] called occupied but nothing up to {top} is visible"
            );
        }
    }
    let vol = sparse([20, 20, 20], 2, 9);
    let occ = Occupancy::for_lut(&MinMax::new(&vol, 4).expect("blocks"), &lut);
    assert!(
        occ.fraction() > 0.0 && occ.fraction() < 1.0,
        "{}",
        occ.fraction()
    );
}

/// The occupancy map is rebuilt only when the table's opacities change:
/// the same table (or one differing only in colour) reuses the map, a new
/// opacity ramp gets a new, correct one.
#[test]
fn occupancy_is_rebuilt_only_when_the_table_changes() {
    let vol = sparse([20, 18, 22], 3, 4);
    let cam = camera(
        DVec3::new(9.5, 8.5, -15.0),
        DVec3::new(9.5, 8.5, 10.5),
        60.0,
        false,
    );
    let prep = Prepared::new(&vol, &cam).expect("view");
    let a = table(&[
        (0.0, [0.0; 4]),
        (60.0, [1.0, 0.0, 0.0, 0.0]),
        (255.0, [1.0, 0.0, 0.0, 1.0]),
    ]);
    let a_recoloured = table(&[
        (0.0, [0.0; 4]),
        (60.0, [0.0, 1.0, 0.0, 0.0]),
        (255.0, [0.0, 1.0, 1.0, 1.0]),
    ]);
    // Opaque air, transparent tissue: every block holds some air.
    let b = table(&[
        (0.0, [1.0; 4]),
        (10.0, [1.0; 4]),
        (11.0, [0.0; 4]),
        (255.0, [0.0; 4]),
    ]);
    let first = prep.occupancy_for(&a);
    assert!(std::sync::Arc::ptr_eq(&first, &prep.occupancy_for(&a)));
    assert!(std::sync::Arc::ptr_eq(
        &first,
        &prep.occupancy_for(&a_recoloured)
    ));
    let other = prep.occupancy_for(&b);
    assert!(!std::sync::Arc::ptr_eq(&first, &other));
    assert_eq!(*other, Occupancy::for_lut(&prep.blocks, &b));
    assert_ne!(*other, *first, "the two ramps see different blocks");
    assert_eq!(*prep.occupancy_for(&a), *first);
}
