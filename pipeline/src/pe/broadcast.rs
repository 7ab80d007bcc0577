//! The controller's broadcast: what it tells every PE between cycles (a
//! slice, a row, a pass or a readout begins, a pass ends, a migration is
//! planned). Each PE applies it to its own state ([`Pe::on_broadcast`]);
//! what a PE answers comes back on its report lines ([`PeReport`]). The
//! controller hands a broadcast to the clock
//! ([`crate::array::Clock::broadcast`]), never to a PE.
//!
//! Within a cycle the controller's signals travel on the step's own bus
//! ([`crate::stages::sample::SampleBus`], [`crate::stages::passes::PassBus`]).
//!
//! [`PeReport`]: super::PeReport

use golden::geometry::RayGrid;

use super::Pe;
use crate::mapping::Route;
use crate::stages::sample::{PrePlan, Row, RowRuns};

/// The owner of each ray index for the next slice or pass, as the
/// controller broadcasts it to a migration.
pub type OwnerFn<'a> = &'a (dyn Fn(i64) -> usize + Sync);

/// What the clock reads of each PE's edge words while it plans a slice
/// ([`Pe::edges_for`]).
#[derive(Clone, Copy)]
pub struct EdgeRead<'a> {
    /// The slice.
    pub z: usize,
    /// The rows' broadcast values.
    pub rows: &'a [Row],
    /// Whether the array shades (the gradient's words travel too).
    pub shade: bool,
}

/// One command of the controller to every PE.
#[derive(Clone, Copy)]
pub enum Broadcast<'a> {
    /// A slice's sampling begins over ray indices `x.0 ..= x.1`: each PE
    /// selects its held columns in that range (reported as
    /// [`PeReport::active`](super::PeReport::active)).
    BeginSlice {
        /// The slice's ray range along x.
        x: (i64, i64),
    },
    /// The slice's rows are known: each PE schedules its rays in every
    /// row ([`Pe::plan_rows`]; reported on [`Pe::row_reports`]).
    PlanRows {
        /// The slice's first row relative to the region's grid.
        first_row: usize,
        /// Rows in the slice.
        rows: usize,
        /// The controller's runs per row.
        runs: &'a RowRuns,
        /// Front to back (the rays' termination flags are read).
        ftb: bool,
        /// Whether some held ray is written back after the slice's first
        /// cycle (the scoreboards are read).
        waits: bool,
        /// A pre-integrated slice's step and runs.
        pre: Option<&'a PrePlan<'a>>,
        /// For the clock's untraced sampler: the slice and its rows'
        /// values, whose edge words each PE presents in each row the clock
        /// reads while the PE plans (one parallel step over the PEs).
        edges: Option<EdgeRead<'a>>,
    },
    /// Row `r` of the slice begins ([`Pe::begin_row`]).
    BeginRow(usize),
    /// A merge of the back grid's rays into the front grid's begins
    /// ([`Pe::begin_merge`]).
    BeginMerge {
        /// The parents' grid.
        back: &'a RayGrid,
        /// The children's grid.
        front: &'a RayGrid,
    },
    /// A split of the front grid's rays into the back grid's begins
    /// ([`Pe::begin_split`]).
    BeginSplit {
        /// The parents' grid.
        front: &'a RayGrid,
        /// The children's grid.
        back: &'a RayGrid,
    },
    /// A fold step into the front grid begins ([`Pe::begin_fold`]).
    BeginFold {
        /// The children's grid.
        front: &'a RayGrid,
    },
    /// The merge ends: the children's bank becomes the held rays.
    EndMerge,
    /// The split ends: the parents are kept for the fold, the children
    /// held.
    EndSplit,
    /// The fold step ends: its kept finals are spent, the children held.
    EndFold,
    /// A migration begins: each PE queues the columns another PE owns
    /// ([`Pe::plan_moves`]).
    PlanMoves {
        /// The owners.
        owner: OwnerFn<'a>,
        /// Line or ring.
        route: Route,
    },
    /// The readout begins: each PE rewinds its cursor.
    BeginReadout,
}

impl Broadcast<'_> {
    /// Whether applying it is a PE's whole-slice work (planning every
    /// row), worth spreading the PEs over threads.
    pub(crate) fn heavy(&self) -> bool {
        matches!(self, Broadcast::PlanRows { .. })
    }
}

impl Pe {
    /// Applies the controller's broadcast `b` to this PE's state.
    pub fn on_broadcast(&mut self, b: &Broadcast<'_>) {
        match *b {
            Broadcast::BeginSlice { x } => self.select(x),
            Broadcast::PlanRows {
                first_row,
                rows,
                runs,
                ftb,
                waits,
                pre,
                ..
            } => self.plan_rows(first_row, rows, runs, (ftb, waits), pre),
            Broadcast::BeginRow(r) => self.begin_row(r),
            Broadcast::BeginMerge { back, front } => {
                self.begin_merge(back, front);
            }
            Broadcast::BeginSplit { front, back } => {
                self.begin_split(front, back);
            }
            Broadcast::BeginFold { front } => {
                self.begin_fold(front);
            }
            Broadcast::EndMerge => self.end_merge(),
            Broadcast::EndSplit => self.end_split(),
            Broadcast::EndFold => self.end_fold(),
            Broadcast::PlanMoves { owner, route } => self.plan_moves(owner, route),
            Broadcast::BeginReadout => self.begin_readout(),
        }
    }
}
