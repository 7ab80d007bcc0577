//! Bit-accurate, cycle-level model of ercube's 1D processing-element array
//! for ER-Perspective ray casting.
//!
//! The dataflow, module by module: [`host`] plans a frame from the golden
//! geometry (regions, rays, slices: one source of truth) and loads voxel
//! words; [`skip`] builds the controller's occupancy memory and plans which
//! samples a frame takes (golden's planner, one source of truth);
//! [`tables`] quantises the classification and opacity tables;
//! [`mapping`] says which PE owns which columns; [`mod@array`] clocks the [`pe`]s through migrate, sample, merge (front to
//! back: split and fold) and readout;
//! each sample runs the [`datapath`] (position, bilinear, classify,
//! correct, composite; [`preint`] for a pre-integrated frame), the
//! bit-exact mirror of `golden::sampling`. The
//! baseplane comes out as raw accumulator words and, scaled to float, goes
//! through the golden warp.
//!
//! [`probes`] declares the array's waveform signals, one table per scope;
//! [`stepper`] steps a frame one clock at a time from outside, reading them.
//!
//! [`fixed`] is the arithmetic every datapath register uses: declared
//! formats with `ap_fixed` quantisation and overflow semantics, exact
//! intermediates, event counters and bit packing. [`config`] holds the
//! run-time choice of every datapath width ([`config::PipelineConfig`]),
//! read from TOML and validated before a run.

#![deny(rustdoc::broken_intra_doc_links)]

pub mod array;
pub mod bound;
pub mod capacity;
pub mod config;
pub mod cosim;
pub mod cost;
pub mod datapath;
pub mod fixed;
pub mod host;
pub mod hw;
pub mod mapping;
pub mod pe;
pub mod preint;
pub mod probes;
pub mod rtl;
pub mod schedule;
pub mod shading;
pub mod skip;
pub mod stages;
pub mod stepper;
pub mod synth;
pub mod tables;
pub mod voi;

pub use array::{Frame, FrameRun, Resident, RunError, VoxelLoad, Voxels};
