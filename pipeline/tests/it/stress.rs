//! Numerical-stability stress tests of the golden model and the pipeline:
//!
//! 1. long accumulation (1024 slices) against the closed form
//!    `1 - (1 - a)^n`, and the pipeline's saturating accumulators on it;
//! 2. eye extremes: very near (`D` = 0.25 voxel) and very far (`D` = 1e4),
//!    fields of view of 1 and 170 degrees, eyes exactly on and 1e-9 off
//!    region-boundary distances, non-integer eyes, all six sides;
//! 3. the pipeline's ray positions `A + m t` against the exact `f64`
//!    positions and their documented bound;
//! 4. the pipeline's error against golden as one width at a time grows;
//! 5. a property test: golden never produces NaN or infinity.
//!
//! Measured numbers are printed with `eprintln!` (`-- --nocapture`). The
//! heavy variants are `#[ignore]`d; run them with
//! `cargo test --release -p pipeline --test it -- --ignored stress`.

use glam::DVec3;
use golden::camera::Camera;
use golden::geometry::{Layout, Regions, View};
use golden::methods::{self, Method, Options};
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::tf::{Lut, TransferFunction};
use golden::volume::{Volume, VoxelType};
use pipeline::bound::{error_bound, r, BoundInputs};
use pipeline::config::PipelineConfig;
use pipeline::datapath::{Acc, Datapath};
use pipeline::fixed::{Format, Overflow, Quant, QuantStats, Wide};
use pipeline::tables::Tables;
use proptest::prelude::*;
use waves::Tracer;

use crate::scenes::{max_diff, splitmix64, tf, up_for, volume, voxel_hash};

/// Unit roundoff of `f32` (round to nearest): `2^-24`.
const U: f64 = 1.0 / 16_777_216.0;

// ---------------------------------------------------------------- helpers

/// A smooth blob with a little noise, so that every stage has work and
/// neighbouring voxels differ.
fn blob(dims: [usize; 3], noise: u64) -> Volume {
    volume(dims, VoxelType::U8, |x, y, z| {
        let p = [x, y, z].map(|v| v as f64);
        let c = dims.map(|n| (n as f64 - 1.0) * 0.5);
        let r2 = (0..3)
            .map(|k| ((p[k] - c[k]) / (0.35 * dims[k] as f64)).powi(2))
            .sum::<f64>();
        let v = 250.0 * (-r2).exp();
        let n = if noise > 0 {
            voxel_hash(7, x, y, z) % noise
        } else {
            0
        };
        (v as u64 + n).min(255) as u16
    })
}

/// The ramp the blob scenes use: transparent below 20, opacity 0.6 at 200.
fn ramp() -> TransferFunction {
    tf(&[(20.0, [1.0, 0.6, 0.2, 0.0]), (200.0, [1.0, 1.0, 1.0, 0.6])])
}

/// Index-space eye `d` voxels outside the face of index axis `axis` (the
/// high face when `positive`), moved `off` voxels from the volume's centre
/// line along the other two axes (in increasing axis order).
fn eye_at(dims: [usize; 3], axis: usize, positive: bool, d: f64, off: [f64; 2]) -> DVec3 {
    let mut p = dims.map(|n| (n as f64 - 1.0) * 0.5);
    let others = match axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    };
    p[others[0]] += off[0];
    p[others[1]] += off[1];
    p[axis] = if positive {
        dims[axis] as f64 - 1.0 + d
    } else {
        -d
    };
    DVec3::from_array(p)
}

/// The facts `error_bound` needs, measured on the data and the view.
fn bound_inputs(vol: &Volume, lut: &Lut, view: &View) -> BoundInputs {
    BoundInputs::measure(vol, lut, view).expect("the view has an ER layout")
}

/// The first value of `img` that is not finite or lies outside [0, 1].
fn bad_value(data: &[[f32; 4]]) -> Option<(usize, [f32; 4])> {
    data.iter()
        .enumerate()
        .find(|(_, p)| {
            p.iter()
                .any(|v| !(v.is_finite() && (0.0..=1.0).contains(v)))
        })
        .map(|(i, p)| (i, *p))
}

/// Pipeline against golden `er` on one view: `(baseplane diff, image diff,
/// bound)`, after checking that both took the same samples per slice.
fn pipeline_vs_golden(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
) -> (f64, f64, f64, pipeline::Frame) {
    let g = render(
        prep,
        lut,
        Technique::Slice(Method::Er),
        &RenderOptions::unskipped(),
    )
    .unwrap();
    let gout = g.slice.as_ref().unwrap();
    let frame = pipeline::run_frame(cfg, vol, lut, &prep.view, Tracer::disabled())
        .unwrap_or_else(|e| panic!("pipeline failed on eye {}: {e}", prep.view.eye));
    assert_eq!(
        frame.samples_per_slice, gout.stats.samples_per_slice,
        "pipeline and golden sample differently"
    );
    let image = golden::warp::warp(&prep.view, &frame.baseplane);
    let b = error_bound(cfg, &bound_inputs(vol, lut, &prep.view));
    (
        max_diff(&frame.baseplane.data, &gout.baseplane.data),
        max_diff(&image.data, &g.image.data),
        b,
        frame,
    )
}

/// Every slice of the stack belongs to exactly one region, in order.
fn assert_regions_partition(layout: &Layout, nz: usize, what: &str) {
    let mut next = 0;
    for (i, g) in layout.grids.iter().enumerate() {
        assert_eq!(
            g.slices.start, next,
            "{what}: region {i} starts at slice {} instead of {next} (bounds {:?})",
            g.slices.start, layout.bounds
        );
        next = g.slices.end;
    }
    assert_eq!(next, nz, "{what}: regions end at slice {next} of {nz}");
}

// ------------------------------------------------- 1. long accumulation

