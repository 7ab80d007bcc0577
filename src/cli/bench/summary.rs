//! The markdown summary of a case and its console table.

use std::fmt::Write as _;

use anyhow::Result;

use golden::camera::ImagePlane;

use super::write::{distances_of, points};
use super::{is_pipeline, BenchMethod, Case, CaseResult, Model, Row};

fn fmt_time(t: Option<f64>) -> String {
    match t {
        None => "skipped".into(),
        Some(t) if t >= 10.0 => format!("{t:.1}"),
        Some(t) if t >= 0.1 => format!("{t:.3}"),
        Some(t) => format!("{t:.4}"),
    }
}

fn fmt_count(n: f64) -> String {
    if n >= 1e6 {
        format!("{:.2} M", n / 1e6)
    } else if n >= 1e3 {
        format!("{:.1} k", n / 1e3)
    } else {
        format!("{n:.0}")
    }
}

/// The markdown summary of one case; plot links are prefixed by `img`.
pub fn summary(case: &Case, res: &CaseResult, img: &str, command: &str) -> Result<String> {
    let pts = points(case, res);
    let ds = distances_of(res);
    let dims = case.vol.dims();
    let labels: Vec<String> = case.methods.iter().map(BenchMethod::label).collect();
    let get = |m: &str, d: f64| pts.iter().find(|p| p.method == m && p.d == d);
    let mut s = String::new();
    writeln!(
        s,
        "Volume `{}` ({}x{}x{}), {}x{} images, image plane {}, eye on the centre line in front of slice 0; `{command}`; \
         times are medians of {} frames (the reference: one frame).\n",
        case.label,
        dims[0],
        dims[1],
        dims[2],
        case.size[0],
        case.size[1],
        match case.plane {
            ImagePlane::Front => "on the front face",
            ImagePlane::Camera => "the camera's",
        },
        case.frames
    )?;
    // Times.
    write!(s, "Median seconds per frame:\n\n| D | fov |")?;
    for l in &labels {
        write!(s, " {l} |")?;
    }
    write!(s, "\n| --- | --- |")?;
    for _ in &labels {
        write!(s, " --- |")?;
    }
    writeln!(s)?;
    for &(d, fov) in &ds {
        write!(s, "| {d} | {fov:.1} |")?;
        for l in &labels {
            write!(s, " {} |", fmt_time(get(l, d).and_then(|p| p.time)))?;
        }
        writeln!(s)?;
    }
    // Errors.
    write!(
        s,
        "\nError against the reference, RMSE (largest difference of 255):\n\n| D |"
    )?;
    let errs: Vec<&String> = labels.iter().filter(|l| *l != "reference").collect();
    for l in &errs {
        write!(s, " {l} |")?;
    }
    write!(s, " Pareto front, fastest first |\n| --- |")?;
    for _ in &errs {
        write!(s, " --- |")?;
    }
    writeln!(s, " --- |")?;
    for &(d, _) in &ds {
        write!(s, "| {d} |")?;
        for l in &errs {
            let cell = match get(l, d).and_then(|p| p.first.err) {
                Some(e) => format!("{:.4} ({})", e.rmse, e.max_abs_255),
                None => "skipped".into(),
            };
            write!(s, " {cell} |")?;
        }
        writeln!(s, " {} |", front_of(&errs, |l| get(l, d)))?;
    }
    writeln!(
        s,
        "\nA method is on the Pareto front at a distance when no other is both faster (median time) and closer to the reference (RMSE) there; the error-against-time plots draw the same front."
    )?;
    // Shading's cost.
    if case.shade.is_some() {
        write!(
            s,
            "\nShading's cost: every method and the reference shaded (Blinn-Phong, docs/golden.md#shading); median seconds of the shaded and of the same method's unshaded frames, and the shaded frame's RMSE against the shaded reference:\n\n\
             | D | method | shaded s | unshaded s | shaded / unshaded | RMSE vs shaded reference |\n| --- | --- | --- | --- | --- | --- |\n"
        )?;
        for &(d, _) in &ds {
            for l in &errs {
                let Some(p) = get(l, d) else { continue };
                let ratio = match (p.time, p.unshaded_time) {
                    (Some(a), Some(b)) if b > 0.0 => format!("{:.2}", a / b),
                    _ => "-".into(),
                };
                writeln!(
                    s,
                    "| {d} | {l} | {} | {} | {ratio} | {} |",
                    fmt_time(p.time),
                    fmt_time(p.unshaded_time),
                    p.first
                        .err
                        .map(|e| format!("{:.4}", e.rmse))
                        .unwrap_or("-".into())
                )?;
            }
        }
    }
    // Samples beside the formulas.
    let (area, nz) = (res.area, res.nz);
    write!(
        s,
        "\nSamples per frame, measured beside the paper's formulas (N^2 = {area:.0} voxels per slice, {nz} slices):\n\n| D |"
    )?;
    let counted: Vec<&String> = labels
        .iter()
        .filter(|l| Model::for_method(l).is_some() && !is_pipeline(l))
        .collect();
    for l in &counted {
        write!(s, " {l} |")?;
    }
    write!(
        s,
        " eq. 10 (over) | eq. 11 (under) | eq. 12 (er) | eq. 14, N^2 nz | eq. 13, 4 N^2 nz |\n| --- |"
    )?;
    for _ in 0..counted.len() + 5 {
        write!(s, " --- |")?;
    }
    writeln!(s)?;
    for &(d, _) in &ds {
        write!(s, "| {d} |")?;
        for l in &counted {
            let cell = get(l, d)
                .and_then(|p| p.first.samples)
                .map(|n| fmt_count(n as f64))
                .unwrap_or_else(|| "skipped".into());
            write!(s, " {cell} |")?;
        }
        for m in [
            Model::Over,
            Model::Under,
            Model::Er,
            Model::Lower,
            Model::Upper,
        ] {
            write!(s, " {} |", fmt_count(m.total(area, nz, d)))?;
        }
        writeln!(s)?;
    }
    // over / er.
    if labels.iter().any(|l| l == "over") && labels.iter().any(|l| l == "er") {
        write!(s, "\nOversampling against ER:\n\n| D | time over/er | samples over/er |\n| --- | --- | --- |\n")?;
        for &(d, _) in &ds {
            let (o, e) = (get("over", d), get("er", d));
            let t = match (o.and_then(|p| p.time), e.and_then(|p| p.time)) {
                (Some(a), Some(b)) => format!("{:.2}", a / b),
                _ => "-".into(),
            };
            let n = match (
                o.and_then(|p| p.first.samples),
                e.and_then(|p| p.first.samples),
            ) {
                (Some(a), Some(b)) => format!("{:.2}", a as f64 / b as f64),
                _ => "-".into(),
            };
            writeln!(s, "| {d} | {t} | {n} |")?;
        }
    }
    // Pipeline.
    let pipes: Vec<&String> = labels.iter().filter(|l| is_pipeline(l)).collect();
    if !pipes.is_empty() {
        write!(
            s,
            "\nPipeline (PE-array model; its time is the simulator's wall clock, its cycles the chip's):\n\n\
             | method | D | cycles | utilization | samples | max of 255 vs golden er | RMSE vs reference |\n| --- | --- | --- | --- | --- | --- | --- |\n"
        )?;
        for l in &pipes {
            for &(d, _) in &ds {
                if let Some(p) = get(l, d) {
                    let r = &p.first;
                    writeln!(
                        s,
                        "| {l} | {d} | {} | {} | {} | {} | {} |",
                        r.cycles.map(|c| fmt_count(c as f64)).unwrap_or("-".into()),
                        r.utilization
                            .map(|u| format!("{u:.3}"))
                            .unwrap_or("-".into()),
                        r.samples.map(|c| fmt_count(c as f64)).unwrap_or("-".into()),
                        r.vs_er
                            .map(|e| e.max_abs_255.to_string())
                            .unwrap_or("-".into()),
                        r.err
                            .map(|e| format!("{:.4}", e.rmse))
                            .unwrap_or("-".into()),
                    )?;
                }
            }
        }
        if let Some(same) = res.pipeline_matches_er {
            writeln!(
                s,
                "\nThe pipeline's samples per slice {} golden er's at every distance.",
                if same { "equal" } else { "differ from" }
            )?;
        }
    }
    // Skips.
    let skips: Vec<&Row> = res.rows.iter().filter(|r| r.skipped.is_some()).collect();
    if !skips.is_empty() {
        writeln!(s, "\nSkipped:\n")?;
        for r in skips {
            writeln!(
                s,
                "- {} at D = {}: {}",
                r.method,
                r.d,
                r.skipped.as_deref().unwrap_or("")
            )?;
        }
    }
    writeln!(
        s,
        "\n![time against D]({img}time_vs_distance.png)\n![error against time]({img}error_vs_time.png)"
    )?;
    if res.per_slice.is_some() {
        writeln!(s, "![samples per slice]({img}samples_per_slice.png)")?;
    }
    writeln!(s, "![samples against D]({img}samples_vs_distance.png)")?;
    Ok(s)
}

