//! A frame's results: its cycles per stage, the [`Frame`] the array reads
//! out, and why a frame fails ([`RunError`]).

use golden::warp::Baseplane;

use crate::config::Order;
use crate::fixed::{Format, QuantStats};
use crate::host::PlanError;
use crate::pe::{PeCounters, StepError};
use crate::probes::Stage;
use crate::skip::SkipCounts;
use crate::stages::raybuf::RayBufferStats;

#[cfg(doc)]
use super::FrameRun;
use super::VoxelLoad;

/// Cycles spent in each stage of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct StageCycles {
    /// Ray migration before slices.
    pub migrate: u64,
    /// Sampling.
    pub sample: u64,
    /// Bartlett merges.
    pub merge: u64,
    /// Baseplane readout.
    pub readout: u64,
    /// Front to back: bilinear splits (left out of the JSON when zero, so
    /// a back-to-front frame reports the four stages it has).
    #[serde(skip_serializing_if = "is_zero")]
    pub split: u64,
    /// Front to back: the fold (merges of differences and adds).
    #[serde(skip_serializing_if = "is_zero")]
    pub fold: u64,
    /// Slices skipped whole by the controller, one cycle each (left out of
    /// the JSON when zero).
    #[serde(skip_serializing_if = "is_zero")]
    pub skip: u64,
    /// Waiting for the datapath to write back its samples in flight
    /// before a merge, split, fold or the readout.
    pub drain: u64,
    /// Row starts held back for a ray still in the datapath from the
    /// previous slice.
    pub stall: u64,
    /// Waiting for the external ray buffer (left out of the JSON when
    /// zero, as it is with the buffer on chip).
    #[serde(skip_serializing_if = "is_zero")]
    pub memory: u64,
    /// Row starts held back until the row's plan is written (the
    /// controller's runs reach the PEs' plan ports one a clock; left out
    /// of the JSON when zero).
    #[serde(skip_serializing_if = "is_zero")]
    pub plan: u64,
}

impl StageCycles {
    /// Counts `n` cycles of `stage`.
    pub fn add(&mut self, stage: Stage, n: u64) {
        let c = match stage {
            Stage::Sample => &mut self.sample,
            Stage::Migrate => &mut self.migrate,
            Stage::Merge => &mut self.merge,
            Stage::Readout => &mut self.readout,
            Stage::Skip => &mut self.skip,
            Stage::Split => &mut self.split,
            Stage::Fold => &mut self.fold,
            Stage::Drain => &mut self.drain,
            Stage::Stall => &mut self.stall,
            Stage::Memory => &mut self.memory,
            Stage::Plan => &mut self.plan,
        };
        *c += n;
    }