/// A thin uniform column `8 x 8 x n` of value 200, seen from
/// `(4, 4, -d)` along +z through a 9x9, 1-degree camera whose centre pixel
/// looks exactly along +z. Ray `m = 4` on both axes sits at `(4, 4)` on
/// every slice (its slope `phi + m - eye` is 0 for every method's grid,
/// whose offsets `phi` are 0 when there is one region), so its path length
/// is exactly 1 and it samples all `n` slices.
fn column(n: usize, d: f64) -> (Volume, Prepared) {
    let vol = volume([8, 8, n], VoxelType::U8, |_, _, _| 200);
    let eye = DVec3::new(4.0, 4.0, -d);
    let cam = Camera::new(
        eye,
        DVec3::new(4.0, 4.0, n as f64 * 0.5),
        DVec3::Y,
        1.0,
        9,
        9,
    )
    .unwrap();
    let prep = Prepared::new(&vol, &cam).unwrap();
    (vol, prep)
}

/// A constant transfer function (one control point): colour
/// `(1, 1/2, 1/4)`, powers of two so that premultiplied colour is exactly
/// `c A` in `f32` (scaling by a power of two commutes with rounding), and
/// opacity `a` per unit length.
fn constant_tf(a: f64) -> TransferFunction {
    tf(&[(0.0, [1.0, 0.5, 0.25, a])])
}

const COLOUR: [f32; 3] = [1.0, 0.5, 0.25];

/// `1 - (1 - a)^n` in `f64`, without cancellation for small `a`.
fn closed_form(a: f64, n: f64) -> f64 {
    -(n * (-a).ln_1p()).exp_m1()
}

/// Worst-case error of `n` f32 compositing steps of opacity `a`, either
/// order. One step `A' = a + (1 - a) A` (or `A' = A + (1 - A) a`) rounds
/// three times (`1 - a`, the product, the sum), each by at most `u` of a
/// value no larger than `A'`: `3 u A_k` at step `k`, which later steps
/// multiply by `(1 - a)^(n - k)`. The corrected opacity itself
/// (`-expm1(ds ln1p(-a))`, `ds = 1`) is off by at most 5 `u` relative
/// (two libm calls of at most one ulp, 2 `u` each, and a product), and
/// `A_n = 1 - (1 - a)^n` has relative sensitivity
/// `a n (1 - a)^(n-1) / A_n <= 1` to `a`, so that adds `5 u A_n`.
fn accumulation_tolerance(a: f64, n: usize) -> f64 {
    let s: f64 = (1..=n)
        .map(|k| closed_form(a, k as f64) * (1.0 - a).powi((n - k) as i32))
        .sum();
    U * (3.0 * s + 5.0 * closed_form(a, n as f64))
}

/// The baseplane index of the sample at view `(4, 4)`.
fn centre_sample(grid: &golden::geometry::BaseGrid) -> usize {
    let k: [usize; 2] = std::array::from_fn(|a| {
        let k = ((4.0 - grid.origin[a]) / grid.spacing).round();
        assert!(
            (grid.origin[a] + k * grid.spacing - 4.0).abs() < 1e-9,
            "no baseplane sample at 4 on axis {a}: {grid:?}"
        );
        k as usize
    });
    k[1] * grid.counts[0] + k[0]
}

/// Golden, every slice-order method, 1024 (and, ignored, up to 8192)
/// slices of constant opacity: the centre ray's opacity matches
/// `1 - (1 - a)^n` within the f32 bound of `accumulation_tolerance`, its
/// colour is exactly `c A`, and the centre pixel of the final image (a
/// convex combination of equal samples) matches within that bound plus
/// 20 `u`: the warp's normalised weights sum to `1 +- 5 u` (2 `u` per
/// axis for the normalisation, `u` for their product) and summing at most
/// 16 taps adds 15 `u`.
fn long_accumulation_golden(n: usize) {
    let (_, prep) = column(n, 1e4);
    assert_eq!(prep.view.d, 1e4);
    assert_eq!(prep.view.regions().count(), 1, "D = 1e4: one region");
    let no_termination = Options {
        terminate: 1.0,
        substeps: 1,
        ..Options::default()
    };
    for a in [1e-4, 0.02, 0.999, 1.0 - 1e-6] {
        // The model sees the f32 table entry, so the closed form uses it.
        let a32 = f64::from(a as f32);
        let lut = Lut::for_bits(&constant_tf(a), 256, 8);
        assert!(lut.rgba.iter().all(|e| f64::from(e[3]) == a32));
        let want = closed_form(a32, n as f64);
        let tol = accumulation_tolerance(a32, n);
        for m in Method::ALL {
            let out = methods::render(m, &prep, &lut, &no_termination).unwrap();
            let base = &out.baseplane;
            let got = base.data[centre_sample(&base.grid)];
            assert!(got.iter().all(|v| v.is_finite()));
            let err = (f64::from(got[3]) - want).abs();
            eprintln!(
                "n {n} a {a:e} {:>6}: A = {:.9} closed form {want:.9} error {err:.2e} \
                 (relative {:.2e}), tolerance {tol:.2e}",
                m.name(),
                got[3],
                err / want
            );
            assert!(
                err <= tol,
                "{} n {n} a {a}: opacity {} vs closed form {want}, error {err:e} > {tol:e}",
                m.name(),
                got[3]
            );
            for c in 0..3 {
                assert_eq!(
                    got[c],
                    COLOUR[c] * got[3],
                    "{} a {a}: channel {c} is not c A",
                    m.name()
                );
            }
            let img = golden::warp::warp(&prep.view, base);
            assert!(bad_value(&img.data).is_none());
            let px = img.get(4, 4)[3];
            let err_img = (f64::from(px) - want).abs();
            assert!(
                err_img <= tol + 20.0 * U * want,
                "{} a {a}: centre pixel {px} vs {want}, error {err_img:e}",
                m.name()
            );
        }
    }
}

#[test]
fn long_accumulation_golden_matches_the_closed_form() {
    long_accumulation_golden(1024);
}

