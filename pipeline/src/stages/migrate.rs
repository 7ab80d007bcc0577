//! Migration: before each slice (and before a merge, split or fold, to the
//! rays' positions on the boundary plane) every ray whose owner changed
//! travels one link per cycle, one ray per link and direction per cycle,
//! until every PE holds exactly its rays. A ray leaves only once its last
//! sample has been written back (the datapath's scoreboard); the cycles it
//! waits are the PE's `waits`.
//!
//! Golden has no twin of this stage: it is where the array's distribution
//! of [`golden::sampling::slice_rays`]' rays over the PEs is kept up to
//! date as the rays' positions move from slice to slice.

use std::collections::VecDeque;

use crate::array::{Array, Links, RunError};
use crate::host::SlicePlan;
use crate::pe::{Pe, Ports, RayColumn, RayMove};
use crate::probes::{Ctrl, Stage};

impl Pe {
    /// Queues every held column whose owner for the next slice is another
    /// PE, given the owner function: the PE's combinational look at its own
    /// ends when the controller starts a migration.
    pub fn plan_moves(&mut self, owner: impl Fn(i64) -> usize) {
        while let Some(c) = self.rays.front() {
            if owner(c.mx) >= self.k {
                break;
            }
            let c = self.rays.pop_front().expect("front exists");
            queue(&mut self.out_left, c);
        }
        while let Some(c) = self.rays.back() {
            if owner(c.mx) <= self.k {
                break;
            }
            let c = self.rays.pop_back().expect("back exists");
            queue(&mut self.out_right, c);
        }
    }

    /// One migration clock at cycle `now`: receives what the neighbours
    /// sent last cycle, sends one ray each way if its last sample has been
    /// written back; a column that is whole joins the held columns (or
    /// moves on if its owner is further along).
    pub fn migrate_step(
        &mut self,
        links: Links<'_>,
        now: u64,
        owner: impl Fn(i64) -> usize,
    ) -> Ports {
        let mut out = Ports::default();
        for (incoming, from_left_side) in
            [(links.from_left.ray, true), (links.from_right.ray, false)]
        {
            let Some(m) = incoming else { continue };
            self.counters.rays_received += 1;
            let pos = match self.incoming.iter().position(|c| c.mx == m.mx) {
                Some(p) => p,
                None => {
                    let rows = m.rows as usize;
                    self.incoming.push(RayColumn {
                        mx: m.mx,
                        acc: Vec::with_capacity(rows),
                        ftb: Vec::with_capacity(if m.ftb.is_some() { rows } else { 0 }),
                        land: Vec::with_capacity(rows),
                    });
                    self.incoming.len() - 1
                }
            };
            let col = &mut self.incoming[pos];
            col.acc.push(m.acc);
            col.land.push(0);
            if let Some(f) = m.ftb {
                col.ftb.push(f);
            }
            if col.acc.len() == m.rows as usize {
                let col = self.incoming.swap_remove(pos);
                let dest = owner(col.mx);
                if dest < self.k {
                    queue(&mut self.out_left, col);
                } else if dest > self.k {
                    queue(&mut self.out_right, col);
                } else if from_left_side {
                    self.rays.push_front(col);
                } else {
                    self.rays.push_back(col);
                }
            }
        }
        let mut waited = false;
        for (q, port) in [
            (&mut self.out_left, &mut out.left),
            (&mut self.out_right, &mut out.right),
        ] {
            match q.front() {
                Some(&(_, land)) if land > now => waited = true,
                Some(_) => {
                    let (m, _) = q.pop_front().expect("front exists");
                    self.counters.rays_sent += 1;
                    port.ray = Some(m);
                }
                None => {}
            }
        }
        self.counters.waits += u64::from(waited);
        out
    }

    /// True when nothing is waiting to move or being received.
    pub fn settled(&self) -> bool {
        self.out_left.is_empty() && self.out_right.is_empty() && self.incoming.is_empty()
    }
}

/// Splits a column into ray moves, row by row, each with the cycle from
/// which it may leave.
fn queue(q: &mut VecDeque<(RayMove, u64)>, c: RayColumn) {
    let rows = c.acc.len() as u32;
    for (row, acc) in c.acc.into_iter().enumerate() {
        let mv = RayMove {
            mx: c.mx,
            row: row as u32,
            rows,
            acc,
            ftb: c.ftb.get(row).copied(),
        };
        q.push_back((mv, c.land.get(row).copied().unwrap_or(0)));
    }
}

impl Array {
    /// Migration before `slice`: clocks until every ray sits in its owner.
    pub(crate) fn migrate(&mut self, slice: &SlicePlan) -> Result<(), RunError> {
        let dp = std::sync::Arc::clone(&self.dp);
        let owners = self.owners(&dp, slice);
        self.migrate_by(slice.z, |mx| owners.of(mx))
    }

    /// Migration to the owners `owner` gives (traced at slice `z`): clocks
    /// until every PE reports itself settled and no ray is on a link.
    pub(crate) fn migrate_by(
        &mut self,
        z: usize,
        owner: impl Fn(i64) -> usize,
    ) -> Result<(), RunError> {
        for pe in self.clock.pes_mut() {
            pe.plan_moves(&owner);
        }
        while !(self.clock.pes().iter().all(Pe::settled)
            && self
                .clock
                .ports()
                .iter()
                .all(|p| p.left.ray.is_none() && p.right.ray.is_none()))
        {
            let now = self.clock.now();
            self.clock
                .tick(Ctrl::at(Stage::Migrate, z, 0), |pe, links| {
                    Ok(pe.migrate_step(links, now, &owner))
                })?;
        }
        Ok(())
    }
}
