//! The probe registry and VCD writer used by the cycle model.

use std::collections::{BTreeSet, HashSet};
use std::fmt;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use bitvec::prelude::*;

use crate::config::{Group, TraceConfig};
use crate::error::WavesError;
use crate::scope::{is_valid_name, ScopePath};
use crate::sinks::Sinks;

mod active;

use active::Active;

/// The clock a trace's time axis assumes, MHz: the one `ercube cost`
/// quotes frame rates at for its default family (Artix-7, 200 MHz), so a
/// time read off a waveform is a time on that part.
pub const CLOCK_MHZ: u64 = 200;

/// The trace's time unit in picoseconds (`$timescale 100ps`; FST
/// exponent -10).
pub const TIME_UNIT_PS: u64 = 100;

/// Time units per clock cycle: cycle `c` starts at time `50 * c`, one
/// 5 ns cycle of the [`CLOCK_MHZ`] clock.
///
/// Fifty rather than one so that the optional `clk` signal can fall
/// half-way through a cycle (time `50 * c + 25`), which GTKWave then
/// draws as the 200 MHz clock it is.
pub const TIME_UNITS_PER_CYCLE: u64 = 1_000_000 / CLOCK_MHZ / TIME_UNIT_PS;

/// The widest signal accepted, in bits; far above any datapath of the chip,
/// it only guards against a corrupted width eating memory.
pub const MAX_WIDTH: u32 = 1 << 16;

/// Largest cycle whose start, falling clock edge and end still fit in `u64`
/// VCD time.
const MAX_CYCLE: u64 = u64::MAX / TIME_UNITS_PER_CYCLE - 1;

/// Name of the clock signal added in scope `top` by
/// [`TraceConfig::with_clock`].
pub const CLOCK_NAME: &str = "clk";

/// Handle of a registered signal, returned by [`Tracer::register`].
///
/// Signals that the filters exclude (and all signals of a disabled tracer)
/// get [`SignalId::NONE`], so that the model can keep setting them
/// unconditionally at the cost of one compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SignalId(u32);

impl SignalId {
    /// The id of a signal that is not traced; setting it does nothing.
    pub const NONE: SignalId = SignalId(u32::MAX);

    /// Whether values set on this id reach the trace (if the cycle is in the
    /// window). Lets a model skip computing an expensive probe value.
    #[inline]
    pub fn is_traced(self) -> bool {
        self != SignalId::NONE
    }
}

/// Description of one traced signal, as written in the VCD header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SignalInfo {
    /// The scope the signal lives in.
    pub scope: ScopePath,
    /// The signal's own name within its scope.
    pub name: String,
    /// Declared width in bits.
    pub width: u32,
    /// Names of the signal's values, for an enumeration (see
    /// [`Tracer::register_enum_in`]): viewers show them through a translate
    /// filter file ([`TraceInfo::write_gtkw`]). Empty for plain numbers.
    pub names: Vec<(u64, String)>,
}

impl SignalInfo {
    /// Dotted hierarchical name, e.g. `top.pe_3.acc`; the key of
    /// [`crate::Trace::signal`].
    pub fn full_name(&self) -> String {
        format!("{}.{}", self.scope, self.name)
    }

    /// The name GTKWave gives the signal, e.g. `top.pe_3.acc[15:0]`:
    /// vectors carry the `[msb:0]` range that the VCD header declares.
    pub fn gtkwave_name(&self) -> String {
        if self.width == 1 {
            self.full_name()
        } else {
            format!("{}[{}:0]", self.full_name(), self.width - 1)
        }
    }
}

/// What a finished trace contains; returned by [`Tracer::finish`] and used to
/// write a GTKWave save file ([`TraceInfo::write_gtkw`]).
#[derive(Clone, Debug)]
pub struct TraceInfo {
    /// The VCD file written, if one was asked for.
    pub vcd_path: Option<PathBuf>,
    /// The FST file written, if one was asked for.
    pub fst_path: Option<PathBuf>,
    /// The traced signals in header order (the clock first, if enabled).
    pub signals: Vec<SignalInfo>,
    /// First and last cycle actually sampled, `None` if no cycle was.
    pub cycles: Option<RangeInclusive<u64>>,
    /// The first changes of the marker signal
    /// ([`TraceConfig::with_markers`]) within the trace, as (cycle, the
    /// value's name), at most [`MAX_MARKERS`]: a save file's named markers.
    pub markers: Vec<(u64, String)>,
}