    /// Every stage's cycles.
    pub fn total(&self) -> u64 {
        self.migrate
            + self.sample
            + self.merge
            + self.readout
            + self.split
            + self.fold
            + self.skip
            + self.drain
            + self.stall
            + self.memory
            + self.plan
    }
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

/// A frame's results.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The baseplane in float (accumulator words scaled), for the warp.
    pub baseplane: Baseplane,
    /// The baseplane's raw words, row-major, R G B A, in
    /// [`Frame::raw_format`].
    pub raw: Vec<[i64; 4]>,
    /// Formats of the raw words (colour, opacity): the accumulators back to
    /// front; front to back the fold's `merge` words (the accumulators when
    /// there is one region and so no fold).
    pub raw_format: [Format; 2],
    /// The compositing order the frame ran in.
    pub order: Order,
    /// The units beside the plain sample the frame's datapath carried.
    pub units: crate::hw::compose::Units,
    /// Cycles per frame.
    pub cycles: u64,
    /// Cycles per stage.
    pub stages: StageCycles,
    /// Samples taken in all.
    pub samples: u64,
    /// Samples per slice, front (slice 0) to back.
    pub samples_per_slice: Vec<u64>,
    /// `samples / P`, the cycles of a perfectly busy array.
    pub ideal_cycles: f64,
    /// Per-PE counters.
    pub pes: Vec<PeCounters>,
    /// Merges performed.
    pub merges: u64,
    /// Quantisation events over the whole datapath.
    pub quant: QuantStats,
    /// Front to back: samples not taken because their ray was terminated.
    pub terminated_samples: u64,
    /// Sampling cycles saved within sampled slices by termination and by
    /// the rows' runs (empty space, clipping), against the same slices with
    /// every active ray sampled (rows as long as the busiest PE's active
    /// rays, and each slice's prologue). Skipped slices and regions save
    /// more; compare with a run without skipping for the total.
    pub cycles_saved: u64,
    /// What the controller skipped.
    pub skipped: SkipCounts,
    /// With the rays' buffer in external memory, what crossed its channel.
    pub ray_buffer: Option<RayBufferStats>,
    /// What the host loaded into the PE memories before the frame (not
    /// clocked: see [`FrameRun::resident`]).
    pub voxel_load: VoxelLoad,
    /// The link FIFOs' probe: the most rows any PE's link FIFO held and
    /// the cycles the PEs' feeds waited for room in a full one. Measured
    /// where the links step (clocked migrations and the overlapped
    /// migration); the untraced migration between slices works out the
    /// same departures from its queues without stepping a FIFO and adds
    /// nothing. Not a stats field.
    pub link_fifo: LinkFifoProbe,
    /// Per PE, the most its ray memories held at once
    /// ([`crate::pe::Occupancy`]: columns, rows, children, line-buffer
    /// row, kept finals), to set beside their declared depths. Not a
    /// stats field.
    pub occupancy: Vec<crate::pe::Occupancy>,
}

/// What a frame's link FIFOs held ([`Frame::link_fifo`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinkFifoProbe {
    /// The most rows one link FIFO held.
    pub peak: u64,
    /// Cycles, summed over PEs and sides, in which a PE's feed had a row
    /// and its FIFO was full (its front waiting for a write-back).
    pub feed_stalls: u64,
}

impl Frame {
    /// `ideal_cycles / cycles`.
    pub fn utilization(&self) -> f64 {
        if self.cycles == 0 {
            0.0
        } else {
            self.ideal_cycles / self.cycles as f64
        }
    }
}

/// Why a frame failed. The wrapped errors are transparent: their text
/// and cause are the frame's, so a chain printer states each once.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Planning failed.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A PE's clock step failed.
    #[error(transparent)]
    Step(#[from] StepError),
    /// The tables could not be built.
    #[error(transparent)]
    Fixed(#[from] crate::fixed::FxError),
    /// The configuration does not fit the volume.
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    /// Writing the waveform failed.
    #[error(transparent)]
    Waves(#[from] waves::WavesError),
    /// The controller could not schedule a stage (a model bug).
    #[error("{0}")]
    Schedule(String),
    /// The frame cannot be shaded as asked.
    #[error("{0}")]
    Shade(crate::shading::ShadeError),
    /// The frame's volume of interest cannot be loaded.
    #[error("{0}")]
    Voi(crate::voi::VoiError),
    /// The frame cannot be pre-integrated as asked.
    #[error("{0}")]
    Preint(#[from] crate::preint::PreintError),
    /// The view needs deeper ray memories than the chip declares.
    #[error(transparent)]
    Depths(#[from] crate::capacity::TooDeep),
}

#[cfg(test)]
mod run_error_tests {
    use super::RunError;
    use std::error::Error as _;

    #[test]
    fn a_wrapped_error_is_stated_once_in_the_chain() {
        let e = RunError::from(waves::WavesError::Io {
            op: "write trace",
            path: "t.vcd".into(),
            source: std::io::Error::other("No space left on device"),
        });
        let mut chain = e.to_string();
        let mut cause = e.source();
        while let Some(c) = cause {
            chain = format!("{chain}: {c}");
            cause = c.source();
        }
        assert_eq!(chain, "cannot write trace t.vcd: No space left on device");
    }
}
