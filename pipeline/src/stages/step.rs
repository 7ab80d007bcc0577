//! The one shape of a PE's cycle: every stage's per-cycle PE behaviour is
//! a named [`Step`], and the [`Clock`](crate::array::Clock) ticks nothing
//! else. A step holds what the controller broadcasts in the cycle (the
//! stage's bus: a sampling row's [`SampleBus`](super::sample::SampleBus),
//! a pass's [`PassBus`](super::passes::PassBus), the migration's owner
//! function) and shows the controller's [`Ctrl`], which the clock counts
//! the cycle under and the probes record. What it steps is one PE's own
//! state, the [`Links`] (its neighbours' port outputs of the last cycle)
//! and its own next port registers, so it is a clocked process: it cannot
//! reach another PE (the clock's rustdoc holds a `compile_fail` example
//! of a step that tries).
//!
//! The steps, by stage:
//!
//! - sample: [`RowStep`](super::sample::RowStep), with
//!   [`Hold`](super::sample::Hold) for the plan's and the memory's waits
//!   and [`Stall`](super::sample::Stall) for the scoreboard's;
//! - merge, split, fold: [`PassStep`](super::boundary::PassStep) of the
//!   stage's [`BoundaryPass`](super::boundary::BoundaryPass);
//! - migrate: [`LinkStep`](super::migrate::LinkStep);
//! - readout: [`StreamStep`](super::readout::StreamStep);
//! - drain, skip, the ray buffer's waits and the migration's tail:
//!   [`Idle`].

use crate::array::Links;
use crate::pe::{Pe, Ports, StepError};
use crate::probes::Ctrl;

/// One PE's behaviour in one cycle of a stage.
pub trait Step {
    /// What the controller shows in the cycle: its stage (the clock counts
    /// the cycle under it), slice and row, and a pass's bus (the probes
    /// record them).
    fn ctrl(&self) -> Ctrl;

    /// PE `pe` steps from its own state and `links`, driving its outputs
    /// into `out` (handed to it idle).
    fn step(&mut self, pe: &mut Pe, links: Links<'_>, out: &mut Ports) -> Result<(), StepError>;
}

/// A cycle in which no PE changes state or drives anything, shown as
/// `Ctrl`: the drain's waits for the datapaths' write-backs
/// ([`super::drain`]), a skipped slice's summary read, the ray buffer's
/// waits for its channel ([`super::raybuf`]) and the overlapped
/// migration's tail ([`super::migrate`]). Golden has no twin: it neither
/// pipelines, skips by the cycle nor waits for a memory
/// ([`golden::methods::render`] composites each sample as it takes it).
#[derive(Debug, Clone, Copy)]
pub struct Idle(pub Ctrl);

impl Step for Idle {
    fn ctrl(&self) -> Ctrl {
        self.0
    }

    #[inline]
    fn step(&mut self, _: &mut Pe, _: Links<'_>, _: &mut Ports) -> Result<(), StepError> {
        Ok(())
    }
}
