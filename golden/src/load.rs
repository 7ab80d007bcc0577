//! Volume loaders: headerless raw, VolPack `.den` and NIfTI-1 (`.nii`,
//! `.nii.gz`).
//!
//! Every loader treats its input as untrusted: sizes come from a header or
//! from the user, and they are checked against the file and against the
//! memory limit (with [`check_dims`]) before the voxel buffer is allocated.
//! Voxels are decoded in fixed-size chunks straight into the final `u16`
//! buffer, so a loader holds at most the volume itself plus 64 KiB (float
//! NIfTI data also needs its `f32` copy; see [`load_nifti`]). Any byte
//! sequence gives either a volume or a one-line [`Error`], never a panic.

use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufReader, ErrorKind, Read, Seek, SeekFrom};
use std::path::Path;
use std::str::FromStr;

use crate::error::{input, Error, Result};
use crate::volume::{check_dims, Volume, VoxelType};

/// Bytes decoded per read: a multiple of every voxel size, small enough to
/// be irrelevant next to the volume.
const CHUNK: usize = 1 << 16;

/// Voxel encoding of a headerless raw file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RawType {
    /// Unsigned 8-bit voxels.
    U8,
    /// Unsigned 16-bit voxels, least significant byte first.
    U16Le,
    /// Unsigned 16-bit voxels, most significant byte first.
    U16Be,
}

impl RawType {
    /// Bytes per voxel in the file.
    pub fn bytes(self) -> u64 {
        match self {
            RawType::U8 => 1,
            RawType::U16Le | RawType::U16Be => 2,
        }
    }

    /// The volume's voxel type for this encoding.
    pub fn voxel_type(self) -> VoxelType {
        match self {
            RawType::U8 => VoxelType::U8,
            RawType::U16Le | RawType::U16Be => VoxelType::U16,
        }
    }
}

impl FromStr for RawType {
    type Err = Error;

    /// Parses `u8`, `u16le` or `u16be` (any case).
    fn from_str(s: &str) -> Result<RawType> {
        match s.to_ascii_lowercase().as_str() {
            "u8" => Ok(RawType::U8),
            "u16le" => Ok(RawType::U16Le),
            "u16be" => Ok(RawType::U16Be),
            _ => Err(input(format!(
                "unknown raw voxel type '{s}': use u8, u16le or u16be"
            ))),
        }
    }
}

impl fmt::Display for RawType {
    /// The spelling [`RawType::from_str`] accepts.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RawType::U8 => "u8",
            RawType::U16Le => "u16le",
            RawType::U16Be => "u16be",
        })
    }
}

/// What the user says about a headerless raw file, since the file cannot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawSpec {
    /// Voxel counts along x, y, z (x varies fastest in the file).
    pub dims: [usize; 3],
    /// Voxel encoding.
    pub kind: RawType,
    /// Bytes to skip at the start of the file (a header we do not parse).
    pub offset: u64,
}

/// Loads a headerless raw volume, x fastest, unit spacing.
///
/// The file must hold exactly `offset + voxels * bytes` bytes. A shorter file
/// is "truncated"; a longer one is refused as well, because a raw file
/// carries no size of its own and extra bytes almost always mean the
/// dimensions or the type were given wrongly (silently reading a prefix
/// would render garbage that looks plausible). Put any trailing header in
/// front with `offset`, or cut the file.
pub fn load_raw(path: &Path, spec: &RawSpec, limit: u64) -> Result<Volume> {
    let [w, h, d] = spec.dims;
    let count = check_dims(spec.dims, 2, limit)?;
    let expected = spec.offset as u128 + count as u128 * spec.kind.bytes() as u128;
    let mut file = open(path)?;
    let len = file_len(&file, path)?;
    if (len as u128) < expected {
        return Err(format_err(
            path,
            format!("truncated: expected {expected} bytes, file has {len}"),
        ));
    }
    if len as u128 > expected {
        return Err(format_err(
            path,
            format!(
                "file has {len} bytes, {expected} expected for {w}x{h}x{d} {} at offset {}",
                spec.kind, spec.offset
            ),
        ));
    }
    file.seek(SeekFrom::Start(spec.offset))
        .map_err(|e| io_err(path, e))?;
    let data = decode(path, file, count, spec.kind, spec.offset)?;
    Volume::new(spec.dims, spec.kind.voxel_type(), data)
}

/// Size of a VolPack `.den` header: an `i16` version, nine `i16` triples, an
/// `i16` warp count and an `i32` voxel count.
const DEN_HEADER: usize = 62;

