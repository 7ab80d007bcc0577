//! `ercube.Chip`: the bit-accurate PE array with one configuration. It
//! runs whole frames (`run_frame`, as `ercube.render` does), or steps one
//! clock at a time (`begin`, `step`, `ports`, `broadcast`, `finish`):
//! the frame runs on a worker thread that hands over after every cycle
//! (`pipeline::stepper`), so the cycles and every PE's values are those
//! of the frame `ercube render --vcd` traces.

use std::sync::{Arc, Mutex};

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use golden::volume::Volume;
use pipeline::probes::SignalSet;
use pipeline::stepper::Cycle;

use crate::arrays::new_buffer;
use crate::records::{self, Layout};
use crate::{error, outputs, run, trace, volume_of, voxels_ref, Error, View};
use ercube::frame::Frozen;

/// A frame being stepped: the stepper while it runs, then its render.
#[derive(Default)]
struct Stepping {
    stepper: Option<ercube::frame::Stepper>,
    /// The last cycle, kept once the stepper has ended.
    last: Option<Cycle>,
    /// The frame's render, once it ended.
    result: Option<Result<ercube::frame::Rendered, PyErr>>,
    cycles: u64,
    /// The records' layouts and numpy dtypes of the frame's signals.
    layouts: Option<Layouts>,
}

/// The layouts of a frame's records and their numpy dtypes.
struct Layouts {
    signals: Arc<SignalSet>,
    pe: Layout,
    ctrl: Layout,
    pe_dtype: Py<PyAny>,
    ctrl_dtype: Py<PyAny>,
}

impl Stepping {
    /// Refuses a frame that failed (its error) or was never begun.
    fn check(&self, py: Python<'_>) -> PyResult<()> {
        if let Some(Err(e)) = &self.result {
            return Err(e.clone_ref(py));
        }
        if self.stepper.is_none() && self.result.is_none() {
            return Err(Error::new_err("no frame: call Chip.begin first"));
        }
        Ok(())
    }

    /// The stepper has no cycle left: keeps its last cycle and its render.
    fn end(&mut self) {
        if let Some(s) = self.stepper.take() {
            self.last = s.current().cloned();
            self.result = Some(finished(s));
        }
    }

    /// The current cycle and the layouts of its frame's records (made at
    /// the frame's first call).
    fn layouts(&mut self, py: Python<'_>) -> PyResult<(&Cycle, &Layouts)> {
        let cycle = self.current()?;
        let fresh = match &self.layouts {
            Some(l) => !records::same_set(cycle, &l.signals),
            None => true,
        };
        if fresh {
            let (pe, ctrl) = (Layout::pe(cycle), Layout::ctrl(cycle));
            let signals = Arc::clone(&cycle.signals);
            self.layouts = Some(Layouts {
                pe_dtype: pe.dtype(py)?.unbind(),
                ctrl_dtype: ctrl.dtype(py)?.unbind(),
                signals,
                pe,
                ctrl,
            });
        }
        let l = self.layouts.as_ref().expect("made above");
        Ok((self.current()?, l))
    }

    /// The last cycle clocked.
    fn current(&self) -> PyResult<&Cycle> {
        self.stepper
            .as_ref()
            .and_then(|s| s.current())
            .or(self.last.as_ref())
            .ok_or_else(|| Error::new_err("no cycle yet: call Chip.begin, then Chip.step"))
    }
}

/// The stepper's end: its render, or its failure or panic.
fn finished(s: ercube::frame::Stepper) -> Result<ercube::frame::Rendered, PyErr> {
    match s.finish() {
        Ok(r) => r.map_err(error),
        Err(p) => Err(Error::new_err(p.to_string())),
    }
}

/// The bit-accurate PE array with one configuration: load a volume, then
/// run frames of it whole (`run_frame`) or one clock at a time (`begin`,
/// `step`, `ports`, `broadcast`, `finish`).
#[pyclass(module = "ercube")]
pub struct Chip {
    config: Option<String>,
    /// The loaded volume and its identity as a buffer that cannot change
    /// (a new one each `load`), so a frame of it is not compared with the
    /// module's kept volume.
    volume: Option<(Volume, Frozen)>,
    stepping: Mutex<Stepping>,
}

impl Chip {
    /// The stepping state; refused while another thread's call holds it
    /// (waiting for it with the GIL held could deadlock that call).
    fn stepping(&self) -> PyResult<std::sync::MutexGuard<'_, Stepping>> {
        match self.stepping.try_lock() {
            Ok(g) => Ok(g),
            Err(std::sync::TryLockError::Poisoned(p)) => Ok(p.into_inner()),
            Err(std::sync::TryLockError::WouldBlock) => {
                Err(Error::new_err("the Chip is busy in another thread's call"))
            }
        }
    }
}

/// A camera: eye, look-at, up, field of view.
type Camera = (Option<[f64; 3]>, Option<[f64; 3]>, [f64; 3], f64);

