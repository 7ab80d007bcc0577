//! One processing element's state: its voxel memory (a block of columns
//! of every slice), the compositing buffer of the rays it holds, the
//! migration FIFOs, the line buffer and pass registers of the merge, split
//! and fold, its edge register, its port types and its counters; the
//! memories and FIFOs declared with their depths in [`Pe::declaration`]
//! (`state.rs`), which the cost model charges.
//!
//! The controller reaches a PE only through the clock: it broadcasts
//! ([`Broadcast`], `broadcast.rs`) and reads the report lines
//! ([`PeReport`]). What a PE does in a cycle lives with its stage, in
//! [`crate::stages`]: each step receives only this state, the
//! [`Links`](crate::array::Links) (its neighbours' port outputs of the
//! previous cycle) and the controller's broadcast, and writes what it
//! drives into its own port registers (which the clock hands it idle).

mod broadcast;
mod occupancy;
mod state;
#[cfg(test)]
mod state_tests;

pub use broadcast::{Broadcast, Command, EdgeRead, OwnerFn};
pub use occupancy::Occupancy;

use std::collections::VecDeque;

use crate::datapath::{Acc, SampleTrace};
use crate::fixed::{FxError, QuantStats};
use crate::mapping::ColumnMap;
use crate::stages::migrate::LinkQueue;
use crate::stages::passes::PassState;

/// The link FIFOs' depth of a PE built without a configuration's
/// (`link_fifo_depth`'s default).
const DEFAULT_LINK_FIFO_DEPTH: usize = 2;

/// A PE's voxel memory as the model stores it: the voxel words, or for
/// 8-bit data the data bytes beside the 256 words they quantise to (the
/// same words on every read, in half the simulator's memory; the chip's
/// memory is `voxel` bits wide either way, as `crate::cost` sizes it).
#[derive(Debug, Clone)]
pub enum VoxelMem {
    /// Voxel words.
    Words(Vec<u16>),
    /// Data bytes and the word each byte value quantises to.
    Codes {
        /// The data bytes.
        codes: Vec<u8>,
        /// `voxel_word` of every byte value.
        words: Box<[u16; 256]>,
    },
}

impl VoxelMem {
    /// The word at index `i`.
    #[inline]
    pub fn get(&self, i: usize) -> u16 {
        match self {
            VoxelMem::Words(w) => w[i],
            VoxelMem::Codes { codes, words } => words[usize::from(codes[i])],
        }
    }

    /// Words held.
    pub fn len(&self) -> usize {
        match self {
            VoxelMem::Words(w) => w.len(),
            VoxelMem::Codes { codes, .. } => codes.len(),
        }
    }

    /// Whether it holds no word.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The local index of a column a PE's memory does not hold.
const ABSENT: u32 = u32::MAX;

/// A column of rays (one ray index `mx`, every row of the region).
#[derive(Debug, Clone, PartialEq)]
pub struct RayColumn {
    /// Ray index along x.
    pub mx: i64,
    /// Accumulators of rows `lo_y ..= hi_y` of the region.
    pub acc: Vec<Acc>,
    /// Front to back, per row: what the ray inherited at the split and its
    /// termination flag; empty back to front.
    pub ftb: Vec<FtbState>,
    /// Per row, the first cycle in which the row's accumulators may be
    /// read again: the sample in flight in the datapath writes them back
    /// then (the scoreboard; 0 once written back).
    pub land: Vec<u64>,
    /// In a pre-integrated frame, per row, the ray's last recorded sample
    /// word (raw `sample`): the other end of its next step
    /// ([`crate::preint`]). Empty otherwise.
    pub prev: Vec<i64>,
}

impl RayColumn {
    /// An empty (transparent, live) column of `rows` rays, with the
    /// front-to-back state when `ftb`.
    pub fn empty(mx: i64, rows: usize, ftb: bool) -> RayColumn {
        RayColumn::empty_with(mx, rows, ftb, false)
    }

