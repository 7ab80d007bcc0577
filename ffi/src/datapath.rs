//! One datapath sample behind the C ABI: the whole plain sample or a named
//! cut of it (`bilinear`, `composite`) as [`pipeline::hw::unit::Unit`]
//! describes it, its ports and outputs listed, its tables loaded by name
//! or filled from a transfer function, evaluated bit for bit as the model
//! computes it.
//!
//! Two ways to evaluate: [`ercube_datapath_eval`] takes and returns
//! arrays (C, Python through ctypes); [`ercube_datapath_set`],
//! [`ercube_datapath_step`] and [`ercube_datapath_get`] take one scalar
//! each, which is what a SystemVerilog DPI-C import passes most simply
//! (`ffi/sv/ercube_pkg.sv`).

use std::ffi::{c_char, c_int, CString};

use pipeline::hw::unit::Unit;

use super::{argument, free_handle, guard, hand_out, text, ErcubeStatus, Failure};

/// One unit of the datapath, with held input and output words.
pub struct ErcubeDatapath {
    unit: Unit,
    inputs: Vec<i64>,
    outputs: Vec<i64>,
    /// The ports' names as C strings, inputs then outputs.
    names: Vec<CString>,
}

impl From<pipeline::hw::unit::UnitError> for Failure {
    fn from(e: pipeline::hw::unit::UnitError) -> Failure {
        Failure(ErcubeStatus::Failed, e.to_string())
    }
}

/// `p` as text, or `None` when it is null or empty.
///
/// # Safety
/// `p` is null or a NUL-terminated string.
unsafe fn optional<'a>(p: *const c_char, what: &str) -> Result<Option<&'a str>, Failure> {
    if p.is_null() {
        return Ok(None);
    }
    let t = text(p, what)?;
    Ok((!t.is_empty()).then_some(t))
}

/// The datapath behind `dp`.
///
/// # Safety
/// `dp` is null or a live handle.
unsafe fn get<'a>(dp: *const ErcubeDatapath) -> Result<&'a ErcubeDatapath, Failure> {
    dp.as_ref().ok_or_else(|| argument("the datapath is null"))
}

/// The datapath behind `dp`, to change.
///
/// # Safety
/// `dp` is null or a live handle, not used elsewhere meanwhile.
unsafe fn get_mut<'a>(dp: *mut ErcubeDatapath) -> Result<&'a mut ErcubeDatapath, Failure> {
    dp.as_mut().ok_or_else(|| argument("the datapath is null"))
}

/// Builds the unit `unit` (`"sample"`, `"bilinear"`, `"composite"`; null
/// or empty: `"sample"`) of the configuration `toml` (null or empty: the
/// defaults) composited in `order` (`"btf"`, `"ftb"`; null or empty: the
/// configuration's), its tables filled from `grey-ramp`.
///
/// # Safety
/// The strings are null or NUL-terminated; `out` is valid for one
/// pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_new(
    toml: *const c_char,
    order: *const c_char,
    unit: *const c_char,
    out: *mut *mut ErcubeDatapath,
) -> c_int {
    guard(|| {
        let toml = optional(toml, "the configuration text")?;
        let order = optional(order, "the order")?;
        let name = optional(unit, "the unit")?.unwrap_or("sample");
        let unit = Unit::from_toml(toml, order, name)?;
        let names = unit
            .inputs()
            .iter()
            .chain(unit.outputs())
            .map(|p| CString::new(p.name.as_str()).expect("port names hold no NUL"))
            .collect();
        hand_out(
            out,
            ErcubeDatapath {
                inputs: vec![0; unit.inputs().len()],
                outputs: vec![0; unit.outputs().len()],
                unit,
                names,
            },
        )
    })
}

/// Releases a datapath (null is ignored).
///
/// # Safety
/// `dp` is null or a live handle, not used again.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_free(dp: *mut ErcubeDatapath) {
    free_handle(dp);
}

/// The number of inputs and outputs and the latency in clocks; any
/// output pointer may be null.
///
/// # Safety
/// `dp` is a live handle; the outputs are null or valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_shape(
    dp: *const ErcubeDatapath,
    n_inputs: *mut u32,
    n_outputs: *mut u32,
    latency: *mut u32,
) -> c_int {
    guard(|| {
        let d = get(dp)?;
        if !n_inputs.is_null() {
            *n_inputs = d.inputs.len() as u32;
        }
        if !n_outputs.is_null() {
            *n_outputs = d.outputs.len() as u32;
        }
        if !latency.is_null() {
            *latency = d.unit.latency();
        }
        Ok(())
    })
}