/// Marker signal changes kept ([`TraceInfo::markers`]): GTKWave's named
/// markers `A` to `Z`.
pub const MAX_MARKERS: usize = 26;

/// The probe registry and VCD writer.
///
/// Register every signal once with [`Tracer::register`] before the first
/// [`Tracer::sample`]; then call `sample` once per clock cycle (cycles must
/// not decrease) and set every traced signal's current value: the tracer
/// writes only values that differ from the last one written, so the model
/// need not track changes (and must not skip unchanged values, or the
/// first cycle of the window would lack them).
///
/// Values that do not fit their declared width, I/O errors and decreasing
/// cycles are not reported by `sample` (that would make the per-cycle call
/// fallible); the first one stops tracing and is returned by
/// [`Tracer::finish`], which then leaves no file behind. A tracer dropped
/// without `finish` leaves no file either.
pub struct Tracer {
    // The window as start and length, so that "disabled or outside the
    // window" is a single wrapping compare in `sample`.
    start: u64,
    len: u64,
    active: Option<Box<Active>>,
    names: HashSet<String>,
}

impl fmt::Debug for Tracer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut d = f.debug_struct("Tracer");
        match &self.active {
            None => d.field("enabled", &false),
            Some(a) => d
                .field("path", &a.config.path)
                .field("signals", &a.info.len())
                .field("cycle", &a.cycle),
        }
        .finish_non_exhaustive()
    }
}

impl Tracer {
    /// A tracer that traces nothing and costs one branch per `sample`.
    pub fn disabled() -> Self {
        Tracer {
            start: 0,
            len: 0,
            active: None,
            names: HashSet::new(),
        }
    }

    /// Starts a trace to `config.path()`.
    ///
    /// The data goes to a temporary file in the same directory, renamed
    /// over the target by [`Tracer::finish`], so that a crashed or failed
    /// run never leaves a truncated VCD under the expected name. The
    /// directory must exist.
    pub fn new(config: TraceConfig) -> Result<Self, WavesError> {
        let (start, end) = (
            *config.cycles.start(),
            (*config.cycles.end()).min(MAX_CYCLE),
        );
        let sinks = Sinks::open(config.path.as_deref(), config.fst.as_deref())?;

        let len = if start > end { 0 } else { end - start + 1 };
        let mut active = Box::new(Active {
            sinks,
            slots: Vec::new(),
            info: Vec::new(),
            clock: None,
            header_written: false,
            cycle: None,
            first_cycle: None,
            time: 0,
            need_timestamp: false,
            error: None,
            scratch: BitVec::new(),
            marker_slot: None,
            markers: Vec::new(),
            marker_values: Vec::new(),
            config,
        });
        let mut names = HashSet::new();
        if active.config.clock {
            let top = ScopePath::top();
            names.insert(format!("{top}.{CLOCK_NAME}"));
            active.clock = Some(active.push_slot(top, CLOCK_NAME, 1, Vec::new()));
        }
        Ok(Tracer {
            start,
            len,
            active: Some(active),
            names,
        })
    }

    /// Whether this tracer writes a file at all.
    pub fn is_enabled(&self) -> bool {
        self.active.is_some()
    }

    /// Whether `sample(cycle, ..)` would record anything; for a model that
    /// wants to skip preparing probe values outside the window.
    #[inline]
    pub fn is_active(&self, cycle: u64) -> bool {
        cycle.wrapping_sub(self.start) < self.len
    }

