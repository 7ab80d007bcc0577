//! Volume loaders: headerless raw, VolPack `.den`, NIfTI-1 (`.nii`,
//! `.nii.gz`), NRRD (`.nrrd`, `.nhdr`), MetaImage (`.mha`, `.mhd`), TIFF
//! stacks (a multi-page `.tif`, or a folder of single-page ones) and DICOM
//! series (a folder of slices, or one multi-frame object).
//!
//! Every loader treats its input as untrusted: sizes come from a header or
//! from the user, and they are checked against the file and against the
//! memory limit (with [`check_dims`]) before the voxel buffer is allocated.
//! Voxels are decoded in fixed-size chunks straight into the final `u16`
//! buffer, so a loader holds at most the volume itself plus 64 KiB (float
//! and 32-bit data also need their stored copy; see [`load_nifti`]). Any
//! byte sequence gives either a volume or a one-line [`Error`], never a
//! panic.
//!
//! One module per format (`raw`, `den`, `nifti`, `nrrd`, `meta`, `tif`,
//! `dicom`),
//! the shared decoding in `decode`: every format maps its stored types onto
//! voxels by the same rule (the NIfTI loader's), so the same data through
//! any format gives the same [`Volume`]. This module holds [`load_auto`],
//! [`Loaded`] and the error helpers every loader uses.
//!
//! [`check_dims`]: crate::volume::check_dims

use std::fs::File;
use std::io::{ErrorKind, Read};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{input, Error, Result};
use crate::volume::{Volume, SPACING_RANGE};

mod decode;
mod den;
mod dicom;
mod meta;
mod nifti;
mod nrrd;
mod raw;
mod tif;

pub use den::load_den;
pub use dicom::{load_dicom_dir, read_dicom_dir, read_dicom_file};
pub use meta::{load_meta, read_meta};
pub use nifti::{load_nifti, read_nifti};
pub use nrrd::{load_nrrd, read_nrrd};
pub use raw::{load_raw, RawSpec, RawType};
pub use tif::{load_tiff, load_tiff_dir};

/// A volume with the placement its header gave, for the formats that carry
/// one (NIfTI, NRRD, MetaImage, DICOM), in LPS world space (see
/// [`crate::orient`]). By default rendering ignores the placement: voxel
/// `(i, j, k)` of the file is voxel `(x, y, z)` of the volume whatever the
/// directions say, and only the spacing is used; `--space world` applies
/// it ([`crate::orient::to_world_grid`]).
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The voxels and the spacing.
    pub volume: Volume,
    /// World position of voxel `(0, 0, 0)`, if the header gave one.
    pub origin: Option<[f64; 3]>,
    /// Unit world direction of each index axis (`axes[0]` is the direction
    /// of increasing x), if the header gave all three.
    pub axes: Option<[[f64; 3]; 3]>,
}

const FORMATS: &str = "use .den, .nii, .nii.gz, .nrrd, .nhdr, .mha, .mhd, .tif, .tiff, \
                       a folder of .tif slices or of DICOM slices, or give --raw-dims";