/// Port `index` of the inputs (`side` 0) or the outputs (`side` 1): its
/// name (living as long as the datapath), width, fraction bits and
/// signedness (1 signed); any output pointer may be null.
///
/// # Safety
/// `dp` is a live handle; the outputs are null or valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_port(
    dp: *const ErcubeDatapath,
    side: u32,
    index: u32,
    name: *mut *const c_char,
    bits: *mut u32,
    frac: *mut i32,
    is_signed: *mut u32,
) -> c_int {
    guard(|| {
        let d = get(dp)?;
        let (ports, base) = match side {
            0 => (d.unit.inputs(), 0),
            1 => (d.unit.outputs(), d.inputs.len()),
            s => return Err(argument(format!("side {s}: 0 for inputs, 1 for outputs"))),
        };
        let i = index as usize;
        let p = ports.get(i).ok_or_else(|| {
            argument(format!(
                "port {index} of {}: there are {}",
                ["inputs", "outputs"][side as usize],
                ports.len()
            ))
        })?;
        if !name.is_null() {
            *name = d.names[base + i].as_ptr();
        }
        if !bits.is_null() {
            *bits = p.word.bits;
        }
        if !frac.is_null() {
            *frac = p.word.frac;
        }
        if !is_signed.is_null() {
            *is_signed = u32::from(p.word.signed);
        }
        Ok(())
    })
}

/// The index of the port named `name` among the inputs (`side` 0) or the
/// outputs (`side` 1).
///
/// # Safety
/// `dp` is a live handle; `name` NUL-terminated; `index` valid for one
/// write.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_find(
    dp: *const ErcubeDatapath,
    side: u32,
    name: *const c_char,
    index: *mut u32,
) -> c_int {
    guard(|| {
        let d = get(dp)?;
        let n = text(name, "the port name")?;
        let found = match side {
            0 => d.unit.input_index(n),
            1 => d.unit.output_index(n),
            s => return Err(argument(format!("side {s}: 0 for inputs, 1 for outputs"))),
        };
        let i = found.ok_or_else(|| {
            let ports = if side == 0 {
                d.unit.inputs()
            } else {
                d.unit.outputs()
            };
            let names: Vec<&str> = ports.iter().map(|p| p.name.as_str()).collect();
            argument(format!(
                "unit {} has no {} '{n}': expected {}",
                d.unit.name(),
                ["input", "output"][side as usize],
                names.join(", ")
            ))
        })?;
        if index.is_null() {
            return Err(argument("the output pointer is null"));
        }
        *index = i as u32;
        Ok(())
    })
}

/// Loads the table `name` (`class_r`, `class_g`, `class_b`, `class_a`,
/// `log_table`, `exp_table`; the whole sample's) with `n` raw words.
///
/// # Safety
/// `dp` is a live handle; `name` NUL-terminated; `words` points at `n`
/// values.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_load_table(
    dp: *mut ErcubeDatapath,
    name: *const c_char,
    words: *const i64,
    n: usize,
) -> c_int {
    guard(|| {
        let d = get_mut(dp)?;
        let t = text(name, "the table name")?;
        if words.is_null() && n > 0 {
            return Err(argument("the words are null"));
        }
        let w = if n == 0 {
            &[][..]
        } else {
            std::slice::from_raw_parts(words, n)
        };
        Ok(d.unit.load_table(t, w)?)
    })
}

/// Fills every table from the transfer function preset `tf` (`grey-ramp`,
/// `ml`, `brain`, ...), as a pipeline frame with `--tf tf` fills them.
///
/// # Safety
/// `dp` is a live handle; `tf` NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_fill_tables(
    dp: *mut ErcubeDatapath,
    tf: *const c_char,
) -> c_int {
    guard(|| {
        let d = get_mut(dp)?;
        let t = text(tf, "the transfer function")?;
        Ok(d.unit.fill_tables(t)?)
    })
}

/// Word `addr` of the table `name` (the whole sample's), into `word`.
///
/// # Safety
/// `dp` is a live handle; `name` NUL-terminated; `word` valid for one
/// write.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_table_get(
    dp: *const ErcubeDatapath,
    name: *const c_char,
    addr: u32,
    word: *mut i64,
) -> c_int {
    guard(|| {
        let d = get(dp)?;
        let t = text(name, "the table name")?;
        let w = d.unit.table_word(t, addr as usize)?;
        if word.is_null() {
            return Err(argument("the output pointer is null"));
        }
        *word = w;
        Ok(())
    })
}

