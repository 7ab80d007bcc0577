//! An enabled tracer's state: each signal's slot (width, last value
//! written), the cycle and time bookkeeping, the marker signal's changes,
//! and the writing of value changes to the sinks.

use bitvec::prelude::*;

use super::{SignalInfo, MAX_CYCLE, MAX_MARKERS, TIME_UNITS_PER_CYCLE};
use crate::config::TraceConfig;
use crate::error::WavesError;
use crate::scope::ScopePath;
use crate::sinks::Sinks;

/// Per-signal state needed on the hot path, kept small and apart from the
/// names so that a sample touches as little memory as possible.
pub(super) struct Slot {
    pub(super) width: u32,
    pub(super) mask: u64,
    pub(super) last: u64,
    pub(super) written: bool,
    /// Previous value of a signal wider than 64 bits.
    pub(super) wide: Option<BitVec<u64, Lsb0>>,
}

/// State of an enabled tracer; boxed so that a disabled [`Tracer`] is a few
/// words.
pub(super) struct Active {
    /// The slot of the marker signal, if traced.
    pub(super) marker_slot: Option<usize>,
    pub(super) markers: Vec<(u64, String)>,
    /// The values the marker signal has taken so far.
    pub(super) marker_values: Vec<u64>,
    pub(super) config: TraceConfig,
    pub(super) sinks: Sinks,
    pub(super) slots: Vec<Slot>,
    pub(super) info: Vec<SignalInfo>,
    pub(super) clock: Option<usize>,
    pub(super) header_written: bool,
    pub(super) cycle: Option<u64>,
    pub(super) first_cycle: Option<u64>,
    pub(super) time: u64,
    /// Without a clock, the `#time` line is only written once something
    /// changes in the cycle, so quiet cycles cost nothing in the file.
    pub(super) need_timestamp: bool,
    pub(super) error: Option<WavesError>,
    pub(super) scratch: BitVec<u64, Lsb0>,
}

impl Active {
    pub(super) fn push_slot(
        &mut self,
        scope: ScopePath,
        name: &str,
        width: u32,
        names: Vec<(u64, String)>,
    ) -> usize {
        self.slots.push(Slot {
            width,
            mask: if width >= 64 {
                u64::MAX
            } else {
                (1 << width) - 1
            },
            last: 0,
            written: false,
            wide: (width > 64).then(BitVec::new),
        });
        let info = SignalInfo {
            scope,
            name: name.to_string(),
            width,
            names,
        };
        if self.config.markers.as_ref().map(|m| m.0.as_str()) == Some(info.full_name().as_str()) {
            self.marker_slot = Some(self.slots.len() - 1);
        }
        self.info.push(info);
        self.slots.len() - 1
    }

    pub(super) fn fail(&mut self, e: WavesError) {
        if self.error.is_none() {
            self.error = Some(e);
        }
    }

    pub(super) fn io_fail(&mut self, e: std::io::Error) {
        let path = self.sinks.error_path();
        self.fail(WavesError::io("write trace", path, e));
    }

    pub(super) fn too_wide(&mut self, i: usize, value: String) {
        let e = WavesError::ValueTooWide {
            signal: self.info[i].full_name(),
            width: self.info[i].width,
            cycle: self.cycle.unwrap_or_default(),
            value,
        };
        self.fail(e);
    }

    /// Opens a new cycle (timestamps, clock edges); false if tracing must
    /// not go on.
    pub(super) fn begin_cycle(&mut self, cycle: u64) -> bool {
        if self.error.is_some() {
            return false;
        }
        if !self.header_written {
            if let Err(e) = self.write_header() {
                self.io_fail(e);
                return false;
            }
        }
        match self.cycle {
            Some(prev) if cycle == prev => return true,
            Some(prev) if cycle < prev => {
                self.fail(WavesError::CycleWentBackwards {
                    cycle,
                    previous: prev,
                });
                return false;
            }
            _ => {}
        }
        if cycle > MAX_CYCLE {
            self.fail(WavesError::CycleTooLarge(cycle));
            return false;
        }
        match self.advance_to(cycle) {
            Ok(()) => true,
            Err(e) => {
                self.io_fail(e);
                false
            }
        }
    }

    pub(super) fn advance_to(&mut self, cycle: u64) -> std::io::Result<()> {
        if let Some(prev) = self.cycle {
            self.close_cycle(prev)?;
        }
        self.cycle = Some(cycle);
        self.first_cycle.get_or_insert(cycle);
        self.time = cycle * TIME_UNITS_PER_CYCLE;
        if let Some(clk) = self.clock {
            self.sinks.timestamp(self.time)?;
            self.sinks.bits.clear();
            self.sinks.bits.push(b'1');
            self.sinks.change(clk)?;
            self.need_timestamp = false;
        } else {
            self.need_timestamp = true;
        }
        Ok(())
    }

