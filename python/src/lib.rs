//! `import ercube`: the ercube renderer and chip model as a Python module.
//! Volumes and images are numpy arrays; every frame is rendered through
//! [`ercube::frame`], the code `ercube render` runs, so images, raw words
//! and statistics are the command line's bit for bit. The GIL is released
//! while a volume loads or a frame renders. The PE array runs whole frames
//! or steps one clock at a time through `ercube.Chip` (`src/chip.rs`); one
//! datapath sample evaluates through `ercube.Datapath` (`src/datapath.rs`);
//! one PE's sample stage over a frame comes back as numpy arrays from
//! `ercube.pe_vectors` (`src/vectors.rs`).
//! Type hints: `ercube.pyi`.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

use std::sync::Mutex;

use ercube::frame::{Frozen, Reuse, VoxelsRef};

use arrays::{array, image_array, voxels_array, Input};
pub(crate) use arrays::{volume_of, voxels_ref};

mod arrays;
mod chip;
mod datapath;
mod records;
mod trace;
mod vectors;

create_exception!(
    ercube,
    Error,
    PyValueError,
    "An ercube failure, carrying the command line's one-line message."
);

fn error(e: ercube::frame::Error) -> PyErr {
    Error::new_err(e.message)
}

/// `options` as command-line flags: `name=value` is `--name=value` with
/// underscores as hyphens; `True` is the bare flag; `False` and `None` are
/// left out; a tuple or list is its items joined by commas.
fn flags(options: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    let mut out = Vec::new();
    let Some(options) = options else {
        return Ok(out);
    };
    for (k, v) in options.iter() {
        let name = format!("--{}", k.extract::<String>()?.replace('_', "-"));
        if v.is_none() {
            continue;
        }
        if let Ok(b) = v.cast::<pyo3::types::PyBool>() {
            if b.is_true() {
                out.push(name);
            }
            continue;
        }
        let value = if v.is_instance_of::<PyTuple>() || v.is_instance_of::<PyList>() {
            let items: Vec<String> = v
                .try_iter()?
                .map(|x| x.and_then(|x| Ok(x.str()?.to_string())))
                .collect::<PyResult<_>>()?;
            items.join(",")
        } else {
            v.str()?.to_string()
        };
        out.push(format!("{name}={value}"));
    }
    Ok(out)
}

/// The camera and method flags of [`render`] and [`Chip::run_frame`].
struct View {
    eye: Option<[f64; 3]>,
    look_at: Option<[f64; 3]>,
    up: [f64; 3],
    fov: f64,
    size: [u32; 2],
    method: String,
    tf: Option<String>,
}

impl View {
    fn args(&self, options: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
        let mut a = vec![format!("--method={}", self.method)];
        a.extend(camera_args(
            (self.eye, self.look_at, self.up),
            self.fov,
            self.size,
            self.tf.as_deref(),
        ));
        a.extend(flags(options)?);
        Ok(a)
    }
}

/// The command line's camera and transfer-function flags: `--up`, `--fov`,
/// `--size`, and `--eye`, `--look-at`, `--tf` where given.
fn camera_args(
    (eye, look_at, up): (Option<[f64; 3]>, Option<[f64; 3]>, [f64; 3]),
    fov: f64,
    size: [u32; 2],
    tf: Option<&str>,
) -> Vec<String> {
    let v3 = |v: [f64; 3]| format!("{},{},{}", v[0], v[1], v[2]);
    let mut a = vec![
        format!("--up={}", v3(up)),
        format!("--fov={fov}"),
        format!("--size={}x{}", size[0], size[1]),
    ];
    if let Some(e) = eye {
        a.push(format!("--eye={}", v3(e)));
    }
    if let Some(l) = look_at {
        a.push(format!("--look-at={}", v3(l)));
    }
    if let Some(t) = tf {
        a.push(format!("--tf={t}"));
    }
    a
}

/// What a frame returns to Python: the image, the raw words (pipeline
/// only) and the statistics dict.
struct Out<'py> {
    image: Bound<'py, PyAny>,
    raw: Option<Bound<'py, PyAny>>,
    stats: Bound<'py, PyAny>,
}

/// The last frame's volume and preparation (the slice stack, the
/// empty-space blocks and occupancy map), kept between calls: rendering
/// the same voxels again (compared value for value), by any camera or
/// method, copies nothing and prepares only what the camera changes
/// (`ercube::frame::render_borrowed`). `clear_cache` drops it.
static REUSE: Mutex<Reuse> = Mutex::new(Reuse::new());

/// Renders `voxels` with `spacing` with the GIL released and converts the
/// results. A call made while another thread's call holds the kept
/// preparation renders without it.
fn run<'py>(
    py: Python<'py>,
    args: Vec<String>,
    (source, frozen): (([usize; 3], [f64; 3], VoxelsRef<'_>), Option<Frozen>),
    config: Option<String>,
    with_raw: bool,
) -> PyResult<Out<'py>> {
    let r = py
        .detach(|| {
            let config = config.as_deref();
            let frame = |reuse: &mut Reuse| {
                ercube::frame::render_borrowed(&args, source, frozen, config, reuse)
            };
            match REUSE.try_lock() {
                Ok(mut reuse) => frame(&mut reuse),
                Err(_) => frame(&mut Reuse::new()),
            }
        })
        .map_err(error)?;
    outputs(py, r, with_raw)
}

