//! The library's one error type (docs/architecture.md).

use std::path::PathBuf;

/// Everything that can go wrong in the library. Per-lane numerical outcomes are *not*
/// errors: they are [`crate::integrate::lane::Status`] values (docs/architecture.md).
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
    /// The run was asked to stop (a signal, a cancel flag); committed units are kept.
    #[error("interrupted after {committed} of {total} work units were committed")]
    Interrupted {
        /// Units committed (this session and earlier ones).
        committed: usize,
        /// Units of the run.
        total: usize,
    },
    /// An error of a layer above this crate (the run directory's locks and occupants, a
    /// shard's end, a picture): its own type, which callers may ask for with
    /// [`Error::layer_error`], and its own message.
    #[error(transparent)]
    Layer(Box<dyn std::error::Error + Send + Sync>),
}

impl Error {
    /// `e`, an error of a layer above this crate, as the library's error.
    pub fn layer(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        Error::Layer(Box::new(e))
    }

    /// The layer's error of type `T` this is, if it is one.
    pub fn layer_error<T: std::error::Error + 'static>(&self) -> Option<&T> {
        match self {
            Error::Layer(e) => e.downcast_ref::<T>(),
            _ => None,
        }
    }

    /// Shorthand for [`Error::InvalidParameter`].
    pub fn invalid(name: &str, value: impl ToString, reason: impl Into<String>) -> Self {
        Error::InvalidParameter {
            name: name.to_string(),
            value: shortened(value.to_string()),
            reason: reason.into(),
        }
    }
}

/// Result alias used across the crate.
pub type Result<T> = std::result::Result<T, Error>;

/// A value as an error shows it: a number Rust writes in full (1e300 is 301 digits)
/// in exponent form, anything else as it is.
fn shortened(text: String) -> String {
    match text.parse::<f64>() {
        Ok(v) if text.len() > 24 && v.is_finite() => format!("{v:e}"),
        _ => text,
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_huge_or_tiny_value_is_shown_in_exponent_form_and_text_as_it_is() {
        let shown = |v: String| match super::Error::invalid("x", v, "r") {
            super::Error::InvalidParameter { value, .. } => value,
            _ => unreachable!(),
        };
        assert_eq!(shown(1e300.to_string()), "1e300");
        assert_eq!(shown((-2.5e-200).to_string()), "-2.5e-200");
        assert_eq!(shown("133.5".into()), "133.5");
        assert_eq!(shown("x_r:-1:1:8".into()), "x_r:-1:1:8");
    }
}