    /// Declares signal `name` of `width` bits in `scope`.
    ///
    /// Names and widths are checked and duplicates rejected even when the
    /// signal is filtered out or the tracer is disabled, so that a bad
    /// probe declaration fails in every run, not only in traced ones.
    /// Returns [`SignalId::NONE`] for signals that are not traced.
    pub fn register(
        &mut self,
        scope: &ScopePath,
        name: &str,
        width: u32,
    ) -> Result<SignalId, WavesError> {
        self.declare(None, scope, name, width, &[])
    }

    /// Declares a signal of `group` (see [`TraceConfig::with_groups`]):
    /// traced only when the group is selected, or, with no selection, when
    /// the group is on by default. Otherwise as [`Tracer::register`].
    pub fn register_in(
        &mut self,
        group: &Group,
        scope: &ScopePath,
        name: &str,
        width: u32,
    ) -> Result<SignalId, WavesError> {
        self.declare(Some(group), scope, name, width, &[])
    }

    /// Declares an enumeration: a signal of `group` whose values have
    /// `names` (value, name). The file holds the numbers; the names reach
    /// viewers through the translate filter file that
    /// [`TraceInfo::write_gtkw`] writes beside the save file.
    pub fn register_enum_in(
        &mut self,
        group: &Group,
        scope: &ScopePath,
        name: &str,
        width: u32,
        names: &[(u64, &str)],
    ) -> Result<SignalId, WavesError> {
        self.declare(Some(group), scope, name, width, names)
    }

    /// The groups the configuration selects, `None` for the defaults.
    pub fn selected_groups(&self) -> Option<&BTreeSet<String>> {
        self.active.as_ref().and_then(|a| a.config.groups.as_ref())
    }

    fn declare(
        &mut self,
        group: Option<&Group>,
        scope: &ScopePath,
        name: &str,
        width: u32,
        names: &[(u64, &str)],
    ) -> Result<SignalId, WavesError> {
        let full = format!("{scope}.{name}");
        if !is_valid_name(name) {
            return Err(WavesError::InvalidName(name.to_string()));
        }
        if let Some(bad) = scope.parts().iter().find(|p| !is_valid_name(p)) {
            return Err(WavesError::InvalidName(bad.clone()));
        }
        if width == 0 || width > MAX_WIDTH {
            return Err(WavesError::InvalidWidth {
                signal: full,
                width,
            });
        }
        let Some(a) = self.active.as_deref_mut() else {
            return if self.names.insert(full.clone()) {
                Ok(SignalId::NONE)
            } else {
                Err(WavesError::DuplicateSignal(full))
            };
        };
        if a.header_written {
            return Err(WavesError::LateRegistration(full));
        }
        if !self.names.insert(full.clone()) {
            return Err(WavesError::DuplicateSignal(full));
        }
        if !a.config.selects(scope, name) || !group.is_none_or(|g| a.config.selects_group(g)) {
            return Ok(SignalId::NONE);
        }
        let names = names.iter().map(|&(v, n)| (v, n.to_string())).collect();
        a.push_slot(scope.clone(), name, width, names);
        // Ids index `slots`; u32::MAX is NONE and unreachable in practice
        // (MAX_WIDTH bits times 4 G signals would not fit in memory).
        Ok(SignalId((a.slots.len() - 1) as u32))
    }

    /// Records the values of cycle `cycle`: `f` is called with a
    /// [`Sampler`] on which to set the values, but only if the tracer is
    /// enabled and `cycle` is in the window. Otherwise this is one compare
    /// and `f` is not called, so a closure that reads model state costs
    /// nothing when tracing is off.
    ///
    /// Several calls for the same cycle are allowed (e.g. one per pipeline
    /// stage); a later value of a signal in the same cycle replaces the
    /// earlier one in viewers.
    #[inline]
    pub fn sample<F: FnOnce(&mut Sampler<'_>)>(&mut self, cycle: u64, f: F) {
        if cycle.wrapping_sub(self.start) < self.len {
            self.sample_in_window(cycle, f);
        }
    }