    /// [`RayColumn::empty`], with the previous-sample registers of a
    /// pre-integrated frame when `preint`.
    pub fn empty_with(mx: i64, rows: usize, ftb: bool, preint: bool) -> RayColumn {
        RayColumn {
            prev: if preint { vec![0; rows] } else { Vec::new() },
            mx,
            acc: vec![Acc::default(); rows],
            ftb: if ftb {
                vec![FtbState::default(); rows]
            } else {
                Vec::new()
            },
            land: vec![0; rows],
        }
    }
}

/// What a front-to-back ray carries beside its accumulators, in the
/// compositing buffer and over the links: the state it inherited at its
/// region's split (the fold subtracts it from the ray's result) and its
/// termination flag (set once its opacity word reaches the threshold, read
/// to skip it). One more accumulator word set and one bit per ray: the
/// front-to-back compositing buffer is twice as wide.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FtbState {
    /// Accumulators inherited at the split (zero in region 0).
    pub inh: Acc,
    /// Early ray termination flag.
    pub done: bool,
}

/// A ray in transit over a link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RayMove {
    /// Ray index along x.
    pub mx: i64,
    /// Row within the region.
    pub row: u32,
    /// Rows in the region (so the receiver knows when a column is whole).
    pub rows: u32,
    /// The ray's accumulators.
    pub acc: Acc,
    /// Front to back: its inherited state and flag, on a link as wide as
    /// both (so a move still takes one cycle).
    pub ftb: Option<FtbState>,
    /// In a pre-integrated frame, its previous-sample word (raw `sample`),
    /// on a link one `sample` word wider; 0 otherwise (a column without
    /// registers reads 0 too, so a zero word need not allocate them).
    pub prev: i64,
}

/// What a PE drives towards one neighbour in a cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Port {
    /// Voxels of the PE's edge column on this side at rows `y0, y0 + 1`
    /// of the row sampled next cycle: its first column to the left
    /// neighbour (the scalar's right taps); while the array shades, its
    /// last column to the right one (the gradient's `x0 - 1` taps). In a
    /// merge, the edge ray's accumulators travel instead (see
    /// [`Port::edge_acc`]).
    pub edge: [u16; 2],
    /// To the left neighbour while the array shades: the gradient's other
    /// words of this PE's first two columns ([`crate::shading::Halo`]).
    pub halo: crate::shading::Halo,
    /// Whether `edge` holds voxels for a row still to be sampled (the
    /// neighbour reads them next cycle); only the waveforms read it.
    pub edge_valid: bool,
    /// Edge ray of a merge row.
    pub edge_acc: Acc,
    /// The index `mx` of the edge ray on `edge_acc`, `None` when no edge
    /// ray is driven: the valid of the parent crossing the link (the
    /// split and the fold check the index; the back-to-front merge finds
    /// its parents by position and sets it for the waveforms only).
    pub edge_mx: Option<i64>,
    /// A ray migrating to the neighbour.
    pub ray: Option<RayMove>,
}

/// A ray word a PE streams to the host during the readout: its index, row
/// and accumulators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Readout {
    /// Ray index along x.
    pub mx: i64,
    /// Row within region 0.
    pub row: u32,
    /// The ray's final words.
    pub acc: Acc,
}

/// Both ports of a PE.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Ports {
    /// Towards PE `k - 1`.
    pub left: Port,
    /// Towards PE `k + 1`.
    pub right: Port,
    /// Towards the host (the readout bus).
    pub host: Option<Readout>,
}

/// Per-PE event counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct PeCounters {
    /// Samples taken.
    pub samples: u64,
    /// Sampling cycles with a sample.
    pub busy: u64,
    /// Sampling cycles without one (load imbalance).
    pub idle: u64,
    /// Voxel words read from this PE's memory (samples and edge drives).
    pub mem_reads: u64,
    /// Voxel words received from a neighbour and used: the scalar's right
    /// taps and, shading, the gradient's taps beyond the block.
    pub edge_voxels: u64,
    /// Rays sent to a neighbour.
    pub rays_sent: u64,
    /// Rays received from a neighbour.
    pub rays_received: u64,
    /// Merge outputs computed (child rays; front to back, the fold's).
    pub merge_outputs: u64,
    /// Front to back: split outputs computed (child rays).
    pub split_outputs: u64,
    /// Front to back: samples not taken because the ray was terminated.
    pub terminated: u64,
    /// Cycles the array stalled at a row start because one of the row's
    /// rays was still in this or another PE's datapath (a read after
    /// write on its accumulators).
    pub stalls: u64,
    /// Migration cycles in which the ray next in this PE's FIFO could not
    /// leave because its last sample was still in the datapath.
    pub waits: u64,
    /// Ray-cycles spent queued behind another ray for a busy link: after
    /// each migration cycle's sends, the rays still in the two FIFOs.
    pub link_queue: u64,
    /// The most rays (one per column and row) this PE held at the start of
    /// a slice's sampling: what its compositing buffer must hold.
    pub rays_held_peak: u64,
}

