//! The entry points that run one frame: from a volume or from a prepared
//! view's slice stack, shaded and with a volume of interest when given.
//! Each loads an [`Array`], hands it the frame's shading, volume of interest
//! and skipping plan, clocks it and reads it out.

use golden::geometry::View;
use golden::volume::Volume;
use waves::Tracer;

use crate::config::PipelineConfig;
use crate::host::{PlanError, VoxelSource};

use super::memory::run_resident;
use super::{run_frame_resident, Array, Frame, Resident, RunError};

/// Runs one frame: plans, loads, clocks and reads out.
pub fn run_frame(
    cfg: &PipelineConfig,
    volume: &Volume,
    lut: &golden::tf::Lut,
    view: &View,
    tracer: Tracer,
) -> Result<Frame, RunError> {
    Array::new(cfg, volume, lut, view, tracer)?.run(view)
}

/// Runs one frame of `prep` with the controller skipping what `skips`
/// allows and clipping to `prep`'s planes: the occupancy memory is built
/// from the volume's min-max blocks (`occupancy_block` voxels) and this
/// pipeline's classification table (see [`crate::skip`]).
pub fn run_frame_with(
    cfg: &PipelineConfig,
    volume: &Volume,
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    skips: golden::skip::Skips,
    tracer: Tracer,
) -> Result<Frame, RunError> {
    run_frame_shaded(cfg, volume, lut, prep, skips, None, tracer)
}

/// [`run_frame_with`], shaded with `shade` when given
/// ([`Array::set_shading`]).
pub fn run_frame_shaded(
    cfg: &PipelineConfig,
    volume: &Volume,
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    skips: golden::skip::Skips,
    shade: Option<&golden::shading::Shade>,
    tracer: Tracer,
) -> Result<Frame, RunError> {
    run_frame_voi(cfg, volume, lut, prep, skips, (shade, None), tracer)
}

/// [`run_frame_shaded`] with the volume of interest `voi` when given
/// ([`Array::set_voi`]).
pub fn run_frame_voi(
    cfg: &PipelineConfig,
    volume: &Volume,
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    skips: golden::skip::Skips,
    (shade, voi): (Option<&golden::shading::Shade>, Option<&golden::voi::Voi>),
    tracer: Tracer,
) -> Result<Frame, RunError> {
    let block = usize::from(cfg.occupancy_block);
    let mm = if prep.blocks.block == block {
        prep.blocks.clone()
    } else {
        golden::occupancy::MinMax::new(volume, block)
            .map_err(|e| RunError::Plan(PlanError::Golden(e)))?
    };
    let source = VoxelSource::Volume(volume, &prep.view);
    run_prepared(
        cfg,
        (source, volume.kind().bits()),
        lut,
        prep,
        mm,
        skips,
        (shade, voi),
        tracer,
    )
}

/// [`run_frame_shaded`] without the volume: the PEs load from `prep`'s
/// slice stack (the same view-space scalars, `data_bits` bits each), so a
/// caller that handed its volume to the stack holds the voxels once.
/// `prep` must have been prepared with min-max blocks of the
/// configuration's `occupancy_block`.
pub fn run_frame_from_stack(
    cfg: &PipelineConfig,
    data_bits: u32,
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    skips: golden::skip::Skips,
    shade: Option<&golden::shading::Shade>,
    tracer: Tracer,
) -> Result<Frame, RunError> {
    run_frame_from_stack_voi(cfg, data_bits, lut, prep, skips, (shade, None), tracer)
}

/// [`run_frame_from_stack`] with the volume of interest `voi` when given
/// ([`Array::set_voi`]).
pub fn run_frame_from_stack_voi(
    cfg: &PipelineConfig,
    data_bits: u32,
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    skips: golden::skip::Skips,
    (shade, voi): (Option<&golden::shading::Shade>, Option<&golden::voi::Voi>),
    tracer: Tracer,
) -> Result<Frame, RunError> {
    run_frame_resident(
        cfg,
        data_bits,
        lut,
        prep,
        skips,
        (shade, voi),
        tracer,
        &mut None,
    )
}