/// The methods on the Pareto front of (median time, RMSE) among `labels`,
/// fastest first.
fn front_of<'a>(
    labels: &[&String],
    get: impl Fn(&str) -> Option<&'a super::write::Point>,
) -> String {
    let pts: Vec<(&str, f64, f64)> = labels
        .iter()
        .filter_map(|l| {
            let p = get(l)?;
            Some((l.as_str(), p.time?, p.first.err?.rmse))
        })
        .collect();
    let xy: Vec<(f64, f64)> = pts.iter().map(|&(_, t, e)| (t, e)).collect();
    let front = super::write::pareto(&xy);
    let names: Vec<&str> = front
        .iter()
        .filter_map(|f| pts.iter().find(|p| (p.1, p.2) == *f).map(|p| p.0))
        .collect();
    if names.is_empty() {
        "-".into()
    } else {
        names.join(", ")
    }
}

/// A compact table of median times for the terminal.
pub(super) fn console_table(case: &Case, res: &CaseResult) -> String {
    let pts = points(case, res);
    let labels: Vec<String> = case.methods.iter().map(BenchMethod::label).collect();
    let mut s = format!("{:>8}", "D");
    for l in &labels {
        let _ = write!(s, " {l:>12}");
    }
    s.push('\n');
    for (d, _) in distances_of(res) {
        let _ = write!(s, "{d:>8}");
        for l in &labels {
            let t = pts
                .iter()
                .find(|p| &p.method == l && p.d == d)
                .and_then(|p| p.time);
            let _ = write!(s, " {:>12}", fmt_time(t));
        }
        s.push('\n');
    }
    s.trim_end().to_string()
}
