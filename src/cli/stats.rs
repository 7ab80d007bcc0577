//! The `--stats` JSON: what was rendered, how, how long it took, what the
//! method counted and how far it is from the reference.

use std::path::Path;

use anyhow::Result;
use serde_json::{json, Value};

use golden::geometry::View;
use golden::metrics::ImageError;
use golden::render::Frame;

/// The stats object for one frame.
pub fn frame_json(
    method: &str,
    (dims, spacing): ([usize; 3], [f64; 3]),
    view: &View,
    eye: glam::DVec3,
    time_s: f64,
    frame: &Frame,
    err: Option<&ImageError>,
) -> Value {
    let mut v = json!({
        "method": method,
        "volume": dims,
        "spacing": spacing,
        "eye": eye.to_array(),
        "principal_axis": view.axes.label(),
        "D": view.d,
        "near_clip_first_slice": view.axes.z_first,
        "image": view.size,
        "time_s": time_s,
    });
    if let Some(out) = &frame.slice {
        let s = &out.stats;
        v["regions"] = json!(s.regions);
        v["K"] = json!(s.regions.len().saturating_sub(1));
        v["samples_total"] = json!(s.samples_total);
        v["samples_per_slice"] = json!(s.samples_per_slice);
        v["rays_per_region"] = json!(s.rays_per_region);
        v["merges"] = json!(s.merges);
        v["skipped"] = json!({
            "slices": s.slices_skipped,
            "beams": s.beams_skipped,
            "rays_culled": s.rays_culled,
            "regions": s.regions_skipped,
            "occupied_blocks": s.occupied_blocks,
        });
        v["baseplane"] = json!({
            "size": out.baseplane.grid.counts,
            "origin": out.baseplane.grid.origin,
            "spacing": out.baseplane.grid.spacing,
        });
    }
    if let Some(m) = &frame.mip {
        v["samples_total"] = json!(m.samples_total);
        v["mipmap"] = json!({
            "classify": m.classify.name(),
            "levels": m.levels,
            "samples_total": m.samples_total,
            "samples_skipped": m.samples_skipped,
            "samples_clipped": m.samples_clipped,
            "jumps": m.jumps,
            "level_histogram": m.level_histogram,
            "rays_terminated": m.rays_terminated,
        });
    }
    if let Some(s) = &frame.sw {
        v["samples_total"] = json!(s.samples_total);
        v["shear_warp"] = json!(s);
    }
    if let Some(g) = &frame.gaze {
        v["gaze"] = json!(g);
    }
    if let Some(g) = &frame.er_gaze {
        v["samples_total"] = json!(g.samples_total);
        v["er_gaze"] = json!(g);
    }
    if let Some(e) = err {
        v["error_vs_reference"] = error_json(e);
    }
    v
}

/// An error record; an infinite PSNR (identical images) is written as null.
pub fn error_json(e: &ImageError) -> Value {
    json!({
        "max_abs_255": e.max_abs_255,
        "rmse": e.rmse,
        "psnr": if e.psnr.is_finite() { json!(e.psnr) } else { Value::Null },
    })
}

/// Writes pretty JSON atomically.
pub fn write_json(path: &Path, v: &Value) -> Result<()> {
    let text = serde_json::to_string_pretty(v)?;
    golden::image::write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// The median of a non-empty list.
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        s[n / 2]
    } else {
        (s[n / 2 - 1] + s[n / 2]) / 2.0
    }
}
