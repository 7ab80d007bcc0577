//! The frame `ercube cosim` and `ercube vectors` capture: its options,
//! and the frame loaded with the emitted datapath it runs through.

use anyhow::{anyhow, bail, Result};
use clap::Args;

use golden::render::Prepared;
use golden::tf::Lut;
use pipeline::config::{Order, PipelineConfig};
use pipeline::datapath::FrameUnit;
use pipeline::hw::compose::Units;
use pipeline::hw::pipeline_rtl::{emit_scheduled, PipelinedModule};
use pipeline::{FrameRun, Voxels};

use super::args::{SliceArgs, ViewArgs};
use super::chip::{self, ConfigArgs};
use super::memory::FrameSpec;
use super::method::MethodArg;
use super::rtl::MODULE;

/// The frame `cosim` and `vectors` capture: the view, the renderer's
/// options, the pipeline configuration and the order.
#[derive(Debug, Args)]
pub struct FrameArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    #[command(flatten)]
    pub slice: SliceArgs,
    #[command(flatten)]
    pub cfg: ConfigArgs,
    /// Compositing order (overrides the configuration): btf or ftb (front
    /// to back with --terminate's threshold).
    #[arg(long, value_parser = ["btf", "ftb"])]
    pub order: Option<String>,
}

/// A frame ready to run with a capture.
pub struct Setup {
    /// The configuration.
    pub cfg: PipelineConfig,
    /// The classification table.
    pub lut: Lut,
    /// The prepared view, holding the voxels.
    pub prep: Prepared,
    /// Bits of the volume's scalars.
    pub bits: u32,
    /// What the controller skips.
    pub skips: golden::skip::Skips,
    /// The volume's name.
    pub label: String,
    /// The emitted datapath (the plain sample's, or the sample composed
    /// with the frame's units).
    pub module: PipelinedModule,
    /// The frame's units beside the plain sample.
    pub units: Units,
    /// The frame's shading.
    pub shade: Option<golden::shading::Shade>,
    /// The frame's volume of interest.
    pub voi: Option<golden::voi::Voi>,
    /// The frame's pre-integrated table (`--preintegrate`).
    pub preint: Option<golden::preint::PreTable>,
}

impl Setup {
    /// The frame, to run with or without a capture.
    pub fn frame(&self) -> FrameRun<'_> {
        FrameRun::prepared(
            &self.cfg,
            &self.lut,
            &self.prep,
            Voxels::Stack {
                data_bits: self.bits,
            },
        )
        .skips(self.skips)
        .unit(self.shade.as_ref())
        .unit(self.voi.as_ref())
        .unit(self.preint.as_ref())
    }

    /// Refuses a pre-integrated frame in one line (as `cmd`): what does not
    /// take the pre-integrated sample's ports yet.
    pub fn refuse_preint(&self, cmd: &str, what: &str) -> Result<()> {
        if self.units.preint {
            bail!("{cmd}: pre-integration (--preintegrate) is not {what}; `ercube cosim` (the datapath stage) co-simulates it");
        }
        Ok(())
    }

    /// The model's write-back latency.
    pub fn latency(&self) -> u64 {
        u64::from(pipeline::cost::sample_latency(&self.cfg, self.units))
    }
}

/// Loads the frame `a` describes, refusing in one line (as `cmd`) what the
/// datapath's stream does not cover yet.
pub fn setup(a: &FrameArgs, cmd: &str) -> Result<Setup> {
    setup_given(a, cmd, None)
}

/// [`setup`] of the volume `given` in memory instead of `--scene` or
/// `--volume` when it is `Some` (a library caller's).
pub fn setup_given(
    a: &FrameArgs,
    cmd: &str,
    given: Option<golden::volume::Volume>,
) -> Result<Setup> {
    let method = match a.order.as_deref() {
        Some("ftb") => MethodArg::PipelineFtb,
        _ => MethodArg::Pipeline,
    };
    let (mut cfg, slice) = chip::configure(&a.cfg, method, &a.slice)?;
    if a.order.as_deref() == Some("btf") {
        cfg.order = Order::BackToFront;
        cfg.validate()?;
    }
    let opts = slice.options()?;
    chip::check_options(&opts)?;
    if opts.slice.preintegrate && opts.slice.pre_colouring != golden::preint::Colouring::Fast {
        bail!(
            "{cmd}: --pre-colouring {}: the pre-integration unit is described (and emitted) for the fast colouring only",
            opts.slice.pre_colouring.name()
        );
    }
    let spec = FrameSpec {
        technique: None,
        shade: false,
        size: a.view.camera.size,
    };
    let (vol, tf, cam) = a.view.load_given(cmd, &spec, given)?;
    let mut opts = opts;
    slice.apply_tf(&mut opts, &tf)?;
    let lut = chip::pipeline_lut(&cfg, &vol, &tf);
    let bits = vol.kind().bits();
    let prep = slice.prepared_owning(vol, &cam)?;
    // Golden's table from the classification table, which the unit
    // quantises (as `ercube render --preintegrate`).
    let preint = opts
        .slice
        .preintegrate
        .then(|| golden::preint::PreTable::with_colouring(&lut, opts.slice.pre_colouring));
    // The units the frame loads (the shading unit built for its lights).
    let (shade, voi) = (opts.slice.shade.as_ref(), opts.slice.voi.as_ref());
    let inputs: Vec<&dyn FrameUnit> = [
        shade.map(|u| u as &dyn FrameUnit),
        voi.map(|u| u as &dyn FrameUnit),
        preint.as_ref().map(|u| u as &dyn FrameUnit),
    ]
    .into_iter()
    .flatten()
    .collect();
    let clipped = !prep.clip.is_empty();
    let units = pipeline::datapath::units_for(&cfg, &lut, &prep.view, bits, clipped, &inputs)
        .map_err(|e| anyhow!("{cmd}: {e}"))?;
    // The schedule the model's latency is read from.
    let g = pipeline::hw::compose::sample(&cfg, units);
    let sch = pipeline::cost::latency::graph_schedule(&cfg, &g);
    let module = emit_scheduled(&g, &sch, MODULE).map_err(|e| anyhow!("{cmd}: {e}"))?;
    Ok(Setup {
        cfg,
        lut,
        prep,
        bits,
        skips: opts.slice.skips,
        label: a.view.source.label(),
        module,
        units,
        shade: opts.slice.shade,
        voi: opts.slice.voi,
        preint,
    })
}
