//! The capture: every sample each PE's datapath issues in a frame, with
//! the words it took and the words it wrote back, recorded from the clocked
//! sample path.
//!
//! The clocked path already leaves each PE's last sampling cycle in
//! `Pe::last` for the waveform probes; in that same copy (compiled only
//! into the clocked path, `TRACE`) it keeps the sample's input bundle
//! ([`SampleIn`]). When a frame is run with a [`Capture`]
//! ([`crate::FrameRun::capture`]) the clock hands the busy PEs' bundles of
//! every sampling cycle to the capture's [`IssueSink`], and the frame runs
//! clocked (the same bits and cycles as the whole-slice path: the array's
//! tests compare them). Without one, nothing is recorded and nothing is
//! different: the whole-slice path never fills the bundle.

use std::sync::{Arc, Mutex};

use golden::geometry::RayGrid;

use crate::array::Clock;
use crate::datapath::{Acc, Datapath};
use crate::pe::{Pe, Readout};

/// The words a sample's datapath takes when it issues, as the model holds
/// them (raw words of their formats): the row broadcast, the ray index, the
/// ray's accumulators before the sample and the four voxel taps; and the
/// tap column it computed and the cycle its result is written back.
///
/// Golden twin: the arguments of `golden::sampling::sample_at`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SampleIn {
    /// Ray index `m` (the ray slot), port `slot_m`.
    pub m: i64,
    /// The slice's x position base (`position`), port `a`.
    pub a: i64,
    /// The slice's x position step per ray (`step`), port `t`.
    pub t: i64,
    /// The region's x slope base (`position`), port `b`.
    pub b: i64,
    /// The region's x slope step per ray (`step`), port `k`.
    pub k: i64,
    /// The row's y weight (`weight`), port `row_wy`.
    pub wy: i64,
    /// The row's y slope (`position`), port `sy`.
    pub sy: i64,
    /// The region's z slope (`position`), port `sz`.
    pub sz: i64,
    /// The ray's accumulators before the sample, ports `acc_r`..`acc_a`.
    pub acc: Acc,
    /// The voxel taps: row y0 at columns x0 and x0 + 1, then row y0 + 1
    /// (ports `v00`, `v01`, `v10`, `v11`), after the memory's clamping.
    pub taps: [u16; 4],
    /// The tap column `x0` (unclamped), output `x0`.
    pub x0: i64,
    /// The cycle the accumulators are written back (issue plus the
    /// model's `datapath_latency`).
    pub land: u64,
    /// The words the units take (zero without them).
    pub units: UnitIn,
}

/// The words a sample's units take beside the plain sample's
/// ([`crate::hw::compose`]): the shading unit's voxel taps other than the
/// scalar's four and the volume-of-interest stage's row and slice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct UnitIn {
    /// The gradient's taps in [`crate::hw::compose::SHADE_TAPS`]' order,
    /// ports `shade_tx_0_0` ... (zero without shading).
    pub taps: [u16; 16],
    /// The row's y position (`position`), port `voi_y`.
    pub y: i64,
    /// The slice index, port `voi_z`.
    pub z: i64,
    /// The pre-integration unit's words (zero unless pre-integrating).
    pub pre: PreIn,
}

/// The words a pre-integrated sample's unit takes
/// ([`crate::hw::compose`]'s `pre.*` ports) for the step the datapath
/// composites at issue, and, when the model's sample composites two
/// (back to front, slice 0's step and then its half step), what the
/// second step takes.
///
/// Golden twin: the pre-integrated branch of
/// `golden::sampling::sample_region` (a step between two scalars, and
/// slice 0's half step).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PreIn {
    /// The ray's previous sample (raw `sample`), port `pre_prev`.
    pub prev: i64,
    /// The sample composites a step, port `pre_step` (a sample that only
    /// keeps its scalar writes its accumulators back as they were).
    pub step: bool,
    /// The step is slice 0's half step at the sample, port `pre_lead`.
    pub lead: bool,
    /// The pass's step is half a slice step long (the last slice's, to
    /// the volume's face), port `pre_half`.
    pub half: bool,
    /// A second step in the same sample: the accumulators after the first
    /// (the second is the other kind: a lead step after a step between
    /// two scalars, or the reverse), written back with the second's
    /// result in [`Issue::out`].
    pub then: Option<Acc>,
}

