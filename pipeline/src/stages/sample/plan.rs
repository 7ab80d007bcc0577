//! The PE's row schedule for a slice: the runs the controller
//! broadcasts for each row ([`RowRuns`]), the held columns each row
//! samples and each row's report to the controller ([`Pe::plan_rows`],
//! kept in a [`RowPlan`]), planned before the slice samples.

use crate::pe::Pe;

use super::preint::PrePlan;

/// One slice's schedules as the PE planned them ([`Pe::plan_rows`]), row
/// by row: the held columns each row samples, in issue order, how many
/// in-run columns were terminated, and the row's report. Reused from
/// slice to slice.
#[derive(Debug, Clone, Default)]
pub struct RowPlan {
    /// Every row's columns (indices into the rays), row after row.
    pub(super) live: Vec<usize>,
    /// Where each row's columns end in `live`.
    ends: Vec<usize>,
    /// Each row's terminated in-run columns.
    terminated: Vec<u64>,
    /// Each row's report: columns sampled, earliest start.
    reports: Vec<(usize, u64)>,
    /// In a pre-integrated pass, what each of `live` does
    /// ([`PrePlan::flags`]); empty otherwise.
    pub(super) flags: Vec<u8>,
}

impl RowPlan {
    /// Where row `r`'s columns lie in `live`.
    pub(super) fn span(&self, r: usize) -> std::ops::Range<usize> {
        r.checked_sub(1).map_or(0, |q| self.ends[q])..self.ends[r]
    }

    /// Row `r`'s columns, in issue order (none before a slice is planned).
    pub(super) fn live(&self, r: usize) -> &[usize] {
        if r < self.ends.len() {
            &self.live[self.span(r)]
        } else {
            &[]
        }
    }

    /// What row `r`'s `c`-th column does in a pre-integrated pass (0
    /// otherwise).
    pub(super) fn flag(&self, r: usize, c: usize) -> u8 {
        self.flags.get(self.span(r).start + c).copied().unwrap_or(0)
    }

    fn clear(&mut self) {
        self.live.clear();
        self.ends.clear();
        self.terminated.clear();
        self.reports.clear();
        self.flags.clear();
    }
}

/// The runs of ray indices each row of a slice samples, as the controller
/// broadcasts them (mirroring `golden::skip::SampleMask::row_runs`): one
/// flat list with per-row offsets, reused from slice to slice.
#[derive(Debug, Clone, Default)]
pub struct RowRuns {
    runs: Vec<(i64, i64)>,
    starts: Vec<usize>,
}

impl RowRuns {
    /// Rows held.
    pub fn rows(&self) -> usize {
        self.starts.len()
    }

    /// Forgets every row.
    pub fn clear(&mut self) {
        self.runs.clear();
        self.starts.clear();
    }

    /// Appends the next row's runs (ascending, disjoint).
    pub fn push_row(&mut self, runs: &[(i64, i64)]) {
        self.starts.push(self.runs.len());
        self.runs.extend_from_slice(runs);
    }

    /// Row `r`'s runs.
    pub fn row(&self, r: usize) -> &[(i64, i64)] {
        let end = self.starts.get(r + 1).copied().unwrap_or(self.runs.len());
        &self.runs[self.starts[r]..end]
    }
}

impl Pe {
    /// The active held columns inside each of a row's `runs` (ascending:
    /// what the controller broadcasts from the occupancy memory and the
    /// clip planes, a comparator pair per PE), as ranges of indices into
    /// the rays, in order. The held columns ascend in `mx` and the runs
    /// are ascending and disjoint, so each run's ends are found by
    /// bisection (the comparator pair's answer): a row costs its runs, not
    /// every held column. The held columns must be contiguous
    /// ([`Pe::plan_rows`] makes them so).
    pub(crate) fn run_ranges(
        &self,
        runs: &[(i64, i64)],
        mut visit: impl FnMut(std::ops::Range<usize>),
    ) {
        let (first, n) = self.active;
        let active = &self.rays.as_slices().0[first..first + n];
        // No run reaches the active columns (the comparators' answer for
        // the row's outermost run ends): nothing to visit.
        let (Some(&(lo, _)), Some(&(_, hi))) = (runs.first(), runs.last()) else {
            return;
        };
        if n == 0 || active[0].mx > hi || active[n - 1].mx < lo {
            return;
        }
        // The held columns' `mx` ascend strictly, so when the first and
        // the last lie `n - 1` apart they are consecutive, and the columns
        // below `x` number `x - mx0` (clamped to `0..=n`): the bisection's
        // answer without reading the columns between.
        let (mx0, dense) = (
            active[0].mx,
            active[n - 1].mx - active[0].mx == n as i64 - 1,
        );
        let below = |x: i64| x.saturating_sub(mx0).clamp(0, n as i64) as usize;
        let up_to = |x: i64| x.saturating_sub(mx0).saturating_add(1).clamp(0, n as i64) as usize;
        let mut from = 0;
        for &(lo, hi) in runs {
            let (a, b) = if dense {
                let a = from.max(below(lo));
                (a, a.max(up_to(hi)))
            } else {
                let a = from + active[from..].partition_point(|c| c.mx < lo);
                (a, a + active[a..].partition_point(|c| c.mx <= hi))
            };
            if a < b {
                visit(first + a..first + b);
            }
            from = b;
            if from == n {
                break;
            }
        }
    }

