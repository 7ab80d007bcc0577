//! Chunked decoding shared by the loaders: voxels are read in fixed-size
//! chunks straight into the final buffer, and a short read is "truncated".

use std::io::{ErrorKind, Read};
use std::path::Path;

use super::{data_err, format_err, RawType};
use crate::error::Result;

/// Bytes decoded per read: a multiple of every voxel size, small enough to
/// be irrelevant next to the volume.
pub(super) const CHUNK: usize = 1 << 16;

/// Reads exactly `count` voxels of an integer encoding into `u16`s,
/// chunk by chunk. `offset` is where the data starts, for messages.
pub(super) fn decode(
    path: &Path,
    r: impl Read,
    count: usize,
    enc: RawType,
    offset: u64,
) -> Result<Vec<u16>> {
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
pub(super) fn decode_f32(
    path: &Path,
    r: impl Read,
    count: usize,
    big: bool,
    offset: u64,
) -> Result<Vec<f32>> {
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
pub(super) fn rescale_f32(floats: &[f32]) -> Vec<u16> {
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
pub(super) fn read_chunks(
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
pub(super) fn fill(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
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
