//! The drain: before a stage that reads every accumulator (a merge, a
//! split, a fold, the readout) the controller waits until every PE reports
//! its datapath empty, i.e. the last sample it issued has been written
//! back `datapath_latency` cycles after it entered. Hardware only: golden
//! has no pipeline to drain ([`golden::methods::render`] composites a
//! sample as it is taken).

use crate::array::{Array, RunError};
use crate::probes::{Ctrl, Stage};
use crate::stages::Idle;

impl Array {
    /// Ticks until every PE's datapath is empty, then (with the rays'
    /// buffer in external memory) until every write-back has landed.
    pub(crate) fn drain(&mut self) -> Result<(), RunError> {
        loop {
            let now = self.clock.now();
            if self.clock.reports().all(|r| r.drained_at <= now) {
                return self.wait_for_ray_buffer();
            }
            self.clock.tick(&mut Idle(Ctrl::at(Stage::Drain, 0, 0)))?;
        }
    }
}