/// Loads a volume, choosing the loader: a raw spec means [`load_raw`]; a
/// folder means [`load_dicom_dir`] if it holds any DICOM file (by its
/// `DICM` magic), else [`load_tiff_dir`]; otherwise the file name decides (any
/// case): `.den` -> [`load_den`], `.nii` or `.nii.gz` -> [`load_nifti`],
/// `.nrrd` or `.nhdr` -> [`load_nrrd`], `.mha` or `.mhd` -> [`load_meta`],
/// `.tif` or `.tiff` -> [`load_tiff`], `.dcm` or a file with the DICOM magic
/// -> [`read_dicom_file`] (a multi-frame object). A file with another name
/// is tried by its magic bytes (NRRD, TIFF, NIfTI-1, MetaImage), if it has
/// any.
pub fn load_auto(path: &Path, raw: Option<&RawSpec>, limit: u64) -> Result<Volume> {
    if let Some(spec) = raw {
        return load_raw(path, spec, limit);
    }
    if path.is_dir() {
        return if dicom::dir_has_dicom(path) {
            load_dicom_dir(path, limit)
        } else {
            load_tiff_dir(path, limit)
        };
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let has = |exts: &[&str]| exts.iter().any(|e| name.ends_with(e));
    if has(&[".den"]) {
        load_den(path, limit)
    } else if has(&[".nii", ".nii.gz"]) {
        load_nifti(path, limit)
    } else if has(&[".nrrd", ".nhdr"]) {
        load_nrrd(path, limit)
    } else if has(&[".mha", ".mhd"]) {
        load_meta(path, limit)
    } else if has(&[".tif", ".tiff"]) {
        load_tiff(path, limit)
    } else if has(&[".dcm"]) || dicom::is_dicom(path) {
        read_dicom_file(path, limit).map(|l| l.volume)
    } else {
        match sniff(path) {
            Some(Sniffed::Nrrd) => load_nrrd(path, limit),
            Some(Sniffed::Tiff) => load_tiff(path, limit),
            Some(Sniffed::Nifti) => load_nifti(path, limit),
            Some(Sniffed::Meta) => load_meta(path, limit),
            Some(Sniffed::Dicom) | None => Err(input(format!(
                "unknown volume format for {}: {FORMATS}",
                path.display()
            ))),
        }
    }
}

/// [`load_auto`] with the placement, for the formats that carry one (raw,
/// `.den` and TIFF have none).
pub fn load_placed(path: &Path, raw: Option<&RawSpec>, limit: u64) -> Result<Loaded> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let has = |exts: &[&str]| exts.iter().any(|e| name.ends_with(e));
    let placed = if raw.is_some() {
        None
    } else if path.is_dir() {
        dicom::dir_has_dicom(path).then_some(Sniffed::Dicom)
    } else if has(&[".nii", ".nii.gz"]) {
        Some(Sniffed::Nifti)
    } else if has(&[".nrrd", ".nhdr"]) {
        Some(Sniffed::Nrrd)
    } else if has(&[".mha", ".mhd"]) {
        Some(Sniffed::Meta)
    } else if has(&[".den", ".tif", ".tiff"]) {
        None
    } else if has(&[".dcm"]) {
        Some(Sniffed::Dicom)
    } else {
        sniff(path)
    };
    match placed {
        Some(Sniffed::Dicom) if path.is_dir() => read_dicom_dir(path, limit),
        Some(Sniffed::Dicom) => read_dicom_file(path, limit),
        Some(Sniffed::Nifti) => read_nifti(path, limit),
        Some(Sniffed::Nrrd) => read_nrrd(path, limit),
        Some(Sniffed::Meta) => read_meta(path, limit),
        _ => Ok(Loaded {
            volume: load_auto(path, raw, limit)?,
            origin: None,
            axes: None,
        }),
    }
}

/// Formats recognisable by their first bytes.
enum Sniffed {
    Dicom,
    Nrrd,
    Tiff,
    Nifti,
    Meta,
}

/// The format a file's magic bytes name, if any (an unreadable file has
/// none, and gets the unknown-format message).
fn sniff(path: &Path) -> Option<Sniffed> {
    let mut head = Vec::with_capacity(352);
    File::open(path)
        .ok()?
        .take(352)
        .read_to_end(&mut head)
        .ok()?;
    let text = String::from_utf8_lossy(&head[..head.len().min(16)]);
    if head.starts_with(b"NRRD000") {
        Some(Sniffed::Nrrd)
    } else if head.starts_with(b"II*\0") || head.starts_with(b"MM\0*") || head.starts_with(b"II+\0")
    {
        Some(Sniffed::Tiff)
    } else if head.len() >= 348 && (&head[344..348] == b"n+1\0") {
        Some(Sniffed::Nifti)
    } else if text.starts_with("ObjectType") || text.starts_with("NDims") {
        Some(Sniffed::Meta)
    } else {
        None
    }
}

/// A header's spacing, by the rule every loader and `--spacing` share
/// ([`SPACING_RANGE`]): each entry finite and within the range, or the
/// header's `field` is refused naming it.
fn spacing_rule(field: &str, s: [f64; 3]) -> std::result::Result<[f64; 3], String> {
    let (lo, hi) = SPACING_RANGE;
    if s.iter().all(|v| v.is_finite() && (lo..=hi).contains(v)) {
        return Ok(s);
    }
    Err(format!(
        "{field} {s:?} is not a voxel spacing: each must be a number from {lo:e} to {hi:e}"
    ))
}