/// Loads a VolPack `.den` volume (8-bit voxels, x fastest).
///
/// The header is read field by field, never guessed: `i16` version (must be
/// 1), then the `i16` triples `orig_min`, `orig_max`, `orig_len`,
/// `extr_min`, `extr_max`, `extr_len`, `map_min`, `map_max`, `map_len`, an
/// `i16` `map_warps` and an `i32` `map_length`. The dimensions are
/// `map_len`; each must be positive, `map_length` must equal their product
/// and the file must hold exactly `62 + map_length` bytes. Only `map_len`
/// shapes the data, so the other triples are not cross-checked (old files
/// disagree on their conventions).
///
/// VolPack wrote the header in the writing machine's byte order. Files from
/// little-endian machines (such as `brainsmall.den`) read version 1
/// directly; files from big-endian machines (old SGI workstations) read
/// version 256, and are then decoded as big-endian. `.den` has no voxel
/// spacing, so the spacing is 1.
pub fn load_den(path: &Path, limit: u64) -> Result<Volume> {
    let mut file = open(path)?;
    let len = file_len(&file, path)?;
    if len < DEN_HEADER as u64 {
        return Err(format_err(
            path,
            format!("truncated: a .den header needs {DEN_HEADER} bytes, file has {len}"),
        ));
    }
    let mut hdr = [0u8; DEN_HEADER];
    file.read_exact(&mut hdr).map_err(|e| io_err(path, e))?;
    let big_endian = match i16::from_le_bytes([hdr[0], hdr[1]]) {
        1 => false,
        256 => true,
        v => {
            return Err(format_err(
                path,
                format!("unsupported .den version {v} (expected 1): not a VolPack .den file?"),
            ))
        }
    };
    let i16_at = |i: usize| {
        let b = [hdr[i], hdr[i + 1]];
        if big_endian {
            i16::from_be_bytes(b)
        } else {
            i16::from_le_bytes(b)
        }
    };
    // map_len is the ninth triple: after the version and eight triples.
    let map_len: [i16; 3] = std::array::from_fn(|k| i16_at(2 + 8 * 6 + 2 * k));
    let b = [hdr[58], hdr[59], hdr[60], hdr[61]];
    let map_length = if big_endian {
        i32::from_be_bytes(b)
    } else {
        i32::from_le_bytes(b)
    };
    if map_len.iter().any(|&n| n <= 0) {
        return Err(format_err(
            path,
            format!("map_len {map_len:?} must be positive"),
        ));
    }
    let dims = map_len.map(|n| n as usize);
    let [w, h, d] = dims;
    let product = w as u64 * h as u64 * d as u64;
    if map_length as i64 != product as i64 {
        return Err(format_err(
            path,
            format!(
                "header map_length {map_length} disagrees with map_len {w}x{h}x{d} = {product}"
            ),
        ));
    }
    let count = check_dims(dims, 2, limit).map_err(|e| from_file(path, e))?;
    let expected = DEN_HEADER as u64 + count as u64;
    if len < expected {
        return Err(format_err(
            path,
            format!("truncated: expected {expected} bytes, file has {len}"),
        ));
    }
    if len > expected {
        return Err(format_err(
            path,
            format!("file has {len} bytes, {expected} expected for a {w}x{h}x{d} .den"),
        ));
    }
    let data = decode(path, file, count, RawType::U8, DEN_HEADER as u64)?;
    Volume::new(dims, VoxelType::U8, data)
}

/// Size of a NIfTI-1 header; the voxel data of a `.nii` starts at or after
/// byte 352 (header plus the 4-byte extension flag).
const NIFTI_HEADER: u64 = 348;

const NIFTI_TYPES: &str = "use uint8, int16, uint16 or float32";

