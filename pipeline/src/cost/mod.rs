//! FPGA cost estimation of the PE array, grounded in synthesis.
//!
//! For a [`PipelineConfig`](crate::config::PipelineConfig), a volume and a
//! PE count, the estimator lists every unit of one PE at the configured
//! widths ([`inventory`]): multipliers (mapped to DSP48E1, MULT18X18D or
//! SB_MAC16 blocks as yosys decomposes them, [`dsp`]), adders, rounding and
//! saturation logic, registers and delay lines, and the memories (tables,
//! slice, compositing and line buffers, FIFOs, the occupancy memory) mapped
//! to LUT-RAM or block RAM ([`memory`]). [`units`] prices each unit per
//! family ([`Target`]); [`parts`] holds real parts' capacities;
//! [`throughput`] turns a pipeline run's cycle count (and the worst-case
//! bound) into frames per second and external voxel bandwidth; [`report`]
//! puts it together as JSON and a readable table; [`arch`] prices the
//! ownership mapping and the ray-buffer placement.
//!
//! The models are structural and their constants come from yosys 0.23:
//! `crate::rtl` emits the PE's units as small Verilog modules built from
//! the same [`shapes`], and `pipeline/tests/it/cost.rs` synthesizes them
//! (`synth_xilinx`, `synth_ice40 -dsp`) and checks the estimate: DSP and
//! block-RAM counts exactly, LUTs and flip-flops within 10% at the default
//! widths (25% at the narrow and wide ones). [`fmax`] predicts the clock
//! from the schedule's stages; [`latency`] gives the datapath's depth in
//! clocks from the same schedule.

pub mod arch;
pub mod clock;
pub mod design;
pub mod dsp;
pub mod fmax;
pub mod inventory;
pub mod latency;
pub mod memory;
pub mod parts;
pub mod preint;
pub mod readout;
pub mod report;
pub mod sample_stage;
pub mod shading;
pub mod shapes;
pub mod target;
pub mod throughput;
pub mod units;

pub use target::{Resources, Target};

pub use latency::{datapath_latency, preint_latency, sample_latency, shaded_latency, unit_latency};
