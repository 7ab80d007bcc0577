//! `ercube.pe_vectors`: one PE's sample stage over a frame as numpy
//! arrays, the words `ercube vectors --stage pe` writes as files
//! ([`ercube::frame::pe_stream`]), so a Python testbench needs no files.

use pyo3::prelude::*;
use pyo3::types::PyDict;

use pipeline::cosim::pe_vectors::{Check, MEMORIES};
use pipeline::hw::pe_sample_rtl::MODULE;

use super::{array, camera_args, error, flags, volume_of, Error};

/// `words` as u64, refused in one line when a word is wider (a port or a
/// write of more than 64 bits, which a configuration can make).
fn narrow(what: &str, bits: u32, words: impl Iterator<Item = u128>) -> PyResult<Vec<u64>> {
    if bits > 64 {
        return Err(Error::new_err(format!(
            "{what} is {bits} bits; ercube.pe_vectors returns words of up to 64 (write the files with ercube vectors --stage pe)"
        )));
    }
    Ok(words.map(|w| w as u64).collect())
}

/// One PE's sample stage (`ercube_pe_sample`) over the frame `ercube
/// vectors --stage pe` captures of `voxels`: the stimulus and expected
/// responses as numpy arrays (see `ercube.pyi`). Defaults are the command
/// line's; further options are its flags with underscores (`pes=3`,
/// `terminate=0.95`). The GIL is released while the frame runs.
#[pyfunction]
#[pyo3(signature = (voxels, *, pe=0, spacing=[1.0, 1.0, 1.0], eye=None, look_at=None,
    up=[0.0, 1.0, 0.0], fov=60.0, size=[256, 256], tf=Some("grey-ramp"), order=None,
    config=None, **options))]
#[allow(clippy::too_many_arguments)]
pub fn pe_vectors<'py>(
    py: Python<'py>,
    voxels: &Bound<'py, PyAny>,
    pe: usize,
    spacing: [f64; 3],
    eye: Option<[f64; 3]>,
    look_at: Option<[f64; 3]>,
    up: [f64; 3],
    fov: f64,
    size: [u32; 2],
    tf: Option<&str>,
    order: Option<&str>,
    config: Option<String>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut args = camera_args((eye, look_at, up), fov, size, tf);
    if let Some(o) = order {
        args.push(format!("--order={o}"));
    }
    args.extend(flags(options)?);
    let vol = volume_of(voxels, spacing)?;
    let st = py
        .detach(|| ercube::frame::pe_stream(&args, Some(vol), config.as_deref(), pe))
        .map_err(error)?;

    let d = PyDict::new(py);
    d.set_item("pe", st.pe)?;
    d.set_item("pes", st.pes)?;
    d.set_item("rows", st.rows)?;
    d.set_item("depth", st.depth)?;
    d.set_item("tap_stage", st.tap_stage)?;
    d.set_item("samples", st.samples.0)?;
    d.set_item("samples_all_pes", st.samples.1)?;
    d.set_item("frame_cycles", st.frame_cycles)?;
    d.set_item("mapping", st.mapping)?;
    let (inputs, outputs, ports) = (PyDict::new(py), PyDict::new(py), PyDict::new(py));
    for c in &st.columns {
        let p = &c.port;
        let words = narrow(&p.name, p.bits, c.words.iter().copied())?;
        let a = array(py, &words, &[words.len()], "uint64")?;
        let side = if p.input { &inputs } else { &outputs };
        side.set_item(&p.name, a)?;
        let checked = match c.check {
            Check::Drive => "stimulus".to_owned(),
            Check::Always => "every cycle".to_owned(),
            Check::When(v) => format!("where {v} is 1"),
        };
        let info = PyDict::new(py);
        info.set_item("bits", p.bits)?;
        info.set_item("signed", p.signed)?;
        info.set_item("direction", if p.input { "in" } else { "out" })?;
        info.set_item("checked", checked)?;
        ports.set_item(&p.name, info)?;
    }
    d.set_item("inputs", inputs)?;
    d.set_item("outputs", outputs)?;
    d.set_item("ports", ports)?;
    let constants = PyDict::new(py);
    for (decl, value) in &st.constants {
        constants.set_item(&decl.name, *value as u64)?;
    }
    d.set_item("constants", constants)?;
    let w = &st.writes;
    let writes = PyDict::new(py);
    let cycle: Vec<u64> = w.iter().map(|x| x.cycle).collect();
    let mem: Vec<u8> = w.iter().map(|x| x.mem).collect();
    let addr: Vec<u64> = w.iter().map(|x| x.addr).collect();
    let data = narrow(
        "a memory write",
        st.write_data_bits,
        w.iter().map(|x| x.data),
    )?;
    writes.set_item("cycle", array(py, &cycle, &[w.len()], "uint64")?)?;
    writes.set_item("mem", array(py, &mem, &[w.len()], "uint8")?)?;
    writes.set_item("addr", array(py, &addr, &[w.len()], "uint64")?)?;
    writes.set_item("data", array(py, &data, &[w.len()], "uint64")?)?;
    d.set_item("writes", writes)?;
    d.set_item("memories", MEMORIES.to_vec())?;
    let tables = PyDict::new(py);
    for (name, words) in &st.tables {
        tables.set_item(name, array(py, words, &[words.len()], "int64")?)?;
    }
    d.set_item("tables", tables)?;
    let verilog = PyDict::new(py);
    verilog.set_item(MODULE, &st.verilog)?;
    verilog.set_item(&st.datapath.0, &st.datapath.1)?;
    d.set_item("verilog", verilog)?;
    Ok(d)
}
