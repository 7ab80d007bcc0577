//! Frame rate and voxel bandwidth, from a pipeline run and from the
//! worst-case bound.

use super::inventory::Geometry;
use crate::array::{Frame, StageCycles};
use crate::host::FramePlan;
use serde::Serialize;

/// What one pipeline run measured.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// The scene or file and view, for the report.
    pub label: String,
    /// The array it ran on.
    pub geometry: Geometry,
    /// Cycles per frame.
    pub cycles: u64,
    /// Cycles per stage.
    pub stages: StageCycles,
    /// Samples taken.
    pub samples: u64,
    /// `samples / P`.
    pub ideal_cycles: f64,
    /// `ideal_cycles / cycles`.
    pub utilization: f64,
    /// Slice-buffer reads over all PEs (the model's `mem_reads`).
    pub buffer_reads: u64,
    /// Ray grid (columns, rows) of the view's largest region: the rays the
    /// whole array held at once in this frame.
    pub largest_region: [usize; 2],
    /// Bytes the frame moved through the external ray buffer's channel,
    /// reads and writes (the model's `Frame::ray_buffer`; 0 on chip).
    pub ray_buffer_bytes: u64,
    /// The run's architecture, e.g. `blocks/on-chip` (`super::arch::label`).
    pub arch: String,
}

impl RunSummary {
    /// Summarises `frame` of `plan`, run with `cfg` on `geometry`.
    pub fn new(
        cfg: &crate::config::PipelineConfig,
        label: impl Into<String>,
        geometry: Geometry,
        (frame, plan): (&Frame, &FramePlan),
    ) -> RunSummary {
        RunSummary {
            label: label.into(),
            geometry,
            cycles: frame.cycles,
            stages: frame.stages,
            samples: frame.samples,
            ideal_cycles: frame.ideal_cycles,
            utilization: frame.utilization(),
            buffer_reads: frame.pes.iter().map(|p| p.mem_reads).sum(),
            largest_region: plan
                .regions
                .iter()
                .map(|r| r.grid.counts())
                .max_by_key(|c| c[0] * c[1])
                .unwrap_or([0, 0]),
            ray_buffer_bytes: frame
                .ray_buffer
                .map_or(0, |r| r.read_bytes + r.written_bytes),
            arch: super::arch::label(cfg),
        }
    }
}

/// Sampling cycles per frame in the worst view: every slice with the
/// most rays a PE can hold, `(2W + 1) (2 ny + 1)` (rays are at least half
/// a voxel apart, so a slice has at most `4 N^2` samples, split over `P`
/// blocks). Migration, merges and readout come on top; in the runs
/// measured they are a few percent.
pub fn bound_cycles(geo: &Geometry) -> u64 {
    geo.dims[2] as u64 * geo.sampled_per_slice()
}

/// Rates at a clock.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Rate {
    /// Cycles per frame.
    pub cycles: u64,
    /// Frames per second.
    pub fps: f64,
    /// External voxel bandwidth, bytes per second, whole array: every
    /// voxel loaded once per frame into the slice buffers.
    pub bandwidth: f64,
    /// The same per PE.
    pub bandwidth_per_pe: f64,
}

/// The rate of `cycles` per frame at `clock_hz` for `geo`, with voxels of
/// `voxel_bits`.
pub fn rate(geo: &Geometry, cycles: u64, clock_hz: f64, voxel_bits: u32) -> Rate {
    let fps = if cycles == 0 {
        0.0
    } else {
        clock_hz / cycles as f64
    };
    let bytes = voxel_bytes(geo, voxel_bits);
    Rate {
        cycles,
        fps,
        bandwidth: bytes * fps,
        bandwidth_per_pe: bytes * fps / f64::from(geo.pes.max(1)),
    }
}

/// Bytes of voxel data per frame, `nx ny nz` voxels of `voxel_bits`
/// packed.
pub fn voxel_bytes(geo: &Geometry, voxel_bits: u32) -> f64 {
    let [nx, ny, nz] = geo.dims;
    (nx * ny * nz) as f64 * f64::from(voxel_bits) / 8.0
}
