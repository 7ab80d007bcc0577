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
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyByteArray, PyCapsule, PyDict, PyList, PyTuple};

use std::ffi::{c_char, c_int};

use std::sync::Mutex;

use ercube::frame::{Reuse, VoxelsRef};
use golden::volume::{Volume, Voxels};

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

/// numpy, imported once.
fn numpy(py: Python<'_>) -> PyResult<&Bound<'_, PyModule>> {
    static NUMPY: PyOnceLock<Py<PyModule>> = PyOnceLock::new();
    NUMPY
        .get_or_try_init(py, || Ok::<_, PyErr>(py.import("numpy")?.unbind()))
        .map(|m| m.bind(py))
}

/// A numpy array of `shape` and `dtype` (numpy's name for `T`, native
/// byte order) holding `values`, backed by a bytearray (one copy).
fn array<'py, T: bytemuck::Pod>(
    py: Python<'py>,
    values: &[T],
    shape: &[usize],
    dtype: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let bytes = PyByteArray::new(py, bytemuck::cast_slice(values));
    numpy(py)?
        .call_method1("frombuffer", (bytes, dtype))?
        .call_method1("reshape", (PyTuple::new(py, shape)?,))
}

/// A frame's pixels lent to numpy without a copy: the array numpy makes
/// of it (`__array_interface__`, writable) reads and writes the frame's
/// own buffer and keeps this object, and so the buffer, alive as its base.
#[pyclass(frozen)]
struct Pixels {
    /// The buffer, never read or moved again (moving the `Vec` would not
    /// move it); numpy reaches it through `address`.
    _data: Vec<[f32; 4]>,
    /// Where the buffer starts, from `as_mut_ptr`: numpy may write there.
    address: usize,
    /// (height, width, 4).
    shape: [usize; 3],
}

#[pymethods]
impl Pixels {
    /// numpy's array interface (version 3): native-order float32 of
    /// `shape`, C-contiguous, writable.
    #[getter]
    fn __array_interface__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("shape", PyTuple::new(py, self.shape)?)?;
        let order = if cfg!(target_endian = "little") {
            "<"
        } else {
            ">"
        };
        d.set_item("typestr", format!("{order}f4"))?;
        d.set_item("data", (self.address, false))?;
        d.set_item("version", 3)?;
        Ok(d)
    }
}

/// The image `im` as a float32 H x W x 4 numpy array, its buffer handed
/// over without a copy ([`Pixels`]).
fn image_array(py: Python<'_>, im: golden::image::Image) -> PyResult<Bound<'_, PyAny>> {
    let shape = [im.height, im.width, 4];
    let mut data = im.data;
    let address = data.as_mut_ptr() as usize;
    let pixels = Bound::new(
        py,
        Pixels {
            _data: data,
            address,
            shape,
        },
    )?;
    numpy(py)?.call_method1("asarray", (pixels,))
}

/// A volume's voxels as a numpy array `(z, y, x)` in their own type.
fn voxels_array<'py>(py: Python<'py>, v: &Volume) -> PyResult<Bound<'py, PyAny>> {
    let [x, y, z] = v.dims();
    match v.voxels() {
        Voxels::U8(d) => array(py, d, &[z, y, x], "uint8"),
        Voxels::U16(d) => array(py, d, &[z, y, x], "uint16"),
    }
}

/// numpy's `PyArrayInterface`: the C struct of the array interface
/// protocol (version 3), which `__array_struct__` hands over in a capsule.
#[repr(C)]
struct ArrayInterface {
    /// 2, always.
    two: c_int,
    /// The number of dimensions.
    nd: c_int,
    /// The kind of element: `b'u'` for an unsigned integer.
    typekind: c_char,
    /// Bytes an element.
    itemsize: c_int,
    /// `C_CONTIGUOUS`, `ALIGNED`, `NOT_SWAPPED`, ...
    flags: c_int,
    /// `nd` extents, slowest first.
    shape: *const isize,
    /// `nd` strides in bytes.
    strides: *const isize,
    /// The first element.
    data: *mut std::ffi::c_void,
    /// A description of the elements (unused here).
    descr: *mut std::ffi::c_void,
}

