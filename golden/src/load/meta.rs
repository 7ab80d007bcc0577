//! MetaImage volumes (ITK's MetaIO: `.mha` with the data inline, `.mhd`
//! naming a `.raw` or `.zraw` data file).

use std::collections::HashMap;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use super::decode::{clip, drain, inflate, numbers, read_scalars, Decoded, HeaderReader, Scalar};
use super::{
    beside, file_len, format_err, from_file, io_err, open, spacing_rule, unit_axes, Loaded,
};
use crate::error::Result;
use crate::volume::{check_dims, Volume};

const TYPES: &str = "use MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT, \
                     MET_FLOAT or MET_DOUBLE";

/// Most dimensions a MetaImage may have (MetaIO's limit).
const MAX_DIM: usize = 10;

/// Where the voxels are.
#[derive(Debug, Clone, PartialEq)]
enum DataFile {
    /// Right after the header, in the same file.
    Local,
    /// In this file, relative to the header.
    File(String),
}

/// What the loader uses of a MetaImage header.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    dims: [usize; 3],
    scalar: Scalar,
    big: bool,
    spacing: [f64; 3],
    compressed: bool,
    compressed_size: Option<u64>,
    /// Bytes before the data in a separate data file; -1 means the data
    /// ends the file.
    header_size: i64,
    origin: Option<[f64; 3]>,
    axes: Option<[[f64; 3]; 3]>,
    data_file: DataFile,
}

/// Loads a MetaImage volume; see [`read_meta`].
pub fn load_meta(path: &Path, limit: u64) -> Result<Volume> {
    read_meta(path, limit).map(|l| l.volume)
}

/// Reads a MetaImage volume (`.mha`, or a `.mhd` naming its data file)
/// with its placement.
///
/// The header is `Key = Value` lines (keys in any case; unknown keys are
/// ignored, a key given twice is refused) ending with `ElementDataFile`:
/// `LOCAL` for data right after that line, or one file in the header's
/// folder (see [`allow_outside_data`](super::allow_outside_data); `LIST` and numbered-file patterns are refused). Required:
/// `NDims` (3, or more with every extra size 1), `DimSize`, `ElementType`
/// (`MET_UCHAR`, `MET_CHAR`, `MET_USHORT`, `MET_SHORT`, `MET_UINT`,
/// `MET_INT`, `MET_FLOAT`, `MET_DOUBLE`). Optional: `ObjectType` (must be
/// `Image`), `ElementNumberOfChannels` (must be 1), `BinaryData` (must be
/// true), `BinaryDataByteOrderMSB`/`ElementByteOrderMSB` (true =
/// big-endian; they must agree), `ElementSpacing` (else `ElementSize`,
/// else 1; each within [`SPACING_RANGE`](crate::volume::SPACING_RANGE)),
/// `CompressedData` (zlib, or gzip by its magic) with
/// `CompressedDataSize`, `HeaderSize` (bytes before the data in a separate
/// data file, -1 = the data ends the file; ignored for `LOCAL`, as MetaIO
/// does), `TransformMatrix` (row `i` is the direction of index axis `i`,
/// as ITK reads it; alias `Rotation`, `Orientation`) and `Offset` (alias
/// `Origin`, `Position`), both kept in [`Loaded`].
///
/// Voxel types become voxels by the NIfTI loader's rule (see
/// [`load_nifti`](super::load_nifti)). Uncompressed data is checked
/// against the file's length before the buffer is allocated; trailing
/// bytes are accepted. Compressed data is decoded as it arrives and read to
/// its end, so its checksum is checked.
pub fn read_meta(path: &Path, limit: u64) -> Result<Loaded> {
    let mut hr = HeaderReader::new(path, BufReader::new(open(path)?), "MetaImage");
    let mut lines = Vec::new();
    loop {
        let Some(line) = hr.line()? else {
            return Err(format_err(
                path,
                "the header ends without an ElementDataFile line: not a MetaImage file?",
            ));
        };
        let last = key_of(&line).eq_ignore_ascii_case("ElementDataFile");
        // A line that is not `Key = Value`: say so without reading on.
        let bad = !line.trim().is_empty() && !line.contains('=');
        lines.push(line);
        if last || bad {
            break;
        }
    }
    let h = parse_header(&lines).map_err(|m| format_err(path, m))?;
    let count = check_dims(h.dims, h.scalar.peak(), limit).map_err(|e| from_file(path, e))?;
    let (data_path, start) = match &h.data_file {
        DataFile::Local => (path.to_owned(), hr.used),
        DataFile::File(name) => (beside(path, name)?, h.header_size.max(0) as u64),
    };
    let (kind, data, units) = read_data(&data_path, &h, count, start)?;
    let volume = Volume::new(h.dims, kind, data)?
        .with_spacing(h.spacing)?
        .with_units(units);
    Ok(Loaded {
        volume,
        origin: h.origin,
        axes: h.axes,
    })
}

