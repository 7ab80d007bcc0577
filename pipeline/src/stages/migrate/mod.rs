//! Migration: before each slice (and before a merge, split or fold, to the
//! rays' positions on the boundary plane) every ray whose owner changed
//! travels one link per cycle, one ray per link and direction per cycle,
//! until every PE holds exactly its rays. A ray leaves only once its last
//! sample has been written back (the datapath's scoreboard); the cycles it
//! waits are the PE's `waits`. Untraced, a migration between slices is
//! worked out from the link queues' departures instead (the clock's
//! `Clock::migrate_untraced`), with the same moves, cycles and counters.
//!
//! Golden has no twin of this stage: it is where the array's distribution
//! of [`golden::sampling::slice_rays`]' rays over the PEs is kept up to
//! date as the rays' positions move from slice to slice.

mod queue;

pub use queue::LinkQueue;

use crate::array::{Array, Links, RunError};
use crate::config::Migration;
use crate::datapath::Acc;
use crate::host::SlicePlan;
use crate::mapping::Route;
use crate::pe::{Broadcast, FtbState, Pe, Ports, RayColumn, RayMove, StepError};
use crate::probes::{Ctrl, Stage};
use crate::stages::{Idle, Step};

impl Pe {
    /// Queues every held column whose owner for the next slice is another
    /// PE, given the owner function and the `route`: the PE's
    /// combinational look at its rays when the controller starts a
    /// migration ([`Pe::take_leaving`]), each column split into its ray
    /// moves.
    pub fn plan_moves(&mut self, owner: impl Fn(i64) -> usize, route: Route) {
        let [left, right] = self.take_leaving(owner, route);
        for c in left {
            queue(&mut self.out_left, c, self.sparse_links);
        }
        for c in right {
            queue(&mut self.out_right, c, self.sparse_links);
        }
    }

    /// Takes every held column whose owner for the next slice is another
    /// PE out of the held ones: those going left, then right, each in the
    /// order they queue. Along a line the owners grow with the ray index,
    /// so only the ends can leave; around a ring any block's ends can.
    /// Leftward columns queue in ascending `mx`, rightward ones in
    /// descending.
    pub fn take_leaving(
        &mut self,
        owner: impl Fn(i64) -> usize,
        route: Route,
    ) -> [Vec<RayColumn>; 2] {
        let (mut left, mut right) = (Vec::new(), Vec::new());
        if route != Route::Line {
            let held = std::mem::take(&mut self.rays);
            for c in held {
                let dest = owner(c.mx);
                if dest == self.k {
                    self.rays.push_back(c);
                } else if route.rightwards(self.k, dest) {
                    right.push(c);
                } else {
                    left.push(c);
                }
            }
            right.reverse();
            return [left, right];
        }
        while let Some(c) = self.rays.front() {
            if owner(c.mx) >= self.k {
                break;
            }
            left.push(self.rays.pop_front().expect("front exists"));
        }
        while let Some(c) = self.rays.back() {
            if owner(c.mx) <= self.k {
                break;
            }
            right.push(self.rays.pop_back().expect("back exists"));
        }
        [left, right]
    }

    /// One migration clock of one lane at cycle `now`: receives what the
    /// neighbours sent on this lane last cycle, sends one ray each way if
    /// its last sample has been written back; a column that is whole joins
    /// the held columns (or moves on if its owner is further along). A ray
    /// received this cycle leaves no earlier than the next, on any lane.
    /// The cycle's waits and queue are counted with its `last` lane.
    pub fn migrate_step(
        &mut self,
        links: Links<'_>,
        now: u64,
        owner: impl Fn(i64) -> usize,
        (route, last): (Route, bool),
        out: &mut Ports,
    ) {
        if links.from_left.ray.is_none()
            && links.from_right.ray.is_none()
            && self.out_left.is_empty()
            && self.out_right.is_empty()
        {
            // Nothing arrives and nothing waits to leave: the PE drives
            // nothing and counts nothing (what the steps below would do).
            return;
        }
        // A column's slot is taken when its first row arrives (what the
        // occupancy probe notes).
        let mut grew = false;
        for (incoming, from_left_side) in
            [(&links.from_left.ray, true), (&links.from_right.ray, false)]
        {
            let Some(m) = incoming else { continue };
            self.counters.rays_received += 1;
            let pos = match self.incoming.iter().position(|c| c.mx == m.mx) {
                Some(p) => p,
                None => {
                    // Rows the links leave out (`link_skip_empty`) stay
                    // transparent, as the slot reads before any write.
                    let col = RayColumn::empty(m.mx, m.rows as usize, m.ftb.is_some());
                    self.incoming.push(col);
                    grew = true;
                    self.incoming.len() - 1
                }
            };
            let col = &mut self.incoming[pos];
            let row = m.row as usize;
            col.acc[row] = m.acc;
            // Received this cycle, readable from the next (what an
            // overlapped migration's rows wait for).
            col.land[row] = now + 1;
            self.model.arrived_by = now + 1;
            if let Some(f) = m.ftb {
                col.ftb[row] = f;
            }
            if m.prev != 0 {
                if col.prev.is_empty() {
                    col.prev = vec![0; col.acc.len()];
                }
                col.prev[row] = m.prev;
            }
            // A column's rows travel in order on one path, its last row
            // always (it closes the column).
            if m.row + 1 == m.rows {
                let col = self.incoming.swap_remove(pos);
                let dest = owner(col.mx);
                if dest == self.k {
                    // Held columns stay in ascending `mx` (along a line an
                    // arrival from the left is the new first).
                    let at = self.rays.partition_point(|c| c.mx < col.mx);
                    self.rays.insert(at, col);
                } else if match route {
                    Route::Line => dest > self.k,
                    // Around a ring a column passing through keeps going
                    // the way it came (the shorter way, decided at its
                    // start).
                    Route::Ring(_) => from_left_side,
                } {
                    queue(&mut self.out_right, col, self.sparse_links);
                } else {
                    queue(&mut self.out_left, col, self.sparse_links);
                }
            }
        }
        let mut waited = false;
        let mut queued = 0;
        for (q, port) in [
            (&mut self.out_left, &mut out.left),
            (&mut self.out_right, &mut out.right),
        ] {
            // The feed reads the next row into the FIFO ahead of the send
            // (see `queue`), so the front is always the queue's next row.
            q.feed();
            match q.front() {
                Some(&(_, land)) if land > now => {
                    waited = true;
                    queued += q.len() - 1;
                }
                Some(_) => {
                    let (m, _) = q.pop().expect("front exists");
                    self.counters.rays_sent += 1;
                    port.ray = Some(m);
                    queued += q.len();
                }
                None => {}
            }
        }
        if last {
            self.counters.waits += u64::from(waited);
            self.counters.link_queue += queued as u64;
        }
        if grew {
            self.note_occupancy();
        }
    }