/// A render's image, raw words (pipeline only, when `with_raw`) and
/// statistics as numpy arrays and a dict (built from the statistics'
/// values, as `json.loads` of `--stats` would); the image's buffer is
/// handed to numpy, not copied.
fn outputs(py: Python<'_>, mut r: ercube::frame::Rendered, with_raw: bool) -> PyResult<Out<'_>> {
    let raw = match ercube::frame::raw_words(&r).filter(|_| with_raw) {
        Some((w, h, words)) => Some(array(py, words.as_flattened(), &[h, w, 4], "int64")?),
        None => None,
    };
    let stats = json_value(py, &r.stats)?;
    let im = std::mem::replace(&mut r.image, golden::image::Image::new(0, 0));
    // The baseplane goes back to the frames' pool of spare buffers, as the
    // command line's `--repeat` frames give theirs back.
    if let Some(b) = r.baseplane.take() {
        golden::merge::recycle(b.data);
    }
    Ok(Out {
        image: image_array(py, im)?,
        raw,
        stats,
    })
}

/// A JSON value as the Python object `json.loads` makes of it: a dict
/// (keys in the map's order), list, str, int, float, bool or None.
/// Built directly from the value: a frame's statistics (some 130
/// values) convert in a few microseconds.
fn json_value<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value;
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => pyo3::types::PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => match (n.as_u64(), n.as_i64()) {
            (Some(u), _) => u.into_pyobject(py)?.into_any(),
            (None, Some(i)) => i.into_pyobject(py)?.into_any(),
            // serde_json's floats are finite.
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(t) => pyo3::types::PyString::new(py, t).into_any(),
        Value::Array(items) => {
            let items = items
                .iter()
                .map(|x| json_value(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        Value::Object(map) => {
            let d = PyDict::new(py);
            for (k, x) in map {
                d.set_item(k, json_value(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// Loads a volume file, in any format `ercube render --volume` reads:
/// returns `(voxels, spacing)`, voxels a read-only numpy array `(z, y,
/// x)` in the file's type (uint8 or uint16) over the loaded volume's own
/// buffer (`voxels.copy()` gives one to change) and spacing `(x, y, z)`. Options are the
/// command line's source flags: `raw_dims=(x, y, z)`, `raw_type="u16le"`,
/// `raw_offset`, `spacing`, `window`, `max_memory`.
#[pyfunction]
#[pyo3(signature = (path, **options))]
fn load<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyAny>, (f64, f64, f64))> {
    let mut args = vec![format!("--volume={}", path.display())];
    args.extend(flags(options)?);
    let v = py.detach(|| ercube::frame::volume(&args)).map_err(error)?;
    let s = v.spacing();
    Ok((voxels_array(py, v)?, (s[0], s[1], s[2])))
}

/// Builds a synthetic scene as `--scene SPEC` does (`"ml:40"`,
/// `"checker:32"`, `"sphere:64"`, `"impulse:16"`): voxels `(z, y, x)`,
/// read-only as [`load`]'s.
#[pyfunction]
fn scene<'py>(py: Python<'py>, spec: &str) -> PyResult<Bound<'py, PyAny>> {
    let args = vec![format!("--scene={spec}")];
    let v = py.detach(|| ercube::frame::volume(&args)).map_err(error)?;
    voxels_array(py, v)
}

/// Renders `voxels` (numpy `(z, y, x)`, uint8 or uint16) as `ercube
/// render` does and returns `(image, stats)`: image the float32 `H x W x
/// 4` premultiplied RGBA array `--npy` writes, stats the dict `--stats`
/// writes. Every default is the command line's: the eye 1.5 volume depths
/// in front of the z = 0 face, looking at the centre. `size` is (width,
/// height); points and spacing are (x, y, z). `config` is a pipeline
/// configuration as TOML text. Further options are `ercube render` flags
/// with underscores: `shade=True`, `terminate=0.95`, `pes=8`, ...
#[pyfunction]
#[pyo3(signature = (voxels, *, spacing=[1.0, 1.0, 1.0], eye=None, look_at=None,
    up=[0.0, 1.0, 0.0], fov=60.0, size=[256, 256], method="er", tf=Some("grey-ramp"),
    config=None, **options))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    voxels: &Bound<'py, PyAny>,
    spacing: [f64; 3],
    eye: Option<[f64; 3]>,
    look_at: Option<[f64; 3]>,
    up: [f64; 3],
    fov: f64,
    size: [u32; 2],
    method: &str,
    tf: Option<&str>,
    config: Option<String>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let input = Input::of(voxels)?;
    let view = View {
        eye,
        look_at,
        up,
        fov,
        size,
        method: method.to_string(),
        tf: tf.map(str::to_string),
    };
    let source = (input.dims, spacing, input.voxels());
    let out = run(
        py,
        view.args(options)?,
        (source, input.frozen()?),
        config,
        false,
    )?;
    Ok((out.image, out.stats))
}

/// Drops the volume and preparation kept from the last `render` or
/// `Chip.run_frame` call (its memory: the voxels and their slice stack).
#[pyfunction]
fn clear_cache(py: Python<'_>) {
    py.detach(|| {
        if let Ok(mut r) = REUSE.lock() {
            r.clear();
        }
    });
}

/// The module.
#[pymodule]
#[pyo3(name = "ercube")]
fn ercube_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(scene, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(clear_cache, m)?)?;
    m.add_function(wrap_pyfunction!(vectors::pe_vectors, m)?)?;
    // The controller's stages by code (`Chip.broadcast()["stage"]`).
    let mut stages = vec![""; pipeline::probes::Stage::ALL.len()];
    for s in pipeline::probes::Stage::ALL {
        stages[s.code() as usize] = s.name();
    }
    m.add("STAGES", stages)?;
    m.add_class::<chip::Chip>()?;
    m.add_class::<datapath::Datapath>()?;
    Ok(())
}
