//! ER-Perspective's properties in the golden model: regions, samples per
//! slice, oversampling's growth, the merge cascade (on buffers and end to end
//! through a render), the paper's figure setups against the reference,
//! front-to-back against back-to-front, symmetry of the six sides and
//! determinism across thread counts.
//!
//! Run with `--nocapture` to see the measured numbers (RMSEs, ratios, max
//! differences); they are printed with `eprintln!`.

use std::sync::OnceLock;

use glam::DVec3;
use golden::camera::{Camera, ImagePlane};
use golden::geometry::{Merge, RayGrid, Regions};
use golden::image::Image;
use golden::merge::{merge, Rgba};
use golden::methods::{self, Method, Options, Output};
use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::scenes::tf_preset;
use golden::tf::{correct_opacity, Lut, TransferFunction};
use golden::volume::{Volume, VoxelType};

mod cascade;
mod ftb;
mod paper;
mod symmetry;

// ---------------------------------------------------------------- helpers

use crate::scenes::{max_diff_f32, scene, tf, up_for, volume_u8 as volume, voxel_hash};

/// A volume where a fraction `density` of the voxels hold random values.
fn sparse_random(dims: [usize; 3], density: f64, seed: u64) -> Volume {
    volume(dims, |x, y, z| {
        let h = voxel_hash(seed, x, y, z);
        if (h & 0xFFFF) as f64 / 65536.0 < density {
            ((h >> 16) % 256) as u16
        } else {
            0
        }
    })
}

fn lut(t: &TransferFunction) -> Lut {
    lut_for(VoxelType::U8, t)
}

fn camera(eye: DVec3, look: DVec3, up: DVec3, fov: f64, w: u32, h: u32) -> Camera {
    Camera::new(eye, look, up, fov, w, h).unwrap()
}

fn prepare(vol: &Volume, cam: &Camera) -> Prepared {
    Prepared::new(vol, cam).unwrap()
}

fn slice_render(m: Method, p: &Prepared, l: &Lut, opts: &Options) -> Output {
    methods::render(m, p, l, opts).unwrap()
}

/// Options with nothing skipped: these tests count and compare every
/// ray's samples (skipping is tested in `skipping.rs`).
fn opts(terminate: f32, substeps: u32) -> Options {
    Options {
        terminate,
        substeps,
        skips: golden::skip::Skips {
            empty: false,
            cull: false,
        },
        shade: None,
        voi: None,
        preintegrate: false,
        pre_colouring: Default::default(),
        lanes: true,
    }
}

fn image(p: &Prepared, l: &Lut, tech: Technique, o: &RenderOptions) -> Image {
    render(p, l, tech, o).unwrap().image
}

/// The cascade of two Bartlett merges in the oldest rays' spacing:
/// `w(k) = (4 - |k|) / 16` for `|k| <= 3`, else 0 (the paper's 1 2 3 4 3 2 1 / 16).
fn cascade2(k: i64) -> f64 {
    if k.abs() <= 3 {
        (4 - k.abs()) as f64 / 16.0
    } else {
        0.0
    }
}

// ------------------------------------------------- 1. regions and K

#[test]
fn region_boundaries_and_count() {
    // The paper's example.
    let r = Regions::new(3.0, 7);
    assert_eq!(r.bounds, vec![0.0, 3.0, 9.0]);
    assert_eq!(r.count(), 2);

    for d in [0.25, 0.5, 1.0, 2.5, 3.0, 7.3, 64.0, 1e4] {
        for nz in [1usize, 2, 7, 64, 100, 256] {
            let r = Regions::new(d, nz);
            let k = r.count();
            let last = nz as f64 - 1.0;
            assert_eq!(r.bounds.len(), k + 1);
            // b_i = D (2^i - 1): the eye is D 2^i from b_i.
            for (i, &b) in r.bounds.iter().enumerate() {
                let want = d * (2f64.powi(i as i32) - 1.0);
                assert!(
                    (b - want).abs() <= 1e-12 * want.max(1.0),
                    "D {d} nz {nz}: b_{i} = {b}, want {want}"
                );
            }
            // K is the smallest count >= 1 whose rear bound reaches nz - 1.
            assert!(k >= 1);
            assert!(r.bounds[k] >= last, "D {d} nz {nz}: b_K < nz - 1");
            if k > 1 {
                assert!(r.bounds[k - 1] < last, "D {d} nz {nz}: K not minimal");
            }
            // K = max(1, ceil(log2((nz - 1) / D + 1))) in closed form.
            let closed = ((last / d + 1.0).log2().ceil() as usize).max(1);
            assert_eq!(k, closed, "D {d} nz {nz}");
            // The slices of the regions partition 0..nz in order; each slice
            // lies in [b_i, b_{i+1}) (the last region also takes b_K).
            let mut next = 0usize;
            for i in 0..k {
                let s = r.slices(i);
                assert_eq!(
                    s.start, next,
                    "D {d} nz {nz}: region {i} starts at {}",
                    s.start
                );
                assert!(s.start <= s.end);
                for z in s.clone() {
                    let z = z as f64;
                    assert!(z >= r.bounds[i], "D {d} nz {nz}: slice {z} before b_{i}");
                    if i + 1 < k {
                        assert!(
                            z < r.bounds[i + 1],
                            "D {d} nz {nz}: slice {z} past b_{}",
                            i + 1
                        );
                    } else {
                        assert!(z <= r.bounds[k]);
                    }
                }
                next = s.end;
            }
            assert_eq!(next, nz, "D {d} nz {nz}: slices do not cover the stack");
        }
    }
}

// ------------------------------------------- 2. samples per slice bound

