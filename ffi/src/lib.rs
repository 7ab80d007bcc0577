//! The ercube model behind a C ABI (`include/ercube.h`): volumes loaded
//! from files, scenes or caller buffers; frames of every golden method and
//! of the bit-accurate pipeline rendered exactly as `ercube render` renders
//! them (through [`ercube::frame`]); the final image, the pipeline's raw
//! accumulator words and the statistics as JSON text; one sample of the
//! datapath (the whole plain sample or a unit of it) evaluated from its
//! input words (`src/datapath.rs`); the array stepped one clock at a
//! time, every PE's signals, ports and report lines read out as
//! `#[repr(C)]` structs (`src/chip.rs`).
//!
//! Every entry returns an [`ErcubeStatus`]-valued `int` (0 is success) and
//! leaves a one-line message for [`ercube_last_error`] when it fails.
//! Objects are opaque handles, created by one call and released by its
//! `_free`. No panic crosses the boundary: each entry runs under
//! `catch_unwind` and reports a panic as [`ErcubeStatus::Panic`].

use std::cell::RefCell;
use std::ffi::{c_char, c_int, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;

use golden::volume::{Volume, Voxels};

pub mod chip;
mod datapath;
pub mod pe_testbench;
pub mod sample_testbench;
pub mod testbench;
pub use chip::ErcubeChip;
pub use datapath::ErcubeDatapath;

/// The ABI's version: it changes whenever a signature, a struct or a
/// meaning in `ercube.h` does (`ERCUBE_ABI_VERSION` there).
pub const ABI_VERSION: u32 = 3;

/// What an entry returns.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErcubeStatus {
    /// Success.
    Ok = 0,
    /// A null pointer, text that is not UTF-8, a buffer that does not
    /// match its dimensions, or a question the object cannot answer.
    Argument = 1,
    /// Malformed `ercube render` arguments (the command line's usage
    /// errors).
    Usage = 2,
    /// The run failed on its input (a file, a configuration, a camera):
    /// the command line's one-line error.
    Failed = 3,
    /// A bug: the model panicked (the message says where).
    Panic = 4,
    /// `ercube_chip_step`: the frame has no cycle left (not a failure).
    Done = 5,
}

/// A pipeline configuration (checked TOML text).
pub struct ErcubeConfig {
    toml: String,
}

/// A volume: voxels (u8 or u16), dimensions and spacing.
pub struct ErcubeVolume {
    volume: Volume,
}

/// A rendered frame and its outputs.
pub struct ErcubeFrame {
    rendered: ercube::frame::Rendered,
    /// The image as contiguous float32 RGBA.
    rgba: Vec<f32>,
    stats: CString,
}

impl ErcubeFrame {
    /// The frame's outputs as the C side reads them.
    fn new(rendered: ercube::frame::Rendered) -> Result<ErcubeFrame, Failure> {
        let rgba = rendered.image.data.iter().flatten().copied().collect();
        let stats = CString::new(rendered.stats.to_string())
            .map_err(|_| argument("the statistics hold a NUL"))?;
        Ok(ErcubeFrame {
            rendered,
            rgba,
            stats,
        })
    }
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// A failed call: its status and message.
struct Failure(ErcubeStatus, String);

impl From<ercube::frame::Error> for Failure {
    fn from(e: ercube::frame::Error) -> Failure {
        let status = if e.usage {
            ErcubeStatus::Usage
        } else {
            ErcubeStatus::Failed
        };
        Failure(status, e.message)
    }
}

fn argument(msg: impl Into<String>) -> Failure {
    Failure(ErcubeStatus::Argument, msg.into())
}

fn set_error(msg: &str) {
    // A message with an interior NUL is cut there: C reads up to it anyway.
    let bytes = msg.as_bytes();
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    let text = CString::new(&bytes[..end]).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = text);
}

/// Runs `f`, turning its failure or panic into a status and the thread's
/// last error.
fn guard(f: impl FnOnce() -> Result<(), Failure>) -> c_int {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => ErcubeStatus::Ok as c_int,
        Ok(Err(Failure(status, msg))) => {
            set_error(&msg);
            status as c_int
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            set_error(&format!("internal error (a bug): {what}"));
            ErcubeStatus::Panic as c_int
        }
    }
}

/// `p` as a UTF-8 string.
///
/// # Safety
/// `p` is null or a NUL-terminated string.
unsafe fn text<'a>(p: *const c_char, what: &str) -> Result<&'a str, Failure> {
    if p.is_null() {
        return Err(argument(format!("{what} is null")));
    }
    CStr::from_ptr(p)
        .to_str()
        .map_err(|_| argument(format!("{what} is not UTF-8")))
}

/// Stores `value` behind `out`.
///
/// # Safety
/// `out` is null or valid for one pointer write.
unsafe fn hand_out<T>(out: *mut *mut T, value: T) -> Result<(), Failure> {
    if out.is_null() {
        return Err(argument("the output pointer is null"));
    }
    *out = Box::into_raw(Box::new(value));
    Ok(())
}