/// Runs one pre-integrated frame of `prep` ([`crate::preint`]), the PEs
/// loading from its slice stack (`data_bits`-bit scalars): golden's table
/// `pt`, pre-integrated from `lut`, goes into the unit, and the controller
/// skips what `skips` allows with an occupancy memory built for the
/// unit's table ([`crate::skip::plan_preint_mask`]), each step's runs over
/// the segment it integrates. The frame is unshaded, without a volume of
/// interest or clip planes ([`Array::set_preint`]). `prep` must have been
/// prepared with min-max blocks of the configuration's `occupancy_block`.
pub fn run_frame_preint(
    cfg: &PipelineConfig,
    data_bits: u32,
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    (pt, skips): (&golden::preint::PreTable, golden::skip::Skips),
    tracer: Tracer,
) -> Result<Frame, RunError> {
    run_frame_preint_resident(cfg, data_bits, lut, prep, (pt, skips), tracer, &mut None)
}

/// [`run_frame_preint`], keeping the PE memories in `resident` across
/// calls as [`crate::run_frame_resident`] does (the same bits and cycles
/// as a fresh load; the frame's [`crate::VoxelLoad`] says whether the host
/// loaded anything).
pub fn run_frame_preint_resident(
    cfg: &PipelineConfig,
    data_bits: u32,
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    (pt, skips): (&golden::preint::PreTable, golden::skip::Skips),
    tracer: Tracer,
    resident: &mut Option<super::Resident>,
) -> Result<Frame, RunError> {
    let units = Units {
        shade: None,
        voi: None,
        preint: Some(pt),
    };
    run_resident(cfg, (data_bits, lut), prep, skips, units, tracer, resident)
}

#[allow(clippy::too_many_arguments)]
fn run_prepared(
    cfg: &PipelineConfig,
    (source, data_bits): (VoxelSource, u32),
    lut: &golden::tf::Lut,
    prep: &golden::render::Prepared,
    mm: golden::occupancy::MinMax,
    skips: golden::skip::Skips,
    (shade, voi): (Option<&golden::shading::Shade>, Option<&golden::voi::Voi>),
    tracer: Tracer,
) -> Result<Frame, RunError> {
    let array = Array::load(cfg, source, data_bits, lut, &prep.view, tracer)?;
    let units = Units {
        shade,
        voi,
        preint: None,
    };
    run_loaded(array, (data_bits, lut), prep, mm, skips, units).map(|(frame, _)| frame)
}

/// The units a frame loads beside the datapath: the gradient and shading
/// unit's constants, a volume of interest, golden's pre-integration table.
#[derive(Clone, Copy, Default)]
pub(super) struct Units<'a> {
    pub(super) shade: Option<&'a golden::shading::Shade>,
    pub(super) voi: Option<&'a golden::voi::Voi>,
    pub(super) preint: Option<&'a golden::preint::PreTable>,
}

/// Loads `units` into a loaded array, plans the skipping of its frame of
/// `prep` (`lut` the classification table, for a pre-integrated frame's
/// occupancy memory) and runs it.
pub(super) fn run_loaded(
    mut array: Array,
    (data_bits, lut): (u32, &golden::tf::Lut),
    prep: &golden::render::Prepared,
    mm: golden::occupancy::MinMax,
    skips: golden::skip::Skips,
    units: Units,
) -> Result<(Frame, Resident), RunError> {
    if let Some(sh) = units.shade {
        array.set_shading(sh, &prep.view, data_bits)?;
    }
    if let Some(v) = units.voi {
        array.set_voi(v, &prep.view)?;
    }
    if let Some(pt) = units.preint {
        if !prep.clip.is_empty() {
            return Err(crate::preint::PreintError::Unsupported(
                "the pipeline's pre-integrated frames take no clip planes; drop --clip or --preintegrate"
                    .into(),
            )
            .into());
        }
        array.set_preint(pt)?;
    }
    let layout = golden::methods::Method::Er
        .layout(&prep.view)
        .map_err(|e| RunError::Plan(PlanError::Golden(e)))?;
    let dp = &array.dp;
    let (mask, counts) = match (units.preint, &dp.preint) {
        (Some(pt), Some(unit)) => crate::skip::plan_preint_mask(
            dp,
            unit,
            (lut, pt.stride()),
            &mm,
            data_bits,
            prep,
            &layout,
            skips,
        ),
        _ => crate::skip::plan_mask(dp, &mm, data_bits, prep, &layout, skips),
    };
    array.set_skipping(mask, counts, &prep.view);
    array.run_keeping(&prep.view)
}
