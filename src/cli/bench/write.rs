//! Writing a case's results: the CSV of every run, the plot points, the
//! PNG plots, and the Pareto front of error against time.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;

use super::{is_pipeline, Case, CaseResult, Model, Row};
use crate::cli::plot::{write_chart, write_charts, Chart, Kind, Series};
use crate::cli::stats::median;

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

fn psnr_text(p: f64) -> String {
    if p.is_finite() {
        format!("{p:.3}")
    } else {
        "inf".into()
    }
}

/// The CSV of every run.
pub fn csv(case: &Case, res: &CaseResult) -> String {
    let dims = case.vol.dims();
    let mut s = String::from(
        "scene,volume,image,D,fov_deg,method,run,status,note,time_s,samples,regions,cycles,utilization,max_abs_255,rmse,psnr,vs_er_max_abs_255,vs_er_rmse,unshaded_time_s\n",
    );
    for r in &res.rows {
        let note = r.skipped.as_deref().unwrap_or("").replace(['"', ','], ";");
        let _ = writeln!(
            s,
            "{},{}x{}x{},{}x{},{},{:.4},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            case.label.replace(',', ";"),
            dims[0],
            dims[1],
            dims[2],
            case.size[0],
            case.size[1],
            r.d,
            r.fov,
            r.method,
            r.run,
            if r.skipped.is_some() { "skipped" } else { "ok" },
            note,
            r.time_s.map(|t| format!("{t:.6}")).unwrap_or_default(),
            opt(r.samples),
            opt(r.regions),
            opt(r.cycles),
            r.utilization.map(|u| format!("{u:.4}")).unwrap_or_default(),
            opt(r.err.map(|e| e.max_abs_255)),
            r.err.map(|e| format!("{:.6}", e.rmse)).unwrap_or_default(),
            r.err.map(|e| psnr_text(e.psnr)).unwrap_or_default(),
            opt(r.vs_er.map(|e| e.max_abs_255)),
            r.vs_er
                .map(|e| format!("{:.6}", e.rmse))
                .unwrap_or_default(),
            r.unshaded_time_s
                .map(|t| format!("{t:.6}"))
                .unwrap_or_default(),
        );
    }
    s
}

/// Per method and distance: median time and the run's counts and errors.
#[derive(Debug, Clone)]
pub struct Point {
    /// Method label.
    pub method: String,
    /// Eye distance.
    pub d: f64,
    /// Median seconds over the frames (`None`: skipped).
    pub time: Option<f64>,
    /// Median seconds of the unshaded frames (`--shade` only).
    pub unshaded_time: Option<f64>,
    /// First run's row (counts and errors are identical in every run).
    pub first: Row,
}

/// Groups rows into points, in method then distance order.
pub fn points(case: &Case, res: &CaseResult) -> Vec<Point> {
    let mut out = Vec::new();
    for m in &case.methods {
        let label = m.label();
        let mut ds: Vec<f64> = Vec::new();
        for r in res.rows.iter().filter(|r| r.method == label) {
            if !ds.contains(&r.d) {
                ds.push(r.d);
            }
        }
        for d in ds {
            let rs: Vec<&Row> = res
                .rows
                .iter()
                .filter(|r| r.method == label && r.d == d)
                .collect();
            let times: Vec<f64> = rs.iter().filter_map(|r| r.time_s).collect();
            let plain: Vec<f64> = rs.iter().filter_map(|r| r.unshaded_time_s).collect();
            out.push(Point {
                method: label.clone(),
                d,
                time: (!times.is_empty()).then(|| median(&times)),
                unshaded_time: (!plain.is_empty()).then(|| median(&plain)),
                first: rs[0].clone(),
            });
        }
    }
    out
}

/// Distances of the case's rows, in sweep order.
pub(super) fn distances_of(res: &CaseResult) -> Vec<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = Vec::new();
    for r in &res.rows {
        if !v.iter().any(|x| x.0 == r.d) {
            v.push((r.d, r.fov));
        }
    }
    v
}