/// The longest stacks the volume allows (MAX_EDGE = 8192):
/// `cargo test --release -p pipeline --test it -- --ignored stress`.
#[test]
#[ignore = "heavy: 4096 and 8192 slices"]
fn long_accumulation_golden_matches_the_closed_form_deep() {
    long_accumulation_golden(4096);
    long_accumulation_golden(8192);
}

/// The pipeline on the same column at default widths. Its datapath is
/// replayed for the centre ray slice by slice (`Datapath` with the host's
/// slice constants, as a PE computes it), the replay is checked against
/// the frame's raw words, and along the ray every accumulator never
/// decreases (a wrap would drop it); near-1 opacities end exactly at the
/// accumulator's largest word (derived below), far from 0; every pixel
/// stays within `error_bound` of golden `er`. An eye 1 voxel away (ten
/// regions, nine merges) checks the bound with merges in the way.
#[test]
fn long_accumulation_pipeline_saturates_within_the_bound() {
    let cfg = PipelineConfig::default();
    for a in [1e-4, 0.02, 0.999, 1.0 - 1e-6, 1.0] {
        let t = constant_tf(a);
        let lut = Lut::for_bits(&t, cfg.table_entries as usize, 8);
        for d in [1e4, 1.0] {
            let (vol, prep) = column(1024, d);
            let (db, di, b, frame) = pipeline_vs_golden(&cfg, &vol, &lut, &prep);
            eprintln!(
                "a {a:e} D {d}: pipeline vs golden baseplane {db:.2e}, image {di:.2e}, \
                 bound {b:.2e}"
            );
            assert!(db <= b && di <= b, "a {a} D {d}: {db} / {di} > {b}");
            assert_words_in_format(&cfg, &frame.raw, &format!("a {a} D {d}"));
            let max = [
                cfg.accum_color.max_raw(),
                cfg.accum_color.max_raw(),
                cfg.accum_color.max_raw(),
                cfg.accum_alpha.max_raw(),
            ];
            if d != 1e4 {
                continue;
            }
            let plan = pipeline::host::plan(&cfg, &prep.view).unwrap();
            assert_eq!(plan.regions.len(), 1);
            let region = &plan.regions[0];
            assert_eq!(region.slices.len(), 1024);
            let dp = Datapath::new(cfg, Tables::new(&cfg, &lut).unwrap());
            let mut st = QuantStats::default();
            let word = pipeline::host::voxel_words(&cfg, &vol, &prep.view, &mut st)[0];
            let m = 4i64;
            let mut acc = Acc::default();
            let mut composited = 0;
            for s in &region.slices {
                assert!(s.range.iter().all(|&(lo, hi)| (lo..=hi).contains(&m)));
                let x = dp.position(s.a[0], s.t[0], m, &mut st).unwrap();
                let y = dp.position(s.a[1], s.t[1], m, &mut st).unwrap();
                let (_, wx) = dp.address(x, &mut st);
                let (_, wy) = dp.address(y, &mut st);
                let sample = dp.bilinear([[word; 2]; 2], wx, wy, &mut st).unwrap();
                let (rgb, alpha) = dp.classify(sample, &mut st).unwrap();
                if alpha.raw() == 0 {
                    continue;
                }
                let slope = |k: usize| {
                    let mt = Wide::new(i128::from(m), 0)
                        .checked_mul(region.slope_k[k])
                        .unwrap();
                    cfg.position.assign(
                        Wide::from(region.slope_b[k]).checked_add(mt).unwrap(),
                        &mut QuantStats::default(),
                    )
                };
                let ds = dp
                    .path(slope(0), slope(1), region.slope_z, &mut st)
                    .unwrap();
                assert_eq!(ds.to_f64(), 1.0, "the centre ray's path is exactly 1");
                let corr = dp.correct(alpha, ds, &mut st).unwrap();
                let before = acc;
                dp.composite_btf(&mut acc, rgb, corr, &mut st).unwrap();
                composited += 1;
                for c in 0..4 {
                    assert!(
                        acc.raw[c] >= before.raw[c],
                        "a {a}: channel {c} fell from {} to {} at slice {}",
                        before.raw[c],
                        acc.raw[c],
                        s.z
                    );
                }
            }
            let g = &region.grid;
            let idx = ((m - g.lo[1]) * (g.hi[0] - g.lo[0] + 1) + (m - g.lo[0])) as usize;
            assert_eq!(acc.raw, frame.raw[idx], "the replay is the PE's arithmetic");
            let opacity = acc.raw[3] as f64 * cfg.accum_alpha.lsb();
            eprintln!(
                "a {a:e}: alpha word {} of {}, {composited} slices composited, final words \
                 {:?} (max {}), opacity {opacity:.6} vs closed form {:.6}",
                dp.tables.alpha[0].raw(),
                cfg.alpha.max_raw(),
                acc.raw,
                max[3],
                closed_form(f64::from(a as f32), 1024.0)
            );
            if a >= 0.999 {
                // The alpha word is at least 4092/4096, so the correction
                // leaves transmittance T <= 2^-10 per slice (log table 10
                // or 12, ds = 1, exactly): after two slices the exact
                // update 1 - T + T A is within 2^-20 of 1, rounds to 1 and
                // saturates to the largest word, where it stays
                // (1 - T 2^-16 rounds up again). Full-opacity white
                // saturates the same way.
                assert_eq!(acc.raw[3], max[3], "a {a}: opacity not saturated");
                assert_eq!(acc.raw[0], max[0], "a {a}: white not saturated");
            }
        }
    }
}

// ------------------------------------------------------ 2. eye extremes

/// What the eye-extremes sweep saw.
#[derive(Debug, Default)]
struct Tally {
    views: usize,
    renders: usize,
    pipeline_runs: usize,
    pipeline_skipped: Vec<String>,
    worst_ratio: f64,
    steep_runs: usize,
    steep_overflows: u64,
    wide_path: usize,
    over_bound: Vec<String>,
}

