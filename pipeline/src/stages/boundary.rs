//! One clock of a region-boundary pass on a PE: what the merge, the split
//! and the fold share, written once. Each is a [`BoundaryPass`]: its x
//! filter (a parent row's child column into the line buffer), its y filter
//! (a child row's column out of it into the children's bank), the sparse
//! work list and the edge it drives. The clock around them is the same for
//! all three:
//!
//! - **dense** ([`Pe::pass_step`]): child `bus.col` of every pass the bus
//!   names, the y pass before the x pass (a read-first line buffer), with
//!   the neighbours' edge rays as their ports show them this cycle; then
//!   the PE drives the edge of the row on `bus.drive`;
//! - **sparse** ([`Pe::pass_step_sparse`], `pass_skip_empty`): in a slot's
//!   first cycle the PE latches both neighbours' edges into its pass
//!   registers and forms its work list; each cycle it works the list's
//!   next entry with the latched edges, then drives as the dense pass does.
//!
//! [`PassStep`] is that clock as the pass's [`Step`]. The controller's
//! side (the slots, the prologue, the broadcasts) is in [`super::passes`].

use super::passes::PassBus;
use super::Step;
use crate::array::Links;
use crate::datapath::{Acc, Datapath};
use crate::pe::{Pe, Ports, StepError};
use crate::probes::{Ctrl, Stage};

/// A neighbour's edge ray as its port carries it: the accumulators and the
/// ray's index (`None` when no edge ray is driven).
pub type Edge = (Acc, Option<i64>);

/// The edge rays both neighbours drive: what a pass's x filter reads beyond
/// the PE's held span (the merge both sides' accumulators, the split the
/// right one with its index, the fold the left one with its index).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Edges {
    /// From PE `k - 1`'s right port.
    pub left: Edge,
    /// From PE `k + 1`'s left port.
    pub right: Edge,
}

impl Edges {
    /// The edges on the ports this cycle.
    pub fn on(links: &Links<'_>) -> Edges {
        Edges {
            left: (links.from_left.edge_acc, links.from_left.edge_mx),
            right: (links.from_right.edge_acc, links.from_right.edge_mx),
        }
    }
}

/// A region-boundary filter as a PE runs it (merge, split or fold; the
/// value carries the pass's grids). Each hook sees only the PE's own state
/// and what the clock hands it.
pub trait BoundaryPass {
    /// Prepares parent row `q` for the x pass before its first column is
    /// filtered (the fold forms the row's differences); nothing by default.
    fn x_row(&self, _pe: &mut Pe, _dp: &Datapath, _q: usize) {}

    /// The x pass: child `c` of parent row `q` into the line buffer, with
    /// the neighbours' `edges`.
    fn x(
        &self,
        pe: &mut Pe,
        dp: &Datapath,
        c: usize,
        q: usize,
        edges: Edges,
    ) -> Result<(), StepError>;

    /// The y pass: child `c` of child row `i` from the line buffer into the
    /// children's bank (`sparse`: entries the x pass left unwritten read
    /// zero).
    fn y(
        &self,
        pe: &mut Pe,
        dp: &Datapath,
        c: usize,
        i: usize,
        sparse: bool,
    ) -> Result<(), StepError>;

    /// The sparse slot's work list for the slot on `bus`
    /// (`Pe::set_work_list`), with the edges latched in
    /// [`PassState::edges`](super::passes::PassState::edges).
    fn work_list(&self, pe: &mut Pe, bus: &PassBus) -> Result<(), StepError>;

    /// Drives the PE's edge of parent row `row` on its ports.
    fn drive(&self, pe: &mut Pe, dp: &Datapath, row: usize, out: &mut Ports);
}

impl Pe {
    /// One clock of a dense boundary pass: `Pe::pass_work` with the
    /// edges on the ports, then the drive the bus names.
    pub fn pass_step<P: BoundaryPass>(
        &mut self,
        pass: &P,
        dp: &Datapath,
        bus: &PassBus,
        links: Links<'_>,
        out: &mut Ports,
    ) -> Result<(), StepError> {
        self.pass_work(pass, dp, bus, Edges::on(&links))?;
        self.pass_drive(pass, dp, bus, out);
        Ok(())
    }

