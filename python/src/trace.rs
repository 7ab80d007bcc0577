//! `Chip.run`'s trace: chosen signals of every cycle clocked, kept as
//! columns of packed numpy integers while the frame steps (no Python
//! object per value), handed over as arrays `(cycle, PE)` or `(cycle,)`.

use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyDict, PyTuple};

use pipeline::probes::Signal;
use pipeline::stepper::Cycle;

use crate::records::{ctrl_values, pe_values, Field, Layout};

/// Where a column's values come from: a PE record's field, or the
/// controller record's.
#[derive(Debug, Clone, Copy)]
enum Source {
    Pe(usize),
    Ctrl(usize),
}

/// One traced signal: its name, field and the words so far.
struct Column {
    name: String,
    field: Field,
    source: Source,
    data: Vec<u8>,
}

/// The trace of one `Chip.run` call.
pub(crate) struct Trace {
    columns: Vec<Column>,
    pes: usize,
    rows: usize,
    pe_fields: usize,
    any_pe: bool,
    scratch: Vec<Signal>,
    pe_vals: Vec<u64>,
    ctrl_vals: Vec<u64>,
}

impl Trace {
    /// A trace of `names` (None: every signal) of the frame whose cycle
    /// `cycle` is; an unknown name is refused in one line listing the
    /// known ones.
    pub fn new(cycle: &Cycle, names: Option<&[String]>) -> Result<Trace, String> {
        let pe = Layout::pe(cycle);
        let ctrl = Layout::ctrl(cycle);
        let ctrl_name = |f: &Field| {
            if f.name == "cycle" {
                f.name.clone()
            } else {
                format!("ctrl.{}", f.name)
            }
        };
        let mut known: Vec<(String, Field, Source)> = Vec::new();
        known.extend(
            ctrl.fields
                .iter()
                .enumerate()
                .map(|(i, f)| (ctrl_name(f), f.clone(), Source::Ctrl(i))),
        );
        known.extend(
            pe.fields
                .iter()
                .enumerate()
                .map(|(i, f)| (f.name.clone(), f.clone(), Source::Pe(i))),
        );
        let chosen: Vec<(String, Field, Source)> = match names {
            None => known,
            Some(names) => {
                // `cycle` always, then the names in order.
                let mut out = vec![known[0].clone()];
                for n in names {
                    let Some(k) = known.iter().find(|k| &k.0 == n) else {
                        let all: Vec<&str> = known.iter().map(|k| k.0.as_str()).collect();
                        return Err(format!(
                            "no signal '{n}' to trace; the frame has {}",
                            all.join(", ")
                        ));
                    };
                    if !out.iter().any(|o| o.0 == *n) {
                        out.push(k.clone());
                    }
                }
                out
            }
        };
        let any_pe = chosen.iter().any(|c| matches!(c.2, Source::Pe(_)));
        Ok(Trace {
            columns: chosen
                .into_iter()
                .map(|(name, field, source)| Column {
                    name,
                    field,
                    source,
                    data: Vec::new(),
                })
                .collect(),
            pes: cycle.pes.len(),
            rows: 0,
            pe_fields: pe.fields.len(),
            any_pe,
            scratch: Vec::new(),
            pe_vals: Vec::new(),
            ctrl_vals: Vec::new(),
        })
    }

    /// Appends `cycle`'s values.
    pub fn record(&mut self, cycle: &Cycle) {
        ctrl_values(cycle, &mut self.ctrl_vals);
        if self.any_pe {
            pe_values(cycle, &mut self.scratch, &mut self.pe_vals);
        }
        for c in &mut self.columns {
            let size = c.field.size();
            match c.source {
                Source::Ctrl(i) => {
                    let at = c.data.len();
                    c.data.resize(at + size, 0);
                    c.field.put(&mut c.data[at..], self.ctrl_vals[i]);
                }
                Source::Pe(i) => {
                    for k in 0..self.pes {
                        let at = c.data.len();
                        c.data.resize(at + size, 0);
                        c.field
                            .put(&mut c.data[at..], self.pe_vals[k * self.pe_fields + i]);
                    }
                }
            }
        }
        self.rows += 1;
    }

    /// The columns as numpy arrays by name.
    pub fn into_dict(self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let np = py.import("numpy")?;
        let out = PyDict::new(py);
        for c in self.columns {
            let kind = if c.field.signed { "i" } else { "u" };
            let dtype = format!("{kind}{}", c.field.size());
            let shape = match c.source {
                Source::Ctrl(_) => PyTuple::new(py, [self.rows])?,
                Source::Pe(_) => PyTuple::new(py, [self.rows, self.pes])?,
            };
            let bytes = PyByteArray::new(py, &c.data);
            let a = np
                .call_method1("frombuffer", (bytes, dtype))?
                .call_method1("reshape", (shape,))?;
            out.set_item(c.name, a)?;
        }
        Ok(out)
    }
}
