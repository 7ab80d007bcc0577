//! Saturation at the extremes: fields of view of 150 to 175 degrees with
//! the eye half the volume, 2 voxels and within a voxel before a face,
//! centred and off-centre, both orders (front to back without
//! termination, what its bound is derived for). ER's rays cover the
//! volume whatever the field of view, so the largest path length per
//! slice step follows the eye's distance: at 2 voxels and nearer it
//! exceeds the default `path` format's 8.
//!
//! Each frame's quantisation counts say per format how often it overflowed
//! and whether that format's overflow is a designed clamp
//! ([`pipeline::config::FormatId::clamps`]). A frame with no range
//! violation ([`range_violations`]) and whose path lengths fit the `path`
//! format has a derived bound, and the pipeline must stay within it of
//! golden. Any other frame must name `path` as its violating format (and
//! only it), and widening `path` to [`path_holding`] the view's largest
//! path length must leave no violation and a bound that holds.

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use pipeline::bound::{path_holding, range_violations};
use pipeline::config::{Order, PipelineConfig};

use super::{bound_inputs, pipeline_vs_golden};
use crate::chip::{subject, Subject};
use crate::scenes::up_for;

/// One frame's outcome at the default widths.
#[derive(Debug)]
struct Case {
    what: String,
    /// Image difference from golden, in 1/255.
    diff_255: f64,
    /// The derived bound in 1/255, when the frame has one.
    bound_255: Option<f64>,
    /// The violating formats and their overflow counts.
    violations: Vec<(&'static str, u64)>,
    /// All overflows and those of the designed clamps.
    overflows: u64,
    /// With `path` widened to hold the view (when the defaults had no
    /// bound): its format, the difference and the bound, in 1/255.
    widened: Option<(String, f64, f64)>,
}

/// Runs one view in one order and checks it (see the module doc);
/// failures are returned, not panicked, so a sweep lists them all.
fn check(s: &Subject, eye: DVec3, fov: f64, order: Order, what: &str) -> Result<Case, String> {
    let centre = DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(eye, centre, up_for(centre - eye), fov, 48, 48).unwrap();
    let prep = Prepared::new(&s.vol, &cam).unwrap();
    let cfg = PipelineConfig {
        order,
        terminate: 1.0,
        ..PipelineConfig::default()
    };
    let what = format!("{what} fov {fov} {}", order.name());
    let (db, di, b, frame) = pipeline_vs_golden(&cfg, &s.vol, &s.lut, &prep);
    let ds_max = bound_inputs(&s.vol, &s.lut, &prep.view).ds_max;
    let saturates = ds_max >= cfg.path.max_value().to_f64();
    let violations = range_violations(&frame.quant);
    let mut case = Case {
        what: what.clone(),
        diff_255: di * 255.0,
        bound_255: None,
        violations: violations.clone(),
        overflows: frame.quant.overflows,
        widened: None,
    };
    if violations.is_empty() && !saturates {
        case.bound_255 = Some(b * 255.0);
        if !(db <= b && di <= b) {
            return Err(format!(
                "{what}: differs by {:.2}/255 (baseplane {:.2}), over its bound {:.2}/255",
                di * 255.0,
                db * 255.0,
                b * 255.0
            ));
        }
        return Ok(case);
    }
    let path_overflows = frame
        .quant
        .by_format
        .iter()
        .find(|(id, _)| id.name() == "path")
        .map_or(0, |(_, c)| c.overflows);
    if violations.iter().any(|&(name, _)| name != "path") {
        return Err(format!(
            "{what}: formats other than path overflow: {violations:?}"
        ));
    }
    if path_overflows > 0 && !saturates {
        return Err(format!(
            "{what}: path overflowed {path_overflows} times with ds_max {ds_max} inside its range"
        ));
    }
    let Some(need) = path_holding(cfg.path, ds_max) else {
        return Err(format!("{what}: no path format holds ds {ds_max}"));
    };
    let wide = PipelineConfig { path: need, ..cfg };
    let (db, di, b, frame) = pipeline_vs_golden(&wide, &s.vol, &s.lut, &prep);
    let left = range_violations(&frame.quant);
    if !left.is_empty() {
        return Err(format!("{what}: with path {need} still {left:?}"));
    }
    if !(db <= b && di <= b) {
        return Err(format!(
            "{what}: with path {need} differs by {:.2}/255, over its bound {:.2}/255",
            di * 255.0,
            b * 255.0
        ));
    }
    case.widened = Some((need.to_string(), di * 255.0, b * 255.0));
    Ok(case)
}

/// Eyes before the `-z` face of an `n`-cube at distance `d`, centred and
/// off-centre by a fraction of a voxel.
fn eyes(n: usize, ds: &[f64]) -> Vec<(String, DVec3)> {
    let c = n as f64 / 2.0;
    ds.iter()
        .flat_map(|&d| {
            [
                (format!("eye {d} before -z"), DVec3::new(c, c, -d)),
                (
                    format!("eye {d} before -z off-centre"),
                    DVec3::new(c - 0.37, c + 0.21, -d),
                ),
            ]
        })
        .collect()
}

/// Sweeps `scene` over `fovs`, `ds` and both orders; prints each case and
/// fails listing every failure. Returns the cases.
fn sweep(scene: &str, fovs: &[f64], ds: &[f64]) -> Vec<Case> {
    let s = subject(scene);
    let mut cases = Vec::new();
    let mut failures = Vec::new();
    for (what, eye) in eyes(s.n, ds) {
        for &fov in fovs {
            for order in [Order::BackToFront, Order::FrontToBack] {
                match check(&s, eye, fov, order, &format!("{scene} {what}")) {
                    Ok(c) => cases.push(c),
                    Err(e) => failures.push(e),
                }
            }
        }
    }
    for c in &cases {
        eprintln!(
            "{}: max {:.1}/255, bound {}, overflows {} (range violations {:?}){}",
            c.what,
            c.diff_255,
            c.bound_255
                .map_or("none".to_string(), |b| format!("{b:.2}/255")),
            c.overflows,
            c.violations,
            c.widened
                .as_ref()
                .map_or(String::new(), |(f, d, b)| format!(
                    "; path {f}: max {d:.2}/255, bound {b:.2}/255"
                ))
        );
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        failures.len() + cases.len(),
        failures.join("\n")
    );
    cases
}

#[test]
fn saturating_views_name_the_path_and_widening_it_bounds_them() {
    let cases = sweep(
        "checker:24",
        &[150.0, 165.0, 170.0, 175.0],
        &[12.0, 2.0, 0.5],
    );
    // The sweep reaches both kinds of frame: bounded at the defaults, and
    // saturating the path (then bounded with it widened).
    assert!(cases.iter().any(|c| c.bound_255.is_some()));
    assert!(cases.iter().any(|c| c.widened.is_some()));
}

/// The sweep on the scene (`checker:64`, eyes 32, 2, 0.9, 0.5 and
/// 0.1 voxels before the face, 150 to 175 degrees):
/// `cargo test --release -p pipeline --test it -- --ignored saturation`.
#[test]
#[ignore = "heavy: checker:64, 100 frames and their widened reruns"]
fn saturating_views_checker64() {
    sweep(
        "checker:64",
        &[150.0, 160.0, 165.0, 170.0, 175.0],
        &[32.0, 2.0, 0.9, 0.5, 0.1],
    );
}