/// Every slice-order method renders `view` finitely in [0, 1]; `er` takes
/// between `(nx-1)(ny-1)` and `(2nx+1)(2ny+1)` samples per slice; the
/// regions partition the stack; oversampling may only refuse with
/// `TooLarge`; the pipeline stays within `error_bound` of golden `er`
/// (at the default widths when their `path` format holds the view's
/// largest `ds`, else with `path` widened to ufixed<22,7>; views beyond
/// that are skipped and listed). Views over the bound are collected in
/// `tally.over_bound`, so one run shows all of them.
fn check_extreme_view(vol: &Volume, lut: &Lut, cam: &Camera, what: &str, tally: &mut Tally) {
    let prep = Prepared::new(vol, cam).unwrap_or_else(|e| panic!("{what}: {e}"));
    let [nx, ny, nz] = prep.view.dims;
    tally.views += 1;
    for m in Method::ALL {
        let frame = match render(&prep, lut, Technique::Slice(m), &RenderOptions::unskipped()) {
            Ok(f) => f,
            Err(golden::Error::TooLarge { .. }) if m == Method::Over => continue,
            Err(e) => panic!("{what}: {} failed: {e}", m.name()),
        };
        tally.renders += 1;
        if let Some((i, p)) = bad_value(&frame.image.data) {
            panic!("{what}: {} pixel {i} is {p:?}", m.name());
        }
        let out = frame.slice.unwrap();
        assert!(
            out.baseplane.data.iter().flatten().all(|v| v.is_finite()),
            "{what}: {} baseplane not finite",
            m.name()
        );
        if m == Method::Er {
            let lo = ((nx - 1) * (ny - 1)) as u64;
            let hi = ((2 * nx + 1) * (2 * ny + 1)) as u64;
            for (z, &s) in out.stats.samples_per_slice.iter().enumerate() {
                assert!(
                    (lo..=hi).contains(&s),
                    "{what}: er slice {z} has {s} samples, outside [{lo}, {hi}]"
                );
            }
            let layout = m.layout(&prep.view).unwrap();
            assert_regions_partition(&layout, nz, what);
        }
    }
    let mut cfg = PipelineConfig::default();
    let inputs = bound_inputs(vol, lut, &prep.view);
    if inputs.ds_max >= cfg.path.max_value().to_f64() {
        // The bound assumes no path length saturates. At the defaults the
        // frame must still run and keep every word in its format; the
        // bound is then checked with a path format 4 integer bits wider.
        let frame = pipeline::run_frame(&cfg, vol, lut, &prep.view, Tracer::disabled())
            .unwrap_or_else(|e| panic!("{what}: pipeline failed on a steep view: {e}"));
        assert_words_in_format(&cfg, &frame.raw, what);
        tally.steep_runs += 1;
        tally.steep_overflows += frame.quant.overflows;
        cfg.path = Format::new(22, 15, false, Quant::Rnd, Overflow::Sat).unwrap();
        if inputs.ds_max >= cfg.path.max_value().to_f64() {
            tally
                .pipeline_skipped
                .push(format!("{what} (ds {:.1})", inputs.ds_max));
            return;
        }
        tally.wide_path += 1;
    }
    let (db, di, b, frame) = pipeline_vs_golden(&cfg, vol, lut, &prep);
    assert_words_in_format(&cfg, &frame.raw, what);
    tally.pipeline_runs += 1;
    tally.worst_ratio = tally.worst_ratio.max(db.max(di) / b);
    if !(db <= b && di <= b) {
        let empty = empty_regions(&prep);
        tally.over_bound.push(format!(
            "{what}: pipeline differs by {db:.4} (baseplane) / {di:.4} (image), bound {b:.4}, \
             path ufixed<{},{}>, {empty} ER region(s) without slices",
            cfg.path.bits(),
            cfg.path.int_bits()
        ));
    }
}

/// Every raw accumulator word lies in its format's range.
fn assert_words_in_format(cfg: &PipelineConfig, raw: &[[i64; 4]], what: &str) {
    let max = [
        cfg.accum_color.max_raw(),
        cfg.accum_color.max_raw(),
        cfg.accum_color.max_raw(),
        cfg.accum_alpha.max_raw(),
    ];
    for w in raw {
        for c in 0..4 {
            assert!(
                (0..=max[c]).contains(&w[c]),
                "{what}: word {w:?} outside its format"
            );
        }
    }
}

/// Eye distances of the sweep: very near, exactly on region-boundary
/// distances (`D` = 1 and 3 put slices 1, 3, 7 and 3, 9 exactly on
/// `b_i = D (2^i - 1)`; `D` = 7/3, not a binary fraction, still gives
/// `b_2 = 7` exactly in `f64`), 1e-9 off them, non-integer, and far (one
/// region).
const DISTANCES: [f64; 11] = [
    0.25,
    0.5,
    1.0,
    1.0 + 1e-9,
    3.0,
    3.0 - 1e-9,
    3.0 + 1e-9,
    7.0 / 3.0,
    2.37,
    40.0,
    1e4,
];

/// ER regions of the view that hold no slice.
fn empty_regions(prep: &Prepared) -> usize {
    Method::Er
        .layout(&prep.view)
        .unwrap()
        .grids
        .iter()
        .filter(|g| g.slices.is_empty())
        .count()
}

impl Tally {
    /// No view went over the derived bound.
    #[track_caller]
    fn assert_within_bound(&self) {
        assert!(
            self.over_bound.is_empty(),
            "{} views over the bound, e.g. {}",
            self.over_bound.len(),
            self.over_bound[0]
        );
    }
}

