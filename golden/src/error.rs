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
    #[error(
        "{what} needs {}, over the memory limit of {}",
        human_bytes(*bytes),
        human_bytes(*limit as u128)
    )]
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

/// A byte count for people: three significant digits in the largest
/// binary unit it reaches (`1.50 GiB`, `640 KiB`, `12 bytes`).
pub fn human_bytes(b: u128) -> String {
    for (unit, shift) in [("TiB", 40), ("GiB", 30), ("MiB", 20), ("KiB", 10)] {
        let u = (1u128 << shift) as f64;
        if b as f64 >= u {
            return format!("{} {unit}", sig3(b as f64 / u));
        }
    }
    format!("{b} bytes")
}

/// `v` (at least 1) with three significant digits.
fn sig3(v: f64) -> String {
    let decimals = if v >= 100.0 {
        0
    } else if v >= 10.0 {
        1
    } else {
        2
    };
    format!("{v:.decimals$}")
}

/// Builds an [`Error::Input`] from anything printable.
pub fn input(msg: impl Into<String>) -> Error {
    Error::Input(msg.into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_print_with_three_significant_digits() {
        assert_eq!(human_bytes(12), "12 bytes");
        assert_eq!(human_bytes(1536), "1.50 KiB");
        assert_eq!(human_bytes(640 << 10), "640 KiB");
        assert_eq!(human_bytes(8_589_934_592), "8.00 GiB");
        assert_eq!(human_bytes(17 << 40), "17.0 TiB");
        let e = Error::TooLarge {
            what: "a 2048x2048x1024 volume".into(),
            bytes: 8 << 30,
            limit: 6 << 30,
        };
        assert_eq!(
            e.to_string(),
            "a 2048x2048x1024 volume needs 8.00 GiB, over the memory limit of 6.00 GiB"
        );
    }
}
