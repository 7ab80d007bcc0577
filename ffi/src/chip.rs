//! The PE array stepped one clock at a time (`ercube_chip_*`): a frame
//! begins as `ercube_render` would render it, then every
//! `ercube_chip_step` clocks one cycle ([`pipeline::stepper`]) and the
//! cycle's controller bus, commands and every PE's signals, ports and
//! report lines read out as `#[repr(C)]` structs; `ercube_chip_finish`
//! runs the rest and returns the frame, whose raw words and statistics are
//! `ercube_render`'s.
//!
//! The structs' values are the waveform's: each field is filled from the
//! probe table's signal of the same name ([`pipeline::probes::SignalSet`]),
//! so a field holds exactly what the VCD shows for that cycle.

use std::ffi::c_int;

use pipeline::stepper::Cycle;

use crate::{
    argument, guard, hand_out, text, ErcubeConfig, ErcubeFrame, ErcubeStatus, ErcubeVolume, Failure,
};

mod structs;
pub use structs::*;

/// The array with one configuration, stepping a frame at a time.
pub struct ErcubeChip {
    toml: Option<String>,
    stepper: Option<ercube::frame::Stepper>,
    /// The finished frame's render (or its failure), once the frame ended.
    result: Option<Result<ercube::frame::Rendered, Failure>>,
    /// The last cycle clocked, kept after the stepper ends.
    last: Option<Cycle>,
    cycles: u64,
}

/// The stepper's worker's end: its render, or its failure or panic.
fn finished(s: ercube::frame::Stepper) -> Result<ercube::frame::Rendered, Failure> {
    match s.finish() {
        Ok(r) => r.map_err(Failure::from),
        Err(p) => Err(Failure(ErcubeStatus::Panic, p.to_string())),
    }
}

impl ErcubeChip {
    /// The last cycle clocked.
    fn current(&self) -> Result<&Cycle, Failure> {
        self.stepper
            .as_ref()
            .and_then(|s| s.current())
            .or(self.last.as_ref())
            .ok_or_else(|| {
                argument("no cycle clocked yet: call ercube_chip_step after ercube_chip_begin")
            })
    }
}

/// Answers a query on the live `chip` into `out`: both checked for null,
/// `answer` run under [`guard`], its value written.
///
/// # Safety
/// `chip` is null or a live handle; `out` is null or valid for one write.
unsafe fn query<T>(
    chip: *const ErcubeChip,
    out: *mut T,
    answer: impl FnOnce(&ErcubeChip) -> Result<T, Failure>,
) -> c_int {
    guard(|| {
        let c = chip.as_ref().ok_or_else(|| argument("the chip is null"))?;
        if out.is_null() {
            return Err(argument("the output pointer is null"));
        }
        *out = answer(c)?;
        Ok(())
    })
}

/// A chip with the pipeline configuration `cfg` (null: the defaults).
///
/// # Safety
/// `cfg` is null or a live handle; `out` is valid for one pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_new(
    cfg: *const ErcubeConfig,
    out: *mut *mut ErcubeChip,
) -> c_int {
    guard(|| {
        let toml = cfg.as_ref().map(|c| c.toml.clone());
        hand_out(
            out,
            ErcubeChip {
                toml,
                stepper: None,
                result: None,
                last: None,
                cycles: 0,
            },
        )
    })
}

/// Begins a frame of `vol` as `ercube_render(vol, cfg, argv, argc)`
/// would render it (a pipeline method; no `--repeat`), dropping any frame
/// in progress. No cycle runs until [`ercube_chip_step`].
///
/// # Safety
/// `chip` and `vol` are live handles; `argv` null (when `argc` is 0) or
/// `argc` NUL-terminated strings.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_begin(
    chip: *mut ErcubeChip,
    vol: *const ErcubeVolume,
    argv: *const *const std::ffi::c_char,
    argc: usize,
) -> c_int {
    guard(|| {
        let c = chip.as_mut().ok_or_else(|| argument("the chip is null"))?;
        let v = &vol
            .as_ref()
            .ok_or_else(|| argument("the volume is null"))?
            .volume;
        if argv.is_null() && argc > 0 {
            return Err(argument("argv is null"));
        }
        let mut args = Vec::with_capacity(argc);
        for k in 0..argc {
            args.push(text(*argv.add(k), "an argument")?);
        }
        // The frame in progress stops (its thread joined) before the next.
        c.stepper = None;
        c.result = None;
        c.last = None;
        c.cycles = 0;
        c.stepper = Some(ercube::frame::stepper(
            &args,
            Some(v.clone()),
            c.toml.as_deref(),
        )?);
        Ok(())
    })
}

