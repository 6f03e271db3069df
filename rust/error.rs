//! The one error type of the core. Every message names the parameter and the offending value, so that the
//! Python layer can show it verbatim (`ShapeError` / `ParameterError`, both subclasses of `ValueError`).

use std::fmt;

/// Everything the core can reject. No pyo3 here: `rust/py/errors.rs` maps the variants to Python exceptions.
#[derive(Debug, Clone, PartialEq)]
pub enum TilesynthError {
    /// An array has the wrong shape, or two arrays disagree.
    Shape {
        /// Parameter name as the caller sees it (`template`, `wx`, ...).
        name: &'static str,
        /// What was expected, in words (`"(H, W, C) with H >= 1"`).
        expected: String,
        /// What was given (`"(0, 5, 3)"`).
        got: String,
    },
    /// A scalar parameter or the content of an array is out of range.
    Parameter {
        /// Parameter name.
        name: &'static str,
        /// The offending value, formatted.
        value: String,
        /// Why it is rejected.
        reason: String,
    },
}

impl TilesynthError {
    /// Shorthand for [`TilesynthError::Shape`].
    pub fn shape(name: &'static str, expected: impl Into<String>, got: impl Into<String>) -> Self {
        TilesynthError::Shape {
            name,
            expected: expected.into(),
            got: got.into(),
        }
    }

    /// Shorthand for [`TilesynthError::Parameter`].
    pub fn param(name: &'static str, value: impl fmt::Display, reason: impl Into<String>) -> Self {
        TilesynthError::Parameter {
            name,
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}

impl fmt::Display for TilesynthError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TilesynthError::Shape {
                name,
                expected,
                got,
            } => write!(f, "{name} has shape {got}, expected {expected}"),
            TilesynthError::Parameter {
                name,
                value,
                reason,
            } => write!(f, "{name} = {value}: {reason}"),
        }
    }
}

impl std::error::Error for TilesynthError {}

/// Result alias used throughout the core.
pub type Result<T> = std::result::Result<T, TilesynthError>;

/// Formats a shape slice as `(a, b, c)` for error messages.
pub fn fmt_shape(shape: &[usize]) -> String {
    let parts: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    if parts.len() == 1 {
        format!("({},)", parts[0])
    } else {
        format!("({})", parts.join(", "))
    }
}