    fn sample_in_window<F: FnOnce(&mut Sampler<'_>)>(&mut self, cycle: u64, f: F) {
        let Some(a) = self.active.as_deref_mut() else {
            return;
        };
        if a.begin_cycle(cycle) {
            f(&mut Sampler { a });
        }
        if a.error.is_some() {
            self.len = 0;
        }
    }

    /// The first error met so far, if any (tracing has then stopped).
    pub fn error(&self) -> Option<&WavesError> {
        self.active.as_ref().and_then(|a| a.error.as_ref())
    }

    /// Completes the files (VCD, FST) and renames them to their final paths.
    ///
    /// Returns `Ok(None)` for a disabled tracer, and the first error met
    /// while sampling, if any (in which case no file is created).
    pub fn finish(self) -> Result<Option<TraceInfo>, WavesError> {
        let Some(mut a) = self.active else {
            return Ok(None);
        };
        if let Some(e) = a.error.take() {
            return Err(e);
        }
        let tmp_path = a.sinks.error_path();
        let io = |e: std::io::Error| WavesError::io("write trace", &tmp_path, e);
        if !a.header_written {
            a.write_header().map_err(io)?;
        }
        let mut end = None;
        if let Some(c) = a.cycle {
            a.close_cycle(c).map_err(io)?;
            // A final timestamp gives the last cycle its full width in
            // viewers instead of ending the trace at its first instant.
            end = Some((c + 1) * TIME_UNITS_PER_CYCLE);
        }
        let Active {
            sinks,
            info,
            first_cycle,
            cycle,
            markers,
            ..
        } = *a;
        // The FST header names its start time: the first traced cycle's.
        let start = first_cycle.map(|c| c * TIME_UNITS_PER_CYCLE);
        let written = sinks.finish(start, end)?;
        Ok(Some(TraceInfo {
            vcd_path: written.vcd,
            fst_path: written.fst,
            signals: info,
            cycles: first_cycle.zip(cycle).map(|(a, b)| a..=b),
            markers,
        }))
    }

    /// Path of the first file this tracer will create (the VCD if it
    /// writes one, else the FST), if enabled.
    pub fn path(&self) -> Option<&Path> {
        self.active.as_ref().map(|a| a.sinks.path())
    }
}

/// Sets the values of one cycle; handed to the closure of
/// [`Tracer::sample`].
///
/// Ids must come from the same tracer; an id of another tracer may panic
/// or set the wrong signal.
pub struct Sampler<'a> {
    a: &'a mut Active,
}

impl Sampler<'_> {
    /// Sets an unsigned value. It must fit in the signal's width; a value
    /// that does not is recorded as [`WavesError::ValueTooWide`] (returned
    /// by [`Tracer::finish`]) rather than truncated, because a silently
    /// masked probe would hide exactly the bugs the trace is for.
    #[inline]
    pub fn set(&mut self, id: SignalId, value: u64) {
        if id.is_traced() {
            self.a.set_u64(id.0 as usize, value, false);
        }
    }

    /// Sets a 1-bit value (or 0/1 on a wider signal).
    #[inline]
    pub fn set_bool(&mut self, id: SignalId, value: bool) {
        self.set(id, value as u64);
    }

    /// Sets a signed value, written in two's complement over the signal's
    /// width; it must be representable in that width (e.g. -128..=127 for
    /// 8 bits).
    #[inline]
    pub fn set_signed(&mut self, id: SignalId, value: i64) {
        if id.is_traced() {
            self.a.set_i64(id.0 as usize, value);
        }
    }

    /// Sets a value given as bits, `bits[0]` being the least significant;
    /// for signals wider than 64 bits. Bits beyond the slice are 0; set
    /// bits beyond the declared width are an error as with [`Sampler::set`].
    pub fn set_bits<T: BitStore, O: BitOrder>(&mut self, id: SignalId, bits: &BitSlice<T, O>) {
        if id.is_traced() {
            self.a.set_bits(id.0 as usize, bits);
        }
    }

    /// The cycle being sampled.
    pub fn cycle(&self) -> u64 {
        self.a.cycle.unwrap_or_default()
    }
}