/// Reads the voxels of `path` from byte `start`.
fn read_data(path: &Path, h: &Header, count: usize, start: u64) -> Result<Decoded> {
    let file = open(path)?;
    let len = file_len(&file, path)?;
    let total = count as u64 * h.scalar.bytes() as u64;
    let at = if h.header_size == -1 && h.data_file != DataFile::Local {
        len.saturating_sub(total)
    } else {
        start
    };
    let mut r = BufReader::new(file);
    r.seek(SeekFrom::Start(at)).map_err(|e| io_err(path, e))?;
    if h.compressed {
        let limit = h.compressed_size.unwrap_or(u64::MAX);
        let mut z = inflate(path, BufReader::new(r.take(limit)))?;
        let decoded = read_scalars(path, &mut z, count, h.scalar, h.big, 0)?;
        drain(path, &mut z)?;
        return Ok(decoded);
    }
    let have = len.saturating_sub(at);
    if have < total {
        let msg = format!("expected {total} bytes of voxel data at offset {at}, found {have}");
        return Err(format_err(path, format!("truncated: {msg}")));
    }
    read_scalars(path, r, count, h.scalar, h.big, at)
}

/// The key of a `Key = Value` line.
fn key_of(line: &str) -> &str {
    line.split('=').next().unwrap_or("").trim()
}

/// Parses MetaIO's booleans.
fn boolean(key: &str, v: &str) -> std::result::Result<bool, String> {
    match v.to_ascii_lowercase().as_str() {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err(format!("{key} '{}' is neither True nor False", clip(v))),
    }
}

