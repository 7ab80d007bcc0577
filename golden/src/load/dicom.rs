//! DICOM series: a folder of single-frame slices (CT, MR, ...), or one
//! multi-frame object (Enhanced CT/MR, or plain multi-frame) whose frames
//! are the slices, read with `dicom-object` and decoded with
//! `dicom-pixeldata`, stacked along the slice normal in patient space.

mod frames;
mod lengths;
mod pixels;

use pixels::{dicom_err, quiet_unwind, read_pixels};

use std::io::Read;
use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::{DefaultDicomObject, OpenFileOptions, Tag};

use super::decode::{rescale, Decoded};
use super::{format_err, from_file, io_err, open, Loaded};
use crate::error::Result;
use crate::volume::{check_dims, Units, Volume, VoxelType, MAX_EDGE};

/// Transfer syntaxes whose pixel data this build decodes: the
/// uncompressed ones, deflate, RLE lossless (all in `dicom-rs` itself) and
/// the JPEG processes `jpeg-decoder` handles (pure Rust). JPEG-LS,
/// JPEG 2000, HTJ2K and JPEG XL need C libraries or heavy decoders and are
/// refused by name.
const SUPPORTED: [(&str, &str); 9] = [
    ("1.2.840.10008.1.2", "implicit VR little endian"),
    ("1.2.840.10008.1.2.1", "explicit VR little endian"),
    ("1.2.840.10008.1.2.2", "explicit VR big endian"),
    (
        "1.2.840.10008.1.2.1.99",
        "deflated explicit VR little endian",
    ),
    ("1.2.840.10008.1.2.5", "RLE lossless"),
    ("1.2.840.10008.1.2.4.50", "JPEG baseline"),
    ("1.2.840.10008.1.2.4.51", "JPEG extended"),
    ("1.2.840.10008.1.2.4.57", "JPEG lossless"),
    ("1.2.840.10008.1.2.4.70", "JPEG lossless SV1"),
];

/// Names of some transfer syntaxes this build refuses, for the message.
const REFUSED: [(&str, &str); 7] = [
    ("1.2.840.10008.1.2.4.80", "JPEG-LS lossless"),
    ("1.2.840.10008.1.2.4.81", "JPEG-LS near-lossless"),
    ("1.2.840.10008.1.2.4.90", "JPEG 2000 lossless"),
    ("1.2.840.10008.1.2.4.91", "JPEG 2000"),
    ("1.2.840.10008.1.2.4.201", "HTJ2K lossless"),
    ("1.2.840.10008.1.2.4.203", "HTJ2K"),
    ("1.2.840.10008.1.2.4.100", "MPEG-2"),
];

/// Two slices' orientations may differ by this much per direction cosine
/// (scanners write IOP to about six decimals).
const ORIENT_TOL: f64 = 1e-4;

/// What one slice's header says, read before any pixel data: a
/// single-frame file's, or one frame's of a multi-frame object.
#[derive(Debug, Clone)]
struct Slice {
    path: PathBuf,
    /// The frame in its file (0 for a single-frame file), of `frames`.
    frame: usize,
    frames: usize,
    rows: usize,
    cols: usize,
    /// Row direction (increasing column, volume x) and column direction
    /// (increasing row, volume y), unit vectors in patient space (LPS).
    orient: [[f64; 3]; 2],
    position: [f64; 3],
    /// Between columns (x) and between rows (y), mm.
    pixel_spacing: [f64; 2],
    bits: u16,
    signed: bool,
    slope: f64,
    intercept: f64,
    series: String,
    thickness: Option<f64>,
}

/// True if `path` starts with a DICOM Part 10 preamble and `DICM` magic.
pub(super) fn is_dicom(path: &Path) -> bool {
    let mut head = [0u8; 132];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && &head[128..132] == b"DICM"
}

/// True if `dir` holds at least one DICOM Part 10 file (so a folder is read
/// as a DICOM series rather than a TIFF stack).
pub(super) fn dir_has_dicom(dir: &Path) -> bool {
    dicom_files(dir, false).is_ok_and(|f| !f.is_empty())
}