fn eye_extremes(dims: [usize; 3], size: u32) -> Tally {
    let vol = blob(dims, 40);
    // The pipeline's table size, for golden too (as in `equivalence.rs`).
    let lut = Lut::for_bits(&ramp(), PipelineConfig::default().table_entries as usize, 8);
    let centre = DVec3::from_array(vol.center_world());
    let mut tally = Tally::default();
    for axis in 0..3 {
        for positive in [false, true] {
            let nz = dims[axis];
            for d in DISTANCES {
                // Boundary distances really put a slice on a boundary, and
                // the 1e-9 shifts really take it off.
                let regions = Regions::new(d, nz);
                let on = regions.bounds[1..]
                    .iter()
                    .any(|&b| b.fract() == 0.0 && b < nz as f64);
                if [1.0, 3.0, 7.0 / 3.0].contains(&d) {
                    assert!(on, "D {d}: bounds {:?}", regions.bounds);
                }
                if [1.0 + 1e-9, 3.0 - 1e-9, 3.0 + 1e-9].contains(&d) {
                    assert!(!on, "D {d}: bounds {:?}", regions.bounds);
                }
                let along = d + (nz as f64 - 1.0) * 0.5;
                // Centred, and off-centre by non-integer amounts (fractions
                // of the distance to the centre, so the axis stays).
                for f in [[0.0, 0.0], [0.37, -0.21]] {
                    let eye = eye_at(dims, axis, positive, d, f.map(|v| v * along));
                    for fov in [1.0, 60.0, 170.0] {
                        let cam =
                            Camera::new(eye, centre, up_for(centre - eye), fov, size, size * 3 / 4)
                                .unwrap();
                        let what = format!(
                            "dims {dims:?} axis {axis} {} D {d} off {f:?} fov {fov}",
                            if positive { "+" } else { "-" }
                        );
                        let prep = Prepared::new(&vol, &cam).unwrap();
                        assert!(
                            (prep.view.d - d).abs() < 1e-9,
                            "{what}: D is {}",
                            prep.view.d
                        );
                        if d == 1e4 {
                            let l = Method::Er.layout(&prep.view).unwrap();
                            assert_eq!(l.grids.len(), 1, "{what}: D = 1e4 is one region");
                        }
                        check_extreme_view(&vol, &lut, &cam, &what, &mut tally);
                    }
                }
            }
        }
    }
    eprintln!(
        "eye extremes {dims:?}: {} views, {} golden renders; pipeline checked against the bound on {} \
         views (worst diff / bound {:.3}); {} views steeper than the default path format's \
         ds < {} ran at the defaults ({} quantisation overflows) and {} of them were bounded \
         with path ufixed<22,7>; skipped for the bound: {}",
        tally.views,
        tally.renders,
        tally.pipeline_runs,
        tally.worst_ratio,
        tally.steep_runs,
        PipelineConfig::default().path.max_value().to_f64(),
        tally.steep_overflows,
        tally.wide_path,
        tally.pipeline_skipped.len()
    );
    for s in &tally.pipeline_skipped {
        eprintln!("  skipped {s}");
    }
    for s in &tally.over_bound {
        eprintln!("  OVER THE BOUND {s}");
    }
    tally
}

#[test]
fn eye_extremes_render_finitely_and_within_the_bound() {
    let t = eye_extremes([12, 10, 14], 16);
    assert_eq!(t.views, 6 * DISTANCES.len() * 2 * 3);
    assert!(
        t.pipeline_runs > t.views / 2,
        "the pipeline ran on too few views"
    );
    t.assert_within_bound();
}

/// The same sweep on a larger volume:
/// `cargo test --release -p pipeline --test it -- --ignored stress`.
#[test]
#[ignore = "heavy: 40x36x48 volume"]
fn eye_extremes_large_volume() {
    let t = eye_extremes([40, 36, 48], 48);
    t.assert_within_bound();
}

/// The baseplane words must not depend on the PE count (README: "PE
/// order cannot matter"; `model.rs` checks P at ordinary eyes).
/// Eyes nearer than half a voxel leave ER regions without any slice
/// (`D` = 0.25: region 1 is `[0.25, 0.75)`), so two merges run back to
/// back with no migration between them; with P = 1 and 4 the words agree,
/// and they must agree with 16 and 64 PEs too. `D` = 0.4 and 0.5 (no empty
/// region) are the controls. The check is on raw words, so it needs no
/// path-length format: the default widths run these steep views.
#[test]
fn pipeline_words_do_not_depend_on_p_when_regions_are_empty() {
    let lut = Lut::for_bits(&ramp(), PipelineConfig::default().table_entries as usize, 8);
    let mut failures = Vec::new();
    for dims in [[12usize, 10, 14], [16, 16, 16], [32, 24, 20]] {
        let vol = blob(dims, 40);
        let centre = DVec3::from_array(vol.center_world());
        for axis in 0..3 {
            for d in [0.1, 0.25, 0.4, 0.5] {
                let eye = eye_at(dims, axis, false, d, [0.0, 0.0]);
                let cam = Camera::new(eye, centre, up_for(centre - eye), 60.0, 16, 12).unwrap();
                let prep = Prepared::new(&vol, &cam).unwrap();
                let empty = empty_regions(&prep);
                assert_eq!(empty > 0, d < 0.4, "dims {dims:?} axis {axis} D {d}");
                let words = |pes: u16| {
                    let cfg = PipelineConfig {
                        pes,
                        ..PipelineConfig::default()
                    };
                    pipeline::run_frame(&cfg, &vol, &lut, &prep.view, Tracer::disabled())
                        .unwrap()
                        .raw
                };
                let one = words(1);
                for pes in [4u16, 16, 64] {
                    let other = words(pes);
                    let differ = one.iter().zip(&other).filter(|(a, b)| a != b).count();
                    let worst = one
                        .iter()
                        .zip(&other)
                        .flat_map(|(a, b)| (0..4).map(move |c| (a[c] - b[c]).abs()))
                        .max()
                        .unwrap_or(0);
                    if differ > 0 {
                        failures.push(format!(
                            "dims {dims:?} axis {axis} D {d} ({empty} empty regions): P = {pes} \
                             changes {differ} of {} baseplane samples, by up to {worst} LSB \
                             ({:.3})",
                            one.len(),
                            worst as f64 / 65536.0
                        ));
                    }
                }
            }
        }
    }
    for f in &failures {
        eprintln!("{f}");
    }
    assert!(
        failures.is_empty(),
        "{} (view, P) pairs change the baseplane, e.g. {}",
        failures.len(),
        failures[0]
    );
}

