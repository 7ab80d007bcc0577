//! The one error type of configuration.

use std::path::PathBuf;
use thiserror::Error;

/// Why a configuration cannot be used. Every message is one line and names
/// the field.
#[derive(Debug, Error)]
pub enum ConfigError {
    /// A field's value is impossible or inconsistent with another field.
    #[error("{message}")]
    Invalid {
        /// The TOML key at fault, e.g. `alpha`.
        field: String,
        /// The full one-line message, starting with the field name.
        message: String,
    },
    /// The TOML text does not parse into the config's shape (syntax error,
    /// unknown key, wrong type, unknown mode name).
    #[error("TOML {0}")]
    Toml(String),
    /// The config file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

impl ConfigError {
    /// The field at fault, for [`ConfigError::Invalid`].
    pub fn field(&self) -> Option<&str> {
        match self {
            ConfigError::Invalid { field, .. } => Some(field),
            _ => None,
        }
    }
}

/// A [`ConfigError::Invalid`] blaming `field`.
pub(super) fn invalid(field: &str, message: String) -> ConfigError {
    ConfigError::Invalid {
        field: field.to_owned(),
        message,
    }
}