/// One processing element: its parameters (which PE, which columns), its
/// state (registers, memories and FIFOs, declared with their depths in
/// [`Pe::declaration`]), its event counters, and beside them the model's
/// scratch and bookkeeping (`PeModel`), which no chip holds.
///
/// The controller never touches these fields: it broadcasts to the PE
/// ([`Broadcast`]) and reads its report lines ([`PeReport`]); each stage's
/// step changes the PE's own state.
#[derive(Debug, Clone)]
pub struct Pe {
    /// Index in the array.
    pub k: usize,
    /// Under column blocks, the owned voxel columns `c0..c1`, whose edge
    /// columns the ports carry; empty under a round-robin mapping, whose
    /// aprons leave the ports nothing to carry.
    pub(crate) cols: std::ops::Range<usize>,
    /// Who owns which column while the array samples.
    pub(crate) map: ColumnMap,
    /// The voxel memory (`slice_buffer`, `edge_column`): words
    /// `[z][y][l]`, `l` the local index of a held column.
    pub(crate) mem: VoxelMem,
    /// The local index of every column this PE's memory holds (its own
    /// and its aprons), [`ABSENT`] for the rest: the address decoder.
    pub(crate) local: Vec<u32>,
    /// Columns held.
    width: usize,
    /// Whether migrating columns leave their transparent rows behind
    /// (`link_skip_empty`).
    pub(crate) sparse_links: bool,
    /// Whether the passes and the readout visit only non-zero rays
    /// (`pass_skip_empty`).
    pub(crate) sparse_passes: bool,
    pub(crate) ny: usize,
    pub(crate) nz: usize,
    /// The compositing buffer (`compositing_buffer`, `column_map`): ray
    /// columns held, in increasing `mx`.
    pub(crate) rays: VecDeque<RayColumn>,
    /// First held column sampled in the current slice, and how many.
    pub(crate) active: (usize, usize),
    /// The link queues to the left / right: each a link FIFO
    /// (`link_fifo`, bounded at its declared depth) fed from the leaving
    /// columns' rows in the compositing buffer, each row with the cycle
    /// from which it may leave (its last sample written back).
    pub(crate) out_left: LinkQueue,
    /// See `out_left`.
    pub(crate) out_right: LinkQueue,
    /// Columns being received, by `mx`.
    pub(crate) incoming: Vec<RayColumn>,
    /// Counters.
    pub(crate) counters: PeCounters,
    /// What the last sampling cycle did: the datapath's output registers
    /// as the waveforms show them.
    pub(crate) last: SampleTrace,
    /// Rows whose edge voxels the edge register holds.
    pub(crate) edge_latch: Option<(usize, usize, usize)>,
    /// The edge registers: what this PE drives on its ports while it
    /// samples (see [`crate::stages::sample`]).
    pub(crate) edge_value: crate::stages::sample::EdgeWords,
    /// The row being sampled, as an index into [`Pe::row_plan`]: its
    /// schedule is the held columns sampled, one per cycle.
    pub(crate) row_now: usize,
    /// The slice's row schedules and reports, as this PE planned them.
    pub(crate) row_plan: crate::stages::sample::RowPlan,
    /// The first cycle in which every sample this PE issued has been
    /// written back (the datapath is empty).
    pub(crate) drained_at: u64,
    /// The readout's state machine ([`crate::stages::readout`]).
    pub(crate) readout: crate::stages::readout::ReadoutFsm,
    /// Front to back (`kept_finals`): the final states of the rays this
    /// PE held at each split (one entry per boundary passed, innermost
    /// last), kept for the fold. With the inherited states this is the
    /// front-to-back mode's memory cost: every region's rays, about
    /// `(W + 1)(ny + 1)` per region boundary per PE, on top of the
    /// twice-as-wide compositing buffer.
    pub(crate) finals: Vec<Vec<RayColumn>>,
    /// The merge, split or fold in progress (`line_buffer`): children,
    /// line buffer, the children's column being built.
    pub(crate) pass: PassState,
    /// The model's scratch and bookkeeping.
    pub(crate) model: PeModel,
}

