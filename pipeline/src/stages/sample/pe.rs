//! The PE's half of sampling: the broadcast of a sampling cycle, each
//! row's samples as planned (`plan.rs`) with the edge registers of
//! `edges.rs`, and the datapath of one sample (the
//! bit-exact twin of [`golden::sampling::sample_at`]), clocked
//! ([`Pe::sample_step`]) or a whole slice at once ([`Pe::sample_slice`]).

use crate::array::Links;
use crate::config::Order;
use crate::datapath::{Datapath, KernelRow, SampleTrace, Tally};
use crate::fixed::{Fx, QuantStats};
use crate::host::SlicePlan;
use crate::pe::{Pe, Ports, StepError};
use crate::shading::{outer_rows, Taps};

use super::edges::{EdgeIn, EdgeWords};

/// Where a voxel column the sample needs lives, seen from one PE.
enum Col {
    /// In this PE's memory.
    Own(usize),
    /// The right neighbour's first column.
    Right0,
    /// The right neighbour's second column.
    Right1,
    /// The left neighbour's last column.
    Left,
}

/// What the controller broadcasts in a sampling cycle.
#[derive(Debug, Clone, Copy)]
pub struct SampleBus<'a> {
    /// The slice being sampled.
    pub slice: &'a SlicePlan,
    /// Ray row sampled this cycle.
    pub my: i64,
    /// Row in the region's buffer.
    pub row: usize,
    /// Clamped voxel rows `y0, y0 + 1` and the y weight of this row.
    pub y: (usize, usize, Fx),
    /// The row's y position (`position`).
    pub yp: Fx,
    /// Cycle within the row.
    pub cycle: usize,
    /// Spacing-scaled y slope of this row and the region's z term.
    pub slope_yz: (Fx, Fx),
    /// Region slope constants on x: `b + m k`.
    pub slope_x: (Fx, Fx),
    /// Voxel rows and slice of the row sampled next cycle (for the edge
    /// voxels this PE drives now).
    pub next: Option<(usize, usize, usize)>,
    /// This cycle's number (a sample issued now is written back
    /// `latency` cycles later).
    pub now: u64,
}

/// The part of the bus that is constant over a row.
#[derive(Debug, Clone, Copy)]
pub struct RowBus<'a> {
    /// The slice being sampled.
    pub slice: &'a SlicePlan,
    /// Ray row.
    pub my: i64,
    /// Row in the region's buffer.
    pub row: usize,
    /// Clamped voxel rows `y0, y0 + 1` and the y weight.
    pub y: (usize, usize, Fx),
    /// The row's y position (`position`).
    pub yp: Fx,
    /// Spacing-scaled y slope of the row and the region's z term.
    pub slope_yz: (Fx, Fx),
    /// Region slope constants on x.
    pub slope_x: (Fx, Fx),
    /// The row's constants for the datapath's
    /// [`Kernel`](crate::datapath::Kernel) (the
    /// whole-slice path only, computed once for every PE).
    pub plain: Option<KernelRow>,
}

impl<'a> RowBus<'a> {
    /// The row part of a cycle's bus.
    pub fn of(b: &SampleBus<'a>) -> RowBus<'a> {
        RowBus {
            slice: b.slice,
            my: b.my,
            row: b.row,
            y: b.y,
            yp: b.yp,
            slope_yz: b.slope_yz,
            slope_x: b.slope_x,
            plain: None,
        }
    }
}

impl Pe {
    /// One sampling clock. `links.from_right` is what the right neighbour
    /// drove last cycle (its first column's voxels for this row).
    pub fn sample_step(
        &mut self,
        dp: &Datapath,
        bus: &SampleBus,
        links: Links<'_>,
        nx: usize,
        out: &mut Ports,
    ) -> Result<(), StepError> {
        let shade = dp.loaded.shade.is_some();
        self.drive_edge(bus.next, shade);
        self.drive_ports(out, shade);
        out.left.edge_valid = bus.next.is_some() && !self.cols.is_empty();
        let Some(&j) = self.row_plan.live(self.row_now).get(bus.cycle) else {
            self.counters.idle += 1;
            self.last.busy = false;
            return Ok(());
        };
        let flags = self.row_plan.flag(self.row_now, bus.cycle);
        let edge = EdgeIn {
            right: links.from_right.edge,
            halo: links.from_right.halo,
            left: links.from_left.edge,
        };
        self.sample_ray::<true>(dp, &RowBus::of(bus), (j, flags), &edge, nx, bus.now)
    }

