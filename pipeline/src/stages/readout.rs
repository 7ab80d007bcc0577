//! The readout: each PE streams its region-0 rays to the host, one per
//! cycle on its host port, row by row and within a row by ascending held
//! column ([`ReadoutFsm`], the registers of the emitted state machine
//! `ercube_pe_readout`, [`crate::hw::readout_rtl`]); the host
//! writes each word where its ray index puts it in the baseplane (cleared
//! first: with `pass_skip_empty` the PEs leave their zero rays out) that
//! [`golden::warp::warp`] then resamples (a [`golden::warp::Baseplane`]
//! in float, the raw words beside it).

use golden::geometry::RayGrid;

use super::Step;
use crate::array::{Array, Links, RunError};
use crate::cosim::capture;
use crate::pe::{Broadcast, Pe, Ports, Readout, StepError};
use crate::probes::{Ctrl, Stage};

/// The readout's registers in a PE, as `ercube_pe_readout` holds them
/// ([`crate::hw::readout_rtl`]): the valid word's read register (the row
/// it holds), the row being worked with its columns still to read, and
/// the compositing buffer's read register, which drives the host port.
#[derive(Debug, Clone, Default)]
pub struct ReadoutFsm {
    /// `BeginReadout` was broadcast and its clock (the read of row 0's
    /// valid word) has not run yet.
    start: bool,
    /// Rows of the held columns.
    rows: usize,
    /// The row whose valid word is in its read register.
    valid_row: Option<usize>,
    /// The row being worked.
    row: Option<usize>,
    /// Its columns to read, ascending (a priority encoder over the valid
    /// word in the RTL), and how many have been read.
    cols: Vec<usize>,
    done_cols: usize,
    /// The buffer's read register: the ray read last clock.
    read: Option<Readout>,
}

impl Pe {
    /// Rewinds the readout to its first clock.
    pub fn begin_readout(&mut self) {
        let f = &mut self.readout;
        f.rows = self.rays.iter().map(|c| c.acc.len()).max().unwrap_or(0);
        f.start = f.rows > 0;
        f.valid_row = None;
        f.row = None;
        f.cols.clear();
        f.done_cols = 0;
        f.read = None;
    }

    /// Whether every ray to stream has been read out of the compositing
    /// buffer and driven on the host port.
    pub fn readout_done(&self) -> bool {
        let f = &self.readout;
        !f.start && f.valid_row.is_none() && f.row.is_none() && f.read.is_none()
    }

    /// Whether ray `(c, r)` is streamed: the column has row `r` and, with
    /// `pass_skip_empty`, the ray is not all zero (its valid bit; the
    /// host's cleared baseplane already holds the zero ones).
    fn streamed(&self, c: usize, r: usize) -> bool {
        self.rays[c]
            .acc
            .get(r)
            .is_some_and(|a| !(self.sparse_passes && a.raw == [0; 4]))
    }

    /// The clocks [`Pe::readout_step`] runs from [`Pe::begin_readout`]
    /// until [`Pe::readout_done`], counted from the rays each row streams
    /// instead of clock by clock (the untraced readout, whose host writes
    /// the words from the buffer): the clock reading row 0's valid word,
    /// each row's as many as it streams rays, at least one, and one more
    /// driving the last ray when the last row streams one. Leaves the
    /// readout done, as its last clock does.
    pub(crate) fn readout_clocks(&mut self) -> u64 {
        let f = &mut self.readout;
        if !f.start {
            return 0;
        }
        let (mut clocks, mut last) = (1, 0);
        for r in 0..f.rows {
            last = (0..self.rays.len())
                .filter(|&c| {
                    self.rays[c]
                        .acc
                        .get(r)
                        .is_some_and(|a| !(self.sparse_passes && a.raw == [0; 4]))
                })
                .count() as u64;
            clocks += last.max(1);
        }
        f.start = false;
        f.valid_row = None;
        f.row = None;
        f.read = None;
        clocks + u64::from(last > 0)
    }

    /// One readout clock, as `ercube_pe_readout` runs it, row by row: the
    /// ray read last clock leaves the buffer's read register for the host
    /// port; the first clock reads row 0's valid word; then each clock
    /// reads the lowest column still to read in the row in hand, and the
    /// clock that leaves a row (its last ray read, or none to read) reads
    /// the next row's valid word. A row costs as many clocks as it has
    /// rays to stream, at least one; the readout two more.
    pub fn readout_step(&mut self, out: &mut Ports) {
        out.host = self.readout.read.take();
        if self.readout.start {
            self.readout.start = false;
            self.readout.valid_row = Some(0);
            return;
        }
        if self.readout.row.is_none() {
            if let Some(r) = self.readout.valid_row.take() {
                let mut cols = std::mem::take(&mut self.readout.cols);
                cols.clear();
                cols.extend((0..self.rays.len()).filter(|&c| self.streamed(c, r)));
                self.readout.cols = cols;
                self.readout.done_cols = 0;
                self.readout.row = Some(r);
            }
        }
        let f = &mut self.readout;
        if let Some(r) = f.row {
            if let Some(&c) = f.cols.get(f.done_cols) {
                f.done_cols += 1;
                let col = &self.rays[c];
                f.read = Some(Readout {
                    mx: col.mx,
                    row: r as u32,
                    acc: col.acc[r],
                });
            }
            if f.done_cols >= f.cols.len() {
                f.row = None;
                if r + 1 < f.rows {
                    f.valid_row = Some(r + 1);
                }
            }
        }
    }
}

/// The readout's cycle on a PE: [`Pe::readout_step`], streaming its next
/// ray on the host port (the twin of the host's read of
/// [`golden::warp::Baseplane`]'s rays before [`golden::warp::warp`]).
#[derive(Debug, Clone, Copy)]
pub struct StreamStep;

impl Step for StreamStep {
    fn ctrl(&self) -> Ctrl {
        Ctrl::at(Stage::Readout, 0, 0)
    }

    fn step(&mut self, pe: &mut Pe, _: Links<'_>, out: &mut Ports) -> Result<(), StepError> {
        pe.readout_step(out);
        Ok(())
    }
}

impl Array {
    /// Streams the rays of region 0 (grid `g`) out: raw words, row-major.
    pub(crate) fn readout(&mut self, g: &RayGrid) -> Result<Vec<[i64; 4]>, RunError> {
        let [w, h] = g.counts();
        let mut raw = vec![[0i64; 4]; w * h];
        self.clock.broadcast(&Broadcast::BeginReadout);
        if !self.clock.tracing() && !self.clocked {
            self.clock.readout_untraced(g, &mut raw);
            return Ok(raw);
        }
        let capture = self.clock.capture().cloned();
        if let Some(c) = &capture {
            capture::readout_begin(c, self.clock.cycle(), g, self.clock.pes());
        }
        // The host writes each word where its ray index puts it.
        let mut store =
            |o: &Readout| raw[o.row as usize * w + (o.mx - g.lo[0]) as usize] = o.acc.raw;
        while !self.clock.reports().all(|r| r.readout_done) {
            self.clock.tick(&mut StreamStep)?;
            for port in self.clock.ports() {
                if let Some(o) = &port.host {
                    store(o);
                }
            }
            if let Some(c) = &capture {
                capture::readout_tick(c, &self.clock);
            }
        }
        Ok(raw)
    }
}
