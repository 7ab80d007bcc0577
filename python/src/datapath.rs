//! `ercube.Datapath`: one sample of the datapath (the whole plain sample,
//! or its `bilinear` or `composite` unit) evaluated from raw input words
//! to raw output words, bit for bit the model's
//! ([`pipeline::hw::unit::Unit`], the C ABI's `ErcubeDatapath`). What a
//! cocotb testbench checks an emitted unit's outputs against.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use pipeline::hw::unit::{Port, Unit, UnitError};

use crate::Error;

fn error(e: UnitError) -> PyErr {
    Error::new_err(e.to_string())
}

/// Ports as a list of dicts: name, bits, frac, signed.
fn ports<'py>(py: Python<'py>, ps: &[Port]) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for p in ps {
        let d = PyDict::new(py);
        d.set_item("name", &p.name)?;
        d.set_item("bits", p.word.bits)?;
        d.set_item("frac", p.word.frac)?;
        d.set_item("signed", p.word.signed)?;
        list.append(d)?;
    }
    Ok(list)
}

/// One unit of the datapath with a configuration and an order.
#[pyclass(module = "ercube")]
pub struct Datapath {
    unit: Unit,
}

#[pymethods]
impl Datapath {
    /// The unit `unit` (`"sample"`, `"bilinear"`, `"composite"`) of the
    /// pipeline configuration `config` (TOML text; `None`: the defaults)
    /// composited in `order` (`"btf"` or `"ftb"`; `None`: the
    /// configuration's). Tables start as the `grey-ramp` transfer
    /// function's.
    #[new]
    #[pyo3(signature = (config=None, order=Some("btf"), unit="sample"))]
    fn new(config: Option<&str>, order: Option<&str>, unit: &str) -> PyResult<Datapath> {
        Ok(Datapath {
            unit: Unit::from_toml(config, order, unit).map_err(error)?,
        })
    }

    /// The unit's name.
    #[getter]
    fn unit(&self) -> &str {
        self.unit.name()
    }

    /// The input ports, in order: dicts of `name`, `bits`, `frac` (the
    /// value is `word * 2**-frac`) and `signed`.
    #[getter]
    fn inputs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        ports(py, self.unit.inputs())
    }

    /// The outputs, as `inputs`.
    #[getter]
    fn outputs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        ports(py, self.unit.outputs())
    }

    /// Clocks from a sample's inputs to its outputs in the unit's Verilog.
    #[getter]
    fn latency(&self) -> u32 {
        self.unit.latency()
    }

    /// The tables the unit reads (the whole sample's): dicts of `name`,
    /// `depth` and `format`.
    #[getter]
    fn tables<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for t in self.unit.tables() {
            let d = PyDict::new(py);
            d.set_item("name", &t.name)?;
            d.set_item("depth", t.depth)?;
            d.set_item("format", t.fmt.to_string())?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// The table `name`'s raw words.
    fn table(&self, name: &str) -> PyResult<Vec<i64>> {
        self.unit
            .table(name)
            .map(<[i64]>::to_vec)
            .ok_or_else(|| Error::new_err(format!("unknown table '{name}'")))
    }

    /// Loads the table `name` with raw words (exactly its depth).
    fn load_table(&mut self, name: &str, words: Vec<i64>) -> PyResult<()> {
        self.unit.load_table(name, &words).map_err(error)
    }

    /// Fills every table from a transfer-function preset (`grey-ramp`,
    /// `ml`, `brain`, ...), as a pipeline frame with `--tf` fills them.
    fn fill_tables(&mut self, tf: &str) -> PyResult<()> {
        self.unit.fill_tables(tf).map_err(error)
    }

    /// One sample: every input's raw word by name, returning every
    /// output's raw word by name.
    #[pyo3(signature = (**words))]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        words: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let u = &self.unit;
        let mut given = vec![None; u.inputs().len()];
        if let Some(w) = words {
            for (k, v) in w.iter() {
                let name: String = k.extract()?;
                let i = u.input_index(&name).ok_or_else(|| {
                    let names: Vec<&str> = u.inputs().iter().map(|p| p.name.as_str()).collect();
                    Error::new_err(format!(
                        "unit {} has no input '{name}': expected {}",
                        u.name(),
                        names.join(", ")
                    ))
                })?;
                given[i] = Some(v.extract::<i64>()?);
            }
        }
        let ins = given
            .iter()
            .zip(u.inputs())
            .map(|(w, p)| w.ok_or_else(|| Error::new_err(format!("input {} is missing", p.name))))
            .collect::<PyResult<Vec<i64>>>()?;
        let outs = u.eval(&ins).map_err(error)?;
        let d = PyDict::new(py);
        for (p, w) in u.outputs().iter().zip(outs) {
            d.set_item(&p.name, w)?;
        }
        Ok(d)
    }

    /// The whole sample's pipelined module as `ercube rtl` emits it, named
    /// `module`: a dict of `name`, `verilog` (the text), `depth` (clocks
    /// from `in_valid` to `out_valid`), `ports` (dicts of `name`, `input`,
    /// `bits`, `frac`, `signed`, `stage`: clocks after issue it is read or
    /// shown) and `tables` (dicts of `name`, `sel`: its `tbl_sel` code,
    /// `depth`, `bits`). A cut is refused (its module is `verilog`).
    #[pyo3(signature = (module="ercube_sample"))]
    fn pipelined<'py>(&self, py: Python<'py>, module: &str) -> PyResult<Bound<'py, PyDict>> {
        let m = self.unit.pipelined(module).map_err(error)?;
        let ports = PyList::empty(py);
        for p in &m.ports {
            let d = PyDict::new(py);
            d.set_item("name", &p.name)?;
            d.set_item("input", p.input)?;
            d.set_item("bits", p.word.bits)?;
            d.set_item("frac", p.word.frac)?;
            d.set_item("signed", p.word.signed)?;
            d.set_item("stage", p.stage)?;
            ports.append(d)?;
        }
        let tables = PyList::empty(py);
        for t in &m.tables {
            let d = PyDict::new(py);
            d.set_item("name", &t.name)?;
            d.set_item("sel", t.sel)?;
            d.set_item("depth", t.depth)?;
            d.set_item("bits", t.bits)?;
            tables.append(d)?;
        }
        let d = PyDict::new(py);
        d.set_item("name", &m.name)?;
        d.set_item("verilog", &m.verilog)?;
        d.set_item("depth", m.depth)?;
        d.set_item("ports", ports)?;
        d.set_item("tables", tables)?;
        Ok(d)
    }

    /// The unit as a Verilog module named `module` (the cuts; the whole
    /// sample's is `pipelined`).
    #[pyo3(signature = (module="ercube_unit"))]
    fn verilog(&self, module: &str) -> PyResult<String> {
        self.unit
            .verilog(module)
            .map_err(|e| Error::new_err(e.to_string()))
    }

    fn __repr__(&self) -> String {
        format!(
            "Datapath(unit={:?}, order={:?}, inputs={}, outputs={}, latency={})",
            self.unit.name(),
            self.unit.config().order.name(),
            self.unit.inputs().len(),
            self.unit.outputs().len(),
            self.unit.latency()
        )
    }
}
