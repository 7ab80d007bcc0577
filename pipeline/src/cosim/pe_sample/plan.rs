//! The row plan in the sample stage's capture: the slice's plans the PEs
//! made, checked against the declared memories and counted, and the
//! controller's runs written for the PEs' plan port (`plan.txt`).

use std::io::Write;

use super::PeCapture;
use crate::pe::Pe;
use crate::stages::sample::RowRuns;

impl PeCapture {
    /// The slice's row plans as the PEs made them from the `PlanRows`
    /// broadcast (`runs`), checked against the declared memories and
    /// counted (the RTL makes its own words from the runs on its plan
    /// port: the held columns inside the row's runs; front to back the PE
    /// leaves out those its termination bits mark).
    pub(super) fn plan(&mut self, first_row: usize, pes: &[Pe], runs: &RowRuns) {
        let s = self.shape;
        let rows = pes.iter().map(Pe::planned_rows).max().unwrap_or(0);
        let mut cols = Vec::new();
        for r in 0..rows {
            let row = first_row + r;
            let sampled = pes.iter().any(|p| p.planned(r).next().is_some());
            for (k, pe) in pes.iter().enumerate() {
                let (lo, active) = self.held[k];
                let mut n = 0;
                cols.clear();
                pe.run_ranges(runs.row(r), |js| cols.extend(js));
                if sampled && s.termination.is_some() {
                    self.terminated_in_rows +=
                        cols.iter().filter(|&&j| pe.rays[j].ftb[row].done).count() as u64;
                }
                for mx in cols.iter().map(|&j| pe.rays[j].mx) {
                    let i = if s.round_robin { 0 } else { mx - lo };
                    if i < 0 || i as u64 >= s.slots() {
                        self.unfit(format!(
                            "PE {k} plans column {mx} outside its held columns from {lo}"
                        ));
                        return;
                    }
                    n += 1;
                }
                if sampled {
                    self.skipped_in_rows += (active - n) as u64;
                }
                if row as u64 >= s.rays.max_rows {
                    self.unfit(format!(
                        "PE {k} plans row {row}, past the declared {} rows",
                        s.rays.max_rows
                    ));
                    return;
                }
            }
        }
    }

    /// The runs of the slice's sampled rows (`lens[r] > 0`) on the plan
    /// port, one a clock from clock `from` (clock, first run of its row,
    /// row, lo, hi).
    pub(super) fn write_runs(
        &mut self,
        from: u64,
        first_row: usize,
        runs: &RowRuns,
        lens: &[usize],
    ) -> std::io::Result<()> {
        let half = 1i64 << (self.shape.index_bits - 1);
        let mut clock = from;
        for r in (0..runs.rows()).filter(|&r| lens.get(r).is_some_and(|&n| n > 0)) {
            let row = first_row + r;
            for (i, &(lo, hi)) in runs.row(r).iter().enumerate() {
                if lo < -half || hi >= half {
                    self.unfit(format!(
                        "row {row}'s run {lo} ..= {hi} is past the plan port's {}-bit ray indices",
                        self.shape.index_bits
                    ));
                    return Ok(());
                }
                writeln!(
                    self.plan_port,
                    "{clock:x} {:x} {row:x} {:x} {:x}",
                    u8::from(i == 0),
                    lo as u64,
                    hi as u64
                )?;
                clock += 1;
                self.plan_runs += 1;
            }
        }
        Ok(())
    }
}
