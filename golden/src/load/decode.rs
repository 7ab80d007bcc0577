//! Decoding shared by the loaders: voxels are read in fixed-size chunks
//! straight into the final buffer (a short read is "truncated") and mapped
//! onto voxels by one rule for every format ([`read_scalars`]); text
//! headers are read line by line under a size cap ([`HeaderReader`]).

use std::io::{BufRead, ErrorKind, Read};
use std::path::Path;
use std::result::Result as StdResult;
use std::str::FromStr;

use super::{data_err, format_err, RawType};
use crate::error::Result;
use crate::volume::{Units, VoxelType};

/// Bytes decoded per read: a multiple of every voxel size, small enough to
/// be irrelevant next to the volume.
const CHUNK: usize = 1 << 16;

/// Makes room in `out` for `extra` more values, never past `count` in all:
/// the buffer grows (doubling) only as data arrives, so a header that
/// promises more voxels than its stream holds costs what the stream holds,
/// not what the header claims.
fn grow<T>(out: &mut Vec<T>, extra: usize, count: usize) -> &mut Vec<T> {
    let need = out.len() + extra;
    if need > out.capacity() {
        let target = (out.capacity() * 2)
            .max(need)
            .max(CHUNK)
            .min(count.max(need));
        out.reserve_exact(target - out.len());
    }
    out
}

/// Reads a compressed stream to its end, so its trailer (the gzip CRC and
/// length, the zlib Adler-32) is checked: a stream whose data was read but
/// whose checksum is wrong or missing is refused.
pub(super) fn drain(path: &Path, r: &mut impl Read) -> Result<()> {
    std::io::copy(r, &mut std::io::sink())
        .map(|_| ())
        .map_err(|e| data_err(path, e))
}

/// Reads exactly `count` voxels of an integer encoding into `u16`s,
/// chunk by chunk. `offset` is where the data starts, for messages.
pub(super) fn decode(
    path: &Path,
    r: impl Read,
    count: usize,
    enc: RawType,
    offset: u64,
) -> Result<Vec<u16>> {
    let mut out = Vec::new();
    read_chunks(
        path,
        r,
        count,
        enc.bytes() as usize,
        offset,
        |chunk| match enc {
            RawType::U8 => {
                grow(&mut out, chunk.len(), count);
                out.extend(chunk.iter().map(|&b| b as u16))
            }
            RawType::U16Le => grow(&mut out, chunk.len() / 2, count).extend(
                chunk
                    .chunks_exact(2)
                    .map(|b| u16::from_le_bytes([b[0], b[1]])),
            ),
            RawType::U16Be => grow(&mut out, chunk.len() / 2, count).extend(
                chunk
                    .chunks_exact(2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]])),
            ),
        },
    )?;
    Ok(out)
}

/// `count` 8-bit voxels as bytes, not widened: an 8-bit file's volume
/// costs its voxel bytes.
pub(super) fn decode_u8(path: &Path, r: impl Read, count: usize, offset: u64) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    read_chunks(path, r, count, 1, offset, |chunk| {
        grow(&mut out, chunk.len(), count).extend_from_slice(chunk)
    })?;
    Ok(out)
}

/// A stored scalar type, as a file header names it. Each loader maps its
/// own type names onto these, and [`read_scalars`] turns them into voxels
/// by one rule for every format, so the same data gives the same volume
/// whichever format carried it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Scalar {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

