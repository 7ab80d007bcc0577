//! Runs are all or nothing: every output path is checked before the work
//! starts ([`check_files`], [`check_dirs`]), and the files a run writes appear together at
//! its end or not at all ([`all_or_nothing`]).

use std::path::Path;

use anyhow::{bail, Result};

/// Refuses, before any work, an output file that cannot be written: a
/// path that is a folder, whose folder does not exist, or where no file
/// can be created.
pub fn check_files(paths: &[Option<&Path>]) -> Result<()> {
    for p in paths.iter().flatten() {
        if p.is_dir() {
            bail!("output {} is a folder: give a file name", p.display());
        }
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            bail!(
                "output {}: the folder {} does not exist",
                p.display(),
                dir.display()
            );
        }
        if let Err(e) = tempfile::NamedTempFile::new_in(dir) {
            let why = e.to_string();
            let why = why.split(" at path ").next().unwrap_or(&why).to_owned();
            bail!(
                "output {}: cannot write in {}: {why}",
                p.display(),
                dir.display()
            );
        }
    }
    Ok(())
}

/// Refuses, before any work, an output folder that cannot be written: a
/// path that is a file, a folder where no file can be created, or a new
/// folder whose parent does not exist or cannot take it. A run makes at
/// most the last folder of the path (and removes it again if it fails).
pub fn check_dirs(paths: &[Option<&Path>]) -> Result<()> {
    for d in paths.iter().flatten() {
        if d.exists() && !d.is_dir() {
            bail!("output folder {} is a file: give a folder", d.display());
        }
        let probe = if d.is_dir() {
            d
        } else {
            let parent = match d.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            if !parent.is_dir() {
                bail!(
                    "output folder {}: the folder {} does not exist",
                    d.display(),
                    parent.display()
                );
            }
            parent
        };
        if let Err(e) = tempfile::NamedTempFile::new_in(probe) {
            let why = e.to_string();
            let why = why.split(" at path ").next().unwrap_or(&why).to_owned();
            bail!(
                "output folder {}: cannot write in {}: {why}",
                d.display(),
                probe.display()
            );
        }
    }
    Ok(())
}

/// Runs `f` with every file written through `golden::image::write_atomic`
/// (and [`golden::image::place`]) held back until it succeeds, then renamed
/// into place together; on an error they are deleted, and any of `dirs`
/// the run created is removed again if it is left empty.
pub fn all_or_nothing<T>(dirs: &[&Path], f: impl FnOnce() -> Result<T>) -> Result<T> {
    let existed: Vec<bool> = dirs.iter().map(|d| d.exists()).collect();
    let staged = golden::image::stage();
    match f() {
        Ok(v) => {
            golden::image::commit(staged)?;
            Ok(v)
        }
        Err(e) => {
            drop(staged);
            for (d, &was) in dirs.iter().zip(&existed) {
                if !was {
                    // Only an empty folder goes: remove_dir refuses others.
                    let _ = std::fs::remove_dir(d);
                }
            }
            Err(e)
        }
    }
}