/// The ABI's version (`ERCUBE_ABI_VERSION` in the header this library was
/// built with); a caller compiled against another header should refuse it.
#[no_mangle]
pub extern "C" fn ercube_abi_version() -> u32 {
    ABI_VERSION
}

/// The message of the last failed call on this thread (empty if none).
/// Valid until the next failing call on the same thread.
#[no_mangle]
pub extern "C" fn ercube_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// Checks the pipeline configuration `toml` (the text of a `--config`
/// file; missing keys keep their defaults) and returns it as a handle.
///
/// # Safety
/// `toml` is a NUL-terminated string; `out` is valid for one pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_config_from_toml(
    toml: *const c_char,
    out: *mut *mut ErcubeConfig,
) -> c_int {
    guard(|| {
        let t = text(toml, "the configuration text")?;
        ercube::frame::check_config(t)?;
        hand_out(
            out,
            ErcubeConfig {
                toml: t.to_string(),
            },
        )
    })
}

/// Drops the boxed handle `p` (null is ignored); a panic in its drop
/// stays on this side of the boundary.
///
/// # Safety
/// `p` is null or a pointer from `Box::into_raw`, not yet freed.
unsafe fn free_handle<T>(p: *mut T) {
    if !p.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| drop(Box::from_raw(p))));
    }
}

/// Releases a configuration (null is ignored).
///
/// # Safety
/// `cfg` is null or a handle from [`ercube_config_from_toml`], not yet freed.
#[no_mangle]
pub unsafe extern "C" fn ercube_config_free(cfg: *mut ErcubeConfig) {
    free_handle(cfg);
}

/// Loads a volume file, in any format `ercube render --volume` reads
/// (`.den`, NIfTI, NRRD, MetaImage, TIFF, DICOM folders).
///
/// # Safety
/// `path` is a NUL-terminated string; `out` is valid for one pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_volume_load(
    path: *const c_char,
    out: *mut *mut ErcubeVolume,
) -> c_int {
    guard(|| {
        let p = text(path, "the path")?;
        let volume = ercube::frame::volume(&["--volume", p])?;
        hand_out(out, ErcubeVolume { volume })
    })
}

/// Builds a synthetic scene as `--scene SPEC` does (`ml:40`,
/// `checker:32`, ...).
///
/// # Safety
/// `spec` is a NUL-terminated string; `out` is valid for one pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_volume_scene(
    spec: *const c_char,
    out: *mut *mut ErcubeVolume,
) -> c_int {
    guard(|| {
        let s = text(spec, "the scene")?;
        let volume = ercube::frame::volume(&["--scene", s])?;
        hand_out(out, ErcubeVolume { volume })
    })
}

/// A volume from `dims[0] * dims[1] * dims[2]` voxels, x fastest, with
/// `spacing` (x, y, z; null for 1, 1, 1).
///
/// # Safety
/// `dims` points at three values; `voxels` at their product; `spacing`
/// is null or points at three values; `out` is valid for one pointer write.
unsafe fn volume_from<T: Copy>(
    voxels: *const T,
    dims: *const usize,
    spacing: *const f64,
    out: *mut *mut ErcubeVolume,
    wrap: fn(Vec<T>) -> Voxels,
) -> c_int {
    guard(|| {
        if dims.is_null() || voxels.is_null() {
            return Err(argument("the voxels or the dimensions are null"));
        }
        let d = [*dims, *dims.add(1), *dims.add(2)];
        let e = |e: golden::error::Error| Failure(ErcubeStatus::Failed, e.to_string());
        // Sane dimensions (none zero or absurd, the byte count addressable)
        // before the caller's buffer is read.
        let bytes = std::mem::size_of::<T>() as u64;
        let n = golden::volume::check_dims(d, bytes, isize::MAX as u64).map_err(e)?;
        let data = std::slice::from_raw_parts(voxels, n).to_vec();
        let mut volume = Volume::from_voxels(d, wrap(data)).map_err(e)?;
        if !spacing.is_null() {
            let s = [*spacing, *spacing.add(1), *spacing.add(2)];
            volume = volume.with_spacing(s).map_err(e)?;
        }
        hand_out(out, ErcubeVolume { volume })
    })
}

/// An 8-bit volume from a caller's buffer (copied): see `ercube.h`.
///
/// # Safety
/// As `ercube.h` states: `dims` three values, `voxels` their product,
/// `spacing` null or three values, `out` one pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_volume_from_u8(
    voxels: *const u8,
    dims: *const usize,
    spacing: *const f64,
    out: *mut *mut ErcubeVolume,
) -> c_int {
    volume_from(voxels, dims, spacing, out, Voxels::U8)
}

/// A 16-bit volume from a caller's buffer (copied): see `ercube.h`.
///
/// # Safety
/// As [`ercube_volume_from_u8`].
#[no_mangle]
pub unsafe extern "C" fn ercube_volume_from_u16(
    voxels: *const u16,
    dims: *const usize,
    spacing: *const f64,
    out: *mut *mut ErcubeVolume,
) -> c_int {
    volume_from(voxels, dims, spacing, out, Voxels::U16)
}

