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

/// A broadcast as plain data, without the tables and plans it carries:
/// which command, and its scalar arguments. What a caller stepping the
/// array sees of the controller's commands between two cycles
/// ([`crate::stepper`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// [`Broadcast::BeginSlice`] over ray indices `lo ..= hi`.
    BeginSlice {
        /// First ray index along x.
        lo: i64,
        /// Last ray index along x.
        hi: i64,
    },
    /// [`Broadcast::PlanRows`]: `rows` rows from `first_row` of the
    /// region's grid.
    PlanRows {
        /// The slice's first row relative to the region's grid.
        first_row: usize,
        /// Rows in the slice.
        rows: usize,
    },
    /// [`Broadcast::BeginRow`] of the slice's row `r`.
    BeginRow(usize),
    /// [`Broadcast::BeginMerge`].
    BeginMerge,
    /// [`Broadcast::BeginSplit`].
    BeginSplit,
    /// [`Broadcast::BeginFold`].
    BeginFold,
    /// [`Broadcast::EndMerge`].
    EndMerge,
    /// [`Broadcast::EndSplit`].
    EndSplit,
    /// [`Broadcast::EndFold`].
    EndFold,
    /// [`Broadcast::PlanMoves`] around a ring (`true`) or along the line.
    PlanMoves {
        /// Whether the route is a ring.
        ring: bool,
    },
    /// [`Broadcast::BeginReadout`].
    BeginReadout,
}

impl Command {
    /// The command's code (its position in [`Command`]'s declaration,
    /// from 0), and its two arguments (0 where it has fewer): `BeginSlice`
    /// (lo, hi), `PlanRows` (first_row, rows), `BeginRow` (r, 0),
    /// `PlanMoves` (ring, 0).
    pub fn words(&self) -> (u32, i64, i64) {
        match *self {
            Command::BeginSlice { lo, hi } => (0, lo, hi),
            Command::PlanRows { first_row, rows } => (1, first_row as i64, rows as i64),
            Command::BeginRow(r) => (2, r as i64, 0),
            Command::BeginMerge => (3, 0, 0),
            Command::BeginSplit => (4, 0, 0),
            Command::BeginFold => (5, 0, 0),
            Command::EndMerge => (6, 0, 0),
            Command::EndSplit => (7, 0, 0),
            Command::EndFold => (8, 0, 0),
            Command::PlanMoves { ring } => (9, i64::from(ring), 0),
            Command::BeginReadout => (10, 0, 0),
        }
    }

    /// The command's name (`begin_slice`, `plan_rows`, ...).
    pub fn name(&self) -> &'static str {
        match self {
            Command::BeginSlice { .. } => "begin_slice",
            Command::PlanRows { .. } => "plan_rows",
            Command::BeginRow(_) => "begin_row",
            Command::BeginMerge => "begin_merge",
            Command::BeginSplit => "begin_split",
            Command::BeginFold => "begin_fold",
            Command::EndMerge => "end_merge",
            Command::EndSplit => "end_split",
            Command::EndFold => "end_fold",
            Command::PlanMoves { .. } => "plan_moves",
            Command::BeginReadout => "begin_readout",
        }
    }
}

impl Broadcast<'_> {
    /// The broadcast as plain data.
    pub fn command(&self) -> Command {
        match *self {
            Broadcast::BeginSlice { x } => Command::BeginSlice { lo: x.0, hi: x.1 },
            Broadcast::PlanRows {
                first_row, rows, ..
            } => Command::PlanRows { first_row, rows },
            Broadcast::BeginRow(r) => Command::BeginRow(r),
            Broadcast::BeginMerge { .. } => Command::BeginMerge,
            Broadcast::BeginSplit { .. } => Command::BeginSplit,
            Broadcast::BeginFold { .. } => Command::BeginFold,
            Broadcast::EndMerge => Command::EndMerge,
            Broadcast::EndSplit => Command::EndSplit,
            Broadcast::EndFold => Command::EndFold,
            Broadcast::PlanMoves { route, .. } => Command::PlanMoves {
                ring: matches!(route, Route::Ring(_)),
            },
            Broadcast::BeginReadout => Command::BeginReadout,
        }
    }

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
        // A pass's children take their slots at its start.
        if matches!(
            b,
            Broadcast::BeginMerge { .. }
                | Broadcast::BeginSplit { .. }
                | Broadcast::BeginFold { .. }
        ) {
            self.note_occupancy();
        }
    }
}
