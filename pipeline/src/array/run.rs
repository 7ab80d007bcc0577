//! The one entry point that runs a frame, [`FrameRun`]: where the PEs'
//! voxels come from, the units the frame loads beside the datapath
//! ([`FrameUnit`]: shading, a volume of interest, pre-integration), what the controller
//! skips, the waveform and the PE memories kept between frames. It loads
//! an [`Array`], hands it those, clocks it and reads it out.

use golden::geometry::View;
use golden::render::Prepared;
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::Volume;
use waves::Tracer;

use crate::config::PipelineConfig;
use crate::datapath::FrameUnit;
use crate::host::{PlanError, VoxelSource};

use super::{Array, Frame, Resident, RunError};

/// Where the host reads the scalars it loads into the PE memories.
#[derive(Clone, Copy)]
pub enum Voxels<'a> {
    /// The volume, through the view's axes (its own data width).
    Volume(&'a Volume),
    /// The prepared view's slice stack (the same view-space scalars,
    /// `data_bits` bits each), so a caller that handed its volume to the
    /// stack holds the voxels once. Only a [`FrameRun::prepared`] frame
    /// has a stack.
    Stack {
        /// Bits of the volume's scalars (8, 12 or 16).
        data_bits: u32,
    },
}

/// What the frame is of: a bare view (nothing skipped), or golden's
/// prepared view with its occupancy, clip planes and slice stack.
#[derive(Clone, Copy)]
enum Camera<'a> {
    View(&'a View),
    Prepared(&'a Prepared),
}

/// One frame of the PE array, built up from its options and run once by
/// [`FrameRun::run`].
///
/// A frame of a bare view ([`FrameRun::new`]) loads the volume and runs
/// every ray of every slice (the controller has no occupancy memory); a
/// frame of golden's prepared view ([`FrameRun::prepared`]) skips what
/// [`FrameRun::skips`] allows (by default empty space and culling), clips
/// to the view's planes, and may load the PEs from the view's slice stack.
///
/// ```no_run
/// # fn frame(
/// #     cfg: &pipeline::config::PipelineConfig,
/// #     lut: &golden::tf::Lut,
/// #     prep: &golden::render::Prepared,
/// #     shade: &golden::shading::Shade,
/// # ) -> Result<(), pipeline::RunError> {
/// use pipeline::{FrameRun, Voxels};
/// let mut kept = None;
/// // A shaded frame from the prepared view's slice stack of 8-bit data,
/// // skipping only empty space, keeping the PE memories for the next
/// // frame of the same axis map.
/// let frame = FrameRun::prepared(cfg, lut, prep, Voxels::Stack { data_bits: 8 })
///     .skips(golden::skip::Skips::EMPTY)
///     .unit(Some(shade))
///     .resident(&mut kept)
///     .run()?;
/// println!("{} cycles", frame.cycles);
/// # Ok(()) }
/// ```
#[must_use = "a FrameRun does nothing until run"]
pub struct FrameRun<'a> {
    cfg: &'a PipelineConfig,
    lut: &'a Lut,
    camera: Camera<'a>,
    voxels: Voxels<'a>,
    skips: Option<Skips>,
    units: Vec<&'a dyn FrameUnit>,
    tracer: Tracer,
    nodes: Vec<String>,
    resident: Option<&'a mut Option<Resident>>,
    capture: Option<crate::cosim::capture::Capture>,
    tap: Option<crate::stepper::Tap>,
    depths: Option<crate::capacity::PeDepths>,
}