/// [`spacing_rule`] as a format error of the file `path`.
fn check_spacing(path: &Path, field: &str, s: [f64; 3]) -> Result<[f64; 3]> {
    spacing_rule(field, s).map_err(|m| format_err(path, m))
}

/// Whether a detached header may name a data file outside its own folder.
static OUTSIDE_DATA: AtomicBool = AtomicBool::new(false);

/// Lets (or stops) detached headers (`.nhdr`, `.mhd`) name data files
/// outside their own folder: an absolute path, a `..` step, or a link that
/// leads out. Off by default, so a header cannot make the program read an
/// arbitrary file (`data file: ../../etc/passwd`); the CLI's
/// `--allow-outside-data` turns it on for the run.
pub fn allow_outside_data(allow: bool) {
    OUTSIDE_DATA.store(allow, Ordering::Relaxed);
}

/// A data file named by a header, resolved against the header's folder and
/// refused if it leaves it (unless [`allow_outside_data`] said otherwise).
fn beside(header: &Path, name: &str) -> Result<PathBuf> {
    let folder = header.parent().unwrap_or(Path::new(""));
    let p = Path::new(name);
    let joined = folder.join(p);
    if OUTSIDE_DATA.load(Ordering::Relaxed) {
        return Ok(joined);
    }
    let refuse = |why: &str| {
        format_err(
            header,
            format!(
                "data file '{}' {why}: it must lie in the header's folder \
                 (--allow-outside-data permits it)",
                decode::clip(name)
            ),
        )
    };
    if p.is_absolute() || p.has_root() {
        return Err(refuse("is an absolute path"));
    }
    if p.components().any(|c| matches!(c, Component::ParentDir)) {
        return Err(refuse("steps out with '..'"));
    }
    // A link inside the folder may still lead out of it.
    let base = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    if let (Ok(real), Ok(root)) = (joined.canonicalize(), base.canonicalize()) {
        if !real.starts_with(&root) {
            return Err(refuse("is a link that leads out of the folder"));
        }
    }
    Ok(joined)
}

/// A folder member that must be a readable file: a folder, a dangling link
/// or a link loop is refused naming it.
fn check_member(p: &Path) -> Result<()> {
    let what = match std::fs::metadata(p) {
        Ok(m) if m.is_file() => return open(p).map(drop),
        Ok(m) if m.is_dir() => "is a folder, not a slice",
        Ok(_) => "is not a regular file",
        Err(_) if std::fs::symlink_metadata(p).is_ok() => {
            "is a link that leads nowhere (dangling, or a loop)"
        }
        Err(e) => return Err(io_err(p, e)),
    };
    Err(format_err(p, format!("{what}: remove it from the folder")))
}