/// Sets word `addr` of the table `name` to `word` (a raw word of its
/// format), as the emitted module's host port writes one word.
///
/// # Safety
/// `dp` is a live handle; `name` NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_table_set(
    dp: *mut ErcubeDatapath,
    name: *const c_char,
    addr: u32,
    word: i64,
) -> c_int {
    guard(|| {
        let d = get_mut(dp)?;
        let t = text(name, "the table name")?;
        Ok(d.unit.set_table_word(t, addr as usize, word)?)
    })
}

/// Evaluates one sample: `n_inputs` input words (raw, in port order) to
/// `n_outputs` output words. The counts must be the unit's.
///
/// # Safety
/// `dp` is a live handle; `inputs` points at `n_inputs` values, `outputs`
/// at room for `n_outputs`.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_eval(
    dp: *const ErcubeDatapath,
    inputs: *const i64,
    n_inputs: usize,
    outputs: *mut i64,
    n_outputs: usize,
) -> c_int {
    guard(|| {
        let d = get(dp)?;
        if inputs.is_null() || outputs.is_null() {
            return Err(argument("the inputs or the outputs are null"));
        }
        if n_outputs != d.outputs.len() {
            return Err(argument(format!(
                "unit {} has {} outputs, room for {n_outputs} given",
                d.unit.name(),
                d.outputs.len()
            )));
        }
        let w = std::slice::from_raw_parts(inputs, n_inputs);
        let y = d.unit.eval(w)?;
        std::slice::from_raw_parts_mut(outputs, n_outputs).copy_from_slice(&y);
        Ok(())
    })
}

/// Holds `word` for input `index` (for [`ercube_datapath_step`]).
///
/// # Safety
/// `dp` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_set(
    dp: *mut ErcubeDatapath,
    index: u32,
    word: i64,
) -> c_int {
    guard(|| {
        let d = get_mut(dp)?;
        let n = d.inputs.len();
        let slot = d
            .inputs
            .get_mut(index as usize)
            .ok_or_else(|| argument(format!("input {index}: there are {n}")))?;
        *slot = word;
        Ok(())
    })
}

/// Evaluates one sample from the held inputs into the held outputs.
///
/// # Safety
/// `dp` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_step(dp: *mut ErcubeDatapath) -> c_int {
    guard(|| {
        let d = get_mut(dp)?;
        d.outputs = d.unit.eval(&d.inputs)?;
        Ok(())
    })
}

/// The held word of output `index` (after [`ercube_datapath_step`]).
///
/// # Safety
/// `dp` is a live handle; `word` valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_get(
    dp: *const ErcubeDatapath,
    index: u32,
    word: *mut i64,
) -> c_int {
    guard(|| {
        let d = get(dp)?;
        let w = d
            .outputs
            .get(index as usize)
            .ok_or_else(|| argument(format!("output {index}: there are {}", d.outputs.len())))?;
        if word.is_null() {
            return Err(argument("the output pointer is null"));
        }
        *word = *w;
        Ok(())
    })
}

/// The unit as a Verilog module named `module` (ports as listed, a clock,
/// registered outputs after the latency), as NUL-terminated text to be
/// released with [`ercube_string_free`]; the whole sample is refused.
///
/// # Safety
/// `dp` is a live handle; `module` NUL-terminated; `out` valid for one
/// pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_datapath_verilog(
    dp: *const ErcubeDatapath,
    module: *const c_char,
    out: *mut *mut c_char,
) -> c_int {
    guard(|| {
        let d = get(dp)?;
        let m = text(module, "the module name")?;
        let v = d
            .unit
            .verilog(m)
            .map_err(|e| Failure(ErcubeStatus::Failed, e.to_string()))?;
        if out.is_null() {
            return Err(argument("the output pointer is null"));
        }
        *out = CString::new(v)
            .map_err(|_| argument("the Verilog holds a NUL"))?
            .into_raw();
        Ok(())
    })
}

/// Releases text from [`ercube_datapath_verilog`] (null is ignored).
///
/// # Safety
/// `s` is null or such text, not used again.
#[no_mangle]
pub unsafe extern "C" fn ercube_string_free(s: *mut c_char) {
    if !s.is_null() {
        drop(CString::from_raw(s));
    }
}
