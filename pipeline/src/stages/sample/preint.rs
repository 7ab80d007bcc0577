//! Sampling's pre-integrated half ([`crate::preint`]): the controller's
//! runs of a pass (the compositing and keeping rays' runs and their union,
//! which the PEs schedule), what each scheduled ray does in the pass, and
//! the PE's step of the unit after the sample: composite the step between
//! this sample and the ray's previous one, slice 0's half step, and keep
//! the sample for the next step. Golden's twin is
//! [`golden::sampling::sample_region`]'s pre-integrated branch.

use super::{RowBus, RowRuns};
use crate::array::{Array, Skipper};
use crate::config::Order;
use crate::datapath::{Datapath, SampleTrace};
use crate::fixed::{Fx, QuantStats};
use crate::host::{PreStep, RegionPlan};
use crate::pe::{Pe, StepError};
use crate::preint::{PreintTrace, PreintUnit};

/// A skipping controller's runs of a pre-integrated pass, per row: of the
/// rays that composite and of those that keep their sample (the union is
/// what the PEs schedule).
#[derive(Debug, Clone, Default)]
pub struct PreRuns {
    /// The compositing rays' runs.
    pub comp: RowRuns,
    /// The keeping rays' runs.
    pub keep: RowRuns,
}

/// What a PE plans a pre-integrated pass's rows with: the pass's
/// broadcast, the first row's index `my0`, and a skipping controller's
/// runs (none: every ray of a rectangle takes its part).
#[derive(Debug, Clone, Copy)]
pub struct PrePlan<'a> {
    /// The pass's broadcast.
    pub step: PreStep,
    /// `my` of the slice's first row.
    pub my0: i64,
    /// The runs, when the controller skips.
    pub runs: Option<&'a PreRuns>,
}

impl PrePlan<'_> {
    /// What ray `(mx, my)`, the `r`-th row's, does in the pass:
    /// [`PRE_COMP`], [`PRE_KEEP`], [`PRE_LEAD`] (the PE's comparators on
    /// the broadcast rectangles and runs).
    pub(super) fn flags(&self, r: usize, mx: i64) -> u8 {
        let my = self.my0 + r as i64;
        let within = |rect: &[(i64, i64); 2]| PreStep::within(rect, mx, my);
        let runs_hold = |runs: &RowRuns| runs.row(r).iter().any(|&(a, b)| (a..=b).contains(&mx));
        let (c, k) = match self.runs {
            Some(p) => (runs_hold(&p.comp), runs_hold(&p.keep)),
            None => (true, true),
        };
        let s = &self.step;
        let mut f = 0;
        if c && within(&s.comp) {
            f |= PRE_COMP;
        }
        if k && within(&s.keep) {
            f |= PRE_KEEP;
        }
        // Slice 0's half step goes with slice 0's step: the pass's
        // composited one back to front, its kept one front to back.
        if (c || k) && within(&s.lead) {
            f |= PRE_LEAD;
        }
        f
    }
}

/// A ray composites the step between this sample and its previous one.
pub(crate) const PRE_COMP: u8 = 1;
/// A ray keeps this sample for its next step.
pub(crate) const PRE_KEEP: u8 = 2;
/// A ray composites slice 0's half step at this sample.
pub(crate) const PRE_LEAD: u8 = 4;

impl Array {
    /// The controller's runs of a pre-integrated pass over the slice's
    /// rows (`range`, the hull of the pass's rectangles): per row the
    /// runs of the rays that composite (`pre.comp` within its step's
    /// runs) and of those that keep their sample (`pre.keep` within its
    /// step's), into `pre_runs`, and their union, which the PEs schedule,
    /// into `runs`. A step's runs are golden's planner over the whole
    /// segment it integrates ([`golden::skip::SampleMask::substep_runs`]
    /// between the step's two ends, [`golden::sampling::preint_span`]).
    pub(super) fn plan_pre_runs(
        &self,
        sk: &Skipper,
        region: &RegionPlan,
        range: [(i64, i64); 2],
        pre: &PreStep,
        runs: &mut RowRuns,
        pre_runs: &mut PreRuns,
    ) {
        let view = &sk.view;
        let nz = view.dims[2];
        let g = &region.grid;
        // A step's two ends: the rays' positions where it begins and ends.
        let ends = |z: usize| {
            golden::sampling::preint_span(z, nz).map(|o| {
                let at = |k| g.at(view.eye, view.d, z as f64 + o, k);
                [at(0), at(1)]
            })
        };
        // Per slice, not per row: the ends are the pass's.
        let (comp_ends, keep_ends) = (pre.comp_z.map(ends), pre.keep_z.map(ends));
        pre_runs.comp.clear();
        pre_runs.keep.clear();
        let (mut tmp, mut union) = (Vec::new(), Vec::new());
        let mut merged: Vec<(i64, i64)> = Vec::new();
        for my in range[1].0..=range[1].1 {
            for (rect, z, step_ends, out) in [
                (&pre.comp, pre.comp_z, comp_ends, &mut pre_runs.comp),
                (&pre.keep, pre.keep_z, keep_ends, &mut pre_runs.keep),
            ] {
                tmp.clear();
                let in_rows = (rect[1].0..=rect[1].1).contains(&my);
                if let (true, Some(z), Some([f, b])) = (in_rows, z, step_ends) {
                    let ys = [f[1].a + my as f64 * f[1].t, b[1].a + my as f64 * b[1].t];
                    sk.mask.substep_runs(z, [f[0], b[0]], ys, rect[0], &mut tmp);
                }
                out.push_row(&tmp);
            }
            let r = pre_runs.comp.rows() - 1;
            union.clear();
            union.extend_from_slice(pre_runs.comp.row(r));
            union.extend_from_slice(pre_runs.keep.row(r));
            union.sort_unstable();
            // Merge overlapping or touching runs.
            merged.clear();
            for &(lo, hi) in &union {
                match merged.last_mut() {
                    Some(last) if lo <= last.1 + 1 => last.1 = last.1.max(hi),
                    _ => merged.push((lo, hi)),
                }
            }
            runs.push_row(&merged);
        }
    }
}

