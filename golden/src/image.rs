//! Float RGBA images (premultiplied colour, as every renderer composites)
//! and their atomic writers: PNG for looking, `.npy` for numbers.

use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};

/// A `width x height` image of premultiplied RGBA in `[0, 1]`, rows from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Pixels, row-major from the top-left.
    pub data: Vec<[f32; 4]>,
}

impl Image {
    /// A transparent black image.
    pub fn new(width: usize, height: usize) -> Image {
        Image {
            width,
            height,
            data: vec![[0.0; 4]; width * height],
        }
    }

    /// Pixel `(i, j)`: column `i`, row `j` from the top.
    pub fn get(&self, i: usize, j: usize) -> [f32; 4] {
        self.data[j * self.width + i]
    }

    /// 8-bit RGB over a black background (what the eye sees).
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.data
            .iter()
            .flat_map(|p| [to8(p[0]), to8(p[1]), to8(p[2])])
            .collect()
    }

    /// Writes the image as an 8-bit RGB PNG over black, atomically.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        write_rgb_png(path, self.width, self.height, &self.to_rgb8())
    }

    /// Writes the image as float32 `H x W x 4` NumPy `.npy`, atomically.
    pub fn write_npy(&self, path: &Path) -> Result<()> {
        let values: Vec<f32> = self.data.iter().flatten().copied().collect();
        write_npy_f32(path, &[self.height, self.width, 4], &values)
    }
}

/// Rounds a `[0, 1]` value to 8 bits.
pub fn to8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Writes `path` atomically: the bytes go to a temporary file in the same
/// directory, which is renamed over `path` only once complete.
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_owned(),
        err: source,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    // tempfile's error names its random temporary path; report the OS error
    // against the path the user asked for instead.
    let plain = |e: std::io::Error| {
        let msg = e.to_string();
        match msg.split_once(" at path ") {
            Some((head, _)) => std::io::Error::new(e.kind(), head.to_string()),
            None => e,
        }
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(|e| io(plain(e)))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w).map_err(io)?;
        w.flush().map_err(io)?;
    }
    // A temporary file is private (0600); the result should have the
    // permissions of an ordinarily created file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .map_err(io)?;
    }
    place(tmp, path).map_err(|e| io(plain(e)))
}

/// Puts a finished temporary file at `path`: renamed now, or at the
/// commit of the open [`Staged`] run (see the `staging` crate).
pub fn place(tmp: tempfile::NamedTempFile, path: &Path) -> std::io::Result<()> {
    staging::place(tmp, path)
}

pub use staging::{adopt, carry, stage, Carried, Staged};

/// Renames every file of `run` into place ([`Staged::commit`]), the error
/// naming the file that could not be.
pub fn commit(run: Staged) -> Result<()> {
    run.commit().map_err(|(path, err)| Error::Io { path, err })
}

/// Writes an 8-bit RGB PNG atomically.
pub fn write_rgb_png(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<()> {
    write_atomic(path, |w| {
        let mut buf = std::io::Cursor::new(Vec::new());
        image::write_buffer_with_format(
            &mut buf,
            rgb,
            width as u32,
            height as u32,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(std::io::Error::other)?;
        w.write_all(buf.get_ref())
    })
}

/// The `.npy` (version 1.0) header for a little-endian array of `descr`
/// (e.g. `<f4`) and `shape`, padded so the data starts 64-byte aligned.
pub fn npy_header(descr: &str, shape: &[usize]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    let unpadded = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    dict.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

/// Writes a float32 `.npy` file atomically.
pub fn write_npy_f32(path: &Path, shape: &[usize], values: &[f32]) -> Result<()> {
    write_atomic(path, |w| {
        w.write_all(&npy_header("<f4", shape))?;
        for v in values {
            w.write_all(&v.to_le_bytes())?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_aligned_and_parsable() {
        let h = npy_header("<f4", &[3, 5, 4]);
        assert_eq!(h.len() % 64, 0);
        let text = std::str::from_utf8(&h[10..]).unwrap();
        assert!(text.contains("'shape': (3, 5, 4)"));
        assert!(text.ends_with('\n'));
    }

    #[test]
    fn atomic_write_leaves_no_partial_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.npy");
        Image::new(3, 2).write_npy(&p).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(bytes.len(), 128 + 3 * 2 * 4 * 4);
        let failed = write_atomic(&dir.path().join("y"), |_| {
            Err(std::io::Error::other("boom"))
        });
        assert!(failed.is_err());
        assert!(!dir.path().join("y").exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_staged_run_writes_all_its_files_on_commit_or_none() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.npy"), dir.path().join("b.npy"));
        let files = || std::fs::read_dir(dir.path()).unwrap().count();
        {
            let _run = stage();
            Image::new(2, 2).write_npy(&a).unwrap();
            Image::new(2, 2).write_npy(&b).unwrap();
            // Written, but not yet at their names.
            assert!(!a.exists() && !b.exists());
            assert_eq!(files(), 2);
        }
        // Dropped uncommitted (a failed run): nothing is left.
        assert_eq!(files(), 0);
        let run = stage();
        Image::new(2, 2).write_npy(&a).unwrap();
        Image::new(2, 2).write_npy(&b).unwrap();
        commit(run).unwrap();
        assert!(a.exists() && b.exists());
        assert_eq!(files(), 2);
        // Outside a run, files appear at once again.
        let c = dir.path().join("c.npy");
        Image::new(2, 2).write_npy(&c).unwrap();
        assert!(c.exists());
    }
}