/// The DICOM Part 10 files of `dir` (by their magic, any name; names
/// starting with `.`, `DICOMDIR` and sub-folders skipped), sorted by name.
/// If `strict`, a member that cannot be read (a dangling link, a link
/// loop, no permission) is refused naming it, since it may be a slice.
fn dicom_files(dir: &Path, strict: bool) -> Result<Vec<PathBuf>> {
    let io = |e| io_err(dir, e);
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let p = entry.map_err(io)?.path();
        let name = p.file_name().unwrap_or_default().to_string_lossy();
        if name.starts_with('.') || name.eq_ignore_ascii_case("DICOMDIR") || p.is_dir() {
            continue;
        }
        if strict {
            super::check_member(&p)?;
        }
        if p.is_file() {
            if is_dicom(&p) {
                files.push(p);
            }
            if files.len() > MAX_EDGE {
                break; // check_dims names the absurd depth
            }
        }
    }
    files.sort();
    Ok(files)
}

impl Slice {
    /// The file's name, and the frame's number (from 1) in a multi-frame
    /// object, for messages.
    fn label(&self) -> String {
        let name = self.path.file_name().unwrap_or_default().to_string_lossy();
        if self.frames > 1 {
            format!("{name} frame {}", self.frame + 1)
        } else {
            name.into_owned()
        }
    }
}

/// Loads a DICOM series; see [`read_dicom_dir`].
pub fn load_dicom_dir(dir: &Path, limit: u64) -> Result<Volume> {
    read_dicom_dir(dir, limit).map(|l| l.volume)
}

/// Reads one DICOM file: a multi-frame object, its frames the slices (see
/// [`read_dicom_dir`]); a single-frame file is refused (its series is the
/// folder).
pub fn read_dicom_file(path: &Path, limit: u64) -> Result<Loaded> {
    read_series(path, vec![path.to_owned()], limit)
}

/// Reads a folder holding one DICOM series of single-frame greyscale
/// slices, or one multi-frame object, with its placement in patient space
/// (LPS, millimetres).
///
/// Files are found by their `DICM` magic whatever their names; others in
/// the folder are ignored. Every header is read and checked before any
/// pixel data is decoded: one `SeriesInstanceUID`, the same `Rows`,
/// `Columns`, `PixelSpacing`, `BitsAllocated`, `PixelRepresentation` and
/// `ImageOrientationPatient` in every slice, one sample per pixel, and a
/// supported transfer syntax (uncompressed, deflate, RLE lossless, JPEG
/// baseline/extended/lossless; see the docs).
///
/// A multi-frame object (`NumberOfFrames` > 1) must be the folder's only
/// DICOM file; its frames are the slices, each placed and rescaled by its
/// functional groups (`PlanePositionSequence`, `PlaneOrientationSequence`,
/// `PixelMeasuresSequence`, `PixelValueTransformationSequence`; the
/// frame's own before the shared ones) or else the top-level attributes,
/// the frames of a plain multi-frame object without positions stepping
/// along the normal by `SpacingBetweenSlices` (else `SliceThickness`).
/// Its sizes are checked before its pixel data is decoded, and pixel data
/// that does not hold `NumberOfFrames` frames is refused.
///
/// Slices are sorted by their position along the slice normal
/// `n = row x column` (`ImagePositionPatient . n`), whatever the file
/// names and order. The slice spacing is the mean gap; the gaps must agree
/// to 1% (or 0.001 mm): a missing slice, two slices at one position or a
/// gantry-tilted (sheared) stack is refused in one line rather than
/// rendered with the wrong geometry. A single slice takes its
/// `SliceThickness` (else 1).
///
/// Voxel `(x, y, z)` is column `x`, row `y` of the `z`-th slice along `n`;
/// [`Loaded::axes`] are the row direction, the column direction and `n`,
/// [`Loaded::origin`] the first slice's `ImagePositionPatient`.
///
/// Values are the stored ones times `RescaleSlope` plus `RescaleIntercept`
/// (per slice; CT in Hounsfield units), mapped onto voxels by the rule all
/// loaders share: integral values are offset by minus a negative minimum
/// and kept when they fit 16 bits (8 bits for 8-bit data), anything else
/// is mapped linearly onto 0..=65535 (see [`load_nifti`](super::load_nifti)).
pub fn read_dicom_dir(dir: &Path, limit: u64) -> Result<Loaded> {
    let files = dicom_files(dir, true)?;
    if files.is_empty() {
        return Err(format_err(
            dir,
            "the folder holds no DICOM files (no 'DICM' magic at byte 128)",
        ));
    }
    read_series(dir, files, limit)
}