    /// A stall cycle: the array holds a row back for a ray still in the
    /// datapath. The edge register holds its value; nothing is sampled.
    pub fn stall_step(&mut self, dp: &Datapath, out: &mut Ports) {
        self.counters.stalls += 1;
        self.hold_step(dp, out)
    }

    /// A cycle the array waits for the external ray buffer: the edge
    /// registers hold their values; nothing is sampled or counted.
    pub fn hold_step(&mut self, dp: &Datapath, out: &mut Ports) {
        self.last.busy = false;
        self.drive_ports(out, dp.loaded.shade.is_some());
    }

    /// The sample of held column `j` in the bus's row, issued in cycle
    /// `now`: the datapath of one busy cycle, shared by the clocked and the
    /// whole-slice paths. The result is computed here and written back
    /// `dp.latency` cycles later: nothing reads the ray's accumulators
    /// before then (the scoreboard in `land`, the drain), so computing
    /// early cannot be observed. With `TRACE` the cycle's words go to
    /// [`Pe::last`] for the waveforms; the whole-slice path, which never
    /// traces, skips that copy (and the accumulator read it needs).
    #[inline]
    fn sample_ray<const TRACE: bool>(
        &mut self,
        dp: &Datapath,
        bus: &RowBus,
        (j, flags): (usize, u8),
        edge_in: &EdgeIn,
        nx: usize,
        now: u64,
    ) -> Result<(), StepError> {
        // The quantisation counters live in a local while the sample runs:
        // then they can stay in registers across the datapath's two dozen
        // assignments instead of chaining loads and stores through the PE.
        let mut st = self.model.stats;
        let done = self.sample_datapath::<TRACE>(dp, bus, (j, flags), edge_in, (nx, now), &mut st);
        self.model.stats = st;
        done
    }

    /// [`Pe::sample_ray`]'s datapath, counting into `st`.
    #[inline(always)]
    fn sample_datapath<const TRACE: bool>(
        &mut self,
        dp: &Datapath,
        bus: &RowBus,
        (j, flags): (usize, u8),
        edge_in: &EdgeIn,
        (nx, now): (usize, u64),
        st: &mut QuantStats,
    ) -> Result<(), StepError> {
        self.counters.busy += 1;
        self.counters.samples += 1;
        let land = now + dp.latency;
        self.rays[j].land[bus.row] = land;
        self.drained_at = self.drained_at.max(land);
        let mx = self.rays[j].mx;
        let s = bus.slice;
        let x = dp.position(s.a[0], s.t[0], mx, st)?;
        let (x0, wx) = dp.address(x, st);
        let last = nx as i64 - 1;
        let (c0, c1) = (x0.clamp(0, last) as usize, (x0 + 1).clamp(0, last) as usize);
        if !self.owns(c0) {
            return Err(StepError::Ownership {
                pe: self.k,
                mx,
                column: c0,
            });
        }
        let (y0, y1, wy) = bus.y;
        let left = [self.voxel(s.z, y0, c0), self.voxel(s.z, y1, c0)];
        let right = if self.holds(c1) {
            [self.voxel(s.z, y0, c1), self.voxel(s.z, y1, c1)]
        } else if c1 == self.cols.end {
            self.counters.edge_voxels += 2;
            edge_in.right
        } else {
            return Err(StepError::Ownership {
                pe: self.k,
                mx,
                column: c1,
            });
        };
        let taps = match &dp.loaded.shade {
            Some(_) => {
                Some(self.taps(s.z, x0, (c0, c1), (y0, y1), (left, right), edge_in, nx, mx)?)
            }
            None => None,
        };
        let sample = dp.bilinear([[left[0], right[0]], [left[1], right[1]]], wx, wy, st)?;
        let row = bus.row;
        // The plain sample's words at issue, kept for a capture (the
        // accumulators before the sample).
        let issue = if TRACE {
            crate::cosim::capture::SampleIn {
                m: mx,
                a: s.a[0].raw(),
                t: s.t[0].raw(),
                b: bus.slope_x.0.raw(),
                k: bus.slope_x.1.raw(),
                wy: wy.raw(),
                sy: bus.slope_yz.0.raw(),
                sz: bus.slope_yz.1.raw(),
                acc: self.rays[j].acc[row],
                taps: [left[0], right[0], left[1], right[1]],
                x0,
                land,
                units: Default::default(),
            }
        } else {
            Default::default()
        };
        if let Some(unit) = &dp.loaded.preint {
            return self.preint_sample::<TRACE>(dp, unit, bus, (j, flags), (sample, issue), st);
        }
        let (mut rgb, mut alpha) = dp.classify(sample, st)?;
        let mut voi = crate::voi::VoiTrace::default();
        if let Some(unit) = &dp.loaded.voi {
            // Golden scales the classified opacity before it shades.
            let f;
            (f, voi) = unit.factor(&dp.cfg, (x, bus.yp, s.z), st)?;
            alpha = crate::voi::VoiUnit::scale(&dp.cfg, alpha, f, st);
        }
        let mut shade = Default::default();
        if let (Some(unit), Some(t)) = (&dp.loaded.shade, &taps) {
            // The gradient and shading of a sample that is visible
            // (golden's `c[3] > 0`): a clock-gated unit otherwise.
            if alpha.raw() > 0 {
                let g = unit.gradient(&dp.cfg, t, (wx, wy), st)?;
                (rgb, alpha, shade) = unit.shade(&dp.cfg, rgb, alpha, &g, st)?;
            }
        }
        let mut corrected = 0;
        let mut terminated = false;
        if alpha.raw() > 0 {
            // The ray's x slope `b + mx k`, in `position` like a position.
            let (b, k) = bus.slope_x;
            let sx = dp.position(b, k, mx, st)?;
            let ds = dp.path(sx, bus.slope_yz.0, bus.slope_yz.1, st)?;
            let a = dp.correct(alpha, ds, st)?;
            corrected = a.raw();
            let ray = &mut self.rays[j];
            if dp.cfg.order == Order::FrontToBack {
                dp.composite_ftb(&mut ray.acc[row], rgb, a, st)?;
                // The comparator behind the accumulator sets the flag the
                // next slice's schedule reads.
                terminated = dp.terminated(&ray.acc[row]);
                ray.ftb[row].done = terminated;
            } else {
                dp.composite_btf(&mut ray.acc[row], rgb, a, st)?;
            }
        }
        if TRACE {
            self.last = SampleTrace {
                busy: true,
                mx,
                row,
                acc: self.rays[j].acc[row],
                sample: sample.raw(),
                alpha: alpha.raw(),
                corrected,
                terminated,
                shade,
                voi,
                preint: Default::default(),
                issue: crate::cosim::capture::SampleIn {
                    units: crate::cosim::capture::UnitIn {
                        taps: taps
                            .as_ref()
                            .map_or([0; 16], crate::cosim::capture::UnitIn::shade_taps),
                        y: if dp.loaded.voi.is_some() {
                            bus.yp.raw()
                        } else {
                            0
                        },
                        z: if dp.loaded.voi.is_some() {
                            s.z as i64
                        } else {
                            0
                        },
                        pre: Default::default(),
                    },
                    ..issue
                },
            };
        }
        Ok(())
    }

