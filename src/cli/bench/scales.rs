//! The report's shear-warp section: time, samples and error against the
//! reference as the intermediate image grows (`--intermediate-scale`,
//! Schulze et al.'s runtime quality knob), at a near and a far eye.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use golden::camera::ImagePlane;
use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::tf::TransferFunction;
use golden::volume::Volume;

use super::run::bench_camera;
use crate::cli::plot::{write_chart, Chart, Kind, Series};

/// Intermediate scales measured (pixels per voxel of the front slice).
pub const SCALES: [f64; 6] = [0.25, 0.5, 1.0, 1.5, 2.0, 4.0];

/// Measures shear-warp at every [`SCALES`] entry and distance in `ds`
/// (fitted field of view, front-face image plane, 256x256), writes
/// `dir/shear_warp_scale.png` and returns the markdown table; `img`
/// prefixes the plot's link.
pub fn section(
    label: &str,
    vol: &Volume,
    tf: &TransferFunction,
    ds: &[f64],
    frames: usize,
    dir: &Path,
    img: &str,
) -> Result<String> {
    let lut = lut_for(vol.kind(), tf);
    let mut s = String::new();
    writeln!(
        s,
        "| D | scale | intermediate image | samples resampled | samples composited | median s | RMSE (max of 255) |\n\
         | --- | --- | --- | --- | --- | --- | --- |"
    )?;
    let mut series = Vec::new();
    for &d in ds {
        let (cam, _) = bench_camera(vol, d, None, [256, 256], ImagePlane::Front)?;
        let prep = Prepared::new(vol, &cam)?;
        let reference = render(&prep, &lut, Technique::Reference, &RenderOptions::default())?;
        prep.classified_for(&lut)?;
        let mut pts = Vec::new();
        for scale in SCALES {
            let o = RenderOptions {
                sw_scale: scale,
                ..RenderOptions::default()
            };
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..frames.max(1) {
                let t = Instant::now();
                let f = render(&prep, &lut, Technique::ShearWarp, &o)?;
                times.push(t.elapsed().as_secs_f64());
                last = Some(f);
            }
            let f = last.expect("one frame");
            times.sort_by(f64::total_cmp);
            let time = times[times.len() / 2];
            let e = compare(&f.image, &reference.image)?;
            let st = f.sw.expect("shear-warp stats");
            writeln!(
                s,
                "| {d} | {scale} | {}x{} | {} | {} | {time:.4} | {:.4} ({}) |",
                st.intermediate[0],
                st.intermediate[1],
                st.samples_total,
                st.samples_composited,
                e.rmse,
                e.max_abs_255
            )?;
            pts.push((time, e.rmse));
        }
        series.push(Series::new(format!("D = {d}"), pts, Kind::LinePoints));
    }
    write_chart(
        &dir.join("shear_warp_scale.png"),
        &Chart {
            title: format!(
                "{label}: shear-warp error against time, intermediate scale {} to {}",
                SCALES[0],
                SCALES[SCALES.len() - 1]
            ),
            x_label: "median seconds per frame".into(),
            y_label: "RMSE against the reference".into(),
            x_log: true,
            y_log: true,
            series,
        },
        (720, 480),
    )?;
    writeln!(
        s,
        "\n![shear-warp error against time by intermediate scale]({img}shear_warp_scale.png)"
    )?;
    Ok(s)
}