/// Reads the series of `files` (the folder, or the one file, `dir`).
fn read_series(dir: &Path, files: Vec<PathBuf>, limit: u64) -> Result<Loaded> {
    check_dims([1, 1, files.len()], 2, u64::MAX).map_err(|e| from_file(dir, e))?;
    let mut slices = Vec::with_capacity(files.len());
    for f in &files {
        let frames = read_header(f, limit)?;
        if frames.len() > 1 && files.len() > 1 {
            return Err(format_err(
                dir,
                format!(
                    "{} is a multi-frame object ({} frames) among {} DICOM files: give it alone",
                    f.file_name().unwrap_or_default().to_string_lossy(),
                    frames.len(),
                    files.len()
                ),
            ));
        }
        slices.extend(frames);
    }
    if slices.len() == 1 && dir == files[0].as_path() {
        return Err(format_err(
            dir,
            "a single DICOM file: give the folder that holds its series",
        ));
    }
    let first = slices[0].clone();
    check_consistent(dir, &slices)?;
    let normal = cross(first.orient[0], first.orient[1]);
    let mut keyed: Vec<(f64, Slice)> = slices
        .into_iter()
        .map(|s| (dot(s.position, normal), s))
        .collect();
    keyed.sort_by(|a, b| a.0.total_cmp(&b.0));
    let dz = slice_spacing(dir, &keyed, normal)?;
    let dims = [first.cols, first.rows, keyed.len()];
    // The rescaled values (f64) and the voxels are held together.
    let count = check_dims(dims, 10, limit).map_err(|e| from_file(dir, e))?;
    let mut vals: Vec<f64> = Vec::with_capacity(count);
    if first.frames > 1 {
        let order: Vec<&Slice> = keyed.iter().map(|(_, s)| s).collect();
        read_pixels(&first.path, &order, &mut vals)?;
    } else {
        for (_, s) in &keyed {
            read_pixels(&s.path, &[s], &mut vals)?;
        }
    }
    let (kind, data, units) = map_values(&vals, first.bits);
    drop(vals);
    let spacing = [first.pixel_spacing[0], first.pixel_spacing[1], dz];
    let spacing = super::check_spacing(dir, "PixelSpacing and the slice gap", spacing)?;
    let volume = Volume::new(dims, kind, data)?
        .with_spacing(spacing)?
        .with_units(units);
    Ok(Loaded {
        volume,
        origin: Some(keyed[0].1.position),
        axes: Some([first.orient[0], first.orient[1], normal]),
    })
}

/// The shared mapping rule on rescaled values (see [`read_dicom_dir`]).
fn map_values(vals: &[f64], bits: u16) -> Decoded {
    let integral = vals.iter().all(|v| v.fract() == 0.0 && v.abs() < 1e15);
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let shift = if lo < 0.0 { -lo } else { 0.0 };
    let kept = |kind| {
        let data = vals.iter().map(|&v| (v + shift) as u16).collect();
        (kind, data, Units::shifted(-shift))
    };
    if integral && hi + shift <= 255.0 && bits == 8 {
        kept(VoxelType::U8)
    } else if integral && hi + shift <= 65535.0 {
        kept(VoxelType::U16)
    } else {
        let (data, units) = rescale(vals.iter().copied());
        (VoxelType::U16, data, units)
    }
}