    /// Where column `c` lives for this PE.
    fn locate(&self, c: usize, mx: i64) -> Result<Col, StepError> {
        let (s, e) = (self.cols.start, self.cols.end);
        if self.holds(c) {
            Ok(Col::Own(c))
        } else if self.cols.is_empty() {
            // A round-robin PE's aprons hold every tap; nothing crosses.
            Err(StepError::Ownership {
                pe: self.k,
                mx,
                column: c,
            })
        } else if c == e {
            Ok(Col::Right0)
        } else if c == e + 1 {
            Ok(Col::Right1)
        } else if c + 1 == s {
            Ok(Col::Left)
        } else {
            Err(StepError::Ownership {
                pe: self.k,
                mx,
                column: c,
            })
        }
    }

    /// Gathers the gradient's taps ([`Taps`]) around a sample at base
    /// column `x0` (unclamped) between clamped columns `c0`, `c1` and rows
    /// `y0`, `y1` of slice `z`, whose scalar taps `scalar` (columns `c0`,
    /// `c1` on both rows) are already read: the rest from this PE's
    /// memory (three slices, four rows) or the neighbours' ports.
    #[allow(clippy::too_many_arguments)]
    fn taps(
        &mut self,
        z: usize,
        x0: i64,
        (c0, c1): (usize, usize),
        (y0, y1): (usize, usize),
        scalar: ([u16; 2], [u16; 2]),
        edge: &EdgeIn,
        nx: usize,
        mx: i64,
    ) -> Result<Taps, StepError> {
        let last = nx as i64 - 1;
        let cm = (x0 - 1).clamp(0, last) as usize;
        let cp = (x0 + 2).clamp(0, last) as usize;
        let (ylo, yhi) = outer_rows(y0, y1, self.ny);
        let (zm, zp) = (z.saturating_sub(1), (z + 1).min(self.nz - 1));
        let rows = [y0, y1];
        let mut t = Taps::default();
        let mut used = 0;
        for (j, &row) in rows.iter().enumerate() {
            t.x[j][1] = scalar.0[j];
            t.x[j][2] = scalar.1[j];
            t.x[j][0] = match self.locate(cm, mx)? {
                Col::Own(c) => self.voxel(z, row, c),
                Col::Left => {
                    used += 1;
                    edge.left[j]
                }
                _ => {
                    return Err(StepError::Ownership {
                        pe: self.k,
                        mx,
                        column: cm,
                    })
                }
            };
            t.x[j][3] = match self.locate(cp, mx)? {
                Col::Own(c) => self.voxel(z, row, c),
                Col::Right0 => {
                    used += 1;
                    edge.right[j]
                }
                Col::Right1 => {
                    used += 1;
                    edge.halo[6 + j]
                }
                Col::Left => {
                    return Err(StepError::Ownership {
                        pe: self.k,
                        mx,
                        column: cp,
                    })
                }
            };
        }
        for (i, c) in [c0, c1].into_iter().enumerate() {
            match self.locate(c, mx)? {
                Col::Own(c) => {
                    t.y[i] = [self.voxel(z, ylo, c), self.voxel(z, yhi, c)];
                    for (k, zz) in [zm, zp].into_iter().enumerate() {
                        t.z[k][0][i] = self.voxel(zz, y0, c);
                        t.z[k][1][i] = self.voxel(zz, y1, c);
                    }
                }
                Col::Right0 => {
                    used += 6;
                    t.y[i] = [edge.halo[0], edge.halo[1]];
                    for k in 0..2 {
                        t.z[k][0][i] = edge.halo[2 + 2 * k];
                        t.z[k][1][i] = edge.halo[3 + 2 * k];
                    }
                }
                _ => {
                    return Err(StepError::Ownership {
                        pe: self.k,
                        mx,
                        column: c,
                    })
                }
            }
        }
        self.counters.edge_voxels += used;
        Ok(t)
    }

