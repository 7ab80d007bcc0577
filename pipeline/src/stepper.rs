//! Stepping a frame one clock at a time from outside: [`Stepper`] runs a
//! frame on a worker thread and hands over after every tick of the array's
//! clock, with the cycle's controller bus, the commands it broadcast
//! before the cycle, and every PE's signals, ports and report lines
//! ([`Cycle`]).
//!
//! The frame's controller is a nest of loops over regions, slices, rows
//! and passes ([`crate::schedule`], [`crate::stages`]); turning it inside
//! out into a state machine would rewrite every stage for one caller. The
//! worker runs that same code instead, clocked (the path a traced frame
//! takes: [`crate::FrameRun::tap`] sets it), and the clock's [`Tap`] makes
//! each tick a rendezvous: the tick waits until the caller asks for a
//! cycle, runs, and sends the caller a copy of what it committed. So the
//! cycles, ports and words are the traced frame's, one tick per
//! [`Stepper::step`], and the frame is deterministic whatever the caller's
//! timing (the worker computes nothing the caller can race with). An
//! untapped frame has no tap and pays one `Option` test per tick.
//!
//! Dropping a [`Stepper`] before the frame's end closes both channels: the
//! worker's next tick fails with [`StepError::Stopped`], the frame unwinds
//! through its ordinary error path, and the drop joins the thread.

