//! `ercube render`: one image of a volume with one method.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};

use super::args::{with_threads, CameraArgs, SourceArgs, TfArgs};
use super::progress::Stage;
use super::stats::{frame_json, write_json};

/// Arguments of `ercube render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub source: SourceArgs,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub tf: TfArgs,
    /// Method: reference, er, er-ftb, under, over or box.
    #[arg(long, default_value = "er")]
    pub method: String,
    /// Output PNG (RGB over black).
    #[arg(long, default_value = "render.png")]
    pub out: PathBuf,
    /// Write statistics as JSON here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Write the final RGBA image as float32 H x W x 4 .npy here.
    #[arg(long)]
    pub npy: Option<PathBuf>,
    /// Write the baseplane image (before the warp) as float32 .npy here.
    #[arg(long)]
    pub baseplane_npy: Option<PathBuf>,
    /// Also render the reference and report the error against it.
    #[arg(long)]
    pub compare_reference: bool,
    /// Early ray termination opacity for er-ftb (1 disables it).
    #[arg(long, default_value_t = 0.99)]
    pub terminate: f32,
    /// Samples per slice crossing for slice-order methods (1 = the paper's one per slice).
    #[arg(long, default_value_t = golden::methods::DEFAULT_SUBSTEPS)]
    pub substeps: u32,
    /// Worker threads (default: all cores); results are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Runs `ercube render`.
pub fn run(a: &RenderArgs) -> Result<()> {
    with_threads(a.threads, || {
        let tech: Technique = a.method.parse()?;
        let opts = render_options(a.terminate, a.substeps)?;
        let (vol, default_tf) = {
            let _s = Stage::start("loading volume");
            a.source.load()?
        };
        let tf = a.tf.resolve(default_tf)?;
        let lut = lut_for(vol.kind(), &tf);
        let cam = a.camera.camera(&vol)?;
        let prep = Prepared::new(&vol, &cam)?;
        let t = Instant::now();
        let frame = {
            let _s = Stage::start(format!("rendering with {}", tech.name()));
            render(&prep, &lut, tech, &opts)?
        };
        let time_s = t.elapsed().as_secs_f64();
        let err = if a.compare_reference {
            let _s = Stage::start("rendering the reference");
            let r = render(&prep, &lut, Technique::Reference, &opts)?;
            Some(compare(&frame.image, &r.image)?)
        } else {
            None
        };
        frame.image.write_png(&a.out)?;
        if let Some(p) = &a.npy {
            frame.image.write_npy(p)?;
        }
        if let Some(p) = &a.baseplane_npy {
            match &frame.slice {
                Some(out) => out.baseplane.to_image().write_npy(p)?,
                None => anyhow::bail!(
                    "--baseplane-npy needs a slice-order method; the reference has no baseplane"
                ),
            }
        }
        if let Some(p) = &a.stats {
            write_json(
                p,
                &frame_json(
                    tech.name(),
                    &vol,
                    &prep.view,
                    cam.eye,
                    time_s,
                    &frame,
                    err.as_ref(),
                ),
            )?;
        }
        let mut line = format!(
            "{}: {}x{} in {:.3} s, principal axis {}, D = {:.3}",
            tech.name(),
            cam.width,
            cam.height,
            time_s,
            prep.view.axes.label(),
            prep.view.d
        );
        if let Some(e) = err {
            line += &format!(
                ", vs reference: max {} /255, rmse {:.5}, psnr {:.2} dB",
                e.max_abs_255, e.rmse, e.psnr
            );
        }
        super::say(&format!("{line} -> {}", a.out.display()));
        Ok(())
    })
}

/// Checks and builds the render options.
pub fn render_options(terminate: f32, substeps: u32) -> Result<RenderOptions> {
    let mut o = RenderOptions::default();
    o.slice.terminate = terminate;
    o.slice.substeps = substeps;
    o.slice.validate()?;
    Ok(o)
}
