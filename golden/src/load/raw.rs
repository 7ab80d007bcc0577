//! Headerless raw volumes: the user gives the dimensions, type and offset.

use std::fmt;
use std::io::{Seek, SeekFrom};
use std::path::Path;
use std::str::FromStr;

use super::decode::{decode, decode_u8};
use super::{file_len, format_err, io_err, open};
use crate::error::{input, Error, Result};
use crate::volume::{check_dims, Volume, VoxelType, Voxels};

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
    let count = check_dims(spec.dims, spec.kind.bytes(), limit)?;
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
    if spec.kind == RawType::U8 {
        let data = decode_u8(path, file, count, spec.offset)?;
        return Volume::from_voxels(spec.dims, Voxels::U8(data));
    }
    let data = decode(path, file, count, spec.kind, spec.offset)?;
    Volume::new(spec.dims, spec.kind.voxel_type(), data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::tests::{assert_err, pattern, write};
    use crate::volume::DEFAULT_MEMORY_LIMIT;

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
            "over the memory limit",
        );
        assert_err(
            load_raw(&path, &spec([10, 10, 1], RawType::U8, 0), 99),
            "over the memory limit",
        );
        // An 8-bit volume is kept in bytes: 100 voxels take 100 bytes.
        assert!(load_raw(&path, &spec([10, 10, 1], RawType::U8, 0), 100).is_ok());
        let missing = dir.path().join("nope.raw");
        assert_err(
            load_raw(&missing, &spec([1, 1, 1], RawType::U8, 0), lim),
            "nope.raw",
        );
    }
}