/// The camera and method arguments of `begin` and `run_frame`, refusing a
/// golden method.
fn view_of(
    (eye, look_at, up, fov): Camera,
    size: [u32; 2],
    method: &str,
    tf: Option<&str>,
) -> PyResult<View> {
    if !method.starts_with("pipeline") {
        return Err(Error::new_err(format!(
            "a Chip runs --method pipeline or pipeline-ftb; {method} is a golden method (use ercube.render)"
        )));
    }
    Ok(View {
        eye,
        look_at,
        up,
        fov,
        size,
        method: method.to_string(),
        tf: tf.map(str::to_string),
    })
}

#[pymethods]
impl Chip {
    /// A chip with the pipeline configuration `config` (TOML text, as a
    /// `--config` file holds; missing keys keep their defaults), or the
    /// default configuration.
    #[new]
    #[pyo3(signature = (config=None))]
    fn new(config: Option<String>) -> PyResult<Chip> {
        if let Some(c) = &config {
            ercube::frame::check_config(c).map_err(error)?;
        }
        Ok(Chip {
            config,
            volume: None,
            stepping: Mutex::default(),
        })
    }

    /// Loads `voxels` (numpy `(z, y, x)`, uint8 or uint16) with `spacing`
    /// (x, y, z) for the next frames.
    #[pyo3(signature = (voxels, spacing=[1.0, 1.0, 1.0]))]
    fn load(&mut self, voxels: &Bound<'_, PyAny>, spacing: [f64; 3]) -> PyResult<()> {
        let frozen = Frozen {
            buffer: new_buffer(),
            offset: 0,
        };
        self.volume = Some((volume_of(voxels, spacing)?, frozen));
        Ok(())
    }