impl<'a> FrameRun<'a> {
    /// A frame of `volume` seen through `view`, classified by `lut`: the
    /// host loads the volume, the controller skips nothing, no unit beside
    /// the datapath, no waveform.
    pub fn new(
        cfg: &'a PipelineConfig,
        lut: &'a Lut,
        volume: &'a Volume,
        view: &'a View,
    ) -> FrameRun<'a> {
        FrameRun::of(cfg, lut, Camera::View(view), Voxels::Volume(volume))
    }

    /// A frame of golden's prepared view `prep`, classified by `lut`, the
    /// PEs loaded from `voxels`: the controller skips what
    /// [`FrameRun::skips`] allows (default: empty space and culling) with
    /// an occupancy memory built from the volume's min-max blocks
    /// (`occupancy_block` voxels; from a stack, `prep` must have been
    /// prepared with blocks of that edge) and this pipeline's
    /// classification table ([`crate::skip`]), and clips to `prep`'s
    /// planes.
    pub fn prepared(
        cfg: &'a PipelineConfig,
        lut: &'a Lut,
        prep: &'a Prepared,
        voxels: Voxels<'a>,
    ) -> FrameRun<'a> {
        FrameRun::of(cfg, lut, Camera::Prepared(prep), voxels)
    }

    fn of(
        cfg: &'a PipelineConfig,
        lut: &'a Lut,
        camera: Camera<'a>,
        voxels: Voxels<'a>,
    ) -> FrameRun<'a> {
        FrameRun {
            cfg,
            lut,
            camera,
            voxels,
            skips: None,
            units: Vec::new(),
            tracer: Tracer::disabled(),
            nodes: Vec::new(),
            resident: None,
            capture: None,
            tap: None,
            depths: None,
        }
    }

    /// Runs the frame on a chip whose PEs declare their ray memories
    /// `depths` deep, each its own
    /// ([`crate::cost::inventory::Geometry::pe_rays`]): a frame whose view
    /// needs more in some PE ([`crate::capacity::need`]), or a declaration
    /// for another PE count, is refused before it plans or loads anything.
    /// Without it the chip is taken as sized for the view.
    pub fn depths(mut self, depths: crate::capacity::PeDepths) -> Self {
        self.depths = Some(depths);
        self
    }

    /// What the controller of a prepared frame skips. A frame of a bare
    /// view has no occupancy memory: it refuses this at [`FrameRun::run`].
    pub fn skips(mut self, skips: Skips) -> Self {
        self.skips = Some(skips);
        self
    }

    /// Loads `unit` beside the datapath when given ([`Array::set_units`]):
    /// golden's shading (`golden::shading::Shade`), volume of interest
    /// (`golden::voi::Voi`) or pre-integration table
    /// (`golden::preint::PreTable`, pre-integrated from this frame's
    /// `lut`; a prepared frame's occupancy memory is then built for the
    /// unit's table, [`crate::skip::plan_preint_mask`]). A pre-integrated
    /// frame takes no shading, volume of interest or clip planes.
    pub fn unit<U: FrameUnit>(mut self, unit: Option<&'a U>) -> Self {
        if let Some(u) = unit {
            self.units.push(u);
        }
        self
    }

    /// Records the frame's waveforms with `tracer` (default: none).
    pub fn trace(mut self, tracer: Tracer) -> Self {
        self.tracer = tracer;
        self
    }

    /// Also traces the datapath description's nodes that `patterns` name
    /// (`*` globs; [`crate::probes::nodes`]), in scope `top.pe_K.hw` of
    /// the waveform; a pattern naming no node, or a pre-integrated frame,
    /// is refused when the frame starts.
    pub fn trace_nodes(mut self, patterns: Vec<String>) -> Self {
        self.nodes = patterns;
        self
    }

    /// Keeps the PE memories in `resident` across frames: when it holds
    /// the memories of a frame with the same axis map, configuration and
    /// data width, the PEs start from them and the host loads nothing (the
    /// frame's [`crate::VoxelLoad`] says so); otherwise they load from the
    /// frame's voxels (into its buffers, [`Resident::stale`]). Either way
    /// `resident` holds this frame's memories afterwards. The frame is
    /// bit-identical, cycles included, to one loaded afresh.
    pub fn resident(mut self, resident: &'a mut Option<Resident>) -> Self {
        self.resident = Some(resident);
        self
    }

    /// Records every sample the PEs' datapaths issue into `capture`
    /// ([`crate::cosim::capture`]): the frame runs clocked, with the same
    /// bits and cycles.
    pub fn capture(mut self, capture: crate::cosim::capture::Capture) -> Self {
        self.capture = Some(capture);
        self
    }

    /// Hands every cycle to the caller stepping the frame through `tap`
    /// ([`crate::stepper::Stepper`]): the frame runs clocked, as a traced
    /// one does, with the same bits and cycles, each tick waiting for the
    /// caller.
    pub fn tap(mut self, tap: crate::stepper::Tap) -> Self {
        self.tap = Some(tap);
        self
    }

    /// Plans, loads, clocks and reads out the frame.
    pub fn run(self) -> Result<Frame, RunError> {
        let FrameRun {
            cfg,
            lut,
            camera,
            voxels,
            skips,
            units,
            tracer,
            nodes,
            resident,
            capture,
            tap,
            depths,
        } = self;
        let view = match camera {
            Camera::View(view) => view,
            Camera::Prepared(prep) => &prep.view,
        };
        if let Some(declared) = depths {
            let need = crate::capacity::need(cfg, view)
                .map_err(|e| RunError::Plan(crate::host::PlanError::Golden(e)))?;
            crate::capacity::check(&need, &declared)?;
        }
        let (source, data_bits) = match (voxels, camera) {
            (Voxels::Volume(vol), _) => (VoxelSource::Volume(vol, view), vol.kind().bits()),
            (Voxels::Stack { data_bits }, Camera::Prepared(prep)) => {
                (VoxelSource::Stack(&prep.stack), data_bits)
            }
            (Voxels::Stack { .. }, Camera::View(_)) => {
                return Err(RunError::Schedule(
                    "a frame of a bare view has no slice stack: prepare the view".into(),
                ))
            }
        };
        // The occupancy memory's min-max blocks, checked before the load.
        let blocks =
            match camera {
                Camera::View(_) if skips.is_some() => return Err(RunError::Schedule(
                    "a frame of a bare view has no occupancy memory to skip with: prepare the view"
                        .into(),
                )),
                Camera::View(_) => None,
                Camera::Prepared(prep) => Some(min_max(cfg, prep, voxels)?),
            };
        let mut spare = None;
        let resident = resident.unwrap_or(&mut spare);
        let mut array =
            Array::load_reusing(cfg, source, data_bits, lut, view, tracer, resident.take())?;
        array.trace_nodes = nodes;
        let clipped = matches!(camera, Camera::Prepared(prep) if !prep.clip.is_empty());
        if !units.is_empty() {
            array.set_units(&units, view, data_bits, clipped)?;
        }
        if let (Camera::Prepared(prep), Some(mm)) = (camera, blocks) {
            plan_skipping(
                &mut array,
                (data_bits, lut),
                prep,
                mm,
                skips.unwrap_or_default(),
            )?;
        }
        if let Some(c) = capture {
            crate::cosim::capture::begin(&c, &array.dp);
            array.clocked = true;
            array.clock.set_capture(c);
        }
        if let Some(t) = tap {
            array.clocked = true;
            array.clock.set_tap(t);
        }
        let (frame, kept) = array.run_keeping(view)?;
        *resident = Some(kept);
        Ok(frame)
    }
}

