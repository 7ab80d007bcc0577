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
//! from the schedule's stages.

pub mod arch;
pub mod clock;
pub mod design;
pub mod dsp;
pub mod fmax;
pub mod inventory;
pub mod memory;
pub mod parts;
pub mod preint;
pub mod report;
pub mod shading;
pub mod shapes;
pub mod target;
pub mod throughput;
pub mod units;
pub mod voi;

pub use target::{Resources, Target};

/// The sample datapath's depth in clocks, from a ray slot's read to its
/// accumulators' write-back: [`PipelineConfig::datapath_latency`] when set,
/// else the depth [`inventory`]'s schedule derives for the configured
/// widths (the square root's bits set it apart from a fixed count).
///
/// [`PipelineConfig::datapath_latency`]: crate::config::PipelineConfig::datapath_latency
pub fn datapath_latency(cfg: &crate::config::PipelineConfig) -> u32 {
    if cfg.datapath_latency > 0 {
        return u32::from(cfg.datapath_latency);
    }
    inventory::schedule_depth(cfg).max(1)
}

/// [`datapath_latency`] of a datapath with the gradient and shading unit
/// (`shading`) and the volume-of-interest stage (`voi`): the configured
/// latency, or the depth of that schedule.
pub fn unit_latency(cfg: &crate::config::PipelineConfig, units: (bool, bool)) -> u32 {
    if cfg.datapath_latency > 0 {
        return u32::from(cfg.datapath_latency);
    }
    inventory::unit_schedule_depth(cfg, units).max(1)
}

/// [`datapath_latency`] of a datapath with the gradient and shading unit:
/// the configured latency, or the depth of the shaded schedule.
pub fn shaded_latency(cfg: &crate::config::PipelineConfig) -> u32 {
    if cfg.datapath_latency > 0 {
        return u32::from(cfg.datapath_latency);
    }
    inventory::shaded_schedule_depth(cfg).max(1)
}

/// [`datapath_latency`] of a datapath with the pre-integration unit
/// ([`crate::preint`], priced in [`preint`]): the configured latency, or
/// the depth of that schedule, where the unit takes the classification's
/// and the log table's place: from the sample, the table position
/// multiply, the address, the table read, two lerp levels and `tau len`
/// into the exp stage, and the colour dividers beside it, before the
/// compositing. The dividers' quotient bits set it: 29 clocks against 26
/// at the default widths (`p` and the exp stage finish where the plain
/// datapath's do, both waiting for the path length's square root).
pub fn preint_latency(cfg: &crate::config::PipelineConfig) -> u32 {
    if cfg.datapath_latency > 0 {
        return u32::from(cfg.datapath_latency);
    }
    inventory::preint_schedule_depth(cfg).max(1)
}