/// Oversampling a 128^3 volume from `D` = 0.25 would need about
/// `(128 * 127.25 / 0.25)^2 = 4.2e9` rays at slice 0: it must refuse with
/// `TooLarge` (before allocating: the call returns at once), while the
/// other methods render the view.
#[test]
fn oversampling_too_near_refuses_instead_of_allocating() {
    let vol = blob([128; 3], 0);
    let lut = lut_for(VoxelType::U8, &ramp());
    let eye = DVec3::new(63.5, 63.5, -0.25);
    let cam = Camera::new(eye, DVec3::splat(63.5), DVec3::Y, 90.0, 16, 16).unwrap();
    let prep = Prepared::new(&vol, &cam).unwrap();
    let start = std::time::Instant::now();
    match render(
        &prep,
        &lut,
        Technique::Slice(Method::Over),
        &RenderOptions::default(),
    ) {
        Err(golden::Error::TooLarge { bytes, limit, what }) => {
            eprintln!("over at D = 0.25: refused, {what}: {bytes} bytes > {limit}");
            assert!(bytes > u128::from(limit));
        }
        Err(e) => panic!("over failed with the wrong error: {e}"),
        Ok(_) => panic!("over rendered 4e9 rays"),
    }
    assert!(start.elapsed().as_secs_f64() < 1.0, "refusal took too long");
    for m in [Method::Er, Method::ErFtb, Method::Box, Method::Under] {
        let f = render(&prep, &lut, Technique::Slice(m), &RenderOptions::default()).unwrap();
        assert!(bad_value(&f.image.data).is_none(), "{}", m.name());
    }
}

// ---------------------------------------------------- 3. position drift

/// Worst position error of a view.
#[derive(Debug, Default, Clone, Copy)]
struct Drift {
    /// Largest |fixed - exact| in voxels.
    worst: f64,
    /// Largest error / bound.
    ratio: f64,
    /// Positions checked.
    count: u64,
}

/// Every ray of every region and slice (on x every ray the region holds,
/// as the owner computation forms them; on y every row sampled): the
/// pipeline's `A + m t` from the host's per-slice constants against the
/// exact `f64` position, within `2 r(position) + |m| r(step)` plus the
/// `f64` evaluation's own rounding (`2^-52 (|a| + |m t|)`, far below).
fn position_drift(cfg: &PipelineConfig, view: &View) -> Drift {
    let lut = Lut::for_bits(&ramp(), cfg.table_entries as usize, 8);
    let dp = Datapath::new(*cfg, Tables::new(cfg, &lut).unwrap());
    let plan = pipeline::host::plan(cfg, view).unwrap();
    let layout = Method::Er.layout(view).unwrap();
    let (rp, rs) = (r(cfg.position), r(cfg.step));
    let mut st = QuantStats::default();
    let mut d = Drift::default();
    for (region, grid) in plan.regions.iter().zip(&layout.grids) {
        assert_eq!(region.grid, *grid);
        for s in &region.slices {
            for k in 0..2 {
                let exact = grid.at(view.eye, view.d, s.z as f64, k);
                let ms = if k == 0 {
                    (grid.lo[0], grid.hi[0])
                } else {
                    s.range[1]
                };
                for m in ms.0..=ms.1 {
                    let fixed = dp.position(s.a[k], s.t[k], m, &mut st).unwrap().to_f64();
                    let want = exact.a + m as f64 * exact.t;
                    let err = (fixed - want).abs();
                    let slack = f64::EPSILON * (exact.a.abs() + (m as f64 * exact.t).abs());
                    let bound = 2.0 * rp + m.unsigned_abs() as f64 * rs + slack;
                    assert!(
                        err <= bound,
                        "z {} axis {k} ray {m}: position {fixed} vs {want}, error {err:e} > \
                         {bound:e}",
                        s.z
                    );
                    d.worst = d.worst.max(err);
                    d.ratio = d.ratio.max(err / bound);
                    d.count += 1;
                }
            }
        }
    }
    assert_eq!(st.overflows, 0, "a position saturated");
    d
}

fn view_of(vol: &Volume, eye: DVec3) -> View {
    let c = DVec3::from_array(vol.center_world());
    let cam = Camera::new(eye, c, up_for(c - eye), 60.0, 8, 8).unwrap();
    Prepared::new(vol, &cam).unwrap().view
}

#[test]
fn ray_positions_stay_within_the_documented_bound() {
    let fmt = |bits, frac, signed, q| Format::new(bits, frac, signed, q, Overflow::Sat).unwrap();
    let configs = [
        ("default", PipelineConfig::default()),
        (
            "narrow RND (position fixed<20,12>, step ufixed<13,1>)",
            PipelineConfig {
                position: fmt(20, 8, true, Quant::Rnd),
                step: fmt(13, 12, false, Quant::Rnd),
                ..PipelineConfig::default()
            },
        ),
        (
            "TRN (position fixed<28,12>, step ufixed<25,1>)",
            PipelineConfig {
                position: fmt(28, 16, true, Quant::Trn),
                step: fmt(25, 24, false, Quant::Trn),
                ..PipelineConfig::default()
            },
        ),
    ];
    let views: Vec<(&str, Volume, DVec3)> = vec![
        (
            "far, 128 slices in one region",
            blob([16, 16, 128], 0),
            DVec3::new(7.8, 7.3, -1e4),
        ),
        (
            "far, 1024 slices in one region",
            blob([8, 8, 1024], 0),
            DVec3::new(4.3, 3.9, -1e4),
        ),
        (
            "near, D = 0.5",
            blob([32, 32, 32], 0),
            DVec3::new(15.3, 16.7, -0.5),
        ),
        (
            "oblique, non-integer eye",
            blob([24, 20, 28], 0),
            DVec3::new(-10.3, 30.2, -7.9),
        ),
        (
            "wide, rays up to |m| ~ 1000",
            blob([512, 512, 16], 0),
            DVec3::new(200.3, 301.7, -0.75),
        ),
    ];
    for (cname, cfg) in &configs {
        cfg.validate().unwrap();
        let lsb = cfg.position.lsb();
        for (vname, vol, eye) in &views {
            let view = view_of(vol, *eye);
            let d = position_drift(cfg, &view);
            let layout = Method::Er.layout(&view).unwrap();
            let longest = layout.grids.iter().map(|g| g.slices.len()).max().unwrap();
            eprintln!(
                "{cname}, {vname} ({} regions, longest {longest} slices): {} positions, \
                 worst {:.3} LSB = {:.2e} voxels, {:.2} of the bound",
                layout.grids.len(),
                d.count,
                d.worst / lsb,
                d.worst,
                d.ratio
            );
        }
    }
}