    /// Visits the held columns inside `row`'s `runs` ([`Pe::run_ranges`]),
    /// in order: `visit(j, live)`, `live` false for a column whose
    /// termination flag is set (front to back), which the row does not
    /// sample. Returns how many in-run columns were terminated.
    fn schedule(
        &self,
        row: usize,
        runs: &[(i64, i64)],
        ftb: bool,
        mut visit: impl FnMut(usize, bool),
    ) -> u64 {
        let mut terminated = 0;
        // Contiguous: `run_ranges` needs it too.
        let rays = self.rays.as_slices().0;
        self.run_ranges(runs, |cols| {
            for j in cols {
                let live = !(ftb && rays[j].ftb[row].done);
                terminated += u64::from(!live);
                visit(j, live);
            }
        });
        terminated
    }

    /// Schedules the slice's rows `first_row..first_row + n` (the `r`-th
    /// in `runs.row(r)`; in a pre-integrated pass each column with what it
    /// does there, from `pre`) and reports, for each, how many columns this PE
    /// samples in it (see [`Pe::begin_row`]) and the earliest cycle the
    /// row may start so that each of them issues after its accumulators
    /// were written back (its `c`-th column issues `c` cycles after the
    /// start) and, front to back, so that every in-run column whose flag
    /// is set has had its last write-back land in a clock before the
    /// row's first issue (the PE reads the row's termination bits in the
    /// clock before it, [`crate::hw::pe_sample_rtl`]):
    /// [`Pe::row_reports`]. The controller runs each row for as
    /// many cycles as the largest count, from the latest start (a max tree
    /// over the PEs' report lines, the one signal besides the broadcast
    /// that is not nearest-neighbour).
    ///
    /// The rows are scheduled before the slice samples, and each schedule
    /// is kept for [`Pe::begin_row`]. Nothing a schedule reads changes in
    /// between: the held columns stay, and a row's termination flags
    /// change only when that row samples, after it began.
    ///
    /// `waits` is false when no held ray's accumulators are written back
    /// after the slice's first cycle (front to back, in it or after): then
    /// no row can wait for one, and
    /// the reports' starts are 0 instead of reading every ray's
    /// scoreboard (the same schedule).
    pub fn plan_rows(
        &mut self,
        first_row: usize,
        n: usize,
        runs: &RowRuns,
        (ftb, waits): (bool, bool),
        pre: Option<&PrePlan>,
    ) {
        let mut plan = std::mem::take(&mut self.row_plan);
        plan.clear();
        self.rays.make_contiguous();
        if !ftb && pre.is_none() {
            // No termination flag and no step flags: a row's columns are
            // its run ranges whole, and its start waits (when rays may
            // still be written back) for the latest of their scoreboards,
            // the `k`-th column's less the `k` cycles it issues after the
            // start.
            let rays = self.rays.as_slices().0;
            for r in 0..n {
                let row = first_row + r;
                let start = plan.live.len();
                let mut ready = 0;
                self.run_ranges(runs.row(r), |cols| {
                    if waits {
                        let k0 = (plan.live.len() - start) as u64;
                        for (k, ray) in (k0..).zip(&rays[cols.clone()]) {
                            ready = ready.max(ray.land[row].saturating_sub(k));
                        }
                    }
                    plan.live.extend(cols);
                });
                plan.ends.push(plan.live.len());
                plan.terminated.push(0);
                plan.reports.push((plan.live.len() - start, ready));
            }
            self.row_plan = plan;
            return;
        }
        let rays = self.rays.as_slices().0;
        for r in 0..n {
            let row = first_row + r;
            let (mut k, mut ready) = (0, 0);
            let terminated = self.schedule(row, runs.row(r), ftb, |j, live| {
                if !live {
                    // The PE reads the row's termination bits in the clock
                    // before its first issue, forwarding a write-back of
                    // that clock: the flag's write-back must land before
                    // the row starts.
                    let land = rays[j].land[row];
                    if waits && land > 0 {
                        ready = ready.max(land + 1);
                    }
                    return;
                }
                if waits {
                    ready = ready.max(rays[j].land[row].saturating_sub(k as u64));
                }
                k += 1;
                plan.live.push(j);
                if let Some(p) = pre {
                    plan.flags.push(p.flags(r, rays[j].mx));
                }
            });
            plan.ends.push(plan.live.len());
            plan.terminated.push(terminated);
            plan.reports.push((k, ready));
        }
        self.row_plan = plan;
    }

