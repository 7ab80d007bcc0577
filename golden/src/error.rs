//! The one error type of the golden model: every bad input becomes a
//! one-line message naming the problem, never a panic.

use std::path::PathBuf;

/// Everything that can go wrong in the golden model.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter (camera value, size, scene name, ...) is out of range.
    #[error("{0}")]
    Input(String),
    /// A file exists but its contents are not what they claim to be.
    #[error("{path}: {msg}")]
    Format {
        /// The offending file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// Reading or writing a file failed at the operating-system level.
    /// (The OS error is part of the message, not a separate cause, so a
    /// chain printer states it once.)
    #[error("{path}: {err}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        err: std::io::Error,
    },
    /// A request would allocate more than the configured memory limit.
    #[error("{what} needs {bytes} bytes, over the limit of {limit} bytes")]
    TooLarge {
        /// What was to be allocated.
        what: String,
        /// How many bytes it would take.
        bytes: u128,
        /// The limit in force.
        limit: u64,
    },
}

/// Shorthand for results of the golden model.
pub type Result<T> = std::result::Result<T, Error>;

/// Builds an [`Error::Input`] from anything printable.
pub fn input(msg: impl Into<String>) -> Error {
    Error::Input(msg.into())
}
