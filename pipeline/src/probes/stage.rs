//! The controller's stages, as `top.ctrl.stage` codes them.

/// The controller's stage, `top.ctrl.stage`. The codes are those the
/// waveforms have always carried, so raw traces compare across versions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Sampling a slice.
    Sample = 0,
    /// Rays migrating to their owners.
    Migrate = 1,
    /// The Bartlett merge at a region boundary.
    Merge = 2,
    /// Streaming the baseplane out.
    Readout = 3,
    /// A slice the controller skipped (its occupancy bits are all clear).
    Skip = 4,
    /// Front to back: the bilinear split at a region boundary.
    Split = 5,
    /// Front to back: the fold after the last region.
    Fold = 6,
    /// Waiting for the samples in flight in the datapath to be written
    /// back (before a merge, split, fold or the readout).
    Drain = 7,
    /// A row start held back because one of its rays is still in the
    /// datapath from the previous slice (read after write).
    Stall = 8,
    /// Waiting for the external ray buffer: a row's rays still arriving,
    /// a pass's traffic, or the write-backs before a drain completes.
    Memory = 9,
    /// A row start held back until the row's plan is written: the
    /// controller streams the slice's runs to the PEs' plan ports one a
    /// clock from the slice's start.
    Plan = 10,
}

impl Stage {
    /// Every stage, in code order.
    pub const ALL: [Stage; 11] = [
        Stage::Sample,
        Stage::Migrate,
        Stage::Merge,
        Stage::Readout,
        Stage::Skip,
        Stage::Split,
        Stage::Fold,
        Stage::Drain,
        Stage::Stall,
        Stage::Memory,
        Stage::Plan,
    ];

    /// The code on `top.ctrl.stage`.
    pub fn code(self) -> u64 {
        self as u64
    }

    /// The name viewers show.
    pub const fn name(self) -> &'static str {
        match self {
            Stage::Sample => "sample",
            Stage::Migrate => "migrate",
            Stage::Merge => "merge",
            Stage::Readout => "readout",
            Stage::Skip => "skip",
            Stage::Split => "split",
            Stage::Fold => "fold",
            Stage::Drain => "drain",
            Stage::Stall => "stall",
            Stage::Memory => "memory",
            Stage::Plan => "plan",
        }
    }
}
