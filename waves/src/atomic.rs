//! Temporary files next to their final path, for write-then-rename.

use std::path::Path;

use tempfile::NamedTempFile;

use crate::error::WavesError;

/// Creates a hidden temporary file in the directory of `path`; the same
/// directory so that the final rename is atomic (no cross-device copy).
pub(crate) fn temp_beside(path: &Path) -> Result<NamedTempFile, WavesError> {
    let name = path.file_name().ok_or_else(|| {
        WavesError::io(
            "create",
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "no file name"),
        )
    })?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let prefix = format!(".{}.", name.to_string_lossy());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        // NamedTempFile defaults to 0600; traces are meant to be opened by
        // whoever debugs the run, so use the usual (umask-ed) 0644.
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    builder
        .tempfile_in(dir)
        .map_err(|e| WavesError::io("create temporary file in", dir, e))
}