#[test]
fn er_samples_per_slice_stay_between_n2_and_4n2() {
    // Counting does not depend on contents, but a sparse random volume makes
    // sure transparent samples are counted too.
    let l = lut(&tf_preset("sphere").unwrap());
    let mut labels = std::collections::BTreeSet::new();
    let mut checked = 0usize;
    for dims in [[24usize, 16, 20], [16, 16, 16], [32, 20, 12]] {
        let vol = sparse_random(dims, 0.05, 7);
        let c = DVec3::from_array(dims.map(|n| (n as f64 - 1.0) / 2.0));
        for axis in 0..3 {
            for sign in [1.0f64, -1.0] {
                let n = dims[axis] as f64;
                for d in [0.5, 1.0, 2.5, 7.3, n, 4.0 * n, 16.0 * n] {
                    // Lateral offsets as fractions of the principal distance
                    // from the eye to the centre: below 1 so the principal axis
                    // stays `axis`; 0.95 at large D puts the eye far outside the
                    // footprint (grazing view of the near side faces).
                    for (fa, fb) in [(0.0, 0.0), (0.5, -0.3), (-0.95, 0.2), (0.95, 0.95)] {
                        let along = d + (n - 1.0) / 2.0;
                        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
                        let mut eye = c;
                        eye[axis] = if sign > 0.0 { -d } else { n - 1.0 + d };
                        eye[a] += fa * along;
                        eye[b] += fb * along;
                        let up = up_for(c - eye);
                        let cam = camera(eye, c, up, 60.0, 4, 4);
                        let p = prepare(&vol, &cam);
                        let want = format!(
                            "{}{}",
                            if sign > 0.0 { '+' } else { '-' },
                            ["x", "y", "z"][axis]
                        );
                        assert_eq!(p.view.axes.label(), want, "eye {eye}");
                        assert!((p.view.d - d).abs() < 1e-9, "eye {eye}: D {}", p.view.d);
                        labels.insert(want);
                        let out = slice_render(Method::Er, &p, &l, &opts(1.0, 1));
                        let [nx, ny, nz] = p.view.dims;
                        let s = &out.stats.samples_per_slice;
                        assert_eq!(s.len(), nz);
                        assert_eq!(out.stats.samples_total, s.iter().sum::<u64>());
                        assert_eq!(out.stats.regions, Regions::new(p.view.d, nz).bounds);
                        // Ray spacing within a slice is in [1/2, 1] voxel, and a
                        // ray counts when its position lies in [-1/2, n - 1/2):
                        // between n - 1 and 2n + 1 rays per axis.
                        let lo = ((nx - 1) * (ny - 1)) as u64;
                        let hi = ((2 * nx + 1) * (2 * ny + 1)) as u64;
                        for (z, &count) in s.iter().enumerate() {
                            assert!(
                                (lo..=hi).contains(&count),
                                "dims {dims:?} eye {eye} D {d}: slice {z} has {count} samples, \
                                 outside [{lo}, {hi}]"
                            );
                        }
                        checked += 1;
                    }
                }
            }
        }
    }
    assert_eq!(labels.len(), 6, "all six sides: {labels:?}");
    assert_eq!(checked, 3 * 6 * 7 * 4);
}

// ------------------------------- 3. oversampling grows as ((N + D)/D)^2

#[test]
fn oversampling_front_slice_grows_as_the_eye_nears() {
    let n = 32usize;
    let vol = sparse_random([n; 3], 0.05, 3);
    let l = lut(&tf_preset("sphere").unwrap());
    let c = (n as f64 - 1.0) / 2.0;
    let mut prev = 0u64;
    for d in [64.0, 32.0, 16.0, 8.0, 4.0] {
        let eye = DVec3::new(c, c, -d);
        let cam = camera(eye, DVec3::splat(c), DVec3::Y, 60.0, 4, 4);
        let p = prepare(&vol, &cam);
        let over = slice_render(Method::Over, &p, &l, &opts(1.0, 1));
        let er = slice_render(Method::Er, &p, &l, &opts(1.0, 1));
        // Oversampling's rays are one voxel apart on the last slice z = N - 1,
        // so D / (N - 1 + D) apart on slice 0: N / t rays per axis, give or
        // take one ray at the edges.
        let per_axis = n as f64 * (n as f64 - 1.0 + d) / d;
        let count = over.stats.samples_per_slice[0];
        let ratio = count as f64 / (n * n) as f64;
        let want = ((n as f64 - 1.0 + d) / d).powi(2);
        eprintln!(
            "D {d:>4}: over slice 0 = {count} = {ratio:.3} N^2 (((N-1+D)/D)^2 = {want:.3}); \
             er slice 0 = {}",
            er.stats.samples_per_slice[0]
        );
        assert!(
            ((per_axis - 1.0).powi(2)..=(per_axis + 1.0).powi(2)).contains(&(count as f64)),
            "D {d}: over slice 0 has {count}, want ({per_axis:.2} +- 1)^2"
        );
        assert!(
            // One ray per axis more or less: (1 + 1/p)^2 - 1 relative.
            (ratio / want - 1.0).abs() <= (1.0 + 1.0 / per_axis).powi(2) - 1.0 + 1e-9,
            "D {d}: {ratio} vs {want}"
        );
        assert!(count > prev, "grows as the eye nears");
        prev = count;
        let e0 = er.stats.samples_per_slice[0];
        assert!(
            ((n - 1) * (n - 1)) as u64 <= e0 && e0 <= ((2 * n + 1) * (2 * n + 1)) as u64,
            "D {d}: er slice 0 has {e0}"
        );
    }
}
