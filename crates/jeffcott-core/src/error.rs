//! The library's one error type (DESIGN.md 2.4).

use std::path::PathBuf;

/// Everything that can go wrong in the library. Per-lane numerical outcomes are *not*
/// errors: they are [`crate::integrate::lane::Status`] values (DESIGN.md 2.5).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A model or run parameter is outside its allowed range.
    #[error("invalid value for `{name}`: {value} ({reason})")]
    InvalidParameter {
        /// The field or option name, as the user spells it.
        name: String,
        /// The offending value, as text.
        value: String,
        /// What is allowed.
        reason: String,
    },
    /// A configuration file could not be read or parsed.
    #[error("cannot use config file {path}: {message}")]
    Config {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// Reading or writing a file failed (the message names the file and the operating
    /// system's reason, e.g. "No space left on device").
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Drawing a plot failed.
    #[error("cannot draw {path}: {message}")]
    Plot {
        /// The picture being drawn.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// No usable GPU adapter (none found, or none with what the run needs).
    #[error("no usable GPU adapter: {reason}")]
    NoAdapter {
        /// Why none fits (what was looked for, what was found).
        reason: String,
    },
    /// The GPU backend reported an error (device creation, validation, mapping).
    #[error("GPU error: {message}")]
    Gpu {
        /// What the backend said.
        message: String,
    },
    /// The GPU device was lost (driver reset, watchdog, unplugged) during a run.
    #[error("the GPU device was lost")]
    DeviceLost,
    /// Another run holds the output directory's lock.
    #[error(
        "another jeffcott run is writing into {path}; wait for it to end or choose another --out"
    )]
    Busy {
        /// The output directory.
        path: PathBuf,
    },
    /// The output directory's lock file was removed or replaced while this run held it:
    /// another run may have taken the directory, so this one writes nothing more and is
    /// not marked complete.
    #[error(
        "the lock file {path}/.jeffcott.lock was removed or replaced while this run was writing; another run may have written into {path}, so this run stopped and is not marked complete (its committed units are kept): rerun the same command when no other run writes there, or choose another --out"
    )]
    LockLost {
        /// The output directory.
        path: PathBuf,
    },
    /// The output directory holds another run.
    #[error(
        "{path} holds {reason}; choose another --out, or give --overwrite to remove that run's files first"
    )]
    Occupied {
        /// The output directory.
        path: PathBuf,
        /// What it holds.
        reason: String,
    },
    /// A shard reached the assembly: its own share is done (the command line turns this
    /// into a finished shard directory, not an error).
    #[error("a shard computes units only; `jeffcott merge` assembles them")]
    NotInShard,
    /// The run was asked to stop (a signal, a cancel flag); committed units are kept.
    #[error("interrupted after {committed} of {total} work units were committed")]
    Interrupted {
        /// Units committed (this session and earlier ones).
        committed: usize,
        /// Units of the run.
        total: usize,
    },
}

impl Error {
    /// Shorthand for [`Error::InvalidParameter`].
    pub fn invalid(name: &str, value: impl ToString, reason: impl Into<String>) -> Self {
        Error::InvalidParameter {
            name: name.to_string(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}

/// Result alias used across the crate.
pub type Result<T> = std::result::Result<T, Error>;
