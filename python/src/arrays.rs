//! numpy arrays in and out of the module without copies where it can:
//! frames' images handed to numpy ([`Pixels`]), loaded volumes as
//! read-only arrays over a buffer that cannot change ([`FrozenVoxels`]),
//! and a caller's array read in place ([`Input`]).

use std::ffi::{c_char, c_int};
use std::sync::atomic::{AtomicU64, Ordering};

use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyByteArray, PyCapsule, PyDict, PyTuple};

use ercube::frame::{Frozen, VoxelsRef};
use golden::volume::{Volume, Voxels};

use crate::Error;

/// numpy, imported once.
pub(crate) fn numpy(py: Python<'_>) -> PyResult<&Bound<'_, PyModule>> {
    static NUMPY: PyOnceLock<Py<PyModule>> = PyOnceLock::new();
    NUMPY
        .get_or_try_init(py, || Ok::<_, PyErr>(py.import("numpy")?.unbind()))
        .map(|m| m.bind(py))
}

/// `numpy.ndarray`, looked up once.
fn ndarray(py: Python<'_>) -> PyResult<&Bound<'_, PyAny>> {
    static NDARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
    NDARRAY
        .get_or_try_init(py, || {
            Ok::<_, PyErr>(numpy(py)?.getattr("ndarray")?.unbind())
        })
        .map(|t| t.bind(py))
}

/// A numpy array of `shape` and `dtype` (numpy's name for `T`, native
/// byte order) holding `values`, backed by a bytearray (one copy).
pub(crate) fn array<'py, T: bytemuck::Pod>(
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
/// of it (`__array_struct__`, writable) reads and writes the frame's own
/// buffer and keeps this object, and so the buffer, alive as its base (as
/// does the capsule numpy reads it from).
#[pyclass(frozen, module = "ercube")]
struct Pixels {
    /// The buffer, never read or moved again (moving the `Vec` would not
    /// move it); numpy reaches it through `address`. Given back to the
    /// frames' pool of spare buffers when numpy lets go of it.
    data: Vec<[f32; 4]>,
    /// Where the buffer starts, from `as_mut_ptr`: numpy may write there.
    address: usize,
    /// (height, width, 4), which numpy reads while it makes the array.
    shape: [isize; 3],
}

impl Drop for Pixels {
    fn drop(&mut self) {
        // No array reads the buffer any more (this object is every such
        // array's base), so a later frame may write it.
        golden::merge::recycle(std::mem::take(&mut self.data));
    }
}

#[pymethods]
impl Pixels {
    /// numpy's array interface in its C form (`PyArrayInterface`, version
    /// 3, one capsule: no dict, tuple or type string to parse):
    /// native-order float32 of `shape`, C-contiguous, writable.
    #[getter]
    fn __array_struct__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyCapsule>> {
        let py = slf.py();
        let me = slf.get();
        let ai = ArrayInterface {
            two: 2,
            nd: 3,
            typekind: b'f' as c_char,
            itemsize: 4,
            flags: ArrayInterface::C_CONTIGUOUS
                | ArrayInterface::ALIGNED
                | ArrayInterface::NOT_SWAPPED
                | ArrayInterface::WRITEABLE,
            shape: me.shape.as_ptr(),
            // C order: numpy works the strides out.
            strides: std::ptr::null(),
            data: me.address as *mut std::ffi::c_void,
            descr: std::ptr::null_mut(),
        };
        // numpy reads the capsule's pointer with no name
        // (`PyCapsule_GetPointer(capsule, NULL)`), which only a capsule
        // without one gives: made here, its box freed with it. The
        // pointers in it lead into this object, which the capsule holds
        // (its context, a strong reference) for as long as it lives.
        unsafe extern "C" fn free(capsule: *mut pyo3::ffi::PyObject) {
            // SAFETY: the capsule was made below from a boxed
            // `ArrayInterface`, no name and a strong reference to its
            // `Pixels` as context; this runs once, as it dies, with the
            // GIL held.
            unsafe {
                let p = pyo3::ffi::PyCapsule_GetPointer(capsule, std::ptr::null());
                if !p.is_null() {
                    drop(Box::from_raw(p.cast::<ArrayInterface>()));
                }
                let owner = pyo3::ffi::PyCapsule_GetContext(capsule);
                if !owner.is_null() {
                    pyo3::ffi::Py_DecRef(owner.cast());
                }
            }
        }
        let boxed = Box::into_raw(Box::new(ai));
        // SAFETY: `boxed` is a valid pointer owned by the capsule from
        // here on (freed by `free`, or below when no capsule is made); the
        // context's reference is taken only once the capsule exists, so
        // `free` releases exactly the one taken.
        unsafe {
            let obj = pyo3::ffi::PyCapsule_New(boxed.cast(), std::ptr::null(), Some(free));
            if obj.is_null() {
                drop(Box::from_raw(boxed));
                return Err(PyErr::fetch(py));
            }
            let capsule: Bound<'py, PyCapsule> =
                Bound::from_owned_ptr(py, obj).cast_into_unchecked();
            let owner = slf.clone().into_ptr();
            if pyo3::ffi::PyCapsule_SetContext(obj, owner.cast()) != 0 {
                pyo3::ffi::Py_DecRef(owner);
                return Err(PyErr::fetch(py));
            }
            Ok(capsule)
        }
    }
}

/// The image `im` as a float32 H x W x 4 numpy array, its buffer handed
/// over without a copy ([`Pixels`]).
pub(crate) fn image_array(py: Python<'_>, im: golden::image::Image) -> PyResult<Bound<'_, PyAny>> {
    // Sides are at most 16384 (the command line's limit on `--size`).
    let shape = [im.height as isize, im.width as isize, 4];
    let mut data = im.data;
    let address = data.as_mut_ptr() as usize;
    let pixels = Bound::new(
        py,
        Pixels {
            data,
            address,
            shape,
        },
    )?;
    numpy(py)?.call_method1("asarray", (pixels,))
}

/// Identities of [`FrozenVoxels`] buffers, each given once in the
/// process.
static NEXT_BUFFER: AtomicU64 = AtomicU64::new(1);

/// A new buffer identity, never given before in the process.
pub(crate) fn new_buffer() -> u64 {
    NEXT_BUFFER.fetch_add(1, Ordering::Relaxed)
}

/// A loaded volume's voxels lent to numpy read-only, without a copy: the
/// array numpy makes of it (`__array_interface__`, read-only) keeps this
/// object, and so the volume, alive as its base. numpy will not make an
/// array over this object writable (it offers no writable buffer, so
/// setting `flags.writeable` raises), so the voxels cannot change while
/// any array over them lives; a render of such an array (or of a
/// C-contiguous view into it) is known to hold the voxels the last call
/// copied from the same place without comparing them ([`Input::frozen`]).
#[pyclass(frozen, module = "ercube")]
pub(crate) struct FrozenVoxels {
    /// The volume whose voxels numpy reads; never changed or moved out.
    _volume: Volume,
    /// This buffer's identity ([`NEXT_BUFFER`]).
    id: u64,
    /// Where the voxels start.
    address: usize,
    /// Their length in bytes.
    bytes: usize,
    /// (z, y, x).
    shape: [usize; 3],
    /// 16-bit voxels (else 8-bit).
    u16: bool,
}

#[pymethods]
impl FrozenVoxels {
    /// numpy's array interface (version 3): uint8 or native-order uint16
    /// of `shape`, C-contiguous, read-only.
    #[getter]
    fn __array_interface__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("shape", PyTuple::new(py, self.shape)?)?;
        let typestr = match (self.u16, cfg!(target_endian = "little")) {
            (false, _) => "|u1",
            (true, true) => "<u2",
            (true, false) => ">u2",
        };
        d.set_item("typestr", typestr)?;
        d.set_item("data", (self.address, true))?;
        d.set_item("version", 3)?;
        Ok(d)
    }
}

/// A volume's voxels as a read-only numpy array `(z, y, x)` in their own
/// type, over the volume's own buffer ([`FrozenVoxels`]).
pub(crate) fn voxels_array(py: Python<'_>, v: Volume) -> PyResult<Bound<'_, PyAny>> {
    let [x, y, z] = v.dims();
    let (address, bytes, u16) = match v.voxels() {
        Voxels::U8(d) => (d.as_ptr() as usize, d.len(), false),
        Voxels::U16(d) => (d.as_ptr() as usize, 2 * d.len(), true),
    };
    let frozen = Bound::new(
        py,
        FrozenVoxels {
            _volume: v,
            id: new_buffer(),
            address,
            bytes,
            shape: [z, y, x],
            u16,
        },
    )?;
    numpy(py)?.call_method1("asarray", (frozen,))
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
    /// The data may be written.
    const WRITEABLE: c_int = 0x400;
}

/// A numpy array's voxels, borrowed: the array, C-contiguous and aligned
/// (`numpy.require`; an array that already is one is not copied), held so
/// its buffer stays alive while the voxels are read, and where that buffer
/// is.
pub(crate) struct Input<'py> {
    _array: Bound<'py, PyAny>,
    /// (x, y, z).
    pub(crate) dims: [usize; 3],
    u16: bool,
    address: usize,
    count: usize,
}

impl<'py> Input<'py> {
    /// `voxels` (an array-like `(z, y, x)` of uint8 or uint16).
    pub(crate) fn of(voxels: &Bound<'py, PyAny>) -> PyResult<Input<'py>> {
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
        if !voxels.is_instance(ndarray(py)?)? {
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

    /// Where the voxels lie when they are in a [`FrozenVoxels`] buffer
    /// (the array is one numpy made over it, or a view of such an array,
    /// found through the arrays' `base`): the buffer's identity and the
    /// voxels' offset in it. `None` for any other array, whose voxels
    /// may change between calls.
    pub(crate) fn frozen(&self) -> PyResult<Option<Frozen>> {
        let py = self._array.py();
        let size = if self.u16 { 2 } else { 1 };
        let mut b = self._array.clone();
        // numpy collapses chains of views to the array that owns (or
        // borrows) the memory, so the walk is short; it is bounded anyway.
        for _ in 0..32 {
            if let Ok(f) = b.cast::<FrozenVoxels>() {
                let f = f.get();
                let end = self.address + self.count * size;
                let inside = self.address >= f.address && end <= f.address + f.bytes;
                return Ok((inside && f.u16 == self.u16).then(|| Frozen {
                    buffer: f.id,
                    offset: self.address - f.address,
                }));
            }
            if !b.is_instance(ndarray(py)?)? {
                return Ok(None);
            }
            b = b.getattr(pyo3::intern!(py, "base"))?;
        }
        Ok(None)
    }

    /// The voxels, x fastest.
    ///
    /// They are read with the GIL released; the array must not be resized
    /// or written by another thread meanwhile (as for numpy's own
    /// functions, which release it too).
    pub(crate) fn voxels(&self) -> VoxelsRef<'_> {
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
pub(crate) fn volume_of(voxels: &Bound<'_, PyAny>, spacing: [f64; 3]) -> PyResult<Volume> {
    let input = Input::of(voxels)?;
    let v = Volume::from_voxels(input.dims, input.voxels().to_voxels())
        .map_err(|e| Error::new_err(e.to_string()))?;
    v.with_spacing(spacing)
        .map_err(|e| Error::new_err(e.to_string()))
}

/// A volume's voxels, borrowed.
pub(crate) fn voxels_ref(v: &Volume) -> VoxelsRef<'_> {
    match v.voxels() {
        Voxels::U8(d) => VoxelsRef::U8(d),
        Voxels::U16(d) => VoxelsRef::U16(d),
    }
}