/// What the model keeps beside a PE's state, which no chip holds: scratch
/// buffers reused from slice to slice, and counts and bounds the model
/// keeps to report or to skip work.
#[derive(Debug, Clone, Default)]
pub(crate) struct PeModel {
    /// Quantisation events of this PE's datapath.
    pub(crate) stats: QuantStats,
    /// The whole-slice path's table of a slice's sampled rows and its
    /// columns' addresses.
    pub(crate) plain_order: crate::stages::sample::ColumnOrder,
    pub(crate) plain_cols: Vec<crate::stages::sample::ColumnTaps>,
    /// The latest scoreboard stamp a migration wrote into a ray this PE
    /// received (with `drained_at`, a bound on every held ray's `land`,
    /// so the controller need not read every scoreboard).
    pub(crate) arrived_by: u64,
    /// The most the ray memories have held ([`Occupancy`]).
    pub(crate) occupancy: Occupancy,
}

impl Pe {
    /// PE `k` of `map` over a `[nx, ny, nz]` volume, holding columns
    /// `held` ([`ColumnMap::held`]), its memory `mem` loaded with them
    /// (`[z][y][l]`).
    pub fn new(k: usize, map: ColumnMap, held: &[usize], mem: VoxelMem, dims: [usize; 3]) -> Pe {
        let [nx, ny, nz] = dims;
        let cols = if map.round_robin() {
            0..0
        } else {
            held.first().map_or(0..0, |&c| c..c + held.len())
        };
        let mut local = vec![ABSENT; nx];
        for (l, &c) in held.iter().enumerate() {
            local[c] = l as u32;
        }
        let w = held.len();
        debug_assert_eq!(mem.len(), w * ny * nz);
        Pe {
            k,
            cols,
            map,
            local,
            width: w,
            sparse_links: false,
            sparse_passes: false,
            mem,
            ny,
            nz,
            rays: VecDeque::new(),
            active: (0, 0),
            out_left: LinkQueue::new(DEFAULT_LINK_FIFO_DEPTH),
            out_right: LinkQueue::new(DEFAULT_LINK_FIFO_DEPTH),
            incoming: Vec::new(),
            counters: PeCounters::default(),
            last: SampleTrace::default(),
            edge_latch: None,
            edge_value: Default::default(),
            row_now: 0,
            row_plan: Default::default(),
            drained_at: 0,
            readout: Default::default(),
            finals: Vec::new(),
            pass: PassState::default(),
            model: PeModel::default(),
        }
    }

    /// Builds the link FIFOs `depth` rows deep (`link_fifo_depth`), empty.
    pub fn set_link_fifo_depth(&mut self, depth: usize) {
        debug_assert!(self.settled());
        self.out_left = LinkQueue::new(depth);
        self.out_right = LinkQueue::new(depth);
    }

    /// The most rows either link FIFO has held, and the cycles its feed
    /// waited for room (both sides).
    pub fn link_fifo_probe(&self) -> (usize, u64) {
        let (l, r) = (&self.out_left, &self.out_right);
        (l.peak().max(r.peak()), l.feed_stalls() + r.feed_stalls())
    }

    /// Voxel `(x, y)` of slice `z` from this PE's memory (`x` held),
    /// counted as a read.
    #[inline]
    pub(crate) fn voxel(&mut self, z: usize, y: usize, x: usize) -> u16 {
        self.counters.mem_reads += 1;
        self.mem
            .get((z * self.ny + y) * self.width + self.local[x] as usize)
    }

    /// Whether this PE's memory holds column `c`.
    #[inline]
    pub fn holds(&self, c: usize) -> bool {
        self.local.get(c).is_some_and(|&l| l != ABSENT)
    }

    /// Whether this PE owns column `c` (samples the rays based there).
    #[inline]
    pub fn owns(&self, c: usize) -> bool {
        c < self.map.nx && self.map.owner(c) == self.k
    }

    /// Columns this PE's memory holds.
    pub fn held_columns(&self) -> usize {
        self.width
    }

    /// The columns this PE samples in a slice whose x range is `lo ..=
    /// hi`: the held columns whose `mx` lies in it (contiguous, since both
    /// are sorted).
    pub fn select(&mut self, (lo, hi): (i64, i64)) {
        let held: u64 = self.rays.iter().map(|c| c.acc.len() as u64).sum();
        self.counters.rays_held_peak = self.counters.rays_held_peak.max(held);
        let first = self.rays.partition_point(|c| c.mx < lo);
        let end = self.rays.partition_point(|c| c.mx <= hi);
        self.active = (first, end.saturating_sub(first));
        self.note_occupancy();
    }

