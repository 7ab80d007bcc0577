//! The external ray buffer (`ray_buffer = "external"`): the rays'
//! compositing buffer lives in DDR or HBM shared by the PEs, and each PE
//! keeps only a double row buffer on chip. One channel moves
//! `ray_buffer_bandwidth` bytes per cycle, reads and writes alike, in the
//! order the controller issues them:
//!
//! - a row's rays (those it samples, in every PE) are read up to
//!   `ray_buffer_rows - 1` rows ahead (when the row that many before it
//!   starts, its buffer being free then), and arrive `ray_buffer_latency`
//!   cycles after their read is issued plus their transfer time; a row
//!   waits for them (**memory** cycles, a stage of their own);
//! - a row's rays are written back once its last sample has, after the
//!   next row's read;
//! - a merge, split or fold reads its parents and writes its children
//!   through the channel while it runs, and the array waits for the rest;
//! - before a drain completes, every write has landed.
//!
//! Migration costs nothing here: a ray stays where it is in the shared
//! buffer and the PE that owns it next fetches it, so the controller
//! reassigns rays between PEs without a link cycle.
//!
//! Golden has no twin: where the buffer lives changes cycles, never bits
//! ([`golden::methods::render`] composites into its own memory).

use serde::Serialize;

use crate::array::{Array, RunError};
use crate::config::{Order, PipelineConfig, RayBuffer};
use crate::probes::{Ctrl, Stage};
use crate::stages::Idle;

/// What a frame moved through the external ray buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct RayBufferStats {
    /// Bytes read from the buffer.
    pub read_bytes: u64,
    /// Bytes written to it.
    pub written_bytes: u64,
    /// Bytes per ray (its accumulator words, front to back with the
    /// inherited state and the flag), rounded up to whole bytes.
    pub ray_bytes: u64,
}

/// The controller's view of the external ray buffer's channel: the
/// cycles it is busy, as disjoint intervals in time order. A transfer
/// takes the first free cycles from its issue on (a burst may fill a gap
/// and continue after the next busy stretch), so requests issued early
/// (reads ahead) are served before later ones (write-backs) whatever the
/// order the controller plans them in.
#[derive(Debug, Clone)]
pub(crate) struct Channel {
    bandwidth: u64,
    latency: u64,
    /// Busy intervals `[start, end)`, sorted and disjoint; those before
    /// the latest read's issue are dropped (no later request starts
    /// earlier).
    busy: Vec<(u64, u64)>,
    pub(crate) stats: RayBufferStats,
}

/// Bytes of one ray in the buffer under `cfg`.
pub fn ray_bytes(cfg: &PipelineConfig) -> u64 {
    let acc = 3 * u64::from(cfg.accum_color.bits()) + u64::from(cfg.accum_alpha.bits());
    let bits = match cfg.order {
        Order::BackToFront => acc,
        Order::FrontToBack => 2 * acc + 1,
    };
    bits.div_ceil(8)
}

impl Channel {
    /// The channel of `cfg`, `None` with the buffer on chip.
    pub(crate) fn of(cfg: &PipelineConfig) -> Option<Channel> {
        (cfg.ray_buffer == RayBuffer::External).then(|| Channel {
            bandwidth: u64::from(cfg.ray_buffer_bandwidth),
            latency: u64::from(cfg.ray_buffer_latency),
            busy: Vec::new(),
            stats: RayBufferStats {
                ray_bytes: ray_bytes(cfg),
                ..RayBufferStats::default()
            },
        })
    }

    /// Books `bytes` from cycle `at` on; returns the cycle after the last.
    fn book(&mut self, at: u64, bytes: u64) -> u64 {
        let mut left = bytes.div_ceil(self.bandwidth);
        let mut t = at;
        let mut i = self.busy.partition_point(|&(_, e)| e <= t);
        let mut pieces = Vec::new();
        while left > 0 {
            let gap_end = self.busy.get(i).map_or(u64::MAX, |iv| iv.0);
            if t < gap_end {
                let take = left.min(gap_end - t);
                pieces.push((t, t + take));
                left -= take;
                t += take;
            }
            if left > 0 {
                t = t.max(self.busy[i].1);
                i += 1;
            }
        }
        for p in pieces {
            let at = self.busy.partition_point(|&(s, _)| s < p.0);
            self.busy.insert(at, p);
        }
        // Coalesce touching intervals.
        let mut merged: Vec<(u64, u64)> = Vec::with_capacity(self.busy.len());
        for &(s, e) in &self.busy {
            match merged.last_mut() {
                Some(last) if last.1 == s => last.1 = e,
                _ => merged.push((s, e)),
            }
        }
        self.busy = merged;
        t
    }

    /// Issues a read of `rays` at cycle `at`; returns the cycle its last
    /// word has arrived by.
    pub(crate) fn read(&mut self, at: u64, rays: u64) -> u64 {
        let cut = self.busy.partition_point(|&(_, e)| e <= at);
        self.busy.drain(..cut);
        let bytes = rays * self.stats.ray_bytes;
        self.stats.read_bytes += bytes;
        self.book(at, bytes) + self.latency
    }

    /// Issues the write-back of `rays` at cycle `at`.
    pub(crate) fn write(&mut self, at: u64, rays: u64) {
        let bytes = rays * self.stats.ray_bytes;
        self.stats.written_bytes += bytes;
        self.book(at, bytes);
    }

    /// The cycle every issued transfer has completed.
    pub(crate) fn idle_at(&self) -> u64 {
        self.busy.last().map_or(0, |iv| iv.1)
    }

    /// A pass from cycle `start` that read `reads` rays and wrote `writes`:
    /// both through the channel, from `start` on.
    pub(crate) fn pass(&mut self, start: u64, reads: u64, writes: u64) {
        let (r, w) = (reads * self.stats.ray_bytes, writes * self.stats.ray_bytes);
        self.stats.read_bytes += r;
        self.stats.written_bytes += w;
        let done = self.book(start, r) + self.latency;
        self.book(done, w);
    }
}

impl Array {
    /// Ticks memory cycles until the external buffer's channel has
    /// completed every transfer (nothing with the buffer on chip).
    pub(crate) fn wait_for_ray_buffer(&mut self) -> Result<(), RunError> {
        let Some(ch) = self.channel.as_mut() else {
            return Ok(());
        };
        let until = ch.idle_at();
        while self.clock.now() < until {
            self.clock.tick(&mut Idle(Ctrl::at(Stage::Memory, 0, 0)))?;
        }
        Ok(())
    }

    /// After a pass that began at cycle `start` over `reads` parent rays
    /// and `writes` child rays: their traffic, and the wait for it.
    pub(crate) fn ray_buffer_pass(
        &mut self,
        start: u64,
        reads: u64,
        writes: u64,
    ) -> Result<(), RunError> {
        if let Some(ch) = self.channel.as_mut() {
            ch.pass(start, reads, writes);
        }
        self.wait_for_ray_buffer()
    }
}