/// Writes bench.csv, samples_per_slice.csv and the plots into `dir`.
pub fn write_case(dir: &Path, case: &Case, res: &CaseResult, title: &str) -> Result<()> {
    let text = csv(case, res);
    golden::image::write_atomic(&dir.join("bench.csv"), |w| w.write_all(text.as_bytes()))?;
    let pts = points(case, res);
    let name = if title.is_empty() {
        case.label.clone()
    } else {
        title.to_string()
    };
    const SIZE: (u32, u32) = (900, 600);

    // Figure 9: time against D.
    let mut series = Vec::new();
    for m in &case.methods {
        let label = m.label();
        let p: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| p.method == label)
            .filter_map(|p| p.time.map(|t| (p.d, t)))
            .collect();
        if !p.is_empty() {
            series.push(Series::new(label, p, Kind::LinePoints));
        }
    }
    write_chart(
        &dir.join("time_vs_distance.png"),
        &Chart {
            title: format!("{name}: time per frame against eye distance"),
            x_label: "eye distance D to the front slice (voxels)".into(),
            y_label: format!("median seconds per frame ({} frames)", case.frames),
            x_log: true,
            y_log: true,
            series,
        },
        SIZE,
    )?;

    // Error against time at up to three distances (the nearest, a middle
    // one and the farthest), each with its Pareto front: a front only
    // means something among renderings of the same view.
    let all_d: Vec<f64> = distances_of(res).iter().map(|x| x.0).collect();
    let picked: Vec<f64> = if all_d.len() <= 3 {
        all_d.clone()
    } else {
        let mut v = all_d.clone();
        v.sort_by(f64::total_cmp);
        vec![v[0], v[v.len() / 2], v[v.len() - 1]]
    };
    let mut charts = Vec::new();
    for &d in &picked {
        let mut series = Vec::new();
        let mut all: Vec<(f64, f64)> = Vec::new();
        for m in &case.methods {
            let label = m.label();
            let p: Vec<(f64, f64)> = pts
                .iter()
                .filter(|p| p.method == label && p.d == d)
                .filter_map(|p| Some((p.time?, p.first.err?.rmse)))
                .filter(|&(_, e)| e > 0.0)
                .collect();
            all.extend(&p);
            if !p.is_empty() {
                series.push(Series::new(label, p, Kind::Points));
            }
        }
        let front = pareto(&all);
        if front.len() > 1 {
            series.push(
                Series::new("Pareto front", front, Kind::Line)
                    .with_color(plotters::style::RGBColor(90, 90, 90)),
            );
        }
        charts.push(Chart {
            title: format!("{name}, D = {d}: error against time"),
            x_label: "median seconds per frame".into(),
            y_label: "RMSE against the reference".into(),
            x_log: true,
            y_log: true,
            series,
        });
    }
    write_charts(&dir.join("error_vs_time.png"), &charts, (640, 560))?;

    // Samples per slice at one distance, with the bounds and the models.
    if let Some(ps) = &res.per_slice {
        let mut series = Vec::new();
        let mut csv = String::from("slice");
        let mut cols: Vec<Vec<f64>> = Vec::new();
        for (label, v) in &ps.measured {
            if !is_pipeline(label) {
                series.push(Series::new(
                    format!("{label} measured"),
                    v.iter()
                        .enumerate()
                        .map(|(z, &s)| (z as f64, s as f64))
                        .collect(),
                    Kind::Line,
                ));
            }
            let _ = write!(csv, ",{label}");
            cols.push(v.iter().map(|&s| s as f64).collect());
        }
        for model in Model::ALL {
            let shown = match model {
                Model::Upper | Model::Lower => true,
                m => ps
                    .measured
                    .iter()
                    .any(|(l, _)| Model::for_method(l) == Some(m)),
            };
            if !shown {
                continue;
            }
            let v = model.slices(ps.area, ps.nz, ps.d);
            let label = match model {
                Model::Over => "over model (eq. 9)",
                Model::Under => "under model",
                Model::Er => "er model",
                Model::Upper => "4 N^2 (eq. 13)",
                Model::Lower => "N^2 (eq. 14)",
            };
            let mut s = Series::new(
                label,
                v.iter().enumerate().map(|(z, &s)| (z as f64, s)).collect(),
                Kind::Dashed,
            );
            if matches!(model, Model::Upper | Model::Lower) {
                s = s.with_color(plotters::style::RGBColor(110, 110, 110));
            }
            series.push(s);
            let _ = write!(csv, ",model_{}", model_key(model));
            cols.push(v);
        }
        csv.push('\n');
        for z in 0..ps.nz {
            let _ = write!(csv, "{z}");
            for c in &cols {
                let _ = write!(
                    csv,
                    ",{}",
                    trim_float(c.get(z).copied().unwrap_or(f64::NAN))
                );
            }
            csv.push('\n');
        }
        golden::image::write_atomic(&dir.join("samples_per_slice.csv"), |w| {
            w.write_all(csv.as_bytes())
        })?;
        write_chart(
            &dir.join("samples_per_slice.png"),
            &Chart {
                title: format!("{name}: samples per slice at D = {}", ps.d),
                x_label: "slice z (0 = front)".into(),
                y_label: "samples on the slice".into(),
                x_log: false,
                y_log: true,
                series,
            },
            SIZE,
        )?;
    }

    // Samples per frame against D, beside equations 10 to 14.
    let mut series = Vec::new();
    let ds: Vec<f64> = distances_of(res).iter().map(|x| x.0).collect();
    for m in &case.methods {
        let label = m.label();
        let p: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| p.method == label)
            .filter_map(|p| Some((p.d, p.first.samples? as f64)))
            .collect();
        if !p.is_empty() && !is_pipeline(&label) {
            series.push(Series::new(format!("{label} measured"), p, Kind::Points));
        }
    }
    if !ds.is_empty() && res.nz > 0 {
        let lo = ds.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ds.iter().copied().fold(0.0, f64::max);
        let grid: Vec<f64> = (0..=48)
            .map(|k| lo * (hi / lo).powf(k as f64 / 48.0))
            .collect();
        for model in Model::ALL {
            let shown = match model {
                Model::Upper | Model::Lower => true,
                m => case
                    .methods
                    .iter()
                    .any(|x| Model::for_method(&x.label()) == Some(m)),
            };
            if !shown {
                continue;
            }
            let p = grid
                .iter()
                .map(|&d| (d, model.total(res.area, res.nz, d)))
                .collect();
            let mut s = Series::new(model.label(), p, Kind::Dashed);
            if matches!(model, Model::Upper | Model::Lower) {
                s = s.with_color(plotters::style::RGBColor(110, 110, 110));
            }
            series.push(s);
        }
    }
    write_chart(
        &dir.join("samples_vs_distance.png"),
        &Chart {
            title: format!("{name}: samples per frame, measured and the paper's formulas"),
            x_label: "eye distance D to the front slice (voxels)".into(),
            y_label: "samples per frame".into(),
            x_log: true,
            y_log: true,
            series,
        },
        SIZE,
    )?;
    Ok(())
}

fn model_key(m: Model) -> &'static str {
    match m {
        Model::Over => "over",
        Model::Under => "under",
        Model::Er => "er",
        Model::Upper => "upper_4n2",
        Model::Lower => "lower_n2",
    }
}

/// A number without float noise: integers as integers, others to 6
/// significant digits.
fn trim_float(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        format!("{v:.6e}")
    }
}

/// The points no other point beats in both time and error, by time.
pub fn pareto(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if front.last().is_none_or(|l| q.1 < l.1) {
            front.push(q);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_keeps_the_undominated() {
        let f = pareto(&[(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (0.5, 9.0)]);
        assert_eq!(f, vec![(0.5, 9.0), (1.0, 5.0), (2.0, 3.0), (4.0, 1.0)]);
    }
}