    /// Hands this PE's voxel memory out, leaving it empty (the memory
    /// stays resident for the next frame).
    pub(crate) fn take_memory(&mut self) -> VoxelMem {
        std::mem::replace(&mut self.mem, VoxelMem::Words(Vec::new()))
    }

    /// `mx` of the first and last held column.
    pub fn span(&self) -> Option<(i64, i64)> {
        Some((self.rays.front()?.mx, self.rays.back()?.mx))
    }

    /// Replaces the held columns.
    pub fn set_rays(&mut self, cols: Vec<RayColumn>) {
        self.rays = cols.into();
        self.note_occupancy();
    }

    /// Whether every sample this PE issued has been written back by cycle
    /// `now` (the PE's "empty" report, read by the controller's drain).
    pub fn datapath_empty(&self, now: u64) -> bool {
        self.drained_at <= now
    }
}

/// A PE's report lines to the controller: the fixed-width facts the PE
/// computes from its own state, which are all the controller reads of a
/// PE while a frame runs ([`Pe::report`], [`crate::array::Clock::reports`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PeReport {
    /// The first cycle by which every sample the PE issued has been
    /// written back: its datapath is empty from then on (the drain waits
    /// for every PE's).
    pub drained_at: u64,
    /// A bound on every held ray's scoreboard stamp: `drained_at`, or the
    /// latest stamp a migration wrote into a ray it received (a row start
    /// can wait only while some PE's is in the future).
    pub lands_by: u64,
    /// Its link queues (FIFOs and the rows still to feed them) and
    /// receive buffer are empty.
    pub settled: bool,
    /// Its readout has streamed every held ray.
    pub readout_done: bool,
    /// The held columns it samples in the current slice (its row length
    /// at most).
    pub active: u32,
    /// The children its current merge, split or fold computes (the pass's
    /// slots are as wide as the most).
    pub pass_width: u32,
    /// The length of its current sparse pass slot's work list (its done
    /// line falls after that many cycles).
    pub slot_work: u32,
    /// Child rays its merges (front to back, folds) have written so far.
    pub merge_outputs: u64,
    /// Front to back: child rays its splits have written so far.
    pub split_outputs: u64,
}

impl Pe {
    /// This PE's report lines ([`PeReport`]).
    #[inline]
    pub fn report(&self) -> PeReport {
        PeReport {
            drained_at: self.drained_at,
            lands_by: self.drained_at.max(self.model.arrived_by),
            settled: self.settled(),
            readout_done: self.readout_done(),
            active: self.active.1 as u32,
            pass_width: self.pass.children.len() as u32,
            slot_work: self.pass.slot.len() as u32,
            merge_outputs: self.counters.merge_outputs,
            split_outputs: self.counters.split_outputs,
        }
    }
}

/// A clock step that cannot happen in correct hardware.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    /// A ray needed a voxel column its PE neither owns nor receives.
    #[error("PE {pe} holds ray {mx} but cannot reach voxel column {column}")]
    Ownership {
        /// The PE.
        pe: usize,
        /// The ray.
        mx: i64,
        /// The column.
        column: usize,
    },
    /// A split or fold needed a ray that is neither held by the PE nor on
    /// a neighbour's port (the array's ownership rule was broken).
    #[error("PE {pe} needs ray {mx} for a split or fold but cannot reach it")]
    Unreachable {
        /// The PE.
        pe: usize,
        /// The ray.
        mx: i64,
    },
    /// A pass read a line-buffer row that is not (or no longer) there:
    /// the controller's pass schedule overran the buffer's depth.
    #[error("PE {pe}'s line buffer no longer holds row {row}")]
    LineBuffer {
        /// The PE.
        pe: usize,
        /// The row.
        row: usize,
    },
    /// The frame was stopped before its end: the caller stepping it
    /// ([`crate::stepper::Stepper`]) let it go.
    #[error("the frame was stopped before its end (its stepper was dropped)")]
    Stopped,
    /// An intermediate outgrew the 128-bit model.
    #[error("{0}")]
    Fixed(#[from] FxError),
}