impl PreIn {
    /// The two steps of `issue`, each as the datapath takes it: the first
    /// written back with the accumulators between the steps, the second
    /// reading them; `issue` itself when it composites at most one.
    pub fn steps(issue: &Issue) -> (Issue, Option<Issue>) {
        let p = issue.input.units.pre;
        let Some(mid) = p.then else {
            return (*issue, None);
        };
        let mut first = *issue;
        first.out = mid;
        first.input.units.pre.then = None;
        let mut second = first;
        second.input.acc = mid;
        second.input.units.pre.lead = !p.lead;
        second.out = issue.out;
        (first, Some(second))
    }
}

impl UnitIn {
    /// The gradient's taps of `t` in [`crate::hw::compose::SHADE_TAPS`]'
    /// order.
    pub fn shade_taps(t: &crate::shading::Taps) -> [u16; 16] {
        [
            t.x[0][0],
            t.x[0][3],
            t.x[1][0],
            t.x[1][3],
            t.y[0][0],
            t.y[0][1],
            t.y[1][0],
            t.y[1][1],
            t.z[0][0][0],
            t.z[0][0][1],
            t.z[0][1][0],
            t.z[0][1][1],
            t.z[1][0][0],
            t.z[1][0][1],
            t.z[1][1][0],
            t.z[1][1][1],
        ]
    }
}

/// One issued sample: its cycle, its PE, what it took and what it wrote
/// back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Issue {
    /// The cycle it issued (the frame's cycles count from 1).
    pub cycle: u64,
    /// The PE.
    pub pe: usize,
    /// What it took.
    pub input: SampleIn,
    /// The accumulators written back at `input.land` (unchanged for an
    /// invisible sample), outputs `acc_out_r`..`acc_out_a`.
    pub out: Acc,
}

/// Where a capture's issues go.
pub trait IssueSink: Send {
    /// The frame's datapath (configuration, tables and units), before its
    /// first cycle.
    fn begin(&mut self, _dp: &Datapath) {}
    /// One issued sample, in cycle order, PEs in index order within a
    /// cycle.
    fn issue(&mut self, issue: &Issue);
    /// The readout's start: every PE's compositing buffer and column map
    /// as the broadcast `BeginReadout` finds them.
    fn readout_begin(&mut self, _start: &ReadoutStart) {}
    /// One readout clock: every PE's host port in it and its
    /// `readout_done` report line after it.
    fn readout_tick(&mut self, _tick: &ReadoutTick) {}
    /// A dense split pass, every clock of it
    /// ([`crate::cosim::split`]), after its last clock.
    fn split_pass(&mut self, _pass: &crate::cosim::split::SplitCapture) {}
    /// A dense merge pass, every clock of it
    /// ([`crate::cosim::merge`]), after its last clock.
    fn merge_pass(&mut self, _pass: &crate::cosim::merge::MergeCapture) {}
    /// A dense fold pass, every clock of it
    /// ([`crate::cosim::fold`]), after its last clock.
    fn fold_pass(&mut self, _pass: &crate::cosim::fold::FoldCapture) {}
    /// A sampling clock's broadcast, before the clock runs
    /// ([`crate::cosim::pe_sample`]).
    fn sample_bus(&mut self, _bus: &crate::cosim::pe_sample::BusCycle) {}
    /// A slice's start: every PE as `BeginSlice` left it, after clock
    /// `cycle` ([`crate::cosim::pe_sample`]).
    fn slice_begin(&mut self, _cycle: u64, _z: usize, _pes: &[Pe]) {}
    /// The slice's rows are planned: every PE as `PlanRows` left it (its
    /// row `r` the region's `first_row + r`, sampling inside `runs.row(r)`),
    /// after clock `cycle` ([`crate::cosim::pe_sample`]).
    fn rows_planned(
        &mut self,
        _cycle: u64,
        _first_row: usize,
        _pes: &[Pe],
        _runs: &crate::stages::sample::RowRuns,
    ) {
    }
    /// A sampled slice's runs (its row `r` the region's `first_row + r`)
    /// of the rows that take clocks (`lens[r] > 0`) on the PEs' plan
    /// port, one a clock from clock `from` ([`crate::cosim::pe_sample`]).
    fn plan_runs(
        &mut self,
        _from: u64,
        _first_row: usize,
        _runs: &crate::stages::sample::RowRuns,
        _lens: &[usize],
    ) {
    }
}

