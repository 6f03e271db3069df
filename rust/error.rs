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

/// The number of elements of an array of shape `dims`, or an error naming `name` if it overflows `usize`.
pub fn checked_len(name: &'static str, dims: &[usize]) -> Result<usize> {
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| TilesynthError::param(name, fmt_shape(dims), "array size overflows"))
}

/// A vector of `n` copies of `value`, allocated fallibly: where the size comes from the input, an allocation
/// the system refuses becomes an error naming `name` and the size instead of aborting the process.
pub fn try_vec<T: Clone>(name: &'static str, n: usize, value: T) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        TilesynthError::param(
            name,
            format!("{n} elements of {} bytes", std::mem::size_of::<T>()),
            "cannot allocate that much memory (use a smaller input or tile size)",
        )
    })?;
    v.resize(n, value);
    Ok(v)
}

/// Checks that `bytes` could be allocated now (reserving and releasing them), so that a kernel about to make
/// allocations of that total reports an error instead of aborting in the middle.
pub fn probe_alloc(name: &'static str, bytes: usize) -> Result<()> {
    let mut v: Vec<u8> = Vec::new();
    v.try_reserve_exact(bytes).map_err(|_| {
        TilesynthError::param(
            name,
            format!("{bytes} bytes"),
            "cannot allocate that much memory (use a smaller input or tile size)",
        )
    })
}

#[cfg(test)]
mod alloc_tests {
    use super::*;

    #[test]
    fn refused_allocations_are_errors() {
        assert!(try_vec::<f64>("x", usize::MAX / 8, 0.0).is_err());
        assert!(probe_alloc("x", usize::MAX / 2).is_err());
        assert!(checked_len("x", &[usize::MAX, 2]).is_err());
        assert_eq!(try_vec("x", 3, 1u8).unwrap(), vec![1, 1, 1]);
        assert_eq!(checked_len("x", &[2, 3, 4]).unwrap(), 24);
    }
}
