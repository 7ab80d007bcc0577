//! A stepped cycle as numpy structured arrays: one record per PE (its
//! signals, ports and report lines) and one for the controller, a field
//! per signal named as the waveform names it, of the smallest numpy
//! integer holding the signal's width (signed where its word is two's
//! complement). The records are written into one `bytearray` per call and
//! numpy views it (one copy, no Python object per field).

use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyDict, PyList};

use pipeline::pe::PeReport;
use pipeline::probes::{Signal, SignalSet};
use pipeline::stepper::Cycle;

/// One field of a record: the signal's name, width and signedness.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Field {
    pub name: String,
    pub width: u32,
    pub signed: bool,
}

impl Field {
    fn of(s: &Signal, prefix: &str) -> Field {
        let name = match (prefix, s.scope) {
            (p, "") => format!("{p}{}", s.name),
            (p, scope) => format!("{p}{scope}.{}", s.name),
        };
        Field {
            name,
            width: s.width,
            signed: s.signed,
        }
    }

    /// Bytes of the numpy integer holding the field.
    pub fn size(&self) -> usize {
        match self.width {
            0..=8 => 1,
            9..=16 => 2,
            17..=32 => 4,
            _ => 8,
        }
    }

    /// numpy's name of the field's type (native byte order).
    fn dtype(&self) -> String {
        format!("{}{}", if self.signed { "i" } else { "u" }, self.size())
    }

    /// Writes `value` (the low `width` bits of the word, as the waveform
    /// holds it) into `dst` (`size()` bytes), sign-extended when signed.
    pub fn put(&self, dst: &mut [u8], value: u64) {
        let v = if self.signed && self.width > 0 && self.width < 64 {
            let shift = 64 - self.width;
            (((value << shift) as i64) >> shift) as u64
        } else {
            value
        };
        match self.size() {
            1 => dst.copy_from_slice(&(v as u8).to_ne_bytes()),
            2 => dst.copy_from_slice(&(v as u16).to_ne_bytes()),
            4 => dst.copy_from_slice(&(v as u32).to_ne_bytes()),
            _ => dst.copy_from_slice(&v.to_ne_bytes()),
        }
    }
}

/// The report lines' fields (`report.NAME`), in the order
/// [`report_values`] gives their values.
const REPORT: [(&str, u32); 9] = [
    ("drained_at", 64),
    ("lands_by", 64),
    ("settled", 1),
    ("readout_done", 1),
    ("active", 32),
    ("pass_width", 32),
    ("slot_work", 32),
    ("merge_outputs", 64),
    ("split_outputs", 64),
];

fn report_values(r: &PeReport) -> [u64; 9] {
    [
        r.drained_at,
        r.lands_by,
        u64::from(r.settled),
        u64::from(r.readout_done),
        u64::from(r.active),
        u64::from(r.pass_width),
        u64::from(r.slot_work),
        r.merge_outputs,
        r.split_outputs,
    ]
}

/// A record's fields and where each sits.
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    pub fields: Vec<Field>,
    pub offsets: Vec<usize>,
    pub itemsize: usize,
}

impl Layout {
    fn new(fields: Vec<Field>) -> Layout {
        let mut offsets = Vec::with_capacity(fields.len());
        let mut at = 0;
        for f in &fields {
            offsets.push(at);
            at += f.size();
        }
        Layout {
            fields,
            offsets,
            itemsize: at,
        }
    }

    /// A PE's record in `cycle`'s frame: its signals (`busy`, ...,
    /// `left.ray_valid`, ..., `host.r`) then its report lines
    /// (`report.drained_at`, ...).
    pub fn pe(cycle: &Cycle) -> Layout {
        let mut fields: Vec<Field> = match cycle.pes.first() {
            Some(pe) => cycle
                .signals
                .pe(pe)
                .iter()
                .map(|s| Field::of(s, ""))
                .collect(),
            None => Vec::new(),
        };
        fields.extend(REPORT.iter().map(|&(n, w)| Field {
            name: format!("report.{n}"),
            width: w,
            signed: false,
        }));
        Layout::new(fields)
    }

    /// The controller's record: `cycle`, then its signals (`stage`,
    /// `slice`, `row`, ...).
    pub fn ctrl(cycle: &Cycle) -> Layout {
        let mut fields = vec![Field {
            name: "cycle".into(),
            width: 64,
            signed: false,
        }];
        fields.extend(
            cycle
                .signals
                .ctrl(&cycle.ctrl)
                .iter()
                .map(|s| Field::of(s, "")),
        );
        Layout::new(fields)
    }

    /// The numpy dtype: packed fields, each signal's width in its
    /// metadata (`dtype.metadata["bits"][name]`).
    pub fn dtype<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let spec = PyDict::new(py);
        let names = PyList::new(py, self.fields.iter().map(|f| f.name.as_str()))?;
        let formats = PyList::new(py, self.fields.iter().map(Field::dtype))?;
        spec.set_item("names", names)?;
        spec.set_item("formats", formats)?;
        spec.set_item("offsets", PyList::new(py, &self.offsets)?)?;
        spec.set_item("itemsize", self.itemsize)?;
        let bits = PyDict::new(py);
        for f in &self.fields {
            bits.set_item(&f.name, f.width)?;
        }
        let meta = PyDict::new(py);
        meta.set_item("bits", bits)?;
        let kw = PyDict::new(py);
        kw.set_item("metadata", meta)?;
        py.import("numpy")?
            .getattr("dtype")?
            .call((spec,), Some(&kw))
    }
}

/// Every PE's values in `cycle` in [`Layout::pe`]'s order, each PE's
/// after the previous one's; `scratch` is reused.
pub(crate) fn pe_values(cycle: &Cycle, scratch: &mut Vec<Signal>, out: &mut Vec<u64>) {
    out.clear();
    for pe in &cycle.pes {
        cycle.signals.pe_into(pe, scratch);
        out.extend(scratch.iter().map(|s| s.value));
        out.extend(report_values(&pe.report));
    }
}

/// The controller's values in `cycle` in [`Layout::ctrl`]'s order.
pub(crate) fn ctrl_values(cycle: &Cycle, out: &mut Vec<u64>) {
    out.clear();
    out.push(cycle.number);
    out.extend(cycle.signals.ctrl(&cycle.ctrl).iter().map(|s| s.value));
}

/// `records` records of `layout` whose values, `layout.fields.len()` per
/// record, are `values`, as a numpy structured array of `dtype` (written
/// once into a bytearray that numpy views).
pub(crate) fn array<'py>(
    py: Python<'py>,
    layout: &Layout,
    dtype: &Bound<'py, PyAny>,
    values: &[u64],
) -> PyResult<Bound<'py, PyAny>> {
    let n = layout.fields.len();
    let records = values.len().checked_div(n).unwrap_or(0);
    let bytes = PyByteArray::new_with(py, records * layout.itemsize, |buf| {
        for (rec, vals) in buf.chunks_exact_mut(layout.itemsize).zip(values.chunks(n)) {
            for ((f, &at), &v) in layout.fields.iter().zip(&layout.offsets).zip(vals) {
                f.put(&mut rec[at..at + f.size()], v);
            }
        }
        Ok(())
    })?;
    py.import("numpy")?
        .call_method1("frombuffer", (bytes, dtype))
}

/// Whether `a` is a cycle of the frame whose signals are `b` (a cached
/// layout still fits).
pub(crate) fn same_set(a: &Cycle, b: &std::sync::Arc<SignalSet>) -> bool {
    std::sync::Arc::ptr_eq(&a.signals, b)
}