/// Parses a header's lines, the last being `ElementDataFile`.
fn parse_header(lines: &[String]) -> std::result::Result<Header, String> {
    let mut fields: HashMap<String, String> = HashMap::new();
    for (i, line) in lines.iter().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(format!(
                "header line {} '{}' is not 'Key = Value': not a MetaImage file?",
                i + 1,
                clip(line)
            ));
        };
        if fields
            .insert(key.trim().to_ascii_lowercase(), value.trim().to_owned())
            .is_some()
        {
            return Err(format!("key '{}' is given twice", clip(key.trim())));
        }
    }
    let get = |k: &str| fields.get(&k.to_ascii_lowercase()).map(String::as_str);
    let first = |ks: &[&'static str]| ks.iter().find_map(|k| get(k).map(|v| (*k, v)));
    let need = |k: &str| get(k).ok_or_else(|| format!("the required key '{k}' is missing"));
    let flag = |k: &str| get(k).map(|v| boolean(k, v)).transpose();

    if let Some(t) = get("ObjectType") {
        if !t.eq_ignore_ascii_case("Image") {
            return Err(format!("ObjectType '{}' is not Image", clip(t)));
        }
    }
    let nd_s = need("NDims")?;
    let nd: usize = nd_s
        .parse()
        .map_err(|_| format!("NDims '{}' is not a number", clip(nd_s)))?;
    if !(3..=MAX_DIM).contains(&nd) {
        return Err(format!(
            "MetaImage NDims {nd}: only 3D volumes are supported"
        ));
    }
    let sizes: Vec<usize> = numbers("DimSize", need("DimSize")?, nd)?;
    if let Some(k) = (3..nd).find(|&k| sizes[k] != 1) {
        return Err(format!(
            "DimSize {sizes:?} (a {nd}D image, axis {k} has {}): only 3D volumes are supported",
            sizes[k]
        ));
    }
    let ty = need("ElementType")?;
    let scalar = match ty.to_ascii_uppercase().as_str() {
        "MET_UCHAR" => Scalar::U8,
        "MET_CHAR" => Scalar::I8,
        "MET_USHORT" => Scalar::U16,
        "MET_SHORT" => Scalar::I16,
        "MET_UINT" => Scalar::U32,
        "MET_INT" => Scalar::I32,
        "MET_FLOAT" => Scalar::F32,
        "MET_DOUBLE" => Scalar::F64,
        _ => return Err(format!("unsupported ElementType '{}': {TYPES}", clip(ty))),
    };
    if let Some(c) = get("ElementNumberOfChannels") {
        if c != "1" {
            return Err(format!(
                "ElementNumberOfChannels '{}': only scalar (1-channel) images are supported",
                clip(c)
            ));
        }
    }
    if flag("BinaryData")? == Some(false) {
        return Err("BinaryData = False (text voxels) is not supported".into());
    }
    let big = match (
        flag("BinaryDataByteOrderMSB")?,
        flag("ElementByteOrderMSB")?,
    ) {
        (Some(a), Some(b)) if a != b => {
            return Err("BinaryDataByteOrderMSB and ElementByteOrderMSB disagree".into())
        }
        (a, b) => a.or(b).unwrap_or(false),
    };
    let spacing = match first(&["ElementSpacing", "ElementSize"]) {
        Some((k, v)) => {
            let s = numbers::<f64>(k, v, nd)?;
            spacing_rule(k, [s[0], s[1], s[2]])?
        }
        None => [1.0; 3],
    };
    let compressed = flag("CompressedData")?.unwrap_or(false);
    let compressed_size = get("CompressedDataSize")
        .map(|v| {
            v.parse::<u64>()
                .map_err(|_| format!("CompressedDataSize '{}' is not a byte count", clip(v)))
        })
        .transpose()?;
    let header_size = match get("HeaderSize") {
        Some(v) => v
            .parse::<i64>()
            .ok()
            .filter(|&n| n >= -1)
            .ok_or_else(|| format!("HeaderSize '{}' is not -1 or a byte count", clip(v)))?,
        None => 0,
    };
    if header_size == -1 && compressed {
        return Err("HeaderSize -1 (data at the end of the file) needs uncompressed data".into());
    }
    let axes = match first(&["TransformMatrix", "Rotation", "Orientation"]) {
        Some((k, v)) => {
            let m = numbers::<f64>(k, v, nd * nd)?;
            let row = |i: usize| [m[i * nd], m[i * nd + 1], m[i * nd + 2]];
            unit_axes([row(0), row(1), row(2)])
        }
        None => None,
    };
    let origin = match first(&["Offset", "Origin", "Position"]) {
        Some((k, v)) => {
            let o = numbers::<f64>(k, v, nd)?;
            Some([o[0], o[1], o[2]]).filter(|o| o.iter().all(|c| c.is_finite()))
        }
        None => None,
    };
    let file = need("ElementDataFile")?;
    let data_file = if file.eq_ignore_ascii_case("LOCAL") {
        DataFile::Local
    } else if file.is_empty()
        || file.eq_ignore_ascii_case("LIST")
        || file.to_ascii_uppercase().starts_with("LIST ")
        || file.split_whitespace().count() >= 4
    {
        return Err(format!(
            "ElementDataFile '{}': only LOCAL or a single data file is supported",
            clip(file)
        ));
    } else {
        DataFile::File(file.to_owned())
    };
    Ok(Header {
        dims: [sizes[0], sizes[1], sizes[2]],
        scalar,
        big,
        spacing,
        compressed,
        compressed_size,
        header_size,
        origin,
        axes,
        data_file,
    })
}

#[cfg(test)]
mod tests;