/// Clocks one cycle: `ERCUBE_OK` when it ran (read it with the calls
/// below), `ERCUBE_DONE` when the frame has no cycle left (it has ended;
/// [`ercube_chip_finish`] returns it), or the frame's failure.
///
/// # Safety
/// `chip` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_step(chip: *mut ErcubeChip) -> c_int {
    let mut done = false;
    let status = guard(|| {
        let c = chip.as_mut().ok_or_else(|| argument("the chip is null"))?;
        if let Some(Err(Failure(s, m))) = &c.result {
            return Err(Failure(*s, m.clone()));
        }
        let s = c
            .stepper
            .as_mut()
            .ok_or_else(|| argument("no frame: call ercube_chip_begin first"))?;
        if let Some(cycle) = s.step() {
            c.cycles = cycle.number;
            return Ok(());
        }
        let s = c.stepper.take().expect("stepping it above");
        c.last = s.current().cloned();
        let r = finished(s);
        let failed = r.as_ref().err().map(|Failure(s, m)| Failure(*s, m.clone()));
        c.result = Some(r);
        if let Some(f) = failed {
            return Err(f);
        }
        if c.result.as_ref().is_some_and(Result::is_ok) {
            done = true;
        }
        Ok(())
    });
    if status == ErcubeStatus::Ok as c_int && done {
        ErcubeStatus::Done as c_int
    } else {
        status
    }
}

/// The cycles clocked so far in this frame (after `ERCUBE_DONE`: the
/// frame's cycles).
///
/// # Safety
/// `chip` is a live handle; `cycle` is valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_cycle(chip: *const ErcubeChip, cycle: *mut u64) -> c_int {
    query(chip, cycle, |c| Ok(c.cycles))
}

/// The PEs of the frame (known after the first cycle).
///
/// # Safety
/// `chip` is a live handle; `n` is valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_pes(chip: *const ErcubeChip, n: *mut u32) -> c_int {
    query(chip, n, |c| Ok(c.current()?.pes.len() as u32))
}

/// PE `k` in the last cycle clocked: its signals, ports and report lines.
///
/// # Safety
/// `chip` is a live handle; `out` is valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_ports(
    chip: *const ErcubeChip,
    k: u32,
    out: *mut ErcubePe,
) -> c_int {
    query(chip, out, |c| {
        let cycle = c.current()?;
        pe_of(cycle, k as usize).ok_or_else(|| {
            argument(format!(
                "PE {k} is outside the array's {} PEs",
                cycle.pes.len()
            ))
        })
    })
}

/// The controller in the last cycle clocked.
///
/// # Safety
/// `chip` is a live handle; `out` is valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_broadcast(
    chip: *const ErcubeChip,
    out: *mut ErcubeBroadcast,
) -> c_int {
    query(chip, out, |c| Ok(broadcast_of(c.current()?)))
}

/// Command `i` of those broadcast before the last cycle clocked.
///
/// # Safety
/// `chip` is a live handle; `out` is valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_command(
    chip: *const ErcubeChip,
    i: u32,
    out: *mut ErcubeCommand,
) -> c_int {
    query(chip, out, |c| {
        let cycle = c.current()?;
        let cmd = cycle.commands.get(i as usize).ok_or_else(|| {
            argument(format!(
                "command {i} is outside the cycle's {}",
                cycle.commands.len()
            ))
        })?;
        let (kind, a, b) = cmd.words();
        Ok(ErcubeCommand { kind, a, b })
    })
}

/// Runs the rest of the frame (without handing over) and returns it: the
/// frame `ercube_render` returns for the same volume, configuration and
/// arguments (image, raw words, statistics). The chip can begin another.
///
/// # Safety
/// `chip` is a live handle; `out` is valid for one pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_finish(
    chip: *mut ErcubeChip,
    out: *mut *mut ErcubeFrame,
) -> c_int {
    guard(|| {
        let c = chip.as_mut().ok_or_else(|| argument("the chip is null"))?;
        if out.is_null() {
            return Err(argument("the output pointer is null"));
        }
        let r = match (c.result.take(), c.stepper.take()) {
            (Some(r), _) => r,
            (None, Some(s)) => finished(s),
            (None, None) => return Err(argument("no frame: call ercube_chip_begin first")),
        };
        c.last = None;
        hand_out(out, ErcubeFrame::new(r?)?)
    })
}

/// Releases a chip, stopping its frame (null is ignored).
///
/// # Safety
/// `chip` is null or a live handle, not used again.
#[no_mangle]
pub unsafe extern "C" fn ercube_chip_free(chip: *mut ErcubeChip) {
    crate::free_handle(chip);
}