impl Pe {
    /// The pre-integrated half of a sample ([`crate::preint`]): with what
    /// the ray does in the pass (`flags`, from the broadcast [`PreStep`]
    /// and runs, [`PrePlan::flags`]), composites the step between this
    /// sample and the ray's previous one (back to front this sample is the
    /// step's front, front to back its back), slice 0's half step at this
    /// sample, and records the sample for the next step. Front to back the
    /// termination comparator reads the accumulators after a whole step
    /// only, as golden checks termination between slices (slice 0's half
    /// step and its whole one composite together).
    #[inline(always)]
    pub(super) fn preint_sample<const TRACE: bool>(
        &mut self,
        dp: &Datapath,
        unit: &PreintUnit,
        bus: &RowBus,
        (j, flags): (usize, u8),
        (sample, issue): (Fx, crate::cosim::capture::SampleIn),
        st: &mut QuantStats,
    ) -> Result<(), StepError> {
        let Some(pre) = bus.slice.pre else {
            // Every pass of a pre-integrated frame is planned with its
            // broadcast ([`crate::host::preint_passes`]).
            unreachable!("a pre-integrated frame samples only planned passes");
        };
        let (mx, row) = (self.rays[j].mx, bus.row);
        let comp = flags & PRE_COMP != 0;
        let lead = flags & PRE_LEAD != 0;
        let keep = flags & PRE_KEEP != 0;
        let ftb = dp.cfg.order == Order::FrontToBack;
        let mut trace = PreintTrace::default();
        let (mut corrected, mut terminated) = (0, false);
        // For a capture: the ray's previous sample as its register holds
        // it, and the accumulators between two steps.
        let prev_in = if TRACE {
            self.rays[j].prev.get(row).copied().unwrap_or(0)
        } else {
            0
        };
        let mut then = None;
        if comp || lead {
            let (b, k) = bus.slope_x;
            let sx = dp.position(b, k, mx, st)?;
            let ds = dp.path(sx, bus.slope_yz.0, bus.slope_yz.1, st)?;
            // A column without registers has recorded only zeros (a
            // migration leaves a zero word's registers unallocated).
            let prev = Fx::from_raw_unchecked(
                self.rays[j].prev.get(row).copied().unwrap_or(0),
                dp.cfg.sample,
            );
            let acc = &mut self.rays[j].acc[row];
            let step = |acc: &mut crate::datapath::Acc,
                        (s0, s1): (Fx, Fx),
                        half: bool,
                        st: &mut QuantStats| {
                let e = unit.lookup(&dp.cfg, s0, s1, st)?;
                let out = PreintUnit::step(dp, e, (ds, half), st)?;
                if let Some((rgb, a)) = out {
                    if ftb {
                        dp.composite_ftb(acc, rgb, a, st)?;
                    } else {
                        dp.composite_btf(acc, rgb, a, st)?;
                    }
                }
                Ok::<_, crate::fixed::FxError>((e[3].raw(), out.map_or(0, |o| o.1.raw())))
            };
            if ftb && lead {
                step(acc, (sample, sample), true, st)?;
                if TRACE && comp {
                    then = Some(*acc);
                }
            }
            if comp {
                let (front, back) = if ftb { (prev, sample) } else { (sample, prev) };
                (trace.tau, corrected) = step(acc, (front, back), pre.half, st)?;
                trace.back = back.raw();
                if TRACE && !ftb && lead {
                    then = Some(*acc);
                }
            }
            if !ftb && lead {
                step(acc, (sample, sample), true, st)?;
            }
            if ftb && comp {
                let ray = &mut self.rays[j];
                terminated = dp.terminated(&ray.acc[row]);
                ray.ftb[row].done = terminated;
            }
        }
        if keep {
            let ray = &mut self.rays[j];
            if ray.prev.is_empty() {
                // A column a merge or split made has no register yet: its
                // first pass allocates it (once per column and region).
                ray.prev = vec![0; ray.acc.len()];
            }
            ray.prev[row] = sample.raw();
        }
        if TRACE {
            self.last = SampleTrace {
                busy: true,
                mx,
                row,
                acc: self.rays[j].acc[row],
                sample: sample.raw(),
                alpha: 0,
                corrected,
                terminated,
                shade: Default::default(),
                voi: Default::default(),
                preint: trace,
                issue: crate::cosim::capture::SampleIn {
                    units: crate::cosim::capture::UnitIn {
                        pre: crate::cosim::capture::PreIn {
                            prev: prev_in,
                            step: comp || lead,
                            // The first step: front to back the lead's,
                            // back to front the one between two scalars.
                            lead: lead && (ftb || !comp),
                            half: pre.half,
                            then,
                        },
                        ..Default::default()
                    },
                    ..issue
                },
            };
        }
        Ok(())
    }
}