// --------------------------------------------- 4. width monotonicity

/// Widths swept one at a time around the defaults.
#[derive(Debug, Clone, Copy)]
enum Sweep {
    Alpha,
    Accum,
    PositionFrac,
    Weight,
}

fn swept(which: Sweep, bits: u8) -> PipelineConfig {
    let u = |b: u8, f: u8, q| Format::new(b, f, false, q, Overflow::Sat).unwrap();
    let base = PipelineConfig::default();
    let cfg = match which {
        Sweep::Alpha => PipelineConfig {
            alpha: u(bits, bits, Quant::Rnd),
            ..base
        },
        // Both accumulators; the merge keeps 4 integer bits over them and
        // the corrected opacity may not have more fraction bits than its
        // accumulator (the config refuses it), so below 15 it narrows too.
        Sweep::Accum => PipelineConfig {
            accum_color: u(bits, bits, Quant::Rnd),
            accum_alpha: u(bits, bits, Quant::Rnd),
            merge: u(bits + 4, bits, Quant::Rnd),
            opacity_corr: if bits < base.opacity_corr.frac() {
                u(bits + 1, bits, Quant::Rnd)
            } else {
                base.opacity_corr
            },
            ..base
        },
        Sweep::PositionFrac => PipelineConfig {
            position: Format::new(12 + bits, bits, true, Quant::Rnd, Overflow::Sat).unwrap(),
            ..base
        },
        Sweep::Weight => PipelineConfig {
            weight: u(bits, bits, Quant::Trn),
            ..base
        },
    };
    cfg.validate()
        .unwrap_or_else(|e| panic!("{which:?} {bits}: {e}"));
    cfg
}

/// One width at a time on a small smooth scene: the pipeline's largest
/// image difference from golden `er` does not grow by more than noise when
/// two bits are added. Noise allowance: exactly one LSB of the final 8-bit
/// image, 1/255 (rounding can move an error by less than that either way,
/// anything beyond it would be visible).
#[test]
fn error_does_not_grow_with_width() {
    let vol = blob([24, 20, 28], 0);
    let c = DVec3::from_array(vol.center_world());
    let cam = Camera::new(DVec3::new(11.0, 9.0, -12.0), c, DVec3::Y, 50.0, 24, 20).unwrap();
    let prep = Prepared::new(&vol, &cam).unwrap();
    let sweeps = [
        (Sweep::Alpha, 8..=16),
        (Sweep::Accum, 10..=20),
        (Sweep::PositionFrac, 8..=20),
        (Sweep::Weight, 8..=14),
    ];
    let noise = 1.0 / 255.0;
    for (which, range) in sweeps {
        let curve: Vec<(u8, f64, f64)> = range
            .map(|bits| {
                let cfg = swept(which, bits);
                let lut = Lut::for_bits(&ramp(), cfg.table_entries as usize, 8);
                let (db, di, _, _) = pipeline_vs_golden(&cfg, &vol, &lut, &prep);
                (bits, di, db)
            })
            .collect();
        eprintln!("{which:?}: bits -> max image diff (baseplane diff), in 1/255");
        for &(b, di, db) in &curve {
            eprintln!("  {b:>2}: {:8.3} ({:8.3})", di * 255.0, db * 255.0);
        }
        for w in curve.windows(3) {
            let ((b0, e0, _), (b2, e2, _)) = (w[0], w[2]);
            assert!(
                e2 <= e0 + noise,
                "{which:?}: error grew from {e0:e} at {b0} bits to {e2:e} at {b2} bits"
            );
        }
    }
}

// ------------------------------------- 5. no NaN or infinity in golden

/// A random case biased to edges.
#[derive(Clone)]
struct Wild {
    dims: [usize; 3],
    sixteen: bool,
    pattern: u8,
    seed: u64,
    spacing: [f64; 3],
    points: Vec<(f64, [f64; 4])>,
    side: usize,
    dist: f64,
    off: [f64; 2],
    fov: f64,
    size: [u32; 2],
    substeps: u32,
    terminate: f32,
}

/// Shrunk failures print what reproduces them.
impl std::fmt::Debug for Wild {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Wild")
            .field("dims", &self.dims)
            .field("sixteen", &self.sixteen)
            .field("pattern", &self.pattern)
            .field("seed", &self.seed)
            .field("spacing", &self.spacing)
            .field("points", &self.points)
            .field("side", &self.side)
            .field("dist", &self.dist)
            .field("off", &self.off)
            .field("fov", &self.fov)
            .field("size", &self.size)
            .field("substeps", &self.substeps)
            .field("terminate", &self.terminate)
            .finish()
    }
}

