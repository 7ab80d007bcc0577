//! The array's stages, one module each. A stage is two halves: the PE's
//! step (a named [`Step`], which sees only the PE's state, the
//! [`Links`](crate::array::Links) and the broadcast the controller hands
//! it) and the controller's side, which plans the stage's cycles and ticks
//! the [`Clock`](crate::array::Clock) through them.
//!
//! - [`migrate`]: rays travel one link per cycle to the PE that samples
//!   them next.
//! - [`sample`]: one ray per PE per cycle through the [`crate::datapath`],
//!   rows in order; the voxel column right of a block comes over the port;
//!   rows wait for rays still in the datapath (stalls).
//! - [`drain`]: the samples in flight are written back before a stage that
//!   reads every accumulator.
//! - [`merge`], [`split`], [`fold`]: the region-boundary filters, each an
//!   x pass (edge rays over the ports) into a line buffer and a y pass out
//!   of it, one [`boundary::BoundaryPass`] each, clocked by
//!   [`boundary`] and scheduled by [`passes`].
//! - [`readout`]: each PE streams its rays to the host.
//! - [`raybuf`]: with the rays' buffer in external memory, the channel
//!   every row's rays cross, and the waits for it.
//!
//! Which stages run in which order is the frame's schedule, in
//! [`crate::schedule`].

pub mod boundary;
pub mod drain;
pub mod fold;
mod fold_capture;
pub mod merge;
mod merge_capture;
pub mod migrate;
pub mod passes;
pub mod raybuf;
pub mod readout;
pub mod sample;
pub mod split;
pub mod step;

pub use step::{Idle, Step};
