//! The array's one clock: a two-phase tick that every stage uses.
//!
//! In a tick each PE steps from its own state, the [`Links`] (what its
//! neighbours drove on their ports in the previous cycle, read only) and the
//! controller's broadcast, which the step closure captures, and writes
//! what it drives this cycle into its next port registers, handed to it
//! idle (in place: a PE's `Ports` is a few hundred bytes, and copying them
//! out of every step was a tenth of a frame). Only after every PE has stepped do
//! the new port outputs commit, so the order in which PEs step cannot
//! matter (tests step them in other orders and compare every bit).
//!
//! The tick counts the cycle under its [`Stage`] and records the probes.
//! No stage counts cycles of its own: [`StageCycles`] is what the ticks
//! counted (the untraced whole-slice sampling path and the untraced dense
//! merge add the cycles the clocked path would have ticked, and tests
//! compare the two).
//!
//! A step cannot reach another PE's state: it receives `&mut Pe` for its
//! own and [`Links`] (shared references to port registers), and while [`Clock::tick`] holds the array
//! mutably nothing else can borrow the PEs:
//!
//! ```compile_fail
//! # use pipeline::array::{Clock, Links};
//! # use pipeline::probes::{Ctrl, Stage};
//! # fn f(clock: &mut Clock) {
//! // A step that peeks at PE 0's rays does not compile.
//! clock.tick(Ctrl::at(Stage::Sample, 0, 0), |pe, _links: Links, _out| {
//!     let _ = clock.pes()[0].rays.len();
//!     Ok(())
//! });
//! # }
//! ```

mod eval;
mod events;

use crate::datapath::Acc;
use crate::pe::{Broadcast, Pe, PeReport, Port, Ports, RayColumn, StepError, VoxelMem};
use crate::probes::{Ctrl, Probes, Stage};
use crate::stages::sample::EdgeWords;

use super::warm::each_mut;
use super::StageCycles;

/// What a PE receives from its neighbours in a cycle: read-only views of
/// the port registers they drove towards it in the previous cycle (the
/// committed outputs, never their state). An end PE's missing neighbour
/// drives nothing, or in a ring only the rays on the wrap link.
#[derive(Debug, Clone, Copy)]
pub struct Links<'a> {
    /// What PE `k - 1` drove on its right port.
    pub from_left: &'a Port,
    /// What PE `k + 1` drove on its left port.
    pub from_right: &'a Port,
}

