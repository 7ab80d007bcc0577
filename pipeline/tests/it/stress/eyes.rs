//! Eye extremes: very near and very far eyes, narrow and wide fields of
//! view, eyes on and just off region-boundary distances, all six sides.

use glam::DVec3;
use golden::camera::Camera;
use golden::geometry::{Layout, Regions};
use golden::methods::Method;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::tf::Lut;
use golden::volume::{Volume, VoxelType};
use pipeline::config::{Order, PipelineConfig};
use pipeline::fixed::{Format, Overflow, Quant};

use super::{
    assert_words_in_format, bad_value, blob, bound_inputs, eye_at, pipeline_vs_golden, ramp,
};
use crate::scenes::up_for;

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
/// `TooLarge`; the pipeline stays within `error_bound` of golden `er`, and
/// front to back (termination off) within `ftb_error_bound` of `er-ftb`
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
        let frame = pipeline::FrameRun::new(&cfg, lut, vol, &prep.view)
            .run()
            .unwrap_or_else(|e| panic!("{what}: pipeline failed on a steep view: {e}"));
        assert_words_in_format(&frame, what);
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
    // Both orders, front to back without termination (what its bound is
    // derived for), against golden er and er-ftb.
    for order in [Order::BackToFront, Order::FrontToBack] {
        let cfg = PipelineConfig {
            order,
            terminate: 1.0,
            ..cfg
        };
        let (db, di, b, frame) = pipeline_vs_golden(&cfg, vol, lut, &prep);
        assert_words_in_format(&frame, what);
        tally.pipeline_runs += 1;
        tally.worst_ratio = tally.worst_ratio.max(db.max(di) / b);
        if !(db <= b && di <= b) {
            let empty = empty_regions(&prep);
            tally.over_bound.push(format!(
                "{what} {}: pipeline differs by {db:.4} (baseplane) / {di:.4} (image), bound \
                 {b:.4}, path ufixed<{},{}>, {empty} ER region(s) without slices",
                order.name(),
                cfg.path.bits(),
                cfg.path.int_bits()
            ));
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
                    for fov in [1.0, 60.0, 170.0, 175.0] {
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
        "eye extremes {dims:?}: {} views, {} golden renders; pipeline checked against the bound in {} runs \
         (both orders; worst diff / bound {:.3}); {} views steeper than the default path format's \
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
    assert_eq!(t.views, 6 * DISTANCES.len() * 2 * 4);
    assert!(
        t.pipeline_runs > t.views,
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
                    pipeline::FrameRun::new(&cfg, &lut, &vol, &prep.view)
                        .run()
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