/// One PE's rays at the readout's start: its held columns in order (the
/// column map's slots), each column's rows (the compositing buffer's words
/// of region 0, column after column).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PeRays {
    /// Each held column's ray index `mx`.
    pub mx: Vec<i64>,
    /// Each held column's row count.
    pub rows: Vec<usize>,
    /// The rays' raw words, column after column, row after row.
    pub words: Vec<[i64; 4]>,
}

/// What the readout starts from.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadoutStart {
    /// The cycle before the readout's first.
    pub cycle: u64,
    /// Region 0's first ray index along x.
    pub lo: i64,
    /// Region 0's rays along x and y.
    pub size: [usize; 2],
    /// Per PE.
    pub pes: Vec<PeRays>,
}

/// One readout clock as the model ran it.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadoutTick {
    /// The cycle.
    pub cycle: u64,
    /// Per PE, what its host port carried.
    pub host: Vec<Option<Readout>>,
    /// Per PE, its `readout_done` report after the clock.
    pub done: Vec<bool>,
}

/// Tells `capture` what the readout starts from.
pub(crate) fn readout_begin(capture: &Capture, cycle: u64, g: &RayGrid, pes: &[Pe]) {
    let start = ReadoutStart {
        cycle,
        lo: g.lo[0],
        size: g.counts(),
        pes: pes
            .iter()
            .map(|pe| PeRays {
                mx: pe.rays.iter().map(|c| c.mx).collect(),
                rows: pe.rays.iter().map(|c| c.acc.len()).collect(),
                words: pe
                    .rays
                    .iter()
                    .flat_map(|c| c.acc.iter().map(|a| a.raw))
                    .collect(),
            })
            .collect(),
    };
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .readout_begin(&start);
}

/// Hands `capture` the readout clock `clock` just ran.
pub(crate) fn readout_tick(capture: &Capture, clock: &Clock) {
    let tick = ReadoutTick {
        cycle: clock.cycle(),
        host: clock.ports().iter().map(|p| p.host).collect(),
        done: clock.reports().map(|r| r.readout_done).collect(),
    };
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .readout_tick(&tick);
}

/// A capture handed to a frame: the caller keeps its own handle on the
/// sink to read it afterwards.
pub type Capture = Arc<Mutex<dyn IssueSink>>;

/// Hands every PE that sampled in `cycle` to `capture`.
pub(crate) fn record(capture: &Capture, cycle: u64, pes: &[Pe]) {
    let mut sink = capture.lock().unwrap_or_else(|e| e.into_inner());
    for (pe, p) in pes.iter().enumerate() {
        if p.last.busy {
            sink.issue(&Issue {
                cycle,
                pe,
                input: p.last.issue,
                out: p.last.acc,
            });
        }
    }
}

/// Tells `capture` the frame's datapath.
pub(crate) fn begin(capture: &Capture, dp: &Datapath) {
    capture.lock().unwrap_or_else(|e| e.into_inner()).begin(dp);
}

/// A sink keeping the issues in memory (optionally only those issued in
/// a window of cycles) and the frame's table words.
#[derive(Debug, Clone, Default)]
pub struct Recorded {
    /// The issues kept, in capture order.
    pub issues: Vec<Issue>,
    /// The frame's tables by name ([`crate::hw::sample::MEMORIES`]), raw
    /// words.
    pub tables: Vec<(String, Vec<i64>)>,
    /// The units' per-frame ports ([`frame_words`]).
    pub frame: Vec<(String, i64)>,
    /// The model's write-back latency.
    pub latency: u64,
    /// Issues seen in all (kept or not).
    pub seen: u64,
    /// Whether issues in the window were dropped past the limit.
    pub overflow: bool,
    /// What the readout started from.
    pub readout: Option<ReadoutStart>,
    /// The readout's clocks.
    pub ticks: Vec<ReadoutTick>,
    window: Option<(u64, u64)>,
    limit: Option<usize>,
}