/// Unit vectors of `dirs`, if every one has a finite, positive length.
fn unit_axes(dirs: [[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let mut out = dirs;
    for v in &mut out {
        let n = norm(v);
        if !(n.is_finite() && n > 0.0) {
            return None;
        }
        v.iter_mut().for_each(|c| *c /= n);
    }
    Some(out)
}

/// Euclidean length.
fn norm(v: &[f64]) -> f64 {
    v.iter().map(|c| c * c).sum::<f64>().sqrt()
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
        msg: one_line(msg.into()),
    }
}

/// `msg` with its control characters escaped (`\n`, `\u{1b}`): messages
/// quote values read from the file (a DICOM string, a header field), and a
/// corrupt file's newline must not break the one-line error.
fn one_line(msg: String) -> String {
    if !msg.chars().any(char::is_control) {
        return msg;
    }
    msg.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
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

    /// 4x3x2 u16 voxels and their bytes in the given order.
    pub(crate) fn u16_data(big: bool) -> (Vec<u16>, Vec<u8>) {
        let vals = pattern(24, 65536);
        let bytes = vals
            .iter()
            .flat_map(|&v| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            })
            .collect();
        (vals, bytes)
    }

    /// Every header of `cases` is refused by `parse` with one line that
    /// mentions its needle.
    pub(crate) fn assert_headers_refused<H: std::fmt::Debug>(
        cases: &[(String, &str)],
        parse: impl Fn(&str) -> std::result::Result<H, String>,
    ) {
        for (text, needle) in cases {
            let e = parse(text.as_str())
                .map(|h| format!("parsed {h:?}"))
                .unwrap_err();
            assert!(
                e.contains(needle),
                "{text:?}: error {e:?} should mention {needle:?}"
            );
            assert!(!e.contains('\n'), "{e:?} should be one line");
        }
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
        assert_eq!(load_auto(&den, None, lim).unwrap().data()[..], [9; 8]);
        let nii = Nii::new([2, 2, 2], 2, 8).bytes(&[4; 8]);
        let gz = write(&dir, "y.Nii.Gz", &gzip(&nii));
        assert_eq!(load_auto(&gz, None, lim).unwrap().data()[..], [4; 8]);
        let plain = write(&dir, "y.nii", &nii);
        assert_eq!(load_auto(&plain, None, lim).unwrap().data()[..], [4; 8]);
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
            "z.vol: use .den, .nii, .nii.gz, .nrrd",
        );
    }

    /// A fixture of `tests/data` (written by an independent writer).
    fn fixture(name: &str) -> Vec<u8> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
        std::fs::read(dir.join(name)).unwrap()
    }

    #[test]
    fn load_auto_dispatches_new_formats_by_name_then_magic() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        let want = load_auto(&write(&dir, "a.nii", &fixture("vol_u8.nii")), None, lim).unwrap();
        for (src, name) in [
            ("vol_u8.nrrd", "b.NRRD"),
            ("vol_u8.mha", "c.MHA"),
            ("vol_u8.tif", "d.TIFF"),
            // No telling name: the magic bytes decide.
            ("vol_u8_gz.nrrd", "e.dat"),
            ("vol_u8.mha", "f.dat"),
            ("vol_u8.tif", "g.dat"),
            ("vol_u8.nii", "h.dat"),
        ] {
            let v = load_auto(&write(&dir, name, &fixture(src)), None, lim).unwrap();
            assert_eq!((v.dims(), v.data()), (want.dims(), want.data()), "{name}");
        }
        // A name decides over the magic: a NRRD called .mha is no MetaImage.
        let wrong = write(&dir, "i.mha", &fixture("vol_u8.nrrd"));
        assert_err(load_auto(&wrong, None, lim), "not 'Key = Value'");
        let missing = dir.path().join("j.dat");
        assert_err(load_auto(&missing, None, lim), "unknown volume format");
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
                ("f.nrrd", fixture("vol_i16.nrrd")),
                ("f.nrrd", fixture("vol_f32_gz.nrrd")),
                ("f.mha", fixture("vol_u16.mha")),
                ("f.tif", fixture("vol_u16.tif")),
                ("f.nii", fixture("head_ras.nii")),
                ("f.nrrd", fixture("head_perm.nrrd")),
                ("f.mha", fixture("head_perm.mha")),
            ]
        }

        /// Loading gives a volume or a one-line error.
        fn check(r: Result<Volume>) -> std::result::Result<(), TestCaseError> {
            if let Err(e) = r {
                prop_assert!(!e.to_string().contains('\n'), "{}", e);
            }
            Ok(())
        }

        const NAMES: [&str; 10] = [
            "g.den", "g.nii", "g.nii.gz", "g.nrrd", "g.nhdr", "g.mha", "g.mhd", "g.tif", "g.dat",
            "g.dcm",
        ];

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(200))]

            /// Corrupting bytes of valid files never panics, and never
            /// allocates past a small limit (an absurd header errors out).
            #[test]
            fn corrupted_files_never_panic(
                which in 0usize..10,
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
                check(load_auto(&path, None, 1 << 16))?;
                check(load_placed(&path, None, 1 << 16).map(|l| l.volume))?;
            }

            #[test]
            fn arbitrary_bytes_never_panic(
                which in 0usize..NAMES.len(),
                bytes in prop::collection::vec(any::<u8>(), 0..600),
            ) {
                let dir = tempfile::tempdir().unwrap();
                let name = NAMES[which];
                let path = write(&dir, name, &bytes);
                check(load_auto(&path, None, 1 << 16))?;
            }
        }
    }
}
