//! The architecture fields of the config: which PE owns which voxel
//! columns and rays while the array samples ([`Mapping`]), and where the
//! rays' compositing buffer lives ([`RayBuffer`]).

use serde::{Deserialize, Serialize};

/// Which PE owns voxel column `x` (and so samples the rays whose base
/// column is `x`) while the array samples a slice.
///
/// Every mapping keeps the links neighbour-only. The merges, splits and
/// folds run on the column blocks in every mapping (their edge rays are
/// one link away only there): before a pass the rays migrate to their
/// block owners, after it back, and those migrations are counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mapping {
    /// Column blocks: PE `k` owns columns `k W .. (k + 1) W`,
    /// `W = ceil(nx / P)`; a ray changes PE only at block edges. The
    /// model's original mapping, bit and cycle for bit and cycle.
    #[default]
    Blocks,
    /// Cube-4's interleave: column `x` on PE `x mod P`. A ray hops one
    /// link (around the ring) at every column it crosses.
    Interleave,
    /// Blocks of `cyclic_width` columns dealt round-robin: column `x` on
    /// PE `(x / cyclic_width) mod P`. Narrower than `W`, so the occupied
    /// columns of a row spread over every PE and skipped work shortens
    /// every PE's row alike; wider than 1, so rays hop `1 / cyclic_width`
    /// as often as under the interleave.
    Cyclic,
}

impl Mapping {
    /// The name in TOML and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Mapping::Blocks => "blocks",
            Mapping::Interleave => "interleave",
            Mapping::Cyclic => "cyclic",
        }
    }

    /// Every mapping, in the order reports list them.
    pub const ALL: [Mapping; 3] = [Mapping::Blocks, Mapping::Interleave, Mapping::Cyclic];
}

/// When the rays whose owner changes between slices cross the links.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Migration {
    /// A stage of its own before each slice: the array samples only once
    /// every ray is home (the model's original schedule).
    #[default]
    BetweenSlices,
    /// While the slice samples: the links move rays row by row in the
    /// same cycles as the datapath, and a row waits (stall cycles) only
    /// for a ray of its own still on a link. The compositing buffer takes
    /// a link port beside the datapath's. Merges, splits and folds still
    /// wait for every ray.
    Overlapped,
}

impl Migration {
    /// The name in TOML and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Migration::BetweenSlices => "between-slices",
            Migration::Overlapped => "overlapped",
        }
    }
}

/// Where the compositing buffer of the rays lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RayBuffer {
    /// In each PE's block RAM, `(2W + 1)(2 ny + 1)` rays per PE (the
    /// model's original placement).
    #[default]
    OnChip,
    /// In external memory (DDR or HBM) shared by the PEs, streamed a row at
    /// a time through an on-chip row buffer: the controller fetches a row's
    /// rays while the row before samples, and a row waits (stall cycles)
    /// until its rays are in and the rays of the row before it are written
    /// back, at `ray_buffer_bandwidth` bytes per cycle after
    /// `ray_buffer_latency` cycles.
    External,
}

impl RayBuffer {
    /// The name in TOML and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            RayBuffer::OnChip => "on-chip",
            RayBuffer::External => "external",
        }
    }
}
