//! How a frame loads its units' per-frame constants (a light, a region,
//! a table): each unit's golden input implements [`FrameUnit`] in the
//! unit's own model file and fills its slot of
//! [`FrameUnits`](crate::hw::compose::FrameUnits), which the datapath
//! carries ([`Datapath::with_units`](super::Datapath::with_units)). The
//! array loads any of them through one entry point
//! ([`Array::set_units`](crate::array::Array::set_units),
//! [`FrameRun::unit`](crate::FrameRun::unit)), so a unit's loader lives
//! beside its model and nowhere else.

use golden::geometry::View;

use super::Datapath;
use crate::array::RunError;
use crate::config::PipelineConfig;
use crate::fixed::QuantStats;
use crate::hw::compose::{FrameUnits, Units};
use crate::mapping::ColumnMap;
use crate::tables::Tables;

/// What a unit's per-frame constants are built for: the frame's datapath
/// (its configuration and classification tables), view, data width, the
/// PEs' column map and whether clip planes cut the frame.
#[derive(Debug, Clone, Copy)]
pub struct UnitFrame<'a> {
    /// The datapath the units join (configuration and tables).
    pub dp: &'a Datapath,
    /// The frame's view.
    pub view: &'a View,
    /// Bits of the volume's scalars (8, 12 or 16).
    pub data_bits: u32,
    /// Which PE samples which voxel columns.
    pub map: ColumnMap,
    /// The frame is clipped by planes.
    pub clipped: bool,
}

/// What loading a unit's constants gives: nothing, or why the frame
/// cannot take the unit.
pub type Loaded = Result<(), RunError>;

/// A unit's per-frame input (golden's description of a light, a region,
/// a table), which the host quantises into the unit's constants.
pub trait FrameUnit {
    /// Builds the unit's constants for `frame` into its slot of `units`,
    /// counting the host's roundings into `st`; refuses a frame the unit
    /// does not model in one line.
    fn load(&self, frame: &UnitFrame, units: &mut FrameUnits, st: &mut QuantStats) -> Loaded;
}

impl UnitFrame<'_> {
    /// Loads `inputs` into `loaded` in turn, then refuses units the
    /// composed sample does not combine
    /// ([`FrameUnits::check`](crate::hw::compose::FrameUnits::check)).
    pub fn load(
        &self,
        inputs: &[&dyn FrameUnit],
        loaded: &mut FrameUnits,
        st: &mut QuantStats,
    ) -> Result<(), RunError> {
        for unit in inputs {
            unit.load(self, loaded, st)?;
        }
        Ok(loaded.check()?)
    }
}

/// The units `inputs` load into a frame of `view` (`data_bits`-bit data,
/// classified by `lut`, clipped by planes when `clipped`) under `cfg`, as
/// [`Array::set_units`](crate::array::Array::set_units) loads them: for a
/// caller that builds the composed sample before the frame runs.
pub fn units_for(
    cfg: &PipelineConfig,
    lut: &golden::tf::Lut,
    view: &View,
    data_bits: u32,
    clipped: bool,
    inputs: &[&dyn FrameUnit],
) -> Result<Units, RunError> {
    let dp = Datapath::new(*cfg, Tables::new(cfg, lut)?);
    let frame = UnitFrame {
        dp: &dp,
        view,
        data_bits,
        map: ColumnMap::of(cfg, view.dims[0]),
        clipped,
    };
    let mut loaded = FrameUnits::default();
    frame.load(inputs, &mut loaded, &mut QuantStats::default())?;
    Ok(loaded.units())
}