/// Loads a single-file NIfTI-1 volume (`.nii`, or gzip-compressed
/// `.nii.gz`; compression is detected from the gzip magic bytes, not the
/// name).
///
/// The header is parsed with the `nifti` crate and checked first (3D only:
/// `dim[0] == 3`, or up to 7 with every extra dimension 1; each edge within
/// [`check_dims`]; `bitpix` agreeing with the datatype; `vox_offset` at or
/// past byte 352); only then is the voxel buffer allocated and filled by
/// streaming the data. The crate's whole-object reader is not used because
/// it allocates extension blocks sized by the file and keeps a raw byte
/// copy beside the decoded data. Trailing bytes after the voxel data are
/// accepted, since the header states the size itself. Header-only
/// `.hdr`/`.img` pairs and NIfTI-2 are refused.
///
/// Datatypes and how they become voxels:
/// - `uint8`: kept as is ([`VoxelType::U8`]).
/// - `uint16`: kept as is ([`VoxelType::U16`]).
/// - `int16`: kept as is when no voxel is negative; otherwise every voxel is
///   offset by minus the minimum, so the minimum maps to 0 and the whole
///   range fits `u16` without clamping ([`VoxelType::U16`]).
/// - `float32`: the finite minimum..maximum is mapped linearly onto
///   0..=65535 and rounded ([`VoxelType::U16`]); NaN and infinite voxels
///   (common outside masks) become 0; a constant volume becomes all 0.
///
/// `scl_slope`/`scl_inter` are not applied: transfer functions are written
/// in stored units, a positive linear scaling only relabels the scalar axis,
/// and float data is rescaled anyway. The orientation (qform/sform) is
/// ignored: voxel `(i, j, k)` of the file is voxel `(x, y, z)`. The spacing
/// is `|pixdim[1..4]|`, in the file's units; a zero or non-finite entry is
/// taken as 1.
///
/// Memory: the limit is checked against 2 bytes per voxel (the volume), or
/// 6 for `float32`, whose voxels are held as `f32` until the range is known.
pub fn load_nifti(path: &Path, limit: u64) -> Result<Volume> {
    let file = open(path)?;
    let mut buffered = BufReader::new(file);
    let gz = buffered
        .fill_buf()
        .map_err(|e| io_err(path, e))?
        .starts_with(&[0x1f, 0x8b]);
    let mut reader: Box<dyn Read> = if gz {
        Box::new(flate2::bufread::MultiGzDecoder::new(buffered))
    } else {
        Box::new(buffered)
    };
    let header = nifti::NiftiHeader::from_reader(&mut reader).map_err(|e| nifti_err(path, e))?;
    let fmt = |msg: String| format_err(path, msg);

    if header.sizeof_hdr != NIFTI_HEADER as i32 {
        return Err(fmt(format!(
            "sizeof_hdr is {}, not {NIFTI_HEADER}: not a NIfTI-1 file",
            header.sizeof_hdr
        )));
    }
    if &header.magic != nifti::header::MAGIC_CODE_NIP1 {
        return Err(fmt(
            "a header-only NIfTI (.hdr/.img pair) is not supported: convert it to a single .nii"
                .into(),
        ));
    }
    let ndim = header.dim[0] as usize;
    if !(3..=7).contains(&ndim) {
        return Err(fmt(format!(
            "NIfTI image has {ndim} dimensions: only 3D volumes are supported"
        )));
    }
    if let Some(k) = (4..=ndim).find(|&k| header.dim[k] != 1) {
        return Err(fmt(format!(
            "NIfTI dim[{k}] = {} (a {ndim}D image): only 3D volumes are supported",
            header.dim[k] as i16
        )));
    }
    // The spec's dims are i16; the crate reads them as u16, so a negative
    // edge shows up as a huge one and check_dims calls it absurd.
    let dims = [
        header.dim[1] as usize,
        header.dim[2] as usize,
        header.dim[3] as usize,
    ];
    let datatype = header.data_type().map_err(|_| {
        fmt(format!(
            "unknown NIfTI datatype code {}: {NIFTI_TYPES}",
            header.datatype
        ))
    })?;
    use nifti::NiftiType as T;
    let (stored, elem, peak) = match datatype {
        T::Uint8 => (Stored::U8, 1, 2),
        T::Uint16 => (Stored::U16, 2, 2),
        T::Int16 => (Stored::I16, 2, 2),
        T::Float32 => (Stored::F32, 4, 6),
        other => {
            let code = header.datatype;
            return Err(fmt(format!(
                "unsupported NIfTI datatype {other:?} (code {code}): {NIFTI_TYPES}"
            )));
        }
    };
    if header.bitpix as i64 != 8 * elem as i64 {
        return Err(fmt(format!(
            "bitpix {} disagrees with datatype {datatype:?} ({} bits)",
            header.bitpix,
            8 * elem
        )));
    }
    let offset = header.vox_offset;
    if !offset.is_finite() || offset < 352.0 || offset.fract() != 0.0 || offset > 1e12 {
        return Err(fmt(format!(
            "vox_offset {offset} is not a byte offset at or after 352"
        )));
    }
    let offset = offset as u64;
    let count = check_dims(dims, peak, limit).map_err(|e| from_file(path, e))?;

    // Skip the extension flag and any extensions.
    let skip = offset - NIFTI_HEADER;
    let skipped = std::io::copy(&mut (&mut reader).take(skip), &mut std::io::sink())
        .map_err(|e| data_err(path, e))?;
    if skipped != skip {
        return Err(fmt(format!(
            "truncated: vox_offset is {offset}, file ends at byte {}",
            NIFTI_HEADER + skipped
        )));
    }

    let big = header.endianness == nifti::Endianness::Big;
    let u16_enc = if big { RawType::U16Be } else { RawType::U16Le };
    let (kind, data) = match stored {
        Stored::U8 => (
            VoxelType::U8,
            decode(path, reader, count, RawType::U8, offset)?,
        ),
        Stored::U16 => (
            VoxelType::U16,
            decode(path, reader, count, u16_enc, offset)?,
        ),
        Stored::I16 => {
            let mut data = decode(path, reader, count, u16_enc, offset)?;
            // Bits were stored as read; reinterpret as i16 to find the floor.
            let min = data.iter().map(|&v| v as i16).min().unwrap_or(0);
            if min < 0 {
                for v in &mut data {
                    *v = (*v as i16 as i32 - min as i32) as u16;
                }
            }
            (VoxelType::U16, data)
        }
        Stored::F32 => {
            let floats = decode_f32(path, reader, count, big, offset)?;
            (VoxelType::U16, rescale_f32(&floats))
        }
    };
    let spacing = [1, 2, 3].map(|k| {
        let s = (header.pixdim[k] as f64).abs();
        if s.is_finite() && s > 0.0 {
            s
        } else {
            1.0
        }
    });
    Volume::new(dims, kind, data)?.with_spacing(spacing)
}

/// Loads a volume, choosing the loader: a raw spec means [`load_raw`],
/// otherwise the file name decides (`.den` -> [`load_den`], `.nii` or
/// `.nii.gz` -> [`load_nifti`], any case).
pub fn load_auto(path: &Path, raw: Option<&RawSpec>, limit: u64) -> Result<Volume> {
    if let Some(spec) = raw {
        return load_raw(path, spec, limit);
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if name.ends_with(".den") {
        load_den(path, limit)
    } else if name.ends_with(".nii") || name.ends_with(".nii.gz") {
        load_nifti(path, limit)
    } else {
        Err(input(format!(
            "unknown volume format for {}: use .den, .nii, .nii.gz or give --raw-dims",
            path.display()
        )))
    }
}

/// The NIfTI datatypes we accept, as stored in the file.
#[derive(Debug, Clone, Copy)]
enum Stored {
    U8,
    U16,
    I16,
    F32,
}

/// Reads exactly `count` voxels of an integer encoding into `u16`s,
/// chunk by chunk. `offset` is where the data starts, for messages.
fn decode(path: &Path, r: impl Read, count: usize, enc: RawType, offset: u64) -> Result<Vec<u16>> {
    let mut out = Vec::with_capacity(count);
    read_chunks(
        path,
        r,
        count,
        enc.bytes() as usize,
        offset,
        |chunk| match enc {
            RawType::U8 => out.extend(chunk.iter().map(|&b| b as u16)),
            RawType::U16Le => out.extend(
                chunk
                    .chunks_exact(2)
                    .map(|b| u16::from_le_bytes([b[0], b[1]])),
            ),
            RawType::U16Be => out.extend(
                chunk
                    .chunks_exact(2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]])),
            ),
        },
    )?;
    Ok(out)
}