impl Scalar {
    /// Bytes per stored value.
    pub(super) fn bytes(self) -> usize {
        match self {
            Scalar::U8 | Scalar::I8 => 1,
            Scalar::U16 | Scalar::I16 => 2,
            Scalar::U32 | Scalar::I32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// Bytes per voxel held while loading, for the memory limit: the `u16`
    /// volume, plus the stored values for the types whose mapping needs the
    /// whole range first.
    pub(super) fn peak(self) -> u64 {
        match self {
            Scalar::U8 | Scalar::I8 | Scalar::U16 | Scalar::I16 => 2,
            Scalar::U32 | Scalar::I32 | Scalar::F32 => 6,
            Scalar::F64 => 10,
        }
    }
}

/// Reads exactly `count` values of `scalar` (big-endian if `big`) and maps
/// them onto voxels, the rule every loader shares (it is the NIfTI
/// loader's, extended to more types):
/// - `u8` and `u16` are kept as they are ([`VoxelType::U8`], [`VoxelType::U16`]).
/// - `i8` and `i16` are kept when no value is negative; otherwise every
///   value is offset by minus the minimum, so the minimum maps to 0 and the
///   range fits the unsigned type of the same width without clamping.
/// - `u32` and `i32` are offset the same way and kept exactly when the
///   result fits `u16`; a wider range is mapped linearly like floats.
/// - `f32` and `f64`: the finite minimum..maximum is mapped linearly onto
///   0..=65535 and rounded; NaN and infinite values become 0; a constant
///   volume becomes all 0.
///
/// The [`Units`] returned say how each voxel relates to the stored value
/// (`base + step * voxel`), for `--window`.
///
/// `offset` is where the data starts, for messages.
pub(super) fn read_scalars(
    path: &Path,
    r: impl Read,
    count: usize,
    scalar: Scalar,
    big: bool,
    offset: u64,
) -> Result<Decoded> {
    let u16_enc = if big { RawType::U16Be } else { RawType::U16Le };
    let n = scalar.bytes();
    let id = Units::IDENTITY;
    Ok(match scalar {
        Scalar::U8 => (
            VoxelType::U8,
            decode(path, r, count, RawType::U8, offset)?,
            id,
        ),
        Scalar::U16 => (VoxelType::U16, decode(path, r, count, u16_enc, offset)?, id),
        Scalar::I8 => {
            let mut data = decode(path, r, count, RawType::U8, offset)?;
            // Bits were stored as read; reinterpret as i8 to find the floor.
            let min = data.iter().map(|&v| v as u8 as i8).min().unwrap_or(0);
            if min < 0 {
                for v in &mut data {
                    *v = (*v as u8 as i8 as i32 - min as i32) as u16;
                }
            }
            (VoxelType::U8, data, Units::shifted(min.min(0) as f64))
        }
        Scalar::I16 => {
            let mut data = decode(path, r, count, u16_enc, offset)?;
            // Bits were stored as read; reinterpret as i16 to find the floor.
            let min = data.iter().map(|&v| v as i16).min().unwrap_or(0);
            if min < 0 {
                for v in &mut data {
                    *v = (*v as i16 as i32 - min as i32) as u16;
                }
            }
            (VoxelType::U16, data, Units::shifted(min.min(0) as f64))
        }
        Scalar::U32 => {
            let vals = decode_wide(path, r, count, n, offset, |b| word(b, big) as i64)?;
            let (data, units) = fit_or_rescale(&vals);
            (VoxelType::U16, data, units)
        }
        Scalar::I32 => {
            let vals = decode_wide(path, r, count, n, offset, |b| word(b, big) as i32)?;
            let vals: Vec<i64> = vals.into_iter().map(i64::from).collect();
            let (data, units) = fit_or_rescale(&vals);
            (VoxelType::U16, data, units)
        }
        Scalar::F32 => {
            let vals = decode_wide(path, r, count, n, offset, |b| f32::from_bits(word(b, big)))?;
            let (data, units) = rescale(vals.iter().map(|&v| v as f64));
            (VoxelType::U16, data, units)
        }
        Scalar::F64 => {
            let vals = decode_wide(path, r, count, n, offset, |b| {
                let b: [u8; 8] = b.try_into().expect("8-byte chunk");
                if big {
                    f64::from_be_bytes(b)
                } else {
                    f64::from_le_bytes(b)
                }
            })?;
            let (data, units) = rescale(vals.iter().copied());
            (VoxelType::U16, data, units)
        }
    })
}

/// Voxels as a loader returns them: the type, the values, and how they
/// relate to the stored ones.
pub(super) type Decoded = (VoxelType, Vec<u16>, Units);

/// A 4-byte word in the given byte order.
fn word(b: &[u8], big: bool) -> u32 {
    let b = [b[0], b[1], b[2], b[3]];
    if big {
        u32::from_be_bytes(b)
    } else {
        u32::from_le_bytes(b)
    }
}

/// Reads exactly `count` values of `elem` bytes each, parsed by `parse`.
fn decode_wide<T>(
    path: &Path,
    r: impl Read,
    count: usize,
    elem: usize,
    offset: u64,
    parse: impl Fn(&[u8]) -> T,
) -> Result<Vec<T>> {
    let mut out = Vec::new();
    read_chunks(path, r, count, elem, offset, |chunk| {
        grow(&mut out, chunk.len() / elem, count).extend(chunk.chunks_exact(elem).map(&parse))
    })?;
    Ok(out)
}

/// Wide integers: offset by minus a negative minimum, kept when the result
/// fits `u16`, otherwise mapped linearly onto 0..=65535.
fn fit_or_rescale(vals: &[i64]) -> (Vec<u16>, Units) {
    let lo = vals.iter().copied().min().unwrap_or(0);
    let hi = vals.iter().copied().max().unwrap_or(0);
    let shift = if lo < 0 { -lo } else { 0 };
    if hi + shift <= u16::MAX as i64 {
        let data = vals.iter().map(|&v| (v + shift) as u16).collect();
        (data, Units::shifted(-shift as f64))
    } else {
        rescale(vals.iter().map(|&v| v as f64))
    }
}

/// Maps the finite range of `vals` linearly onto 0..=65535; non-finite
/// values become 0 and a constant volume becomes all 0.
pub(super) fn rescale(vals: impl Iterator<Item = f64> + Clone) -> (Vec<u16>, Units) {
    let (lo, hi) = vals
        .clone()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let scale = if hi > lo { 65535.0 / (hi - lo) } else { 0.0 };
    let units = Units {
        base: if lo.is_finite() { lo } else { 0.0 },
        step: if hi > lo { (hi - lo) / 65535.0 } else { 1.0 },
    };
    let data = vals
        .map(|v| {
            if v.is_finite() {
                ((v - lo) * scale).round().clamp(0.0, 65535.0) as u16
            } else {
                0
            }
        })
        .collect();
    (data, units)
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

/// Longest text header read (NRRD, MetaImage): real ones are a few KiB,
/// and a binary file taken for a header must not be read whole.
pub(super) const MAX_HEADER: u64 = 1 << 20;

/// Reads a text header line by line, counting the bytes it has taken.
pub(super) struct HeaderReader<'a, R> {
    r: R,
    path: &'a Path,
    what: &'static str,
    /// Bytes of the header read so far (where the data starts if it is
    /// attached).
    pub(super) used: u64,
    lines: usize,
}

impl<'a, R: BufRead> HeaderReader<'a, R> {
    /// A reader of `what` headers (for messages) from `r`, the file `path`.
    pub(super) fn new(path: &'a Path, r: R, what: &'static str) -> Self {
        HeaderReader {
            r,
            path,
            what,
            used: 0,
            lines: 0,
        }
    }

    /// The next line without its `\n` (or `\r\n`), `None` at the end of
    /// the input. Fails past [`MAX_HEADER`] bytes or on a line that is not
    /// UTF-8 text.
    pub(super) fn line(&mut self) -> Result<Option<String>> {
        let mut buf = Vec::new();
        let left = MAX_HEADER.saturating_sub(self.used);
        let n = (&mut self.r)
            .take(left + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|e| data_err(self.path, e))?;
        if n == 0 {
            return Ok(None);
        }
        self.used += n as u64;
        self.lines += 1;
        let what = self.what;
        if self.used > MAX_HEADER {
            return Err(format_err(
                self.path,
                format!("{what} header runs past {MAX_HEADER} bytes: not a {what} file?"),
            ));
        }
        if buf.last() == Some(&b'\n') {
            buf.pop();
            if buf.last() == Some(&b'\r') {
                buf.pop();
            }
        }
        String::from_utf8(buf).map(Some).map_err(|_| {
            format_err(
                self.path,
                format!("{what} header line {} is not text", self.lines),
            )
        })
    }
}

/// Parses exactly `n` whitespace-separated values of `field`.
pub(super) fn numbers<T: FromStr>(field: &str, value: &str, n: usize) -> StdResult<Vec<T>, String> {
    let vals: Vec<T> = value
        .split_whitespace()
        .map(|w| w.parse::<T>())
        .collect::<StdResult<_, _>>()
        .map_err(|_| format!("{field} '{}' is not a list of numbers", clip(value)))?;
    if vals.len() != n {
        return Err(format!(
            "{field} '{}' has {} values, {n} expected",
            clip(value),
            vals.len()
        ));
    }
    Ok(vals)
}

/// A header value shortened for a message, control characters escaped.
pub(super) fn clip(s: &str) -> String {
    let short: String = s.chars().take(40).collect();
    let more = if short.len() < s.len() { "..." } else { "" };
    format!("{}{more}", short.escape_debug())
}

/// A data stream, inflated if the header says it is compressed: gzip when
/// it starts with the gzip magic, zlib otherwise.
pub(super) fn inflate<'r>(path: &Path, mut r: impl BufRead + 'r) -> Result<Box<dyn Read + 'r>> {
    let gz = r
        .fill_buf()
        .map_err(|e| data_err(path, e))?
        .starts_with(&[0x1f, 0x8b]);
    Ok(if gz {
        Box::new(flate2::bufread::MultiGzDecoder::new(r))
    } else {
        Box::new(flate2::bufread::ZlibDecoder::new(r))
    })
}

