//! The co-simulation of the model against the emitted Verilog: the
//! datapath of every PE, every cycle of a real frame, and the readout.
//!
//! The model runs the frame with a [`capture`] of every sample each PE's
//! datapath issues; [`replay`] writes each PE's issue stream as a file and
//! a generated top that instantiates the pipelined datapath
//! ([`crate::hw::pipeline_rtl`]) once per PE and replays the streams cycle
//! by cycle (bubbles included, the voxel taps served one clock after the
//! tap column, as from a block RAM), checking every output of every PE on
//! every cycle against the model's write-backs; [`build`] builds it with
//! Verilator or Icarus, cached by a hash of its text. [`vectors`] writes the
//! same capture as per-port `$readmemh` files with a plain testbench.
//!
//! [`readout`] is the second stage: the emitted readout (each PE's
//! compositing buffer, column map and readout state machine, and the array
//! of them, [`crate::hw::readout_rtl`]) loaded with the buffers as the
//! model held them at `BeginReadout`, compared on every readout cycle and
//! then on the host's baseplane, word for word.
//!
//! The PE's other control, the array's links and the controller are not
//! emitted yet: the replay stands in for them, feeding each datapath what
//! the model's PE fed its own.

pub mod build;
pub mod capture;
pub mod fold;
pub mod merge;
pub mod outcome;
pub mod pass;
pub mod pe_sample;
pub mod pe_vectors;
pub mod readout;
pub mod replay;
pub mod split;
pub mod vectors;