/// Reads one file's header (up to the pixel data) and checks what the
/// loader needs of it: one slice per frame.
fn read_header(path: &Path, limit: u64) -> Result<Vec<Slice>> {
    // dicom-object holds a file's elements in memory: bound the file first.
    let len = open(path)?.metadata().map_err(|e| io_err(path, e))?.len();
    if len > limit {
        return Err(format_err(
            path,
            format!(
                "the file is {}, over the memory limit of {}",
                crate::error::human_bytes(len as u128),
                crate::error::human_bytes(limit as u128)
            ),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| io_err(path, e))?;
    lengths::check_lengths(&bytes, limit).map_err(|m| format_err(path, m))?;
    drop(bytes);
    let obj = open_dicom(path, true)?;
    let ts = obj.meta().transfer_syntax().trim_end_matches('\0').trim();
    if !SUPPORTED.iter().any(|(uid, _)| *uid == ts) {
        let name = REFUSED
            .iter()
            .find(|(uid, _)| *uid == ts)
            .map(|(_, n)| format!(" ({n})"))
            .unwrap_or_default();
        return Err(format_err(
            path,
            format!(
                "transfer syntax {ts}{name} is not supported: use uncompressed, deflate, \
                 RLE lossless or JPEG baseline/extended/lossless (e.g. gdcmconv --raw)"
            ),
        ));
    }
    let bad = |msg: String| format_err(path, msg);
    let need_int = |tag: Tag, name: &str| -> Result<u32> {
        elem(&obj, tag)
            .and_then(|e| e.to_int::<u32>().ok())
            .ok_or_else(|| bad(format!("{name} is missing or not a number")))
    };
    let rows = need_int(tags::ROWS, "Rows")? as usize;
    let cols = need_int(tags::COLUMNS, "Columns")? as usize;
    check_dims([cols, rows, 1], 2, u64::MAX).map_err(|e| from_file(path, e))?;
    let samples = elem(&obj, tags::SAMPLES_PER_PIXEL)
        .and_then(|e| e.to_int::<u32>().ok())
        .unwrap_or(1);
    if samples != 1 {
        return Err(bad(format!(
            "{samples} samples per pixel: only greyscale (1 sample) slices are supported"
        )));
    }
    let frames = match elem(&obj, tags::NUMBER_OF_FRAMES) {
        None => 1,
        Some(e) => e
            .to_int::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| bad("NumberOfFrames is not a positive number".into()))?
            as usize,
    };
    // Before anything per frame is allocated.
    check_dims([cols, rows, frames], 2, limit).map_err(|e| from_file(path, e))?;
    let bits = need_int(tags::BITS_ALLOCATED, "BitsAllocated")?;
    if bits != 8 && bits != 16 {
        return Err(bad(format!(
            "BitsAllocated {bits}: only 8- and 16-bit slices are supported"
        )));
    }
    let int = |tag: Tag| elem(&obj, tag).and_then(|e| e.to_int::<u32>().ok());
    let stored = int(tags::BITS_STORED).unwrap_or(bits);
    let high = int(tags::HIGH_BIT).unwrap_or(stored.saturating_sub(1));
    if stored == 0 || stored > bits || high >= bits || high + 1 < stored {
        return Err(bad(format!(
            "BitsStored {stored} and HighBit {high} do not fit BitsAllocated {bits}"
        )));
    }
    if let Some(pi) = elem(&obj, tags::PHOTOMETRIC_INTERPRETATION).and_then(|e| e.to_str().ok()) {
        let pi = pi.trim_end_matches('\0').trim();
        if pi != "MONOCHROME1" && pi != "MONOCHROME2" {
            return Err(bad(format!(
                "PhotometricInterpretation {pi}: only greyscale (MONOCHROME1/2) slices are supported"
            )));
        }
    }
    let signed = need_int(tags::PIXEL_REPRESENTATION, "PixelRepresentation")? == 1;
    let geometry = frames::frame_geometry(&obj, frames).map_err(bad)?;
    let series = elem(&obj, tags::SERIES_INSTANCE_UID)
        .and_then(|e| e.to_str().ok())
        .map(|s| s.trim_end_matches('\0').trim().to_owned())
        .unwrap_or_default();
    Ok(geometry
        .into_iter()
        .enumerate()
        .map(|(frame, g)| Slice {
            path: path.to_owned(),
            frame,
            frames,
            rows,
            cols,
            orient: g.orient,
            position: g.position,
            pixel_spacing: g.pixel_spacing,
            bits: bits as u16,
            signed,
            slope: g.slope,
            intercept: g.intercept,
            series: series.clone(),
            thickness: g.thickness,
        })
        .collect())
}

/// Parses a file, up to its pixel data if `header_only`.
fn open_dicom(path: &Path, header_only: bool) -> Result<DefaultDicomObject> {
    let opened = quiet_unwind(|| {
        let opts = OpenFileOptions::new();
        let opts = if header_only {
            opts.read_until(tags::PIXEL_DATA)
        } else {
            opts
        };
        opts.open_file(path).map_err(|e| e.to_string())
    });
    match opened {
        Some(Ok(obj)) => Ok(obj),
        Some(Err(e)) => Err(dicom_err(path, "unreadable DICOM", &e)),
        None => Err(format_err(
            path,
            "unreadable DICOM: the parser failed on corrupt data",
        )),
    }
}

use frames::elem;

/// The unit row and column directions of an `ImageOrientationPatient`, if
/// they are non-zero and orthogonal (to 1e-3 after normalising).
fn orientation(iop: &[f64]) -> Option<[[f64; 3]; 2]> {
    let unit = |v: [f64; 3]| {
        let n = dot(v, v).sqrt();
        (n > 1e-6).then(|| v.map(|c| c / n))
    };
    let r = unit([iop[0], iop[1], iop[2]])?;
    let c = unit([iop[3], iop[4], iop[5]])?;
    (dot(r, c).abs() < 1e-3).then_some([r, c])
}

/// Every slice like the first in what makes a volume.
fn check_consistent(dir: &Path, slices: &[Slice]) -> Result<()> {
    let first = &slices[0];
    let name = Slice::label;
    let series: std::collections::BTreeSet<&str> =
        slices.iter().map(|s| s.series.as_str()).collect();
    if series.len() > 1 {
        return Err(format_err(
            dir,
            format!(
                "the folder holds {} series (SeriesInstanceUID): give a folder of one series",
                series.len()
            ),
        ));
    }
    for s in &slices[1..] {
        let differs = |what: &str, a: String, b: String| {
            format_err(
                dir,
                format!(
                    "{} has {what} {a}, {} has {b}: every slice must agree",
                    name(s),
                    name(first)
                ),
            )
        };
        if (s.rows, s.cols) != (first.rows, first.cols) {
            return Err(differs(
                "size",
                format!("{}x{}", s.cols, s.rows),
                format!("{}x{}", first.cols, first.rows),
            ));
        }
        if (s.bits, s.signed) != (first.bits, first.signed) {
            let d = |s: &Slice| {
                format!(
                    "{}-bit {}",
                    s.bits,
                    if s.signed { "signed" } else { "unsigned" }
                )
            };
            return Err(differs("pixels", d(s), d(first)));
        }
        let close =
            |a: &[f64], b: &[f64], tol: f64| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol);
        if !close(
            &s.pixel_spacing,
            &first.pixel_spacing,
            1e-6 * first.pixel_spacing[0].max(1.0),
        ) {
            return Err(differs(
                "PixelSpacing",
                format!("{:?}", s.pixel_spacing),
                format!("{:?}", first.pixel_spacing),
            ));
        }
        if !close(
            s.orient.as_flattened(),
            first.orient.as_flattened(),
            ORIENT_TOL,
        ) {
            return Err(differs(
                "ImageOrientationPatient",
                format!("{:?}", s.orient),
                format!("{:?}", first.orient),
            ));
        }
    }
    Ok(())
}