    pub(super) fn close_cycle(&mut self, cycle: u64) -> std::io::Result<()> {
        if let Some(clk) = self.clock {
            self.sinks
                .timestamp(cycle * TIME_UNITS_PER_CYCLE + TIME_UNITS_PER_CYCLE / 2)?;
            self.sinks.bits.clear();
            self.sinks.bits.push(b'0');
            self.sinks.change(clk)?;
        }
        Ok(())
    }

    pub(super) fn write_header(&mut self) -> std::io::Result<()> {
        self.header_written = true;
        self.sinks.header(&self.info)
    }

    #[inline]
    pub(super) fn set_u64(&mut self, i: usize, value: u64, sign: bool) {
        let slot = &mut self.slots[i];
        if slot.wide.is_some() {
            return self.set_wide_from_u64(i, value, sign);
        }
        if value & !slot.mask != 0 {
            return self.too_wide(i, format!("{value:#x}"));
        }
        if slot.written && slot.last == value {
            return;
        }
        slot.last = value;
        slot.written = true;
        if self.marker_slot == Some(i) {
            self.note_marker(i, value);
        }
        if let Err(e) = self.emit_narrow(i) {
            self.io_fail(e);
        }
    }

    /// Keeps a change of the marker signal, named by its value's name.
    #[cold]
    pub(super) fn note_marker(&mut self, i: usize, value: u64) {
        let always = self
            .config
            .markers
            .as_ref()
            .is_some_and(|m| m.1.contains(&value));
        let first = !self.marker_values.contains(&value);
        if first {
            self.marker_values.push(value);
        }
        if (first || always) && self.markers.len() < MAX_MARKERS {
            let names = &self.info[i].names;
            let label = names
                .iter()
                .find(|(v, _)| *v == value)
                .map_or_else(|| value.to_string(), |(_, n)| n.clone());
            self.markers.push((self.cycle.unwrap_or_default(), label));
        }
    }

    pub(super) fn set_i64(&mut self, i: usize, value: i64) {
        let width = self.slots[i].width;
        if width < 64 {
            let half = 1i64 << (width - 1);
            if value < -half || value >= half {
                return self.too_wide(i, format!("{value} (signed)"));
            }
        }
        self.set_u64(i, (value as u64) & self.slots[i].mask, value < 0);
    }

    pub(super) fn set_bits<T: BitStore, O: BitOrder>(&mut self, i: usize, bits: &BitSlice<T, O>) {
        let width = self.slots[i].width as usize;
        if let Some(high) = bits.last_one().filter(|&b| b >= width) {
            return self.too_wide(i, format!("with bit {high} set"));
        }
        if self.slots[i].wide.is_none() {
            let value = bits.iter_ones().fold(0u64, |v, b| v | 1 << b);
            return self.set_u64(i, value, false);
        }
        let mut new = std::mem::take(&mut self.scratch);
        new.clear();
        new.extend(bits.iter().by_vals().take(width));
        new.resize(width, false);
        self.set_wide(i, new);
    }

    pub(super) fn set_wide_from_u64(&mut self, i: usize, value: u64, sign: bool) {
        let width = self.slots[i].width as usize;
        let mut new = std::mem::take(&mut self.scratch);
        new.clear();
        new.resize(width, sign);
        new[..64].store_le(value);
        self.set_wide(i, new);
    }

    /// Takes `new` (the scratch buffer) and gives back the old value's
    /// buffer as scratch, so wide signals allocate only at first use.
    pub(super) fn set_wide(&mut self, i: usize, mut new: BitVec<u64, Lsb0>) {
        let slot = &mut self.slots[i];
        let Some(last) = slot.wide.as_mut() else {
            self.scratch = new;
            return;
        };
        if slot.written && *last == new {
            self.scratch = new;
            return;
        }
        std::mem::swap(last, &mut new);
        self.scratch = new;
        slot.written = true;
        if let Err(e) = self.emit_wide(i) {
            self.io_fail(e);
        }
    }

    pub(super) fn timestamp_if_needed(&mut self) -> std::io::Result<()> {
        if self.need_timestamp {
            self.need_timestamp = false;
            self.sinks.timestamp(self.time)?;
        }
        Ok(())
    }

    pub(super) fn emit_narrow(&mut self, i: usize) -> std::io::Result<()> {
        self.timestamp_if_needed()?;
        let slot = &self.slots[i];
        let bits = &mut self.sinks.bits;
        bits.clear();
        bits.extend(
            (0..slot.width)
                .rev()
                .map(|b| b'0' + ((slot.last >> b) & 1) as u8),
        );
        self.sinks.change(i)
    }

    pub(super) fn emit_wide(&mut self, i: usize) -> std::io::Result<()> {
        self.timestamp_if_needed()?;
        let Some(wide) = self.slots[i].wide.as_ref() else {
            return Ok(());
        };
        let bits = &mut self.sinks.bits;
        bits.clear();
        bits.extend(wide.iter().by_vals().rev().map(|b| b'0' + b as u8));
        self.sinks.change(i)
    }
}