impl ArrayInterface {
    /// The elements lie in C order without gaps.
    const C_CONTIGUOUS: c_int = 0x1;
    /// The data is aligned for its element type.
    const ALIGNED: c_int = 0x100;
    /// The elements are in the machine's byte order.
    const NOT_SWAPPED: c_int = 0x200;
}

/// A numpy array's voxels, borrowed: the array, C-contiguous and aligned
/// (`numpy.require`; an array that already is one is not copied), held so
/// its buffer stays alive while the voxels are read, and where that buffer
/// is.
struct Input<'py> {
    _array: Bound<'py, PyAny>,
    /// (x, y, z).
    dims: [usize; 3],
    u16: bool,
    address: usize,
    count: usize,
}

impl<'py> Input<'py> {
    /// `voxels` (an array-like `(z, y, x)` of uint8 or uint16).
    fn of(voxels: &Bound<'py, PyAny>) -> PyResult<Input<'py>> {
        if let Some(input) = Input::ready(voxels)? {
            return Ok(input);
        }
        let py = voxels.py();
        let a = numpy(py)?.call_method1("require", (voxels, py.None(), "CA"))?;
        let shape: Vec<usize> = a.getattr("shape")?.extract()?;
        if shape.len() != 3 {
            return Err(Error::new_err(format!(
                "voxels must be a 3-D array (z, y, x); got {} dimensions",
                shape.len()
            )));
        }
        // `str(dtype)` names a byte order only when it is not the
        // machine's: ">u2" is refused.
        let u16 = match a.getattr("dtype")?.str()?.to_string().as_str() {
            "uint8" => false,
            "uint16" => true,
            other => {
                return Err(Error::new_err(format!(
                    "voxels must be uint8 or uint16; got {other}"
                )))
            }
        };
        let (address, _readonly): (usize, bool) = a
            .getattr("__array_interface__")?
            .get_item("data")?
            .extract()?;
        let align = if u16 { 2 } else { 1 };
        if address % align != 0 {
            return Err(Error::new_err("voxels: the array's buffer is not aligned"));
        }
        Ok(Input {
            _array: a,
            dims: [shape[2], shape[1], shape[0]],
            u16,
            address,
            count: shape.iter().product(),
        })
    }

    /// `voxels` when it is a numpy array that `numpy.require` would return
    /// as it is (3-D, C-contiguous, aligned, uint8 or native uint16), read
    /// from its `__array_struct__` alone (one capsule: no dict, tuple or
    /// string is made, as `__array_interface__` makes them); `None` for
    /// anything else, which [`Input::of`] converts or refuses.
    fn ready(voxels: &Bound<'py, PyAny>) -> PyResult<Option<Input<'py>>> {
        let py = voxels.py();
        static NDARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
        let ndarray = NDARRAY.get_or_try_init(py, || {
            Ok::<_, PyErr>(numpy(py)?.getattr("ndarray")?.unbind())
        })?;
        if !voxels.is_instance(ndarray.bind(py))? {
            return Ok(None);
        }
        let Ok(capsule) = voxels
            .getattr(pyo3::intern!(py, "__array_struct__"))?
            .cast_into::<PyCapsule>()
        else {
            return Ok(None);
        };
        let p = capsule.pointer_checked(None)?;
        // SAFETY: numpy's `__array_struct__` is a capsule holding a
        // `PyArrayInterface` (numpy's array interface protocol, the C
        // struct `ArrayInterface` mirrors), alive with the capsule, whose
        // `shape` points at `nd` dimensions; the capsule is held here.
        let ai = unsafe { &*(p.as_ptr() as *const ArrayInterface) };
        let want =
            ArrayInterface::C_CONTIGUOUS | ArrayInterface::ALIGNED | ArrayInterface::NOT_SWAPPED;
        if ai.two != 2 || ai.nd != 3 || ai.typekind != b'u' as c_char || ai.flags & want != want {
            return Ok(None);
        }
        let u16 = match ai.itemsize {
            1 => false,
            2 => true,
            _ => return Ok(None),
        };
        // SAFETY: as above; `nd` is 3.
        let shape: [isize; 3] = unsafe { [*ai.shape, *ai.shape.add(1), *ai.shape.add(2)] };
        let Ok(shape) = shape
            .map(usize::try_from)
            .into_iter()
            .collect::<Result<Vec<_>, _>>()
        else {
            return Ok(None);
        };
        Ok(Some(Input {
            _array: voxels.clone(),
            dims: [shape[2], shape[1], shape[0]],
            u16,
            address: ai.data as usize,
            count: shape.iter().product(),
        }))
    }

    /// The voxels, x fastest.
    ///
    /// They are read with the GIL released; the array must not be resized
    /// or written by another thread meanwhile (as for numpy's own
    /// functions, which release it too).
    fn voxels(&self) -> VoxelsRef<'_> {
        if self.count == 0 {
            return if self.u16 {
                VoxelsRef::U16(&[])
            } else {
                VoxelsRef::U8(&[])
            };
        }
        // SAFETY: `_array` is a C-contiguous, aligned numpy array of
        // `count` elements of this type, alive as long as `self`, whose
        // buffer starts at `address` (`__array_struct__` or
        // `__array_interface__`); numpy does not resize an array while
        // another reference to it (this one) exists.
        unsafe {
            if self.u16 {
                VoxelsRef::U16(std::slice::from_raw_parts(
                    self.address as *const u16,
                    self.count,
                ))
            } else {
                VoxelsRef::U8(std::slice::from_raw_parts(
                    self.address as *const u8,
                    self.count,
                ))
            }
        }
    }
}

/// A volume from a numpy array `(z, y, x)` of uint8 or uint16 (copied
/// once).
fn volume_of(voxels: &Bound<'_, PyAny>, spacing: [f64; 3]) -> PyResult<Volume> {
    let input = Input::of(voxels)?;
    let v = Volume::from_voxels(input.dims, input.voxels().to_voxels())
        .map_err(|e| Error::new_err(e.to_string()))?;
    v.with_spacing(spacing)
        .map_err(|e| Error::new_err(e.to_string()))
}

/// A volume's voxels, borrowed.
fn voxels_ref(v: &Volume) -> VoxelsRef<'_> {
    match v.voxels() {
        Voxels::U8(d) => VoxelsRef::U8(d),
        Voxels::U16(d) => VoxelsRef::U16(d),
    }
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
    source: ([usize; 3], [f64; 3], VoxelsRef<'_>),
    config: Option<String>,
    with_raw: bool,
) -> PyResult<Out<'py>> {
    let r = py
        .detach(|| {
            let config = config.as_deref();
            match REUSE.try_lock() {
                Ok(mut reuse) => ercube::frame::render_borrowed(&args, source, config, &mut reuse),
                Err(_) => ercube::frame::render_borrowed(&args, source, config, &mut Reuse::new()),
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
/// returns `(voxels, spacing)`, voxels a numpy array `(z, y, x)` in the
/// file's type (uint8 or uint16) and spacing `(x, y, z)`. Options are the
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
    Ok((voxels_array(py, &v)?, (s[0], s[1], s[2])))
}

/// Builds a synthetic scene as `--scene SPEC` does (`"ml:40"`,
/// `"checker:32"`, `"sphere:64"`, `"impulse:16"`): voxels `(z, y, x)`.
#[pyfunction]
fn scene<'py>(py: Python<'py>, spec: &str) -> PyResult<Bound<'py, PyAny>> {
    let args = vec![format!("--scene={spec}")];
    let v = py.detach(|| ercube::frame::volume(&args)).map_err(error)?;
    voxels_array(py, &v)
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
    let out = run(py, view.args(options)?, source, config, false)?;
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