/// The slice spacing of slices sorted by their position `d` along
/// `normal`: the mean gap, if every gap agrees with it and every slice
/// lies on the first one's normal line (no shear).
fn slice_spacing(dir: &Path, keyed: &[(f64, Slice)], normal: [f64; 3]) -> Result<f64> {
    let n = keyed.len();
    if n == 1 {
        return Ok(keyed[0].1.thickness.unwrap_or(1.0));
    }
    let name = |k: usize| keyed[k].1.label();
    let mean = (keyed[n - 1].0 - keyed[0].0) / (n - 1) as f64;
    let tol = (0.01 * mean).max(1e-3);
    for k in 1..n {
        if keyed[k].0 - keyed[k - 1].0 <= 1e-3 {
            return Err(format_err(
                dir,
                format!(
                    "{} and {} lie at the same position {:.4} along the slice normal",
                    name(k - 1),
                    name(k),
                    keyed[k].0
                ),
            ));
        }
    }
    for k in 1..n {
        let gap = keyed[k].0 - keyed[k - 1].0;
        if (gap - mean).abs() > tol {
            return Err(format_err(
                dir,
                format!(
                    "uneven slice spacing: {} to {} is {gap:.4} mm, the mean is {mean:.4} mm \
                     (a missing slice?): only evenly spaced series are supported",
                    name(k - 1),
                    name(k)
                ),
            ));
        }
    }
    let p0 = keyed[0].1.position;
    for (k, (d, s)) in keyed.iter().enumerate() {
        let along = std::array::from_fn::<f64, 3, _>(|i| p0[i] + (d - keyed[0].0) * normal[i]);
        let off = (0..3)
            .map(|i| (s.position[i] - along[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        if off > tol {
            return Err(format_err(
                dir,
                format!(
                    "{} is {off:.4} mm off the first slice's normal (a gantry tilt?): \
                     only stacks along the slice normal are supported",
                    name(k)
                ),
            ));
        }
    }
    Ok(mean)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests;