    /// Samples a whole slice without stepping cycle by cycle: row by row,
    /// each of this PE's rays in order, with the right neighbour's edge
    /// voxels for each row (`right_edges`, from [`Pe::edges_for`]). The
    /// arithmetic and every counter equal the clocked path's (a test proves
    /// it); only the interleaving of PEs within a cycle is gone, which no
    /// result can observe because PEs share nothing within a cycle.
    ///
    /// `lens[r]` is row `r`'s length in cycles (the busiest PE's count)
    /// and `starts[r]` the cycle its first sample issues; rows of length 0
    /// are skipped, and each row samples only its scheduled columns
    /// ([`Pe::begin_row`], as reported), in order, as the clocked
    /// schedule does. `stalls` is the slice's stall cycles.
    #[allow(clippy::too_many_arguments)]
    pub fn sample_slice(
        &mut self,
        dp: &Datapath,
        rows: &[RowBus],
        (lens, starts): (&[usize], &[u64]),
        stalls: u64,
        (right_edges, left_edges): (Option<&[EdgeWords]>, Option<&[EdgeWords]>),
        nx: usize,
    ) -> Result<(), StepError> {
        self.counters.stalls += stalls;
        if let Some(k) = dp
            .kernel()
            .filter(|_| rows.iter().all(|b| b.plain.is_some()))
        {
            let mut tally = Tally::default();
            let mut counts = super::plain::PlainCounts::default();
            let at = (nx, dp.latency);
            let out = (&mut tally, &mut counts);
            if self.sample_columns(k, rows, (lens, starts), right_edges, at, out) {
                k.settle(&mut tally);
                tally.add_to(&mut self.model.stats);
                self.add_plain_counts(&counts);
                return Ok(());
            }
        }
        for (r, bus) in rows.iter().enumerate() {
            self.begin_row(r);
            if lens[r] == 0 {
                continue;
            }

            let (rw, lw) = (
                right_edges.map_or_else(EdgeWords::default, |e| e[r]),
                left_edges.map_or_else(EdgeWords::default, |e| e[r]),
            );
            let edge = EdgeIn {
                right: rw.left,
                halo: rw.halo,
                left: lw.right,
            };
            let span = self.row_plan.span(r);
            self.counters.idle += (lens[r] - span.len()) as u64;
            if span.is_empty() {
                continue;
            }
            for (c, i) in span.enumerate() {
                let j = self.row_plan.live[i];
                let flags = self.row_plan.flags.get(i).copied().unwrap_or(0);
                let now = starts[r] + c as u64;
                self.sample_ray::<false>(dp, bus, (j, flags), &edge, nx, now)?;
            }
        }
        Ok(())
    }
}