    /// True when nothing is waiting to move or being received.
    pub fn settled(&self) -> bool {
        self.out_left.is_empty() && self.out_right.is_empty() && self.incoming.is_empty()
    }
}

/// Whether row `row` of column `c` stays behind on sparse links: it holds
/// nothing (transparent accumulators and, front to back, nothing inherited
/// and no termination; pre-integrated, a zero previous sample) and is not
/// the column's last row, which always goes (it closes the column at the
/// receiver).
pub(crate) fn stays(c: &RayColumn, row: usize) -> bool {
    row + 1 < c.acc.len()
        && c.acc[row] == Acc::default()
        && c.ftb.get(row).is_none_or(|f| *f == FtbState::default())
        && c.prev.get(row).is_none_or(|&p| p == 0)
}

/// Splits a column into ray moves, row by row, each with the cycle from
/// which it may leave, queued behind the link FIFO (the rows stay in the
/// compositing buffer until the feed reads them); with `sparse`, without
/// the rows that stay behind ([`stays`]).
fn queue(q: &mut LinkQueue, c: RayColumn, sparse: bool) {
    let rows = c.acc.len() as u32;
    for row in 0..rows as usize {
        if sparse && stays(&c, row) {
            continue;
        }
        let (acc, ftb) = (c.acc[row], c.ftb.get(row).copied());
        let prev = c.prev.get(row).copied().unwrap_or(0);
        let mv = RayMove {
            mx: c.mx,
            row: row as u32,
            rows,
            acc,
            ftb,
            prev,
        };
        q.enqueue((mv, c.land.get(row).copied().unwrap_or(0)));
    }
}

/// The migration's cycle of one lane on a PE ([`Pe::migrate_step`]): the
/// rays the neighbours sent last cycle arrive, and one ray leaves each way
/// towards its owner for slice `z` under `owner`. Golden has no twin (the
/// module's doc): this keeps the array's share of
/// [`golden::sampling::slice_rays`]' rays where the next slice samples them.
pub struct LinkStep<'a, F> {
    /// The slice the rays move for.
    pub z: usize,
    /// The cycle's number (a received ray leaves no earlier than the next).
    pub now: u64,
    /// The rays' owners for slice `z`.
    pub owner: &'a F,
    /// The links' route (a line or a ring).
    pub route: Route,
    /// Whether this is the cycle's last lane (it counts the waits).
    pub last: bool,
}

impl<F: Fn(i64) -> usize> Step for LinkStep<'_, F> {
    fn ctrl(&self) -> Ctrl {
        Ctrl::at(Stage::Migrate, self.z, 0)
    }

    fn step(&mut self, pe: &mut Pe, links: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        pe.migrate_step(links, self.now, self.owner, (self.route, self.last), out);
        Ok(())
    }
}

impl Array {
    /// Migration before `slice`: clocks until every ray sits in its owner,
    /// or, overlapped, runs the links in the cycles the slice samples.
    pub(crate) fn migrate(&mut self, slice: &SlicePlan) -> Result<(), RunError> {
        let dp = std::sync::Arc::clone(&self.dp);
        let owners = self.owners(&dp, slice);
        if self.dp.cfg.migration == Migration::Overlapped && self.channel.is_none() {
            return self.migrate_overlapped(slice.z, |mx| owners.of(mx));
        }
        self.migrate_by(slice.z, |mx| owners.of(mx))
    }