    /// What a dense pass clock computes (without its drive): the y pass
    /// writes child `bus.col` of child row `bus.y`, then the x pass filters
    /// child `bus.col` of parent row `bus.x`, each when this PE computes
    /// that many children.
    pub(crate) fn pass_work<P: BoundaryPass>(
        &mut self,
        pass: &P,
        dp: &Datapath,
        bus: &PassBus,
        edges: Edges,
    ) -> Result<(), StepError> {
        let c = bus.col;
        let n = self.pass.children.len();
        if let Some(i) = bus.y.filter(|_| c < n) {
            pass.y(self, dp, c, i, false)?;
        }
        if let Some(q) = bus.x {
            pass.x_row(self, dp, q);
            if c < n {
                pass.x(self, dp, c, q, edges)?;
            }
        }
        Ok(())
    }

    /// One clock of a sparse boundary pass (`pass_skip_empty`): in the
    /// slot's first cycle the PE prepares the x row, latches the
    /// neighbours' edges and forms its work list; each cycle it works the
    /// list's next entry (y pass before x pass), and it drives the next
    /// slot's edge throughout.
    pub fn pass_step_sparse<P: BoundaryPass>(
        &mut self,
        pass: &P,
        dp: &Datapath,
        bus: &PassBus,
        links: Links<'_>,
        out: &mut Ports,
    ) -> Result<(), StepError> {
        if bus.col == 0 {
            if let Some(q) = bus.x {
                pass.x_row(self, dp, q);
            }
            self.pass.edges = Edges::on(&links);
            pass.work_list(self, bus)?;
        }
        if let Some(&(c, x, y)) = self.pass.slot.get(bus.col) {
            if let Some(i) = bus.y.filter(|_| y) {
                pass.y(self, dp, c, i, true)?;
            }
            if let Some(q) = bus.x.filter(|_| x) {
                pass.x(self, dp, c, q, self.pass.edges)?;
            }
        }
        self.pass_drive(pass, dp, bus, out);
        Ok(())
    }

    /// What the PE drives in a pass cycle: the edge of the row on
    /// `bus.drive`, or nothing.
    fn pass_drive<P: BoundaryPass>(
        &mut self,
        pass: &P,
        dp: &Datapath,
        bus: &PassBus,
        out: &mut Ports,
    ) {
        if let Some(r) = bus.drive {
            pass.drive(self, dp, r, out);
        }
    }
}

/// A pass's step as its controller clocks it ([`super::passes`]): before
/// each tick the controller shows it the cycle's bus and the row the
/// probes show.
pub trait OnPassBus: Step {
    /// The next cycle's bus `bus`, shown at row `row`.
    fn show(&mut self, bus: PassBus, row: usize);
}

/// A boundary pass's cycle on a PE: the `pass` of `stage` (a
/// [`MergePass`](super::merge::MergePass), twin of
/// [`golden::merge::merge`]; a [`SplitPass`](super::split::SplitPass),
/// twin of [`golden::merge::split`]; or
/// [`FoldGrids`](super::fold::FoldGrids), the fold of
/// [`golden::methods::render`]) clocked dense ([`Pe::pass_step`]) or
/// sparse ([`Pe::pass_step_sparse`]) on the bus the controller shows.
pub struct PassStep<'a, P> {
    pass: P,
    dp: &'a Datapath,
    sparse: bool,
    stage: Stage,
    bus: PassBus,
    row: usize,
}

impl<'a, P: BoundaryPass> PassStep<'a, P> {
    /// The step of `pass` in `stage`, sparse (`pass_skip_empty`) or dense.
    pub fn new(stage: Stage, pass: P, dp: &'a Datapath, sparse: bool) -> Self {
        PassStep {
            pass,
            dp,
            sparse,
            stage,
            bus: PassBus::default(),
            row: 0,
        }
    }

    /// The pass it clocks.
    pub fn pass(&self) -> &P {
        &self.pass
    }

    /// The bus of the cycle it steps.
    pub fn bus(&self) -> &PassBus {
        &self.bus
    }
}

impl<P: BoundaryPass> Step for PassStep<'_, P> {
    fn ctrl(&self) -> Ctrl {
        Ctrl {
            pass: Some(self.bus),
            ..Ctrl::at(self.stage, 0, self.row)
        }
    }

    #[inline]
    fn step(&mut self, pe: &mut Pe, links: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        if self.sparse {
            pe.pass_step_sparse(&self.pass, self.dp, &self.bus, links, out)
        } else {
            pe.pass_step(&self.pass, self.dp, &self.bus, links, out)
        }
    }
}

impl<P: BoundaryPass> OnPassBus for PassStep<'_, P> {
    fn show(&mut self, bus: PassBus, row: usize) {
        self.bus = bus;
        self.row = row;
    }
}
