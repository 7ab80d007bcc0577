//! The readout: each PE streams its region-0 rays to the host, one per
//! cycle on its host port, column by column and row by row; the host
//! writes each word where its ray index puts it in the baseplane (cleared
//! first: with `pass_skip_empty` the PEs leave their zero rays out) that
//! [`golden::warp::warp`] then resamples (a [`golden::warp::Baseplane`]
//! in float, the raw words beside it).

use golden::geometry::RayGrid;

use crate::array::{Array, RunError};
use crate::cosim::capture;
use crate::pe::{Broadcast, Pe, Ports, Readout};
use crate::probes::{Ctrl, Stage};

impl Pe {
    /// Rewinds the readout cursor to the first ray it streams.
    pub fn begin_readout(&mut self) {
        self.readout_at = (0, 0);
        self.readout_read = None;
        self.skip_empty();
    }

    /// Whether every held ray has been read out of the compositing buffer
    /// and its read register has driven the host port.
    pub fn readout_done(&self) -> bool {
        self.readout_at.0 >= self.rays.len() && self.readout_read.is_none()
    }

    /// The cursor's next position after `(c, r)`: the next row of the
    /// column, or the next column's first.
    fn after(&self, (c, r): (usize, usize)) -> (usize, usize) {
        if self.rays.get(c).is_some_and(|col| r + 1 < col.acc.len()) {
            (c, r + 1)
        } else {
            (c + 1, 0)
        }
    }

    /// Moves the cursor past columns without rows (an empty region).
    fn skip_empty(&mut self) {
        while self
            .rays
            .get(self.readout_at.0)
            .is_some_and(|col| col.acc.is_empty())
        {
            self.readout_at = (self.readout_at.0 + 1, 0);
        }
    }

    /// One readout clock, as `ercube_pe_readout` does it: the ray read
    /// last clock leaves the buffer's read register for the host port
    /// (with `pass_skip_empty`, an all-zero word is left off: the host's
    /// cleared baseplane already holds it), and the ray under the cursor
    /// is read. Every held ray costs a clock, zero or not, plus one for
    /// the first read.
    pub fn readout_step(&mut self, out: &mut Ports) {
        out.host = self
            .readout_read
            .take()
            .filter(|o| !(self.sparse_passes && o.acc.raw == [0; 4]));
        let (c, r) = self.readout_at;
        if let Some(col) = self.rays.get(c) {
            self.readout_read = Some(Readout {
                mx: col.mx,
                row: r as u32,
                acc: col.acc[r],
            });
            self.readout_at = self.after((c, r));
        }
        self.skip_empty();
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
            self.clock
                .tick(Ctrl::at(Stage::Readout, 0, 0), |pe, _, out| {
                    pe.readout_step(out);
                    Ok(())
                })?;
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