/// Steps every PE in `order` on the committed `ports.0`, writing what each
/// drives into `ports.1`: PE `k` sees PE `k - 1`'s right port and PE
/// `k + 1`'s left one, and in a `ring` the end PEs see each other's rays.
fn step_all(
    pes: &mut [Pe],
    (ports, next): (&[Ports], &mut [Ports]),
    order: &[usize],
    ring: bool,
    mut step: impl FnMut(&mut Pe, Links<'_>, &mut Ports) -> Result<(), StepError>,
) -> Result<(), StepError> {
    let p = pes.len();
    let (wrap_in_first, wrap_in_last) = if ring {
        (
            Port {
                ray: ports[p - 1].right.ray,
                ..IDLE
            },
            Port {
                ray: ports[0].left.ray,
                ..IDLE
            },
        )
    } else {
        (IDLE, IDLE)
    };
    for &k in order {
        let links = Links {
            from_left: if k > 0 {
                &ports[k - 1].right
            } else {
                &wrap_in_first
            },
            from_right: if k + 1 < p {
                &ports[k + 1].left
            } else {
                &wrap_in_last
            },
        };
        // The step drives its outputs into the register it starts from
        // idle, in place (a `Ports` is a few hundred bytes).
        let out = &mut next[k];
        *out = IDLE_PORTS;
        step(&mut pes[k], links, out)?;
    }
    Ok(())
}

/// Both ports driving nothing.
const IDLE_PORTS: Ports = Ports {
    left: IDLE,
    right: IDLE,
    host: None,
};

/// The port of a missing neighbour.
const IDLE: Port = Port {
    edge: [0; 2],
    halo: [0; 8],
    edge_valid: false,
    edge_acc: Acc { raw: [0; 4] },
    edge_mx: None,
    ray: None,
};

/// The PEs, their committed port outputs, the cycle counter, the cycles
/// per stage and the probes.
pub struct Clock {
    pes: Vec<Pe>,
    ports: Vec<Ports>,
    spare: Vec<Ports>,
    order: Vec<usize>,
    cycle: u64,
    stages: StageCycles,
    probes: Option<Probes>,
    /// The capture of the datapath's issues ([`crate::cosim::capture`]).
    capture: Option<crate::cosim::capture::Capture>,
    /// A stepped frame's handover to its caller ([`crate::stepper`]).
    tap: Option<crate::stepper::Tap>,
    /// Whether PE `P - 1`'s right port drives PE 0's left (a ray-only wrap
    /// link: the round-robin mappings' migrations go around a ring).
    ring: bool,
    /// The untraced sampler's scratch: each PE's edge words in each of the
    /// slice's rows, read with the row plans (reused from slice to slice;
    /// no chip state).
    edge_rows: Vec<Vec<EdgeWords>>,
}

impl Clock {
    pub(crate) fn new(pes: Vec<Pe>, probes: Option<Probes>) -> Clock {
        let p = pes.len();
        Clock {
            pes,
            ports: vec![Ports::default(); p],
            spare: vec![Ports::default(); p],
            order: (0..p).collect(),
            cycle: 0,
            stages: StageCycles::default(),
            probes,
            capture: None,
            tap: None,
            ring: false,
            edge_rows: Vec::new(),
        }
    }

    /// The PEs (read only: the controller's report lines and the host).
    pub fn pes(&self) -> &[Pe] {
        &self.pes
    }

    /// Hands the controller's broadcast `b` to every PE, which applies it
    /// to its own state ([`Pe::on_broadcast`]) between cycles. A PE's
    /// whole-slice work runs the PEs on the pool's threads (they share
    /// nothing, so the order cannot matter); a slice's row plan for the
    /// untraced sampler also reads each PE's edge words in its rows
    /// ([`crate::pe::EdgeRead`]), in the same step.
    pub fn broadcast(&mut self, b: &Broadcast<'_>) {
        if let Some(t) = self.tap.as_mut() {
            t.command(b);
        }
        if let Broadcast::PlanRows {
            runs,
            edges: Some(e),
            ..
        } = *b
        {
            // The untraced sampler's edge words, read while each PE plans.
            let mut edges = std::mem::take(&mut self.edge_rows);
            edges.resize_with(self.pes.len(), Vec::new);
            let mut pairs: Vec<_> = self.pes.iter_mut().zip(&mut edges).collect();
            each_mut(&mut pairs, |_, (pe, out)| {
                pe.on_broadcast(b);
                pe.edges_for(e.z, (e.rows, runs), e.shade, out);
            });
            drop(pairs);
            self.edge_rows = edges;
        } else if b.heavy() {
            each_mut(&mut self.pes, |_, pe| pe.on_broadcast(b));
        } else {
            for pe in &mut self.pes {
                pe.on_broadcast(b);
            }
        }
    }

    /// Every PE's report lines, in PE order: what the controller reads of
    /// the PEs between cycles.
    pub fn reports(&self) -> impl Iterator<Item = PeReport> + '_ {
        self.pes.iter().map(Pe::report)
    }

    /// Every PE's row reports of the slice it planned, in PE order
    /// ([`Pe::row_reports`]: per row, the rays it samples and the earliest
    /// start its scoreboards allow).
    pub fn row_reports(&self) -> impl Iterator<Item = &[(usize, u64)]> + '_ {
        self.pes.iter().map(Pe::row_reports)
    }

    /// The host writes column `col` into PE `k`'s compositing buffer
    /// before a frame's first cycle (a region's empty rays).
    pub(crate) fn load_column(&mut self, k: usize, col: RayColumn) {
        self.pes[k].rays.push_back(col);
    }

    /// Takes every PE's voxel memory back at the frame's end (kept
    /// resident for the next frame), leaving the PEs empty.
    pub(crate) fn take_memories(&mut self) -> Vec<VoxelMem> {
        self.pes.iter_mut().map(Pe::take_memory).collect()
    }

    /// The port outputs committed in the last cycle.
    pub fn ports(&self) -> &[Ports] {
        &self.ports
    }

    /// Cycles ticked so far.
    pub fn cycle(&self) -> u64 {
        self.cycle
    }

    /// The number of the cycle the next tick runs.
    pub fn now(&self) -> u64 {
        self.cycle + 1
    }

    /// Cycles per stage so far.
    pub fn stages(&self) -> StageCycles {
        self.stages
    }

    /// Closes the line of PEs into a ring for migrating rays: the wrap
    /// link carries rays only, never edge voxels or a pass's edge rays
    /// (the passes run on column blocks, whose ends have no neighbour).
    pub(crate) fn set_ring(&mut self, on: bool) {
        self.ring = on && self.pes.len() > 1;
    }

    pub(crate) fn set_order(&mut self, order: Vec<usize>) {
        self.order = order;
    }

    pub(crate) fn tracing(&self) -> bool {
        self.probes.is_some()
    }

    /// Starts recording with `probes` (registered once the datapath is
    /// final, at the frame's start).
    pub(crate) fn attach(&mut self, probes: Probes) {
        self.probes = Some(probes);
    }

    /// Hands every sampling cycle's issues to `capture` from now on.
    pub(crate) fn set_capture(&mut self, capture: crate::cosim::capture::Capture) {
        self.capture = Some(capture);
    }

    /// Hands every cycle to the caller stepping the frame from now on:
    /// each tick waits for the caller first.
    pub(crate) fn set_tap(&mut self, tap: crate::stepper::Tap) {
        self.tap = Some(tap);
    }

    /// Tells the tap the frame's signals, once its datapath is final.
    pub(crate) fn begin_tap(&mut self, signals: crate::probes::SignalSet) {
        if let Some(t) = self.tap.as_mut() {
            t.begin(signals);
        }
    }

    /// The capture the frame runs with, if any.
    pub(crate) fn capture(&self) -> Option<&crate::cosim::capture::Capture> {
        self.capture.as_ref()
    }

    pub(crate) fn take_probes(&mut self) -> Option<Probes> {
        self.probes.take()
    }

    /// One cycle of `ctrl.stage`, the controller showing `ctrl`: every PE
    /// steps, then the ports commit.
    pub fn tick(
        &mut self,
        ctrl: Ctrl,
        step: impl FnMut(&mut Pe, Links<'_>, &mut Ports) -> Result<(), StepError>,
    ) -> Result<(), StepError> {
        if let Some(t) = self.tap.as_mut() {
            t.wait()?;
        }
        step_all(
            &mut self.pes,
            (&self.ports, &mut self.spare),
            &self.order,
            self.ring,
            step,
        )?;
        std::mem::swap(&mut self.ports, &mut self.spare);
        self.cycle += 1;
        self.stages.add(ctrl.stage, 1);
        if let Some(pr) = self.probes.as_mut() {
            pr.sample(self.cycle, &self.pes, &self.ports, ctrl);
        }
        if let Some(c) = self
            .capture
            .as_ref()
            .filter(|_| ctrl.stage == Stage::Sample)
        {
            crate::cosim::capture::record(c, self.cycle, &self.pes);
        }
        if let Some(t) = self.tap.as_mut() {
            t.publish(self.cycle, ctrl, &self.pes, &self.ports);
        }
        Ok(())
    }

    /// One cycle of the links alone, run alongside the sampling stage's
    /// cycles (the overlapped migration): every PE steps on `ports`, the
    /// link registers of that second stage, which then commit. The cycle
    /// counter, the stage counts and the probes are the sampling stage's.
    pub(crate) fn tick_links(
        &mut self,
        ports: &mut (Vec<Ports>, Vec<Ports>),
        step: impl FnMut(&mut Pe, Links<'_>, &mut Ports) -> Result<(), StepError>,
    ) -> Result<(), StepError> {
        let (now, next) = ports;
        step_all(&mut self.pes, (now, next), &self.order, self.ring, step)?;
        std::mem::swap(now, next);
        Ok(())
    }

    /// `n` cycles of `stage` that the untraced whole-slice sampling path
    /// ran without ticking: the cycles the clocked path ticks for the same
    /// work (a test compares the two). The ports end idle, as after the
    /// clocked path's last sampling cycle nothing reads them.
    pub(crate) fn ran_untraced(&mut self, stage: Stage, n: u64) {
        debug_assert!(self.probes.is_none() && self.tap.is_none());
        self.cycle += n;
        self.stages.add(stage, n);
        self.ports.fill(Ports::default());
    }
}