    /// The overlapped migration: the links step alongside the sampling
    /// stage (their own registers, the same clock) from the previous
    /// slice's first sampling cycle on, until every ray is home. A row
    /// leaves once its previous sample has been written back (the
    /// scoreboard), so rays sampled early in the previous slice, or not at
    /// all, travel while it samples. Each received row is stamped with the
    /// cycle from which it may be read, and the slice's row schedule waits
    /// for the stamps (stall cycles), as it waits for the datapath's
    /// write-backs. The link cycles are the sampling stage's, so they add
    /// no cycle of their own; the waveforms do not show these moves on
    /// the ports.
    fn migrate_overlapped(
        &mut self,
        z: usize,
        owner: impl Fn(i64) -> usize + Sync,
    ) -> Result<(), RunError> {
        let route = self.map.route();
        self.clock.broadcast(&Broadcast::PlanMoves {
            owner: &owner,
            route,
        });
        let p = self.clock.pes().len();
        // One pair of port registers per lane: a ray sent on lane `i`
        // arrives through lane `i` next cycle, whatever the other lanes do.
        let lanes = usize::from(self.dp.cfg.link_lanes);
        let mut ports: Vec<_> = (0..lanes)
            .map(|_| (vec![Ports::default(); p], vec![Ports::default(); p]))
            .collect();
        let mut now = self.links_from.max(self.links_free);
        let idle = |l: &(Vec<Ports>, Vec<Ports>)| {
            l.0.iter()
                .all(|p| p.left.ray.is_none() && p.right.ray.is_none())
        };
        while !(self.clock.reports().all(|r| r.settled) && ports.iter().all(idle)) {
            for (i, lane) in ports.iter_mut().enumerate() {
                let last = i + 1 == lanes;
                let mut step = LinkStep {
                    z,
                    now,
                    owner: &owner,
                    route,
                    last,
                };
                self.clock.tick_links(lane, &mut step)?;
            }
            now += 1;
        }
        self.links_free = now;
        Ok(())
    }

    /// Marks every ray home as of now: the next overlapped migration
    /// starts no earlier (after a ticked migration or a pass, which read
    /// or rebuild every ray).
    pub(crate) fn settle_links(&mut self) {
        let now = self.clock.now();
        self.links_from = now;
        self.links_free = now;
    }

    /// Migration to the rays' column-block owners on the plane of `slice`,
    /// before a merge or split there.
    pub(crate) fn migrate_pass(&mut self, slice: &SlicePlan) -> Result<(), RunError> {
        let dp = std::sync::Arc::clone(&self.dp);
        let owners = self.pass_owners(&dp, slice);
        self.migrate_home(slice.z, |mx| owners.of(mx))
    }

    /// Migration before a stage that reads every ray (a pass, the
    /// readout): between slices, clocked until done; overlapped, the links
    /// start with the last slice (as a slice's own migration does) and the
    /// array ticks migration cycles only for what that slice did not hide.
    pub(crate) fn migrate_home(
        &mut self,
        z: usize,
        owner: impl Fn(i64) -> usize + Sync,
    ) -> Result<(), RunError> {
        if self.dp.cfg.migration != Migration::Overlapped || self.channel.is_some() {
            return self.migrate_by(z, owner);
        }
        self.migrate_overlapped(z, owner)?;
        while self.clock.now() < self.links_free {
            self.clock.tick(&mut Idle(Ctrl::at(Stage::Migrate, z, 0)))?;
        }
        self.settle_links();
        Ok(())
    }

    /// Migration to the owners `owner` gives (traced at slice `z`): clocks
    /// until every PE reports itself settled and no ray is on a link. With
    /// the rays' buffer in external memory nothing moves: the controller
    /// hands each ray to its new owner, which fetches it from the shared
    /// buffer when it samples it ([`crate::stages::raybuf`]).
    pub(crate) fn migrate_by(
        &mut self,
        z: usize,
        owner: impl Fn(i64) -> usize + Sync,
    ) -> Result<(), RunError> {
        if self.channel.is_some() {
            self.clock.reassign(owner);
            return Ok(());
        }
        let route = self.map.route();
        if !self.clock.tracing() && !self.clocked {
            self.clock.migrate_untraced(&owner, route);
            self.settle_links();
            return Ok(());
        }
        self.clock.broadcast(&Broadcast::PlanMoves {
            owner: &owner,
            route,
        });
        while !(self.clock.reports().all(|r| r.settled)
            && self
                .clock
                .ports()
                .iter()
                .all(|p| p.left.ray.is_none() && p.right.ray.is_none()))
        {
            let mut step = LinkStep {
                z,
                now: self.clock.now(),
                owner: &owner,
                route,
                last: true,
            };
            self.clock.tick(&mut step)?;
        }
        self.settle_links();
        Ok(())
    }
}