fn wild_volume(w: &Wild) -> Volume {
    let (kind, scale) = if w.sixteen {
        (VoxelType::U16, 257u64)
    } else {
        (VoxelType::U8, 1)
    };
    let edges = [0u64, 1, 254, 255];
    let pick = splitmix64(w.seed) as usize % 4;
    volume(w.dims, kind, |x, y, z| {
        let h = voxel_hash(w.seed, x, y, z);
        let v = match w.pattern {
            0 => edges[pick] * scale,
            1 => edges[(h % 4) as usize] * scale,
            2 => (h >> 8) % (255 * scale + 1),
            // A checkerboard of the extremes with random voxels in it.
            _ => {
                if h.is_multiple_of(5) {
                    (h >> 8) % (255 * scale + 1)
                } else {
                    edges[3 * ((x + y + z) % 2)] * scale
                }
            }
        };
        v as u16
    })
    .with_spacing(w.spacing)
    .unwrap()
}

fn wild() -> impl Strategy<Value = Wild> {
    let dim = || prop_oneof![4 => 4usize..=16, 1 => Just(1usize), 1 => 2usize..=3];
    let value = prop_oneof![
        Just(0.0),
        Just(1.0),
        Just(254.0),
        Just(255.0),
        0.0..=255.0f64
    ];
    let opacity = prop_oneof![
        Just(0.0),
        Just(1e-7),
        Just(1e-30),
        Just(1e-45),
        Just(1.0),
        0.0..=1.0f64
    ];
    let colour = || prop_oneof![Just(0.0), Just(1.0), 0.0..=1.0f64];
    let point = (value, [colour(), colour(), colour()], opacity)
        .prop_map(|(v, c, a)| (v, [c[0], c[1], c[2], a]));
    let spacing = prop_oneof![3 => Just([1.0; 3]), 1 => [0.25..4.0f64, 0.25..4.0, 0.25..4.0]];
    let dist = prop_oneof![
        Just(1e-2),
        Just(1e5),
        (-2.0..5.0f64).prop_map(|e| 10f64.powf(e))
    ];
    let fov = prop_oneof![Just(0.5), Just(179.5), 0.5..179.5f64];
    let volume = (
        [dim(), dim(), dim()],
        any::<bool>(),
        0u8..4,
        any::<u64>(),
        spacing,
    );
    let view = (
        0usize..6,
        dist,
        [-1.5..1.5f64, -1.5..1.5],
        fov,
        [1u32..=8, 1u32..=8],
        prop_oneof![3 => Just(1u32), 1 => Just(2), 1 => Just(8)],
        prop_oneof![Just(0.99f32), Just(1.0)],
    );
    (volume, prop::collection::vec(point, 1..5), view).prop_map(
        |(
            (dims, sixteen, pattern, seed, spacing),
            points,
            (side, dist, off, fov, size, substeps, terminate),
        )| Wild {
            dims,
            sixteen,
            pattern,
            seed,
            spacing,
            points,
            side,
            dist,
            off,
            fov,
            size,
            substeps,
            terminate,
        },
    )
}

/// Oversampling's rays grow as `(N / D)^2` per slice; views whose layout
/// holds more than this many rays skip its render (its layout is still
/// built, and must be `Ok` or `TooLarge`), to keep 256 cases fast.
const OVER_RAYS_RENDERED: usize = 1 << 20;

fn run_wild(w: &Wild) -> Result<(), TestCaseError> {
    let vol = wild_volume(w);
    let scale = if w.sixteen { 257.0 } else { 1.0 };
    let points: Vec<(f64, [f64; 4])> = w.points.iter().map(|&(v, c)| (v * scale, c)).collect();
    let t = tf(&points);
    let lut = lut_for(vol.kind(), &t);
    let axis = w.side / 2;
    let mut eye = eye_at(
        w.dims,
        axis,
        w.side % 2 == 1,
        w.dist,
        w.off.map(|o| o * w.dims[axis].max(2) as f64),
    );
    for k in 0..3 {
        eye[k] *= w.spacing[k];
    }
    let centre = DVec3::from_array(vol.center_world());
    // Clear refusals (an unusable camera or view) are allowed outcomes.
    let Ok(cam) = Camera::new(
        eye,
        centre,
        up_for(centre - eye),
        w.fov,
        w.size[0],
        w.size[1],
    ) else {
        return Ok(());
    };
    let Ok(prep) = Prepared::new(&vol, &cam) else {
        return Ok(());
    };
    let opts = RenderOptions {
        slice: Options {
            terminate: w.terminate,
            substeps: w.substeps,
            ..Options::default()
        },
        ..RenderOptions::default()
    };
    let mut techs = vec![Technique::Reference];
    techs.extend(Method::ALL.map(Technique::Slice));
    for tech in techs {
        if tech == Technique::Slice(Method::Over) {
            match Method::Over.layout(&prep.view) {
                Ok(l) if l.grids[0].len() > OVER_RAYS_RENDERED => continue,
                Ok(_) => {}
                Err(golden::Error::TooLarge { .. }) => continue,
                Err(e) => prop_assert!(false, "over's layout failed oddly: {e}"),
            }
        }
        let frame = match render(&prep, &lut, tech, &opts) {
            Ok(f) => f,
            Err(_) => continue,
        };
        let check = |data: &[[f32; 4]], what: &str| -> Result<(), TestCaseError> {
            if let Some((i, p)) = bad_value(data) {
                prop_assert!(false, "{} {what} value {i} is {p:?}", tech.name());
            }
            Ok(())
        };
        check(&frame.image.data, "image")?;
        if let Some(out) = &frame.slice {
            prop_assert!(
                out.baseplane
                    .data
                    .iter()
                    .flatten()
                    .all(|v| v.is_finite() && *v >= 0.0),
                "{} baseplane not finite or negative",
                tech.name()
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any finite input gives a clear error or a finite image in [0, 1],
    /// for every golden technique.
    #[test]
    fn golden_never_produces_nan_or_infinity(w in wild()) {
        run_wild(&w)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4096))]

    /// The long run: `cargo test --release -p pipeline --test it -- --ignored stress`.
    #[test]
    #[ignore = "long run: 4096 cases"]
    fn golden_never_produces_nan_or_infinity_long_run(w in wild()) {
        run_wild(&w)?;
    }
}
