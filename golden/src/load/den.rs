//! VolPack `.den` volumes: a 62-byte header in the writer's byte order,
//! then 8-bit voxels.

use std::io::Read;
use std::path::Path;

use super::decode::decode_u8;
use super::{file_len, format_err, from_file, io_err, open};
use crate::error::Result;
use crate::volume::{check_dims, Volume, Voxels};

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
    let count = check_dims(dims, 1, limit).map_err(|e| from_file(path, e))?;
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
    let data = decode_u8(path, file, count, DEN_HEADER as u64)?;
    Volume::from_voxels(dims, Voxels::U8(data))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::load::load_auto;
    use crate::load::tests::{assert_err, pattern, write};
    use crate::volume::{VoxelType, DEFAULT_MEMORY_LIMIT};

    /// A `.den` file: header with the given fields, then `data`.
    pub(crate) fn den_bytes(map_len: [i16; 3], map_length: i32, data: &[u8], big: bool) -> Vec<u8> {
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
            "over the memory limit",
        );
    }

    #[test]
    fn brainsmall_loads() {
        // The copy the repository ships (data/README.md).
        let path = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../data/brainsmall.den"
        ));
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
}