    /// Runs one frame of the loaded volume and returns `(image, raw,
    /// stats)`: the image as `render` returns it, raw the int64 `H x W x
    /// 4` accumulator words `--raw-npy` writes (formats in
    /// `stats["raw_format"]`), and the stats dict. `method` is `pipeline`
    /// (back to front) or `pipeline-ftb`; the rest as `render`.
    #[pyo3(signature = (*, eye=None, look_at=None, up=[0.0, 1.0, 0.0], fov=60.0,
        size=[256, 256], method="pipeline", tf=Some("grey-ramp"), **options))]
    #[allow(clippy::too_many_arguments)]
    fn run_frame<'py>(
        &self,
        py: Python<'py>,
        eye: Option<[f64; 3]>,
        look_at: Option<[f64; 3]>,
        up: [f64; 3],
        fov: f64,
        size: [u32; 2],
        method: &str,
        tf: Option<&str>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let view = view_of((eye, look_at, up, fov), size, method, tf)?;
        let Some((volume, frozen)) = &self.volume else {
            return Err(Error::new_err("no volume: call Chip.load(voxels) first"));
        };
        let source = (volume.dims(), volume.spacing(), voxels_ref(volume));
        let out = run(
            py,
            view.args(options)?,
            (source, Some(*frozen)),
            self.config.clone(),
            true,
        )?;
        let raw = out
            .raw
            .ok_or_else(|| Error::new_err("the frame has no raw words"))?;
        Ok((out.image, raw, out.stats))
    }

    /// Begins a frame of `voxels` (numpy `(z, y, x)` with `spacing`) or,
    /// when `voxels` is None, of the loaded volume, with `run_frame`'s
    /// options, to be stepped one clock at a time. Any frame in progress
    /// stops. No cycle runs before `step`.
    #[pyo3(signature = (voxels=None, *, spacing=[1.0, 1.0, 1.0], eye=None, look_at=None,
        up=[0.0, 1.0, 0.0], fov=60.0, size=[256, 256], method="pipeline",
        tf=Some("grey-ramp"), **options))]
    #[allow(clippy::too_many_arguments)]
    fn begin<'py>(
        &self,
        py: Python<'py>,
        voxels: Option<&Bound<'py, PyAny>>,
        spacing: [f64; 3],
        eye: Option<[f64; 3]>,
        look_at: Option<[f64; 3]>,
        up: [f64; 3],
        fov: f64,
        size: [u32; 2],
        method: &str,
        tf: Option<&str>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<()> {
        let view = view_of((eye, look_at, up, fov), size, method, tf)?;
        let volume = match voxels {
            Some(v) => volume_of(v, spacing)?,
            None => self
                .volume
                .as_ref()
                .map(|(v, _)| v.clone())
                .ok_or_else(|| Error::new_err("no volume: pass voxels or call Chip.load first"))?,
        };
        let args = view.args(options)?;
        let config = self.config.clone();
        let old = std::mem::take(&mut *self.stepping()?);
        // The frame in progress stops and its thread is joined first.
        py.detach(move || drop(old));
        let s = ercube::frame::stepper(&args, Some(volume), config.as_deref()).map_err(error)?;
        self.stepping()?.stepper = Some(s);
        Ok(())
    }

    /// Clocks up to `n` cycles (the GIL released) and returns the number
    /// of the last cycle clocked: the frame's cycles once it has ended
    /// (`done`). A frame that fails raises its error here.
    #[pyo3(signature = (n=1))]
    fn step(&self, py: Python<'_>, n: u64) -> PyResult<u64> {
        let mut st = self.stepping()?;
        st.check(py)?;
        let st = &mut *st;
        py.detach(|| {
            for _ in 0..n {
                let Some(s) = st.stepper.as_mut() else {
                    return;
                };
                match s.step() {
                    Some(c) => st.cycles = c.number,
                    None => {
                        st.end();
                        return;
                    }
                }
            }
        });
        if let Some(Err(e)) = &st.result {
            return Err(e.clone_ref(py));
        }
        Ok(st.cycles)
    }

    /// Whether the frame has no cycle left.
    #[getter]
    fn done(&self) -> PyResult<bool> {
        Ok(self.stepping()?.result.is_some())
    }

    /// The number of the last cycle clocked (0 before the first).
    #[getter]
    fn cycle(&self) -> PyResult<u64> {
        Ok(self.stepping()?.cycles)
    }

    /// Every PE in the last cycle clocked, in PE order, as a numpy
    /// structured array (one record per PE): a field per signal, named as
    /// the waveform names it below `top.pe_K` (`busy`, `acc_r`, ...,
    /// `left.ray_valid`, `right.edge_0`, `host.r`, ...), then the report
    /// lines (`report.drained_at`, ...). Each field is the smallest numpy
    /// integer holding the signal's width (`dtype.metadata["bits"]`),
    /// signed where the word is two's complement.
    fn ports<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut st = self.stepping()?;
        let st = &mut *st;
        let (cycle, layouts) = st.layouts(py)?;
        let mut values = Vec::new();
        records::pe_values(cycle, &mut Vec::new(), &mut values);
        records::array(py, &layouts.pe, layouts.pe_dtype.bind(py), &values)
    }

    /// The controller in the last cycle clocked, as a numpy record
    /// (`numpy.void`): `cycle`, then its signals as the waveform names
    /// them below `top.ctrl` (`stage`, `slice`, `row`, `pass_x_valid`,
    /// ...), each the smallest numpy integer holding its width.
    /// `ercube.STAGES[record["stage"]]` names the stage.
    fn broadcast<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut st = self.stepping()?;
        let st = &mut *st;
        let (cycle, layouts) = st.layouts(py)?;
        let mut values = Vec::new();
        records::ctrl_values(cycle, &mut values);
        records::array(py, &layouts.ctrl, layouts.ctrl_dtype.bind(py), &values)?.get_item(0)
    }

    /// The commands the controller broadcast to every PE before the last
    /// cycle clocked (since the previous cycle), in order, each a tuple
    /// `(name, a, b)` (see docs/verify.md).
    fn commands<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let st = self.stepping()?;
        let cycle = st.current()?;
        let cmds = PyList::empty(py);
        for c in &cycle.commands {
            let (_, a, b) = c.words();
            cmds.append((c.name(), a, b))?;
        }
        Ok(cmds)
    }

    /// Clocks up to `cycles` cycles (the GIL released) and returns the
    /// chosen signals of every cycle clocked as numpy arrays by name: a
    /// PE's signal or report line (`ports()`'s field names) as a 2-D
    /// array `(cycle, PE)`, the controller's as `ctrl.NAME` (`ctrl.stage`,
    /// ...) a 1-D array, and always `cycle`, the cycles' numbers. `signals`
    /// None takes every one. Fewer rows than `cycles` when the frame ends.
    #[pyo3(signature = (cycles, signals=None))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        cycles: u64,
        signals: Option<Vec<String>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut st = self.stepping()?;
        st.check(py)?;
        let st = &mut *st;
        let mut trace: Option<trace::Trace> = None;
        let made = py.detach(|| -> Result<(), String> {
            for _ in 0..cycles {
                let Some(s) = st.stepper.as_mut() else {
                    break;
                };
                match s.step() {
                    Some(c) => {
                        st.cycles = c.number;
                        let t = match &mut trace {
                            Some(t) => t,
                            None => trace.insert(trace::Trace::new(c, signals.as_deref())?),
                        };
                        t.record(c);
                    }
                    None => {
                        st.end();
                        break;
                    }
                }
            }
            Ok(())
        });
        made.map_err(Error::new_err)?;
        let t = match trace {
            Some(t) => t,
            // Nothing clocked: the frame had ended; empty columns.
            None => trace::Trace::new(st.current()?, signals.as_deref()).map_err(Error::new_err)?,
        };
        if let Some(Err(e)) = &st.result {
            return Err(e.clone_ref(py));
        }
        t.into_dict(py)
    }

    /// Runs the rest of the frame (the GIL released) and returns `(image,
    /// raw, stats)` as `run_frame` does for the same frame: the same
    /// image, raw words and statistics (apart from the wall-clock times).
    fn finish<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let st = std::mem::take(&mut *self.stepping()?);
        let r = match (st.result, st.stepper) {
            (Some(r), _) => r,
            (None, Some(s)) => py.detach(|| finished(s)),
            (None, None) => return Err(Error::new_err("no frame: call Chip.begin first")),
        }?;
        let out = outputs(py, r, true)?;
        let raw = out
            .raw
            .ok_or_else(|| Error::new_err("the frame has no raw words"))?;
        Ok((out.image, raw, out.stats))
    }
}