/// Skips `n` bytes of `r`; false if it ends first.
pub(super) fn skip_bytes(path: &Path, r: &mut impl Read, n: u64) -> Result<bool> {
    let skipped =
        std::io::copy(&mut r.take(n), &mut std::io::sink()).map_err(|e| data_err(path, e))?;
    Ok(skipped == n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn run(scalar: Scalar, bytes: &[u8], big: bool) -> Result<(VoxelType, Vec<u16>)> {
        let n = bytes.len() / scalar.bytes();
        read_scalars(Path::new("t"), Cursor::new(bytes), n, scalar, big, 0).map(|(k, d, _)| (k, d))
    }

    #[test]
    fn units_give_back_the_stored_values() {
        let units = |s: Scalar, b: &[u8]| {
            let n = b.len() / s.bytes();
            let (_, d, u) = read_scalars(Path::new("t"), Cursor::new(b), n, s, false, 0).unwrap();
            d.iter().map(|&v| u.value(v as f64)).collect::<Vec<_>>()
        };
        let i16s: Vec<u8> = [-1024i16, 0, 3071]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(units(Scalar::I16, &i16s), [-1024.0, 0.0, 3071.0]);
        assert_eq!(units(Scalar::U8, &[0, 9]), [0.0, 9.0]);
        let f32s: Vec<u8> = [-2.0f32, 0.5, 3.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let back = units(Scalar::F32, &f32s);
        // Floats come back to within half a 16-bit level of their range.
        for (b, w) in back.iter().zip([-2.0, 0.5, 3.0]) {
            assert!((b - w).abs() <= 0.5 * 5.0 / 65535.0 + 1e-12, "{b} vs {w}");
        }
    }

    #[test]
    fn every_type_maps_by_the_shared_rule() {
        let ok = |s, b: &[u8], big| run(s, b, big).unwrap();
        assert_eq!(
            ok(Scalar::U8, &[0, 7, 255], false),
            (VoxelType::U8, vec![0, 7, 255])
        );
        // Signed: offset by minus a negative minimum, else kept.
        let i8s: Vec<u8> = [-128i8, -1, 0, 127].iter().map(|&v| v as u8).collect();
        assert_eq!(
            ok(Scalar::I8, &i8s, false),
            (VoxelType::U8, vec![0, 127, 128, 255])
        );
        assert_eq!(ok(Scalar::I8, &[3, 9], false), (VoxelType::U8, vec![3, 9]));
        let i16s: Vec<u8> = [-5i16, 0, 300]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect();
        assert_eq!(
            ok(Scalar::I16, &i16s, true),
            (VoxelType::U16, vec![0, 5, 305])
        );
        // 32-bit integers: exact when the (offset) range fits u16.
        let u32s: Vec<u8> = [0u32, 9, 65535]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(ok(Scalar::U32, &u32s, false).1, vec![0, 9, 65535]);
        let i32s: Vec<u8> = [-1000i32, 0, 1000]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect();
        assert_eq!(ok(Scalar::I32, &i32s, true).1, vec![0, 1000, 2000]);
        // ... and mapped linearly like floats when it does not.
        let wide: Vec<u8> = [0u32, 1 << 20, 1 << 21]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(ok(Scalar::U32, &wide, false).1, vec![0, 32768, 65535]);
        let wide: Vec<u8> = [i32::MIN, 0, i32::MAX]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(ok(Scalar::I32, &wide, false).1, vec![0, 32768, 65535]);
        // Floats: the finite range onto 0..=65535, NaN and infinities 0.
        let f: [f64; 5] = [-1.0, 0.0, 1.0, f64::NAN, f64::NEG_INFINITY];
        let f64s: Vec<u8> = f.iter().flat_map(|v| v.to_le_bytes()).collect();
        let want = vec![0, 32768, 65535, 0, 0];
        assert_eq!(
            ok(Scalar::F64, &f64s, false),
            (VoxelType::U16, want.clone())
        );
        let f32s: Vec<u8> = f.iter().flat_map(|&v| (v as f32).to_be_bytes()).collect();
        assert_eq!(ok(Scalar::F32, &f32s, true), (VoxelType::U16, want));
        let flat: Vec<u8> = [2.5f32; 3].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(ok(Scalar::F32, &flat, false).1, vec![0, 0, 0]);
    }

    #[test]
    fn short_data_is_truncated_for_every_type() {
        for s in [Scalar::U8, Scalar::I16, Scalar::U32, Scalar::F64] {
            let bytes = vec![1u8; 3 * s.bytes() - 1];
            let r = read_scalars(Path::new("t"), Cursor::new(&bytes), 3, s, false, 9)
                .map(|(k, _, _)| k);
            let e = r.unwrap_err().to_string();
            let want = format!("expected {} bytes of voxel data at offset 9", 3 * s.bytes());
            assert!(e.contains(&want), "{s:?}: {e}");
        }
    }

    #[test]
    fn header_lines_strip_line_ends_and_stop_at_the_cap() {
        let text = b"one\r\ntwo\n\nlast";
        let mut hr = HeaderReader::new(Path::new("h"), Cursor::new(&text[..]), "X");
        let mut got = Vec::new();
        while let Some(l) = hr.line().unwrap() {
            got.push(l);
        }
        assert_eq!(got, ["one", "two", "", "last"]);
        assert_eq!(hr.used, text.len() as u64);
        let mut bad = HeaderReader::new(Path::new("h"), Cursor::new(&[0xffu8, b'\n'][..]), "X");
        assert!(bad
            .line()
            .unwrap_err()
            .to_string()
            .contains("line 1 is not text"));
        let long = vec![b'a'; MAX_HEADER as usize + 10];
        let mut hr = HeaderReader::new(Path::new("h"), Cursor::new(&long[..]), "X");
        assert!(hr.line().unwrap_err().to_string().contains("runs past"));
        assert_eq!(clip(&"é".repeat(50)).chars().count(), 43);
        assert_eq!(clip("a\tb"), "a\\tb");
    }
}
