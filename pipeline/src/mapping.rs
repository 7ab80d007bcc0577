//! Which PE owns which voxel columns ([`ColumnMap`]), and how a migrating
//! ray finds its way there ([`Route`]).
//!
//! The array samples under the configured [`Mapping`]; merges, splits
//! and folds always run on column blocks, where a pass's edge rays are one
//! link away (see [`crate::config::Mapping`]). A PE's memory holds the
//! columns it owns and, under a round-robin mapping, an apron around each
//! of its blocks (one column left, two right: the scalar's right tap and
//! the gradient's `x - 1` and `x + 2` taps), written by the host with the
//! volume, so a sample reads every voxel from its own PE's memory. Under
//! column blocks the taps beyond the block cross the ports instead
//! ([`crate::stages::sample`]), as they always have.
//!
//! Golden has no twin: ownership is how the array distributes
//! [`golden::sampling::slice_rays`]' rays, not what they compute.

use crate::config::{Mapping, PipelineConfig};

/// Columns of the apron left of each round-robin block.
pub const APRON_LEFT: usize = 1;
/// Columns of the apron right of each round-robin block.
pub const APRON_RIGHT: usize = 2;

/// The owner of every voxel column of an `nx`-wide slice over `pes` PEs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColumnMap {
    /// The mapping.
    pub mapping: Mapping,
    /// Columns per block: `ceil(nx / P)` for column blocks, 1 for the
    /// interleave, `cyclic_width` for the cyclic mapping.
    pub width: usize,
    /// PEs.
    pub pes: usize,
    /// Voxel columns.
    pub nx: usize,
}

impl ColumnMap {
    /// The sampling map of `cfg` for `nx` columns.
    pub fn of(cfg: &PipelineConfig, nx: usize) -> ColumnMap {
        let pes = usize::from(cfg.pes);
        let width = match cfg.mapping {
            Mapping::Blocks => nx.div_ceil(pes).max(1),
            Mapping::Interleave => 1,
            Mapping::Cyclic => usize::from(cfg.cyclic_width),
        };
        ColumnMap {
            mapping: cfg.mapping,
            width,
            pes,
            nx,
        }
    }

    /// The column-block map the passes run on.
    pub fn blocks(pes: usize, nx: usize) -> ColumnMap {
        ColumnMap {
            mapping: Mapping::Blocks,
            width: nx.div_ceil(pes).max(1),
            pes,
            nx,
        }
    }

    /// Whether blocks are dealt round-robin (so rays wrap around the ring
    /// and PEs hold aprons).
    pub fn round_robin(&self) -> bool {
        self.mapping != Mapping::Blocks && self.pes > 1
    }

    /// The PE owning column `c` (`c < nx`).
    #[inline]
    pub fn owner(&self, c: usize) -> usize {
        if self.round_robin() {
            (c / self.width) % self.pes
        } else {
            (c / self.width).min(self.pes - 1)
        }
    }

    /// The columns PE `k` owns, ascending.
    pub fn owned(&self, k: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.nx).filter(move |&c| self.owner(c) == k)
    }

    /// The columns PE `k`'s memory holds, ascending: its own and, under a
    /// round-robin mapping, each block's apron.
    pub fn held(&self, k: usize) -> Vec<usize> {
        if !self.round_robin() {
            return self.owned(k).collect();
        }
        let mut held = vec![false; self.nx];
        for c in self.owned(k) {
            let lo = c.saturating_sub(APRON_LEFT);
            let hi = (c + APRON_RIGHT).min(self.nx - 1);
            held[lo..=hi].iter_mut().for_each(|h| *h = true);
        }
        (0..self.nx).filter(|&c| held[c]).collect()
    }

    /// How a migrating ray travels: along a line for column blocks, around
    /// the ring otherwise.
    pub fn route(&self) -> Route {
        if self.round_robin() {
            Route::Ring(self.pes)
        } else {
            Route::Line
        }
    }
}

/// Which way a ray leaves a PE for its owner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// PEs in a line: left to a lower index, right to a higher.
    Line,
    /// `P` PEs in a ring (PE `P - 1`'s right port drives PE 0's left): the
    /// shorter way round, rightwards on a tie.
    Ring(usize),
}

impl Route {
    /// True when a ray at PE `k` owned by PE `dest != k` goes right.
    #[inline]
    pub fn rightwards(self, k: usize, dest: usize) -> bool {
        match self {
            Route::Line => dest > k,
            Route::Ring(p) => (dest + p - k) % p <= p / 2,
        }
    }

    /// The PE one link from PE `k`, rightwards or leftwards (around a ring
    /// the ends are neighbours).
    #[inline]
    pub fn next(self, k: usize, right: bool) -> usize {
        match (self, right) {
            (Route::Line, false) => k - 1,
            (Route::Line, true) => k + 1,
            (Route::Ring(p), false) => (k + p - 1) % p,
            (Route::Ring(p), true) => (k + 1) % p,
        }
    }
}
