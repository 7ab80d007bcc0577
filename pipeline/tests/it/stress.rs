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
//! 5. a property test: golden never produces NaN or infinity;
//! 6. saturation at 150 to 175 degrees with the eye 2 voxels before and
//!    within a voxel of a face, both orders: a frame has a derived bound
//!    only without range violations, and it holds; otherwise the
//!    quantisation counts name `path` as the violating format, and
//!    widening it to the format that holds the view bounds the frame
//!    (`saturation`; the `checker:64` sweep is ignored:
//!    `cargo test --release -p pipeline --test it -- --ignored saturation`).
//!
//! Measured numbers are printed with `eprintln!` (`-- --nocapture`). The
//! heavy variants are `#[ignore]`d; run them with
//! `cargo test --release -p pipeline --test it -- --ignored stress`.

mod accumulation;
mod eyes;
mod positions;
mod saturation;
mod widths;
mod wild;

use glam::DVec3;
use golden::geometry::View;
use golden::methods::Method;
use golden::render::{render, Prepared, RenderOptions, Technique};
use golden::tf::{Lut, TransferFunction};
use golden::volume::{Volume, VoxelType};
use pipeline::bound::{error_bound, ftb_error_bound, region_slices, BoundInputs};
use pipeline::config::{Order, PipelineConfig};

use crate::scenes::{max_diff, tf, volume, voxel_hash};

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
    // Front to back is compared with golden er-ftb at the configuration's
    // threshold (the sweeps run it off: the bound is derived without
    // termination).
    let (method, mut opts) = match cfg.order {
        Order::BackToFront => (Method::Er, RenderOptions::unskipped()),
        Order::FrontToBack => (Method::ErFtb, RenderOptions::unskipped()),
    };
    opts.slice.terminate = cfg.terminate as f32;
    let g = render(prep, lut, Technique::Slice(method), &opts).unwrap();
    let gout = g.slice.as_ref().unwrap();
    let frame = pipeline::FrameRun::new(cfg, lut, vol, &prep.view)
        .run()
        .unwrap_or_else(|e| panic!("pipeline failed on eye {}: {e}", prep.view.eye));
    assert_eq!(
        frame.samples_per_slice, gout.stats.samples_per_slice,
        "pipeline and golden sample differently"
    );
    let image = golden::warp::warp(&prep.view, &frame.baseplane);
    let inputs = bound_inputs(vol, lut, &prep.view);
    let b = match cfg.order {
        Order::BackToFront => error_bound(cfg, &inputs),
        Order::FrontToBack => ftb_error_bound(cfg, &inputs, &region_slices(&prep.view).unwrap()),
    };
    (
        max_diff(&frame.baseplane.data, &gout.baseplane.data),
        max_diff(&image.data, &g.image.data),
        b,
        frame,
    )
}

/// Every raw baseplane word lies in its format's range (the accumulators
/// back to front, the fold's words front to back: `Frame::raw_format`).
fn assert_words_in_format(frame: &pipeline::Frame, what: &str) {
    let [colour, alpha] = frame.raw_format.map(|f| f.max_raw());
    let max = [colour, colour, colour, alpha];
    for w in &frame.raw {
        for c in 0..4 {
            assert!(
                (0..=max[c]).contains(&w[c]),
                "{what}: word {w:?} outside its format"
            );
        }
    }
}