/// Reads exactly `count` `f32` voxels, big-endian if `big`.
fn decode_f32(path: &Path, r: impl Read, count: usize, big: bool, offset: u64) -> Result<Vec<f32>> {
    let mut out = Vec::with_capacity(count);
    read_chunks(path, r, count, 4, offset, |chunk| {
        out.extend(chunk.chunks_exact(4).map(|b| {
            let b = [b[0], b[1], b[2], b[3]];
            if big {
                f32::from_be_bytes(b)
            } else {
                f32::from_le_bytes(b)
            }
        }))
    })?;
    Ok(out)
}

/// Maps the finite range of `floats` linearly onto 0..=65535; non-finite
/// voxels become 0 and a constant volume becomes all 0.
fn rescale_f32(floats: &[f32]) -> Vec<u16> {
    let (lo, hi) = floats
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v as f64), hi.max(v as f64))
        });
    let scale = if hi > lo { 65535.0 / (hi - lo) } else { 0.0 };
    floats
        .iter()
        .map(|&v| {
            if v.is_finite() {
                ((v as f64 - lo) * scale).round().clamp(0.0, 65535.0) as u16
            } else {
                0
            }
        })
        .collect()
}

/// Feeds `count * elem` bytes from `r` to `sink` in whole-voxel chunks;
/// fails with "truncated" if the data ends early.
fn read_chunks(
    path: &Path,
    mut r: impl Read,
    count: usize,
    elem: usize,
    offset: u64,
    mut sink: impl FnMut(&[u8]),
) -> Result<()> {
    let total = count as u64 * elem as u64;
    let mut buf = vec![0u8; CHUNK];
    let mut done = 0u64;
    while done < total {
        let want = (total - done).min(CHUNK as u64) as usize;
        let got = fill(&mut r, &mut buf[..want]).map_err(|e| data_err(path, e))?;
        if got < want {
            return Err(format_err(
                path,
                format!(
                    "truncated: expected {total} bytes of voxel data at offset {offset}, found {}",
                    done + got as u64
                ),
            ));
        }
        sink(&buf[..want]);
        done += want as u64;
    }
    Ok(())
}