/// A volume's dimensions (x, y, z), spacing and bits per voxel (8 or 16);
/// any output pointer may be null.
///
/// # Safety
/// `vol` is a live handle; `dims` and `spacing` are null or point at three
/// values; `bits` is null or valid for one write.
#[no_mangle]
pub unsafe extern "C" fn ercube_volume_shape(
    vol: *const ErcubeVolume,
    dims: *mut usize,
    spacing: *mut f64,
    bits: *mut u32,
) -> c_int {
    guard(|| {
        let v = &vol
            .as_ref()
            .ok_or_else(|| argument("the volume is null"))?
            .volume;
        for k in 0..3 {
            if !dims.is_null() {
                *dims.add(k) = v.dims()[k];
            }
            if !spacing.is_null() {
                *spacing.add(k) = v.spacing()[k];
            }
        }
        if !bits.is_null() {
            *bits = v.kind().bits();
        }
        Ok(())
    })
}

/// Releases a volume (null is ignored).
///
/// # Safety
/// `vol` is null or a live handle, not used again.
#[no_mangle]
pub unsafe extern "C" fn ercube_volume_free(vol: *mut ErcubeVolume) {
    free_handle(vol);
}

/// Renders one frame of `vol` as `ercube render ARGV` would (`argv`:
/// `argc` flags such as `"--method"`, `"pipeline"`, `"--size"`, `"64x64"`;
/// every flag not given keeps the command line's default; no `--scene`,
/// `--volume` or output-file flags), with the pipeline configuration
/// `cfg` when it is not null (instead of `--config`).
///
/// # Safety
/// `vol` is a live handle; `cfg` null or a live handle; `argv` null (when
/// `argc` is 0) or `argc` NUL-terminated strings; `out` one pointer write.
#[no_mangle]
pub unsafe extern "C" fn ercube_render(
    vol: *const ErcubeVolume,
    cfg: *const ErcubeConfig,
    argv: *const *const c_char,
    argc: usize,
    out: *mut *mut ErcubeFrame,
) -> c_int {
    guard(|| {
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
        let toml = cfg.as_ref().map(|c| c.toml.as_str());
        let rendered = ercube::frame::render(&args, Some(v.clone()), toml)?;
        hand_out(out, ErcubeFrame::new(rendered)?)
    })
}

/// The frame's final image: `height` rows of `width` RGBA float32 pixels
/// (premultiplied, rows from the top), as `--npy` writes it. The pointer
/// lives as long as the frame.
///
/// # Safety
/// `frame` is a live handle; the outputs are valid for one write each.
#[no_mangle]
pub unsafe extern "C" fn ercube_frame_image(
    frame: *const ErcubeFrame,
    rgba: *mut *const f32,
    width: *mut usize,
    height: *mut usize,
) -> c_int {
    guard(|| {
        let f = frame
            .as_ref()
            .ok_or_else(|| argument("the frame is null"))?;
        if rgba.is_null() || width.is_null() || height.is_null() {
            return Err(argument("an output pointer is null"));
        }
        *rgba = f.rgba.as_ptr();
        *width = f.rendered.image.width;
        *height = f.rendered.image.height;
        Ok(())
    })
}

/// The pipeline's raw accumulator words: `height` rows of `width` R, G,
/// B, A words (int64, in the formats the statistics' `raw_format` names),
/// as `--raw-npy` writes them. A golden method's frame has none
/// ([`ErcubeStatus::Argument`]). The pointer lives as long as the frame.
///
/// # Safety
/// `frame` is a live handle; the outputs are valid for one write each.
#[no_mangle]
pub unsafe extern "C" fn ercube_frame_raw(
    frame: *const ErcubeFrame,
    words: *mut *const i64,
    width: *mut usize,
    height: *mut usize,
) -> c_int {
    guard(|| {
        let f = frame
            .as_ref()
            .ok_or_else(|| argument("the frame is null"))?;
        if words.is_null() || width.is_null() || height.is_null() {
            return Err(argument("an output pointer is null"));
        }
        let (w, h, raw) = ercube::frame::raw_words(&f.rendered).ok_or_else(|| {
            argument("a golden method's frame has no raw words; render --method pipeline")
        })?;
        *words = raw.as_ptr().cast::<i64>();
        *width = w;
        *height = h;
        Ok(())
    })
}

/// The frame's statistics as JSON text, what `--stats` writes; null for a
/// null frame. The text lives as long as the frame.
///
/// # Safety
/// `frame` is null or a live handle.
#[no_mangle]
pub unsafe extern "C" fn ercube_frame_stats_json(frame: *const ErcubeFrame) -> *const c_char {
    match frame.as_ref() {
        Some(f) => f.stats.as_ptr(),
        None => ptr::null(),
    }
}

/// Releases a frame (null is ignored).
///
/// # Safety
/// `frame` is null or a live handle, not used again.
#[no_mangle]
pub unsafe extern "C" fn ercube_frame_free(frame: *mut ErcubeFrame) {
    free_handle(frame);
}
