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
//!
//! One module per format (`raw`, `den`, `nifti`), the shared chunked
//! decoding in `decode`; this module holds [`load_auto`] and the error
//! helpers every loader uses.
//!
//! [`check_dims`]: crate::volume::check_dims

use std::fs::File;
use std::io::ErrorKind;
use std::path::Path;

use crate::error::{input, Error, Result};
use crate::volume::Volume;

mod decode;
mod den;
mod nifti;
mod raw;

pub use den::load_den;
pub use nifti::load_nifti;
pub use raw::{load_raw, RawSpec, RawType};

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::den::tests::den_bytes;
    use crate::load::nifti::tests::Nii;
    use crate::volume::DEFAULT_MEMORY_LIMIT;
    use std::io::Write;
    use std::path::PathBuf;

    pub(crate) fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    pub(crate) fn msg(r: Result<Volume>) -> String {
        r.map(|v| format!("unexpectedly loaded {:?}", v.dims()))
            .unwrap_err()
            .to_string()
    }

    pub(crate) fn assert_err(r: Result<Volume>, needle: &str) {
        let m = msg(r);
        assert!(m.contains(needle), "error {m:?} should mention {needle:?}");
        assert!(!m.contains('\n'), "error {m:?} should be one line");
    }

    pub(crate) fn pattern(n: usize, modulo: usize) -> Vec<u16> {
        (0..n).map(|i| ((i * 37 + 11) % modulo) as u16).collect()
    }

    pub(crate) fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all(bytes).unwrap();
        enc.finish().unwrap()
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