use std::sync::mpsc::{channel, sync_channel, Receiver, SendError, Sender, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;

use crate::pe::{Broadcast, Command, Pe, Ports, StepError};
use crate::probes::{Ctrl, PeCycle, SignalSet};

/// One cycle of a stepped frame: what the array committed in it.
#[derive(Debug, Clone)]
pub struct Cycle {
    /// The cycle's number (the frame's cycles count from 1).
    pub number: u64,
    /// What the controller showed during it (`top.ctrl`: the stage, the
    /// slice and row, a pass's bus).
    pub ctrl: Ctrl,
    /// The commands the controller broadcast to every PE since the
    /// previous cycle, in order (between cycles, so they shaped this one).
    pub commands: Vec<Command>,
    /// Every PE after the cycle, in PE order.
    pub pes: Vec<PeCycle>,
    /// The frame's signals and their widths.
    pub signals: Arc<SignalSet>,
}

/// What the caller tells the worker before a tick.
enum Go {
    /// Run one tick and send it; reuse the previous cycle's buffers.
    Step(Option<Box<Cycle>>),
    /// Run the rest of the frame without handing over.
    Run,
}

/// The clock's end of a stepped frame: it waits for the caller before each
/// tick and sends the caller each committed cycle.
pub struct Tap {
    go: Receiver<Go>,
    out: Sender<Box<Cycle>>,
    signals: Option<Arc<SignalSet>>,
    commands: Vec<Command>,
    spare: Option<Box<Cycle>>,
    /// Told to run the rest of the frame without handing over.
    free: bool,
}

impl Tap {
    /// The frame's signals, known once its datapath is final (at its
    /// start).
    pub(crate) fn begin(&mut self, signals: SignalSet) {
        self.signals = Some(Arc::new(signals));
    }

    /// Notes a broadcast, shown with the next cycle.
    pub(crate) fn command(&mut self, b: &Broadcast<'_>) {
        if !self.free {
            self.commands.push(b.command());
        }
    }

    /// Waits until the caller asks for the next cycle;
    /// [`StepError::Stopped`] when the caller has gone.
    pub(crate) fn wait(&mut self) -> Result<(), StepError> {
        if self.free {
            return Ok(());
        }
        match self.go.recv() {
            Ok(Go::Step(spare)) => {
                self.spare = spare;
                Ok(())
            }
            Ok(Go::Run) => {
                self.free = true;
                self.commands.clear();
                Ok(())
            }
            Err(_) => Err(StepError::Stopped),
        }
    }

    /// Sends the caller cycle `number`: `ctrl`, the PEs and the ports they
    /// committed.
    pub(crate) fn publish(&mut self, number: u64, ctrl: Ctrl, pes: &[Pe], ports: &[Ports]) {
        if self.free {
            return;
        }
        let Some(signals) = &self.signals else {
            return;
        };
        let mut c = self.spare.take().unwrap_or_else(|| {
            Box::new(Cycle {
                number,
                ctrl,
                commands: Vec::new(),
                pes: Vec::with_capacity(pes.len()),
                signals: Arc::clone(signals),
            })
        });
        c.number = number;
        c.ctrl = ctrl;
        c.signals = Arc::clone(signals);
        c.commands.clear();
        c.commands.append(&mut self.commands);
        c.pes.clear();
        c.pes.extend(
            pes.iter()
                .zip(ports)
                .map(|(pe, p)| PeCycle::of(pe, p, ctrl.stage, number, signals)),
        );
        // A caller that has gone is seen at the next wait.
        let _ = self.out.send(c);
    }
}

/// A frame stepped one clock at a time: the frame `f` builds runs on a
/// worker thread with the [`Tap`] it is handed installed in its clock
/// ([`crate::FrameRun::tap`]); `T` is what `f` returns (the frame, or the
/// caller's whole render built around it).
pub struct Stepper<T> {
    go: Option<SyncSender<Go>>,
    cycles: Option<Receiver<Box<Cycle>>>,
    worker: Option<JoinHandle<T>>,
    current: Option<Box<Cycle>>,
    done: bool,
}

/// The worker panicked: its message.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("internal error (a bug): {0}")]
pub struct Panicked(pub String);

impl<T: Send + 'static> Stepper<T> {
    /// Starts `f` on a worker thread, handing it the tap to install. No
    /// cycle runs before the first [`Stepper::step`].
    pub fn start(f: impl FnOnce(Tap) -> T + Send + 'static) -> std::io::Result<Stepper<T>> {
        let (go_tx, go_rx) = sync_channel(0);
        let (out_tx, out_rx) = channel();
        let tap = Tap {
            go: go_rx,
            out: out_tx,
            signals: None,
            commands: Vec::new(),
            spare: None,
            free: false,
        };
        let worker = std::thread::Builder::new()
            .name("ercube-stepper".into())
            .spawn(move || f(tap))?;
        Ok(Stepper {
            go: Some(go_tx),
            cycles: Some(out_rx),
            worker: Some(worker),
            current: None,
            done: false,
        })
    }

    /// Clocks one cycle and returns it; `None` once the frame has no more
    /// cycles (it ended, or failed: [`Stepper::finish`] says which), the
    /// last cycle staying [`Stepper::current`].
    pub fn step(&mut self) -> Option<&Cycle> {
        if self.done {
            return None;
        }
        let spare = self.current.take();
        // A rendezvous: the worker takes it at its next tick, or has ended.
        let sent = match self.go.as_ref().map(|g| g.send(Go::Step(spare))) {
            Some(Ok(())) => true,
            Some(Err(SendError(Go::Step(spare)))) => {
                self.current = spare;
                false
            }
            _ => false,
        };
        match self.cycles.as_ref().filter(|_| sent).map(Receiver::recv) {
            Some(Ok(c)) => {
                self.current = Some(c);
                self.current.as_deref()
            }
            _ => {
                // The frame has ended (its tap is gone) or never ticks.
                self.done = true;
                None
            }
        }
    }

    /// The last cycle clocked (`None` before the first).
    pub fn current(&self) -> Option<&Cycle> {
        self.current.as_deref()
    }

    /// Whether the frame has no more cycles.
    pub fn done(&self) -> bool {
        self.done
    }

    /// Runs the rest of the frame without handing over and returns what
    /// the frame's builder returned.
    pub fn finish(mut self) -> Result<T, Panicked> {
        if let Some(g) = self.go.take() {
            // Taken at the worker's next tick; refused by one past its last.
            let _ = g.send(Go::Run);
        }
        self.cycles = None;
        let worker = self.worker.take().expect("joined only here and in drop");
        worker.join().map_err(|p| {
            Panicked(
                p.downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into()),
            )
        })
    }
}

impl<T> Drop for Stepper<T> {
    fn drop(&mut self) {
        // Closing both channels stops the frame at its next tick.
        self.go = None;
        self.cycles = None;
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
    }
}