    /// The ray indices this PE samples in the slice's `r`-th row, in
    /// issue order, as [`Pe::plan_rows`] planned them (none past the
    /// planned rows).
    pub fn planned(&self, r: usize) -> impl Iterator<Item = i64> + '_ {
        self.row_plan.live(r).iter().map(|&j| self.rays[j].mx)
    }

    /// Rows the last [`Pe::plan_rows`] planned.
    pub fn planned_rows(&self) -> usize {
        self.row_plan.ends.len()
    }

    /// What this PE reported for each of the slice's rows
    /// ([`Pe::plan_rows`]), in row order: the columns it samples there
    /// and the earliest start.
    pub fn row_reports(&self) -> &[(usize, u64)] {
        &self.row_plan.reports
    }

    /// Schedules the slice's `r`-th row as its report planned it: its
    /// columns inside the row's runs (front to back only the live ones),
    /// one per cycle; rays left out cost no cycle. Counts the terminated
    /// ones.
    pub fn begin_row(&mut self, r: usize) {
        self.row_now = r;
        self.counters.terminated += self.row_plan.terminated[r];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::ColumnMap;
    use crate::pe::{RayColumn, VoxelMem};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]
        /// Without termination flags, scoreboards or step flags, the row
        /// plan found from the runs' ends is every active column inside a
        /// run, and the plan visiting ray by ray (which the
        /// scoreboard-reading plan does, every ray written back).
        #[test]
        fn a_plan_by_run_ends_is_the_plan_by_rays(
            mxs in proptest::collection::btree_set(-40i64..40, 0..30),
            rows in proptest::collection::vec(
                proptest::collection::vec((-50i64..50, 0i64..12), 0..5), 1..6),
            skip in 0usize..4,
            consecutive in proptest::option::of(-45i64..20),
        ) {
            // Consecutive columns take `run_ranges`' arithmetic answer,
            // the others its bisection.
            let mxs: Vec<i64> = match consecutive {
                Some(m0) => (m0..m0 + mxs.len() as i64).collect(),
                None => mxs.into_iter().collect(),
            };
            let dims = [8, 6, 2];
            let mut pe = Pe::new(0, ColumnMap::blocks(1, 8), &(0..8).collect::<Vec<_>>(),
                VoxelMem::Words(vec![0; 8 * 6 * 2]), dims);
            pe.set_rays(mxs.iter().map(|&mx| RayColumn::empty(mx, 6, false)).collect());
            let held = pe.rays.len();
            pe.active = (skip.min(held), held - skip.min(held));
            let mut runs = RowRuns::default();
            for row in &rows {
                // Ascending, disjoint runs from starts and lengths.
                let mut at = i64::MIN;
                let mut row_runs = Vec::new();
                for &(lo, len) in row {
                    let lo = lo.max(at);
                    row_runs.push((lo, lo + len));
                    at = lo + len + 1;
                }
                runs.push_row(&row_runs);
            }
            let n = rows.len();
            pe.plan_rows(0, n, &runs, (false, false), None);
            let fast = (pe.row_plan.live.clone(), pe.row_plan.ends.clone(), pe.row_plan.reports.clone());
            pe.plan_rows(0, n, &runs, (false, true), None);
            let slow = (pe.row_plan.live.clone(), pe.row_plan.ends.clone(), pe.row_plan.reports.clone());
            // Each row's columns by definition: every active one whose
            // index lies in one of the row's runs, in order.
            let (first, count) = pe.active;
            let (mut live, mut ends, mut reports) = (Vec::new(), Vec::new(), Vec::new());
            for r in 0..n {
                let before = live.len();
                live.extend((first..first + count).filter(|&j| {
                    runs.row(r).iter().any(|&(lo, hi)| (lo..=hi).contains(&pe.rays[j].mx))
                }));
                ends.push(live.len());
                reports.push((live.len() - before, 0));
            }
            prop_assert_eq!(&fast, &(live, ends, reports));
            prop_assert_eq!(fast, slow);
        }
    }
}
