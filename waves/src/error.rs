//! The crate's single error type.

use std::io;
use std::path::PathBuf;

/// Everything that can go wrong while tracing, writing or reading waves.
///
/// Errors found inside [`crate::Tracer::sample`] cannot be returned from
/// there without making the per-cycle call fallible for the model; they are
/// kept by the tracer (the first one wins, tracing stops) and returned by
/// [`crate::Tracer::finish`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WavesError {
    /// An operating-system I/O error on `path`.
    #[error("cannot {op} {}", path.display())]
    Io {
        /// What was being done, e.g. "write trace".
        op: &'static str,
        /// The file (or directory) involved.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: io::Error,
    },

    /// A VCD file could not be parsed.
    #[error("{}:{line}: invalid VCD: {message}", path.display())]
    Parse {
        /// The file being read.
        path: PathBuf,
        /// 1-based line where the parser stopped.
        line: u64,
        /// What was wrong.
        message: String,
    },

    /// A value did not fit in the declared width of its signal; this is a
    /// bug in the model (or in its probe declaration), so the trace is not
    /// written rather than silently truncated.
    #[error("signal {signal} ({width} bits) at cycle {cycle}: value {value} does not fit")]
    ValueTooWide {
        /// Hierarchical name of the signal.
        signal: String,
        /// Declared width in bits.
        width: u32,
        /// Cycle of the offending sample.
        cycle: u64,
        /// The value, rendered for humans.
        value: String,
    },

    /// The same hierarchical signal name was registered twice.
    #[error("signal {0} registered twice")]
    DuplicateSignal(String),

    /// A signal was declared with width 0 or wider than [`crate::MAX_WIDTH`].
    #[error("signal {signal}: width {width} is not in 1..={max}", max = crate::MAX_WIDTH)]
    InvalidWidth {
        /// Hierarchical name of the signal.
        signal: String,
        /// The width asked for.
        width: u32,
    },

    /// A scope or signal name that VCD readers or GTKWave would mangle.
    #[error(
        "invalid name {0:?}: use ASCII letters, digits and '_' only, not starting with a digit"
    )]
    InvalidName(String),

    /// A signal was registered after the VCD header had been written.
    #[error(
        "signal {0} registered after tracing started; register all signals before the first sample"
    )]
    LateRegistration(String),

    /// `sample` was called with a cycle earlier than a previous one.
    #[error("cycle {cycle} sampled after cycle {previous}: cycles must not go backwards")]
    CycleWentBackwards {
        /// The offending cycle.
        cycle: u64,
        /// The latest cycle sampled before it.
        previous: u64,
    },

    /// A cycle so large that `cycle * TIME_UNITS_PER_CYCLE` overflows.
    #[error("cycle {0} is too large to be represented in VCD time")]
    CycleTooLarge(u64),

    /// A textual trace option (PE list, cycle window) could not be parsed.
    #[error("invalid {what} {text:?}: {reason}")]
    InvalidSpec {
        /// Which option, e.g. "PE list".
        what: &'static str,
        /// The text given.
        text: String,
        /// Why it was rejected.
        reason: String,
    },
}

impl WavesError {
    pub(crate) fn io(op: &'static str, path: impl Into<PathBuf>, source: io::Error) -> Self {
        WavesError::Io {
            op,
            path: path.into(),
            source,
        }
    }
}
