//! The sampling stage's cycles on a PE, as the clock ticks them: a row's
//! sampling cycles ([`RowStep`]), the cycles a row waits for its plan or
//! the ray buffer ([`Hold`]) and those it waits for the scoreboard
//! ([`Stall`]).

use crate::array::Links;
use crate::datapath::Datapath;
use crate::pe::{Pe, Ports, StepError};
use crate::probes::{Ctrl, Stage};
use crate::stages::Step;

use super::SampleBus;

/// A sampling cycle of a row on a PE ([`Pe::sample_step`]): the cycle's
/// scheduled ray through the datapath, bit for bit golden's sample in
/// [`golden::sampling::sample_region`], and the edge voxels of the row on
/// `bus.next` driven on the ports.
pub struct RowStep<'a> {
    /// The datapath.
    pub dp: &'a Datapath,
    /// The cycle's broadcast.
    pub bus: SampleBus<'a>,
    /// Voxel columns of the volume.
    pub nx: usize,
}

impl Step for RowStep<'_> {
    fn ctrl(&self) -> Ctrl {
        Ctrl::at(Stage::Sample, self.bus.slice.z, self.bus.row)
    }

    #[inline]
    fn step(&mut self, pe: &mut Pe, links: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        pe.sample_step(self.dp, &self.bus, links, self.nx, out)
    }
}

/// A cycle in which a row waits for its plan (`Stage::Plan`) or for the
/// ray buffer (`Stage::Memory`) on a PE ([`Pe::hold_step`]): the edge
/// registers hold their values, nothing issues. Golden has no twin: it
/// samples a row when it reaches it ([`golden::sampling::sample_region`]).
pub struct Hold<'a> {
    /// The datapath.
    pub dp: &'a Datapath,
    /// The stage, slice and row shown.
    pub ctrl: Ctrl,
}

impl Step for Hold<'_> {
    fn ctrl(&self) -> Ctrl {
        self.ctrl
    }

    fn step(&mut self, pe: &mut Pe, _: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        pe.hold_step(self.dp, out);
        Ok(())
    }
}

/// A cycle in which row `row` of slice `z` waits for rays still in the
/// datapath (the scoreboard) on a PE ([`Pe::stall_step`]): a [`Hold`]
/// counted in the PE's `stalls`. Golden has no twin: it composites each
/// sample as it takes it ([`golden::sampling::sample_region`]).
pub struct Stall<'a> {
    /// The datapath.
    pub dp: &'a Datapath,
    /// The slice.
    pub z: usize,
    /// The row waiting, in the region's buffer.
    pub row: usize,
}

impl Step for Stall<'_> {
    fn ctrl(&self) -> Ctrl {
        Ctrl::at(Stage::Stall, self.z, self.row)
    }

    fn step(&mut self, pe: &mut Pe, _: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        pe.stall_step(self.dp, out);
        Ok(())
    }
}