/// The min-max blocks of `prep`'s occupancy memory at the configuration's
/// `occupancy_block`: `prep`'s own when they are that size; else built
/// from the volume, which a stack frame does not have.
fn min_max(
    cfg: &PipelineConfig,
    prep: &Prepared,
    voxels: Voxels,
) -> Result<golden::occupancy::MinMax, RunError> {
    let block = usize::from(cfg.occupancy_block);
    if prep.blocks.block == block {
        return Ok(prep.blocks.clone());
    }
    match voxels {
        Voxels::Volume(volume) => golden::occupancy::MinMax::new(volume, block)
            .map_err(|e| RunError::Plan(PlanError::Golden(e))),
        Voxels::Stack { .. } => Err(RunError::Schedule(format!(
            "the view was prepared with {}-voxel blocks, but occupancy_block = {}",
            prep.blocks.block, cfg.occupancy_block
        ))),
    }
}

/// Plans the skipping of `array`'s frame of `prep` over the min-max
/// blocks `mm` (`lut` the classification table, for a pre-integrated
/// frame's occupancy memory) and hands the plan to the controller.
fn plan_skipping(
    array: &mut Array,
    (data_bits, lut): (u32, &Lut),
    prep: &Prepared,
    mm: golden::occupancy::MinMax,
    skips: Skips,
) -> Result<(), RunError> {
    let layout = golden::methods::Method::Er
        .layout(&prep.view)
        .map_err(|e| RunError::Plan(PlanError::Golden(e)))?;
    let dp = &array.dp;
    let (mask, counts) = match &dp.loaded.preint {
        Some(unit) => crate::skip::plan_preint_mask(
            dp,
            unit,
            (lut, unit.stride()),
            &mm,
            data_bits,
            prep,
            &layout,
            skips,
        ),
        None => crate::skip::plan_mask(dp, &mm, data_bits, prep, &layout, skips),
    };
    array.set_skipping(mask, counts, &prep.view);
    Ok(())
}
