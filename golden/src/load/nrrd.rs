//! NRRD volumes (`.nrrd` with the data attached, `.nhdr` with a detached
//! data file), read against teem's NRRD format definition (NRRD0001 to
//! NRRD0005).

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::Path;

use super::decode::clip;
use super::decode::{
    drain, inflate, numbers, read_scalars, skip_bytes, Decoded, HeaderReader, Scalar,
};
use super::{
    beside, data_err, file_len, format_err, from_file, io_err, norm, open, spacing_rule, unit_axes,
    Loaded,
};
use crate::error::Result;
use crate::volume::{check_dims, Volume};

/// Most axes a NRRD may have (teem's `NRRD_DIM_MAX`).
const MAX_DIM: usize = 16;

const TYPES: &str = "use uint8, int8, uint16, int16, uint32, int32, float or double";

/// How the voxel data is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Raw,
    Gzip,
}

/// What the loader uses of a NRRD header.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    dims: [usize; 3],
    scalar: Scalar,
    encoding: Encoding,
    big: bool,
    spacing: [f64; 3],
    origin: Option<[f64; 3]>,
    axes: Option<[[f64; 3]; 3]>,
    data_file: Option<String>,
    line_skip: u64,
    /// Bytes skipped before the data (in the decompressed stream for
    /// gzip); -1 means the data is the end of the file (raw only).
    byte_skip: i64,
}

/// Loads a NRRD volume; see [`read_nrrd`].
pub fn load_nrrd(path: &Path, limit: u64) -> Result<Volume> {
    read_nrrd(path, limit).map(|l| l.volume)
}