impl Recorded {
    /// Keeps every issue.
    pub fn new() -> Recorded {
        Recorded::default()
    }

    /// Keeps the issues of cycles `first..=last` only.
    pub fn window(first: u64, last: u64) -> Recorded {
        Recorded {
            window: Some((first, last)),
            ..Recorded::default()
        }
    }

    /// Keeps at most `n` issues; past them [`Recorded::overflow`] is set.
    pub fn limit(self, n: usize) -> Recorded {
        Recorded {
            limit: Some(n),
            ..self
        }
    }
}

/// The raw words of `dp`'s tables, named as the emitted module's
/// ([`crate::hw::sample::MEMORIES`], the shading unit's power table, the
/// pre-integration unit's banks [`crate::hw::preint::bank_name`]).
pub fn table_words(dp: &Datapath) -> Vec<(String, Vec<i64>)> {
    let t = dp.tables();
    let raw = |v: &[crate::fixed::Fx]| v.iter().map(|x| x.raw()).collect::<Vec<i64>>();
    let cols = [
        t.color.iter().map(|c| c[0].raw()).collect(),
        t.color.iter().map(|c| c[1].raw()).collect(),
        t.color.iter().map(|c| c[2].raw()).collect(),
        raw(&t.alpha),
        raw(&t.log_t),
        raw(&t.exp),
    ];
    let mut v: Vec<(String, Vec<i64>)> = crate::hw::sample::MEMORIES
        .iter()
        .zip(cols)
        .map(|(n, w)| ((*n).to_owned(), w))
        .collect();
    if let Some(unit) = &dp.loaded.shade {
        v.push((
            crate::hw::shading::POWER_TABLE.to_owned(),
            unit.power_words(),
        ));
    }
    if let Some(unit) = &dp.loaded.preint {
        for ch in 0..crate::hw::preint::CHANNELS.len() {
            for odd in [false, true] {
                v.push((
                    crate::hw::preint::bank_name(ch, odd),
                    unit.bank_words(ch, odd),
                ));
            }
        }
    }
    v
}

/// The per-frame ports of `dp`'s units, named as the composed module's
/// ([`crate::hw::compose`]: `shade_ka`, `voi_centre_x`, `pre_scale`, ...), raw words;
/// none for the plain sample.
pub fn frame_words(dp: &Datapath) -> Vec<(String, i64)> {
    let mut v = Vec::new();
    let name = |p: &str, n: &str| crate::hw::pipeline_rtl::verilog_name(&format!("{p}{n}"));
    if let Some(unit) = &dp.loaded.voi {
        v.extend(
            unit.port_words()
                .into_iter()
                .map(|(n, w)| (name("voi.", &n), w)),
        );
    }
    if let Some(unit) = &dp.loaded.shade {
        v.extend(
            unit.port_words()
                .into_iter()
                .map(|(n, w)| (name("shade.", &n), w)),
        );
    }
    if let Some(unit) = &dp.loaded.preint {
        v.push((name("pre.", "scale"), unit.scale().raw()));
    }
    v
}

impl IssueSink for Recorded {
    fn begin(&mut self, dp: &Datapath) {
        self.tables = table_words(dp);
        self.frame = frame_words(dp);
        self.latency = dp.latency;
    }

    fn readout_begin(&mut self, start: &ReadoutStart) {
        self.readout = Some(start.clone());
    }

    fn readout_tick(&mut self, tick: &ReadoutTick) {
        self.ticks.push(tick.clone());
    }

    fn issue(&mut self, issue: &Issue) {
        self.seen += 1;
        if self
            .window
            .is_none_or(|(a, b)| (a..=b).contains(&issue.cycle))
        {
            if self.limit.is_some_and(|n| self.issues.len() >= n) {
                self.overflow = true;
            } else {
                self.issues.push(*issue);
            }
        }
    }
}
