//! A width sweep's outputs: its CSV, its charts, the markdown summary and
//! the narrowest width of each knob within a grey-level limit.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use golden::metrics::ImageError;

use crate::cli::plot::{write_charts, Chart, Kind, Series};

use super::*;

/// The CSV of a sweep.
pub fn csv(res: &SweepResult) -> String {
    let mut s = String::from(
        "knob,value,total_bits,status,note,vs_er_max_abs_255,vs_er_rmse,vs_er_psnr,vs_ref_max_abs_255,vs_ref_rmse,overflows,cycles,time_s\n",
    );
    let e =
        |x: Option<ImageError>, f: fn(&ImageError) -> String| x.as_ref().map(f).unwrap_or_default();
    for r in &res.rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{:.6}",
            r.knob.map_or("base", Knob::name),
            r.value,
            r.total_bits,
            if r.skipped.is_some() { "skipped" } else { "ok" },
            r.skipped.as_deref().unwrap_or("").replace([',', '"'], ";"),
            e(r.vs_er, |x| x.max_abs_255.to_string()),
            e(r.vs_er, |x| format!("{:.8}", x.rmse)),
            e(r.vs_er, |x| if x.psnr.is_finite() {
                format!("{:.3}", x.psnr)
            } else {
                "inf".into()
            }),
            e(r.vs_ref, |x| x.max_abs_255.to_string()),
            e(r.vs_ref, |x| format!("{:.6}", x.rmse)),
            r.overflows,
            r.cycles,
            r.time_s,
        );
    }
    s
}

/// Writes widths.csv and widths.png into `dir`.
pub fn write_sweep(dir: &Path, sw: &Sweep, res: &SweepResult) -> Result<()> {
    let text = csv(res);
    golden::image::write_atomic(&dir.join("widths.csv"), |w| w.write_all(text.as_bytes()))?;
    let mut max_series = Vec::new();
    let mut rmse_series = Vec::new();
    // One distinct colour per knob (tab10's first six).
    const COLORS: [plotters::style::RGBColor; 6] = [
        plotters::style::RGBColor(31, 119, 180),
        plotters::style::RGBColor(255, 127, 14),
        plotters::style::RGBColor(44, 160, 44),
        plotters::style::RGBColor(214, 39, 40),
        plotters::style::RGBColor(148, 103, 189),
        plotters::style::RGBColor(140, 86, 75),
    ];
    for (i, (k, _)) in sw.grid.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let rs: Vec<&WidthRow> = res
            .rows
            .iter()
            .filter(|r| r.knob == Some(*k) && r.vs_er.is_some())
            .collect();
        if rs.is_empty() {
            continue;
        }
        let pts = |f: fn(&ImageError) -> f64| -> Vec<(f64, f64)> {
            rs.iter()
                .filter_map(|r| Some((f64::from(r.total_bits), f(r.vs_er.as_ref()?))))
                .collect()
        };
        max_series.push(
            Series::new(k.name(), pts(|e| e.max_abs_255), Kind::LinePoints).with_color(color),
        );
        rmse_series
            .push(Series::new(k.name(), pts(|e| e.rmse), Kind::LinePoints).with_color(color));
    }
    if let Some(b) = res.rows.iter().find(|r| r.knob.is_none()) {
        if let Some(e) = b.vs_er {
            let x = f64::from(b.total_bits);
            let black = plotters::style::RGBColor(0, 0, 0);
            max_series.push(
                Series::new("defaults", vec![(x, e.max_abs_255)], Kind::Points).with_color(black),
            );
            rmse_series
                .push(Series::new("defaults", vec![(x, e.rmse)], Kind::Points).with_color(black));
        }
    }
    let xs: Vec<f64> = res
        .rows
        .iter()
        .filter(|r| r.vs_er.is_some())
        .map(|r| f64::from(r.total_bits))
        .collect();
    if let (Some(lo), Some(hi)) = (
        xs.iter().copied().reduce(f64::min),
        xs.iter().copied().reduce(f64::max),
    ) {
        rmse_series.push(
            Series::new(
                "golden er vs reference",
                vec![(lo, res.er_vs_ref.rmse), (hi, res.er_vs_ref.rmse)],
                Kind::Dashed,
            )
            .with_color(plotters::style::RGBColor(110, 110, 110)),
        );
        max_series.push(
            Series::new("1 grey level", vec![(lo, 1.0), (hi, 1.0)], Kind::Dashed)
                .with_color(plotters::style::RGBColor(110, 110, 110)),
        );
    }
    write_charts(
        &dir.join("widths.png"),
        &[
            Chart {
                title: format!("{}: largest difference from golden er", sw.label),
                x_label: "total datapath bits".into(),
                y_label: "max |pipeline - golden er| (of 255)".into(),
                x_log: false,
                y_log: false,
                series: max_series,
            },
            Chart {
                title: format!("{}: RMSE from golden er", sw.label),
                x_label: "total datapath bits".into(),
                y_label: "RMSE against golden er".into(),
                x_log: false,
                y_log: true,
                series: rmse_series,
            },
        ],
        (800, 560),
    )?;
    Ok(())
}

/// The markdown summary of a sweep: per knob, the error at each value and
/// the narrowest value within one grey level of golden er.
pub fn summary(sw: &Sweep, res: &SweepResult, img: &str) -> String {
    let mut s = String::new();
    let base = res.rows.iter().find(|r| r.knob.is_none());
    if let Some(b) = base {
        let _ = write!(s, "Base configuration: {} datapath bits", b.total_bits);
        if let Some(e) = b.vs_er {
            let _ = write!(
                s,
                ", largest difference from golden er {} of 255 (RMSE {:.2e})",
                e.max_abs_255, e.rmse
            );
        }
        let _ = writeln!(
            s,
            "; golden er itself is {:.4} RMSE ({} of 255) from the reference.\n",
            res.er_vs_ref.rmse, res.er_vs_ref.max_abs_255
        );
    }
    let _ = writeln!(
        s,
        "| width | default | narrowest within 1 grey level | values: max of 255 (RMSE vs golden er) |\n| --- | --- | --- | --- |"
    );
    for (k, _) in &sw.grid {
        let rs: Vec<&WidthRow> = res.rows.iter().filter(|r| r.knob == Some(*k)).collect();
        let ok = narrowest_within(&rs, 1.0);
        let cells: Vec<String> = rs
            .iter()
            .map(|r| match (&r.skipped, r.vs_er) {
                (Some(_), _) | (_, None) => format!("{}: invalid", r.value),
                (None, Some(e)) => format!("{}: {} ({:.1e})", r.value, e.max_abs_255, e.rmse),
            })
            .collect();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            k.name(),
            k.value(&sw.base),
            ok.map_or("none".to_string(), |v| v.to_string()),
            cells.join(", ")
        );
    }
    let _ = writeln!(s, "\n![widths]({img}widths.png)");
    s
}

/// The smallest value from which every larger value stays within `limit`
/// grey levels of golden er.
pub fn narrowest_within(rows: &[&WidthRow], limit: f64) -> Option<u8> {
    let mut best = None;
    for r in rows.iter().rev() {
        match r.vs_er {
            Some(e) if r.skipped.is_none() && e.max_abs_255 <= limit => best = Some(r.value),
            _ => break,
        }
    }
    best
}