/// Reads a NRRD volume (`.nrrd`, or a `.nhdr` header naming its data file)
/// with its placement.
///
/// The header is the magic line `NRRD0001`..`NRRD0005`, then `field: value`
/// lines, `key:=value` pairs (ignored) and `#` comments, up to a blank line
/// (after which attached data starts) or the end of a detached header.
/// Field names are matched in any case and with or without their spaces
/// (`byte skip` = `byteskip`); unknown fields are ignored, a field given
/// twice is refused. Required: `dimension` (3, or more with every extra
/// size 1), `sizes`, `type` (`uint8`, `int8`, `uint16`, `int16`, `uint32`,
/// `int32`, `float`, `double` and their C spellings), `encoding` (`raw`,
/// `gzip`/`gz`), and `endian` for types wider than a byte. Optional:
/// `spacings`, or `space directions` (then each axis's spacing is the
/// length of its direction vector, and the unit directions are kept in
/// [`Loaded::axes`]), `space`/`space dimension`, `space origin`,
/// `line skip`, `byte skip` (-1 = the data ends the file, raw only; for
/// gzip the bytes are skipped in the decompressed stream, as teem does)
/// and `data file` (one file in the header's folder, see
/// [`allow_outside_data`](super::allow_outside_data); `LIST` and
/// numbered-file patterns are refused).
///
/// Voxel types become voxels by the NIfTI loader's rule (see
/// [`load_nifti`](super::load_nifti)). An absent spacing is 1; a given one
/// must lie in [`SPACING_RANGE`](crate::volume::SPACING_RANGE) (zero,
/// `nan` and negative are refused). Raw data is checked against the file's
/// length before the buffer is allocated; trailing bytes are accepted; a
/// gzip stream is decoded as it arrives and read to its end, so its CRC
/// and length are checked.
pub fn read_nrrd(path: &Path, limit: u64) -> Result<Loaded> {
    let mut hr = HeaderReader::new(path, BufReader::new(open(path)?), "NRRD");
    let mut lines = Vec::new();
    let mut ended = false;
    while let Some(line) = hr.line()? {
        if line.is_empty() {
            ended = true;
            break;
        }
        let first = lines.is_empty();
        lines.push(line);
        if first && !lines[0].starts_with("NRRD") {
            break; // not a NRRD: say so without reading on
        }
    }
    let h = parse_header(&lines).map_err(|m| format_err(path, m))?;
    let count = check_dims(h.dims, h.scalar.peak(), limit).map_err(|e| from_file(path, e))?;
    let (data_path, start) = match &h.data_file {
        Some(name) => (beside(path, name)?, 0),
        None if ended => (path.to_owned(), hr.used),
        None => {
            let msg = "the header neither ends in a blank line nor names a 'data file'";
            return Err(format_err(path, msg));
        }
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

/// Reads the voxels from `path`, whose data (after any line and byte skip)
/// starts at byte `start`.
fn read_data(path: &Path, h: &Header, count: usize, start: u64) -> Result<Decoded> {
    let file = open(path)?;
    let len = file_len(&file, path)?;
    let mut r = BufReader::new(file);
    r.seek(SeekFrom::Start(start))
        .map_err(|e| io_err(path, e))?;
    let mut pos = start;
    for k in 0..h.line_skip {
        let n = r.skip_until(b'\n').map_err(|e| data_err(path, e))?;
        if n == 0 {
            return Err(format_err(
                path,
                format!(
                    "truncated: line skip {} passes the end of the file after {k} lines",
                    h.line_skip
                ),
            ));
        }
        pos += n as u64;
    }
    let total = count as u64 * h.scalar.bytes() as u64;
    match h.encoding {
        Encoding::Raw => {
            let at = if h.byte_skip == -1 {
                len.checked_sub(total)
                    .filter(|&at| at >= pos)
                    .unwrap_or(pos)
            } else {
                pos.saturating_add(h.byte_skip as u64)
            };
            let have = len.saturating_sub(at);
            if have < total {
                let msg =
                    format!("expected {total} bytes of voxel data at offset {at}, found {have}");
                return Err(format_err(path, format!("truncated: {msg}")));
            }
            r.seek(SeekFrom::Start(at)).map_err(|e| io_err(path, e))?;
            read_scalars(path, r, count, h.scalar, h.big, at)
        }
        Encoding::Gzip => {
            let mut gz = inflate(path, r)?;
            let skip = h.byte_skip as u64;
            if !skip_bytes(path, &mut gz, skip)? {
                return Err(format_err(
                    path,
                    format!("truncated: byte skip {skip} passes the end of the data"),
                ));
            }
            let decoded = read_scalars(path, &mut gz, count, h.scalar, h.big, skip)?;
            drain(path, &mut gz)?;
            Ok(decoded)
        }
    }
}

/// The stored type a NRRD `type` names.
fn scalar(name: &str) -> Option<Scalar> {
    Some(match name {
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => Scalar::U8,
        "signed char" | "int8" | "int8_t" => Scalar::I8,
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => Scalar::U16,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            Scalar::I16
        }
        "uint" | "unsigned int" | "uint32" | "uint32_t" => Scalar::U32,
        "int" | "signed int" | "int32" | "int32_t" => Scalar::I32,
        "float" => Scalar::F32,
        "double" => Scalar::F64,
        _ => return None,
    })
}

/// Dimension of a named NRRD space.
fn space_dim(name: &str) -> Option<usize> {
    Some(match name.to_ascii_lowercase().as_str() {
        "right-anterior-superior"
        | "ras"
        | "left-anterior-superior"
        | "las"
        | "left-posterior-superior"
        | "lps"
        | "scanner-xyz"
        | "3d-right-handed"
        | "3d-left-handed" => 3,
        "right-anterior-superior-time"
        | "rast"
        | "left-anterior-superior-time"
        | "last"
        | "left-posterior-superior-time"
        | "lpst"
        | "scanner-xyz-time"
        | "3d-right-handed-time"
        | "3d-left-handed-time" => 4,
        _ => return None,
    })
}

/// Parses a header's lines (the magic line first, no blank line).
fn parse_header(lines: &[String]) -> std::result::Result<Header, String> {
    let magic = lines.first().map(String::as_str).unwrap_or("");
    let b = magic.as_bytes();
    if !(b.len() == 8 && magic.starts_with("NRRD000") && (b'1'..=b'5').contains(&b[7])) {
        return Err(format!(
            "not a NRRD file: the first line is '{}', not NRRD0001..NRRD0005",
            clip(magic)
        ));
    }
    let mut fields: HashMap<String, String> = HashMap::new();
    for (i, line) in lines.iter().enumerate().skip(1) {
        if line.starts_with('#') {
            continue;
        }
        let Some(colon) = line.find(':') else {
            return Err(format!(
                "header line {} '{}' is not 'field: value'",
                i + 1,
                clip(line)
            ));
        };
        if line[colon + 1..].starts_with('=') {
            continue; // key:=value pair
        }
        let name: String = line[..colon]
            .chars()
            .filter(|c| *c != ' ')
            .collect::<String>()
            .to_ascii_lowercase();
        let value = line[colon + 1..].trim().to_owned();
        if fields.insert(name, value).is_some() {
            return Err(format!(
                "field '{}' is given twice",
                clip(line[..colon].trim())
            ));
        }
    }
    let get = |k: &str| fields.get(k).map(String::as_str);
    let need = |k: &str, spelled: &str| {
        get(k).ok_or_else(|| format!("the required field '{spelled}' is missing"))
    };

    let dim_s = need("dimension", "dimension")?;
    let dim: usize = dim_s
        .parse()
        .map_err(|_| format!("dimension '{}' is not a number", clip(dim_s)))?;
    if !(3..=MAX_DIM).contains(&dim) {
        return Err(format!(
            "NRRD dimension {dim}: only 3D volumes are supported"
        ));
    }
    let sizes: Vec<usize> = numbers("sizes", need("sizes", "sizes")?, dim)?;
    if let Some(k) = (3..dim).find(|&k| sizes[k] != 1) {
        return Err(format!(
            "NRRD sizes {sizes:?} (a {dim}D image, axis {k} has {}): only 3D volumes are supported",
            sizes[k]
        ));
    }
    let dims = [sizes[0], sizes[1], sizes[2]];

    let type_s = need("type", "type")?;
    let scalar = scalar(&type_s.to_ascii_lowercase())
        .ok_or_else(|| format!("unsupported NRRD type '{}': {TYPES}", clip(type_s)))?;
    let enc_s = need("encoding", "encoding")?;
    let encoding = match enc_s.to_ascii_lowercase().as_str() {
        "raw" => Encoding::Raw,
        "gzip" | "gz" => Encoding::Gzip,
        _ => {
            return Err(format!(
                "unsupported NRRD encoding '{}': use raw or gzip",
                clip(enc_s)
            ))
        }
    };
    let endian = get("endian").unwrap_or("");
    let big = match get("endian").map(str::to_ascii_lowercase).as_deref() {
        Some("little") => false,
        Some("big") => true,
        Some(_) => {
            return Err(format!(
                "endian '{}' is neither little nor big",
                clip(endian)
            ))
        }
        None if scalar.bytes() > 1 => {
            return Err("the field 'endian' is required for types wider than a byte".into())
        }
        None => false,
    };

    // World directions and origin are kept in LPS (see crate::orient):
    // RAS and LAS spaces change the sign of x and y, or of y; other spaces
    // are taken as LPS.
    let to_lps: fn([f64; 3]) -> [f64; 3] =
        match get("space").map(str::to_ascii_lowercase).as_deref() {
            Some("right-anterior-superior" | "ras" | "right-anterior-superior-time" | "rast") => {
                crate::orient::ras_to_lps
            }
            Some("left-anterior-superior" | "las" | "left-anterior-superior-time" | "last") => {
                |v| [v[0], -v[1], v[2]]
            }
            _ => |v| v,
        };
    let space = match (get("space"), get("spacedimension")) {
        (Some(_), Some(_)) => return Err("both 'space' and 'space dimension' are given".into()),
        (Some(name), None) => {
            Some(space_dim(name).ok_or_else(|| format!("unknown NRRD space '{}'", clip(name)))?)
        }
        (None, Some(n)) => Some(
            n.parse::<usize>()
                .ok()
                .filter(|n| (1..=MAX_DIM).contains(n))
                .ok_or_else(|| format!("space dimension '{}' is not 1..{MAX_DIM}", clip(n)))?,
        ),
        (None, None) => None,
    };
    let mut spacing = [1.0; 3];
    let mut axes = None;
    match (get("spacings"), get("spacedirections")) {
        (Some(_), Some(_)) => return Err("both 'spacings' and 'space directions' are given".into()),
        (Some(s), None) => {
            let vals = numbers::<f64>("spacings", s, dim)?;
            spacing = spacing_rule("spacings", [vals[0], vals[1], vals[2]])?;
        }
        (None, Some(s)) => {
            let sd = space.ok_or("'space directions' needs 'space' or 'space dimension'")?;
            let dirs = vectors("space directions", s, dim, sd)?;
            for k in 0..3 {
                if let Some(v) = &dirs[k] {
                    spacing[k] = norm(v);
                }
            }
            spacing = spacing_rule("space directions (their lengths)", spacing)?;
            if sd == 3 {
                if let [Some(a), Some(b), Some(c)] = &dirs[..3] {
                    let dir = |v: &[f64]| to_lps([v[0], v[1], v[2]]);
                    axes = unit_axes([dir(a), dir(b), dir(c)]);
                }
            }
        }
        (None, None) => {}
    }
    let origin = match get("spaceorigin") {
        Some(s) => {
            let sd = space.ok_or("'space origin' needs 'space' or 'space dimension'")?;
            match vectors("space origin", s, 1, sd)?.remove(0) {
                Some(v) if sd == 3 && v.iter().all(|c| c.is_finite()) => {
                    Some(to_lps([v[0], v[1], v[2]]))
                }
                _ => None,
            }
        }
        None => None,
    };

    let line_skip = match get("lineskip") {
        Some(s) => s
            .parse::<u64>()
            .map_err(|_| format!("line skip '{}' is not a count of lines", clip(s)))?,
        None => 0,
    };
    let byte_skip = match get("byteskip") {
        Some(s) => s
            .parse::<i64>()
            .ok()
            .filter(|&n| n >= -1)
            .ok_or_else(|| format!("byte skip '{}' is not -1 or a count of bytes", clip(s)))?,
        None => 0,
    };
    if byte_skip == -1 && encoding != Encoding::Raw {
        return Err("byte skip -1 (data at the end of the file) needs raw encoding".into());
    }
    let data_file = match get("datafile") {
        Some("") => return Err("'data file' is empty".into()),
        Some(s) if s == "LIST" || s.starts_with("LIST ") || s.split_whitespace().count() >= 4 => {
            return Err(format!(
                "data file '{}': only a single data file is supported",
                clip(s)
            ))
        }
        Some(s) => Some(s.to_owned()),
        None => None,
    };
    Ok(Header {
        dims,
        scalar,
        encoding,
        big,
        spacing,
        origin,
        axes,
        data_file,
        line_skip,
        byte_skip,
    })
}

/// Parses `n` vectors of `sd` components, `(a,b,c)` or `none`, separated by
/// whitespace.
fn vectors(
    field: &str,
    value: &str,
    n: usize,
    sd: usize,
) -> std::result::Result<Vec<Option<Vec<f64>>>, String> {
    let bad = |why: &str| format!("{field} '{}': {why}", clip(value));
    let mut out = Vec::new();
    let mut rest = value.trim_start();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("none") {
            out.push(None);
            rest = r;
        } else if let Some(r) = rest.strip_prefix('(') {
            let close = r.find(')').ok_or_else(|| bad("a '(' is not closed"))?;
            let comps = r[..close]
                .split(',')
                .map(|c| c.trim().parse::<f64>())
                .collect::<std::result::Result<Vec<_>, _>>()
                .map_err(|_| bad("a component is not a number"))?;
            if comps.len() != sd {
                return Err(bad(&format!(
                    "a vector has {} components, the space {sd}",
                    comps.len()
                )));
            }
            out.push(Some(comps));
            rest = &r[close + 1..];
        } else {
            return Err(bad("expected '(' or 'none'"));
        }
        if out.len() > n {
            break;
        }
        rest = rest.trim_start();
    }
    if out.len() != n {
        return Err(bad(&format!("{} vectors, {n} expected", out.len())));
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