/// Reads until `buf` is full or the input ends; returns the bytes read.
fn fill(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

fn open(path: &Path) -> Result<File> {
    File::open(path).map_err(|e| io_err(path, e))
}

fn file_len(file: &File, path: &Path) -> Result<u64> {
    Ok(file.metadata().map_err(|e| io_err(path, e))?.len())
}

fn io_err(path: &Path, source: std::io::Error) -> Error {
    Error::Io {
        path: path.to_owned(),
        err: source,
    }
}

fn format_err(path: &Path, msg: impl Into<String>) -> Error {
    Error::Format {
        path: path.to_owned(),
        msg: msg.into(),
    }
}

/// A read error inside the data: a corrupt or cut gzip stream is the file's
/// fault, anything else is the operating system's.
fn data_err(path: &Path, e: std::io::Error) -> Error {
    match e.kind() {
        ErrorKind::UnexpectedEof | ErrorKind::InvalidData | ErrorKind::InvalidInput => {
            format_err(path, format!("unreadable data: {e}"))
        }
        _ => io_err(path, e),
    }
}

/// Dimensions read from a header are the file's problem, not the user's.
fn from_file(path: &Path, e: Error) -> Error {
    match e {
        Error::Input(msg) => format_err(path, msg),
        other => other,
    }
}

fn nifti_err(path: &Path, e: nifti::NiftiError) -> Error {
    match e {
        nifti::NiftiError::Io(io) if io.kind() == ErrorKind::UnexpectedEof => format_err(
            path,
            format!("truncated: a NIfTI-1 header needs {NIFTI_HEADER} bytes"),
        ),
        nifti::NiftiError::Io(io) => data_err(path, io),
        nifti::NiftiError::InvalidFormat => format_err(
            path,
            "not a NIfTI-1 file (bad magic; NIfTI-2 is not supported)",
        ),
        other => format_err(path, format!("bad NIfTI header: {other}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::DEFAULT_MEMORY_LIMIT;
    use std::io::Write;
    use std::path::PathBuf;

    fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    fn msg(r: Result<Volume>) -> String {
        r.map(|v| format!("unexpectedly loaded {:?}", v.dims()))
            .unwrap_err()
            .to_string()
    }

    fn assert_err(r: Result<Volume>, needle: &str) {
        let m = msg(r);
        assert!(m.contains(needle), "error {m:?} should mention {needle:?}");
        assert!(!m.contains('\n'), "error {m:?} should be one line");
    }

    fn pattern(n: usize, modulo: usize) -> Vec<u16> {
        (0..n).map(|i| ((i * 37 + 11) % modulo) as u16).collect()
    }

    #[test]
    fn raw_type_parses_and_lists_valid_names() {
        assert_eq!("u8".parse::<RawType>().unwrap(), RawType::U8);
        assert_eq!("U16LE".parse::<RawType>().unwrap(), RawType::U16Le);
        assert_eq!("u16be".parse::<RawType>().unwrap(), RawType::U16Be);
        let e = "f32".parse::<RawType>().unwrap_err().to_string();
        assert!(
            e.contains("'f32'") && e.contains("u8, u16le or u16be"),
            "{e}"
        );
        for t in [RawType::U8, RawType::U16Le, RawType::U16Be] {
            assert_eq!(t.to_string().parse::<RawType>().unwrap(), t);
        }
    }

    #[test]
    fn raw_round_trips_all_types_with_offset() {
        let dir = tempfile::tempdir().unwrap();
        let dims = [5, 4, 3];
        for (kind, modulo) in [
            (RawType::U8, 256),
            (RawType::U16Le, 65536),
            (RawType::U16Be, 65536),
        ] {
            let want = pattern(60, modulo);
            let mut bytes = vec![0xAA; 7];
            for &v in &want {
                match kind {
                    RawType::U8 => bytes.push(v as u8),
                    RawType::U16Le => bytes.extend(v.to_le_bytes()),
                    RawType::U16Be => bytes.extend(v.to_be_bytes()),
                }
            }
            let path = write(&dir, &format!("v.{kind}"), &bytes);
            let spec = RawSpec {
                dims,
                kind,
                offset: 7,
            };
            let v = load_raw(&path, &spec, DEFAULT_MEMORY_LIMIT).unwrap();
            assert_eq!(v.dims(), dims);
            assert_eq!(v.kind(), kind.voxel_type());
            assert_eq!(v.data(), &want[..]);
            assert_eq!(v.get(1, 0, 0), want[1]);
            assert_eq!(v.get(0, 1, 0), want[5]);
            assert_eq!(v.get(0, 0, 1), want[20]);
        }
    }

    #[test]
    fn raw_size_mismatches_and_absurd_dims_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(&dir, "v.raw", &[1u8; 100]);
        let spec = |dims, kind, offset| RawSpec { dims, kind, offset };
        let lim = DEFAULT_MEMORY_LIMIT;
        assert_err(
            load_raw(&path, &spec([5, 5, 5], RawType::U8, 0), lim),
            "truncated: expected 125 bytes, file has 100",
        );
        assert_err(
            load_raw(&path, &spec([5, 5, 2], RawType::U16Le, 4), lim),
            "truncated: expected 104 bytes",
        );
        assert_err(
            load_raw(&path, &spec([4, 4, 4], RawType::U8, 0), lim),
            "file has 100 bytes, 64 expected for 4x4x4 u8 at offset 0",
        );
        assert_err(
            load_raw(&path, &spec([100_000, 1, 1], RawType::U8, 0), lim),
            "absurd",
        );
        assert_err(
            load_raw(&path, &spec([0, 10, 10], RawType::U8, 0), lim),
            "zero",
        );
        assert_err(
            load_raw(&path, &spec([8000, 8000, 8000], RawType::U16Be, 0), lim),
            "over the limit",
        );
        assert_err(
            load_raw(&path, &spec([10, 10, 1], RawType::U8, 0), 100),
            "over the limit",
        );
        assert!(load_raw(&path, &spec([10, 10, 1], RawType::U8, 0), 200).is_ok());
        let missing = dir.path().join("nope.raw");
        assert_err(
            load_raw(&missing, &spec([1, 1, 1], RawType::U8, 0), lim),
            "nope.raw",
        );
    }

    /// A `.den` file: header with the given fields, then `data`.
    fn den_bytes(map_len: [i16; 3], map_length: i32, data: &[u8], big: bool) -> Vec<u8> {
        let mut out = Vec::new();
        let put16 = |out: &mut Vec<u8>, v: i16| {
            out.extend(if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            })
        };
        put16(&mut out, 1);
        for triple in 0..9 {
            for len in map_len {
                // min = 0, max = len - 1, len: as VolPack writes them.
                let v = match triple % 3 {
                    0 => 0,
                    1 => len.wrapping_sub(1),
                    _ => len,
                };
                put16(&mut out, v);
            }
        }
        put16(&mut out, 3);
        out.extend(if big {
            map_length.to_be_bytes()
        } else {
            map_length.to_le_bytes()
        });
        assert_eq!(out.len(), DEN_HEADER);
        out.extend_from_slice(data);
        out
    }

    #[test]
    fn den_round_trips_in_both_byte_orders() {
        let dir = tempfile::tempdir().unwrap();
        let data: Vec<u8> = pattern(6 * 5 * 4, 256).iter().map(|&v| v as u8).collect();
        for big in [false, true] {
            let path = write(&dir, "s.den", &den_bytes([6, 5, 4], 120, &data, big));
            let v = load_den(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            assert_eq!(v.dims(), [6, 5, 4]);
            assert_eq!(v.kind(), VoxelType::U8);
            assert_eq!(v.spacing(), [1.0; 3]);
            assert!(v.data().iter().zip(&data).all(|(&a, &b)| a == b as u16));
            assert_eq!(v.get(5, 4, 3) as u8, data[119]);
        }
    }

    #[test]
    fn corrupt_den_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        let good = den_bytes([4, 4, 4], 64, &[7; 64], false);

        let mut bad_version = good.clone();
        bad_version[0] = 2;
        assert_err(
            load_den(&write(&dir, "a.den", &bad_version), lim),
            "version 2",
        );

        let mismatched = den_bytes([4, 4, 4], 65, &[7; 64], false);
        assert_err(
            load_den(&write(&dir, "b.den", &mismatched), lim),
            "map_length 65 disagrees with map_len 4x4x4 = 64",
        );
        assert_err(
            load_den(&write(&dir, "c.den", &good[..40]), lim),
            "truncated: a .den header needs 62 bytes, file has 40",
        );
        assert_err(
            load_den(&write(&dir, "d.den", &good[..100]), lim),
            "truncated: expected 126 bytes, file has 100",
        );
        let mut longer = good.clone();
        longer.push(0);
        assert_err(
            load_den(&write(&dir, "e.den", &longer), lim),
            "file has 127 bytes, 126 expected for a 4x4x4 .den",
        );
        let zero = den_bytes([4, 0, 4], 0, &[], false);
        assert_err(
            load_den(&write(&dir, "f.den", &zero), lim),
            "must be positive",
        );
        let negative = den_bytes([4, -4, 4], -64, &[], false);
        assert_err(
            load_den(&write(&dir, "g.den", &negative), lim),
            "must be positive",
        );
        // Consistent header, absurd size: refused before any allocation.
        let huge = den_bytes([16384, 16384, 1], 16384 * 16384, &[], false);
        assert_err(load_den(&write(&dir, "h.den", &huge), lim), "absurd");
        let big = den_bytes([8000, 8000, 8], 8000 * 8000 * 8, &[], false);
        assert_err(
            load_den(&write(&dir, "i.den", &big), 1 << 20),
            "over the limit",
        );
    }

    #[test]
    fn brainsmall_loads_when_present() {
        let path = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../shared/data/brainsmall.den"
        ));
        if !path.exists() {
            eprintln!("note: {} absent, skipping", path.display());
            return;
        }
        let v = load_den(path, DEFAULT_MEMORY_LIMIT).unwrap();
        assert_eq!(v.dims(), [128, 128, 84]);
        assert_eq!(v.kind(), VoxelType::U8);
        let (lo, hi) = v.value_range();
        assert_eq!(lo, 0);
        assert!((150..=255).contains(&hi), "max {hi}");
        let nonzero = v.data().iter().filter(|&&x| x > 30).count();
        let frac = nonzero as f64 / v.data().len() as f64;
        assert!((0.05..0.6).contains(&frac), "tissue fraction {frac}");
        let via_auto = load_auto(path, None, DEFAULT_MEMORY_LIMIT).unwrap();
        assert_eq!(via_auto.data(), v.data());
    }

    /// Fields of a hand-written NIfTI-1 file.
    #[derive(Clone)]
    struct Nii {
        dim: [i16; 8],
        datatype: i16,
        bitpix: i16,
        pixdim: [f32; 8],
        vox_offset: f32,
        magic: [u8; 4],
        sizeof_hdr: i32,
        big: bool,
    }

    impl Nii {
        fn new(dims: [i16; 3], datatype: i16, bitpix: i16) -> Nii {
            Nii {
                dim: [3, dims[0], dims[1], dims[2], 1, 1, 1, 1],
                datatype,
                bitpix,
                pixdim: [1.0, 0.5, 0.75, 2.0, 1.0, 1.0, 1.0, 1.0],
                vox_offset: 352.0,
                magic: *b"n+1\0",
                sizeof_hdr: 348,
                big: false,
            }
        }

        /// The 348-byte header, the 4-byte extension flag, any padding up
        /// to `vox_offset`, then `data` (already in the file's byte order).
        fn bytes(&self, data: &[u8]) -> Vec<u8> {
            let mut h = vec![0u8; 348];
            let big = self.big;
            let i16b = |v: i16| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            let f32b = |v: f32| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            let i32b = |v: i32| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            h[0..4].copy_from_slice(&i32b(self.sizeof_hdr));
            for (k, &d) in self.dim.iter().enumerate() {
                h[40 + 2 * k..42 + 2 * k].copy_from_slice(&i16b(d));
            }
            h[70..72].copy_from_slice(&i16b(self.datatype));
            h[72..74].copy_from_slice(&i16b(self.bitpix));
            for (k, &p) in self.pixdim.iter().enumerate() {
                h[76 + 4 * k..80 + 4 * k].copy_from_slice(&f32b(p));
            }
            h[108..112].copy_from_slice(&f32b(self.vox_offset));
            h[112..116].copy_from_slice(&f32b(1.0)); // scl_slope
            h[344..348].copy_from_slice(&self.magic);
            h.extend([0; 4]);
            while (h.len() as f32) < self.vox_offset {
                h.push(0);
            }
            h.extend_from_slice(data);
            h
        }
    }

    fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all(bytes).unwrap();
        enc.finish().unwrap()
    }

    #[test]
    fn nifti_u8_round_trips_and_agrees_with_the_crate_reader() {
        let dir = tempfile::tempdir().unwrap();
        let data: Vec<u8> = pattern(7 * 6 * 5, 256).iter().map(|&v| v as u8).collect();
        let bytes = Nii::new([7, 6, 5], 2, 8).bytes(&data);
        for (name, file) in [("a.nii", bytes.clone()), ("a.nii.gz", gzip(&bytes))] {
            let path = write(&dir, name, &file);
            let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            assert_eq!(v.dims(), [7, 6, 5]);
            assert_eq!(v.kind(), VoxelType::U8);
            assert_eq!(v.spacing(), [0.5, 0.75, 2.0]);
            assert!(v.data().iter().zip(&data).all(|(&a, &b)| a == b as u16));
            // Our hand-written file is a real NIfTI: the crate reads the same.
            use nifti::NiftiObject;
            let obj = nifti::ReaderOptions::new().read_file(&path).unwrap();
            assert_eq!(obj.header().dim[..4], [3, 7, 6, 5]);
            assert_eq!(obj.into_volume().into_raw_data(), data);
        }
    }

    #[test]
    fn nifti_16_bit_types_in_both_byte_orders() {
        let dir = tempfile::tempdir().unwrap();
        let n = 4 * 3 * 2;
        let uvals = pattern(n, 65536);
        let ivals: Vec<i16> = (0..n).map(|i| i as i16 * 1000 - 9000).collect();
        for big in [false, true] {
            let enc16 = |v: u16| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            let mut nii = Nii::new([4, 3, 2], 512, 16);
            nii.big = big;
            let udata: Vec<u8> = uvals.iter().flat_map(|&v| enc16(v)).collect();
            let path = write(&dir, "u.nii.gz", &gzip(&nii.bytes(&udata)));
            let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            assert_eq!((v.kind(), v.data()), (VoxelType::U16, &uvals[..]));

            nii.datatype = 4;
            let idata: Vec<u8> = ivals.iter().flat_map(|&v| enc16(v as u16)).collect();
            let path = write(&dir, "i.nii", &nii.bytes(&idata));
            let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            let want: Vec<u16> = ivals.iter().map(|&x| (x as i32 + 9000) as u16).collect();
            assert_eq!((v.kind(), v.data()), (VoxelType::U16, &want[..]));

            // Non-negative int16 keeps its values.
            let pos: Vec<u8> = (0..n as u16).flat_map(|x| enc16(x * 3)).collect();
            let path = write(&dir, "p.nii", &nii.bytes(&pos));
            let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            assert!(v.data().iter().enumerate().all(|(i, &x)| x == 3 * i as u16));
        }
    }

    #[test]
    fn nifti_float32_is_rescaled_to_the_full_u16_range() {
        let dir = tempfile::tempdir().unwrap();
        let vals = [-2.0f32, -1.0, 0.0, 2.0, f32::NAN, 1.0, f32::INFINITY, 0.5];
        let data: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut nii = Nii::new([2, 2, 2], 16, 32);
        nii.pixdim = [1.0, -0.5, 0.0, f32::NAN, 1.0, 1.0, 1.0, 1.0];
        let path = write(&dir, "f.nii", &nii.bytes(&data));
        let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
        assert_eq!(v.kind(), VoxelType::U16);
        let s = 65535.0 / 4.0;
        let want: Vec<u16> = [0.0, 1.0, 2.0, 4.0, f64::NAN, 3.0, f64::NAN, 2.5]
            .iter()
            .map(|&x: &f64| {
                if x.is_nan() {
                    0
                } else {
                    (x * s).round() as u16
                }
            })
            .collect();
        assert_eq!(v.data(), &want[..]);
        assert_eq!(v.spacing(), [0.5, 1.0, 1.0]);

        let flat: Vec<u8> = [3.0f32; 8].iter().flat_map(|v| v.to_le_bytes()).collect();
        let path = write(&dir, "flat.nii", &nii.bytes(&flat));
        assert!(load_nifti(&path, DEFAULT_MEMORY_LIMIT)
            .unwrap()
            .data()
            .iter()
            .all(|&x| x == 0));
    }

    #[test]
    fn nifti_shapes_other_than_3d_are_handled() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        let mut nii = Nii::new([2, 2, 2], 2, 8);
        nii.dim[0] = 4;
        let path = write(&dir, "t1.nii", &nii.bytes(&[5; 8]));
        assert_eq!(load_nifti(&path, lim).unwrap().dims(), [2, 2, 2]);
        nii.dim[4] = 2;
        let path = write(&dir, "t2.nii", &nii.bytes(&[5; 16]));
        assert_err(load_nifti(&path, lim), "dim[4] = 2");
        let mut flat = Nii::new([2, 2, 1], 2, 8);
        flat.dim[0] = 2;
        let path = write(&dir, "2d.nii", &flat.bytes(&[5; 4]));
        assert_err(load_nifti(&path, lim), "2 dimensions");
    }

    #[test]
    fn corrupt_nifti_headers_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        let good = Nii::new([2, 2, 2], 2, 8);
        let check = |nii: &Nii, data: &[u8], needle: &str| {
            let path = write(&dir, "bad.nii", &nii.bytes(data));
            assert_err(load_nifti(&path, lim), needle);
        };
        check(
            &Nii {
                datatype: 64,
                bitpix: 64,
                ..good.clone()
            },
            &[0; 64],
            "unsupported NIfTI datatype",
        );
        check(
            &Nii {
                datatype: 3,
                ..good.clone()
            },
            &[0; 8],
            "unknown NIfTI datatype code 3",
        );
        check(
            &Nii {
                bitpix: 16,
                ..good.clone()
            },
            &[0; 8],
            "bitpix 16 disagrees",
        );
        check(
            &Nii {
                vox_offset: 100.0,
                ..good.clone()
            },
            &[0; 8],
            "vox_offset 100",
        );
        check(
            &Nii {
                vox_offset: f32::NAN,
                ..good.clone()
            },
            &[0; 8],
            "vox_offset NaN",
        );
        check(
            &Nii {
                magic: *b"ni1\0",
                ..good.clone()
            },
            &[0; 8],
            ".hdr/.img",
        );
        check(
            &Nii {
                magic: *b"xyz\0",
                ..good.clone()
            },
            &[0; 8],
            "bad magic",
        );
        check(
            &Nii {
                sizeof_hdr: 540,
                ..good.clone()
            },
            &[0; 8],
            "sizeof_hdr is 540",
        );
        check(
            &good,
            &[0; 5],
            "truncated: expected 8 bytes of voxel data at offset 352, found 5",
        );
        check(
            &Nii {
                vox_offset: 400.0,
                ..good.clone()
            },
            &[],
            "truncated",
        );
        let path = write(&dir, "short.nii", &good.bytes(&[0; 8])[..200]);
        assert_err(
            load_nifti(&path, lim),
            "truncated: a NIfTI-1 header needs 348 bytes",
        );
        let gz = gzip(&good.bytes(&[0; 8]));
        let path = write(&dir, "cut.nii.gz", &gz[..gz.len() - 12]);
        assert!(load_nifti(&path, lim).is_err());
    }

    #[test]
    fn absurd_nifti_dims_are_refused_without_allocating() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        // Each of these would need terabytes if trusted; the file is tiny.
        let cases: [([i16; 3], &str); 4] = [
            ([30000, 30000, 30000], "absurd"),
            ([-5, 4, 4], "absurd"),
            ([0, 4, 4], "zero"),
            ([8000, 8000, 8000], "over the limit"),
        ];
        for (dims, needle) in cases {
            let path = write(&dir, "huge.nii", &Nii::new(dims, 16, 32).bytes(&[0; 64]));
            assert_err(load_nifti(&path, lim), needle);
        }
        let path = write(
            &dir,
            "small.nii",
            &Nii::new([8, 8, 8], 2, 8).bytes(&[1; 512]),
        );
        assert_err(load_nifti(&path, 1000), "over the limit");
        assert!(load_nifti(&path, 1024).is_ok());
    }

    #[test]
    fn load_auto_dispatches_on_name_or_raw_spec() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        let den = write(&dir, "X.DEN", &den_bytes([2, 2, 2], 8, &[9; 8], false));
        assert_eq!(load_auto(&den, None, lim).unwrap().data(), &[9; 8]);
        let nii = Nii::new([2, 2, 2], 2, 8).bytes(&[4; 8]);
        let gz = write(&dir, "y.Nii.Gz", &gzip(&nii));
        assert_eq!(load_auto(&gz, None, lim).unwrap().data(), &[4; 8]);
        let plain = write(&dir, "y.nii", &nii);
        assert_eq!(load_auto(&plain, None, lim).unwrap().data(), &[4; 8]);
        // A raw spec wins over the name: the .den is read as 70 raw bytes.
        let spec = RawSpec {
            dims: [7, 10, 1],
            kind: RawType::U8,
            offset: 0,
        };
        assert_eq!(
            load_auto(&den, Some(&spec), lim).unwrap().dims(),
            [7, 10, 1]
        );
        let vol = write(&dir, "z.vol", &[0; 8]);
        assert_err(
            load_auto(&vol, None, lim),
            "z.vol: use .den, .nii, .nii.gz or give --raw-dims",
        );
    }

    mod fuzz {
        use super::*;
        use proptest::prelude::*;

        fn valid_files() -> Vec<(&'static str, Vec<u8>)> {
            let nii = Nii::new([3, 2, 2], 4, 16).bytes(&[1; 24]);
            vec![
                ("f.den", den_bytes([3, 2, 2], 12, &[1; 12], false)),
                ("f.nii", nii.clone()),
                ("f.nii.gz", gzip(&nii)),
            ]
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(200))]

            /// Corrupting bytes of valid files never panics, and never
            /// allocates past a small limit (an absurd header errors out).
            #[test]
            fn corrupted_files_never_panic(
                which in 0usize..3,
                edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
                cut in any::<prop::sample::Index>(),
                do_cut in any::<bool>(),
            ) {
                let dir = tempfile::tempdir().unwrap();
                let (name, mut bytes) = valid_files().swap_remove(which);
                for (at, b) in edits {
                    let i = at.index(bytes.len());
                    bytes[i] = b;
                }
                if do_cut {
                    bytes.truncate(cut.index(bytes.len() + 1));
                }
                let path = write(&dir, name, &bytes);
                let _ = load_auto(&path, None, 1 << 16);
            }

            #[test]
            fn arbitrary_bytes_never_panic(
                which in 0usize..3,
                bytes in prop::collection::vec(any::<u8>(), 0..600),
            ) {
                let dir = tempfile::tempdir().unwrap();
                let name = ["g.den", "g.nii", "g.nii.gz"][which];
                let path = write(&dir, name, &bytes);
                let _ = load_auto(&path, None, 1 << 16);
            }
        }
    }
}
