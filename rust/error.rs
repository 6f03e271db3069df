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
    let mut v = try_with_capacity(name, n)?;
    v.resize(n, value);
    Ok(v)
}

/// An empty vector with room for exactly `n` elements, allocated fallibly (see [`try_vec`]).
pub fn try_with_capacity<T>(name: &'static str, n: usize) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n)
        .map_err(|_| alloc_error::<T>(name, n))?;
    Ok(v)
}

/// The `n` items of `iter` collected into a vector reserved fallibly up front (see [`try_vec`]); `n` is the
/// number of items the caller knows `iter` yields (more would grow the vector infallibly).
pub fn try_collect<T>(
    name: &'static str,
    n: usize,
    iter: impl Iterator<Item = T>,
) -> Result<Vec<T>> {
    let mut v = try_with_capacity(name, n)?;
    v.extend(iter);
    Ok(v)
}

/// An array of shape `shape` filled with `value`, allocated fallibly (see [`try_vec`]).
pub fn try_array<T: Clone, Sh>(
    name: &'static str,
    shape: Sh,
    value: T,
) -> Result<ndarray::Array<T, Sh::Dim>>
where
    Sh: ndarray::ShapeBuilder,
{
    use ndarray::Dimension;
    let shape = shape.into_shape_with_order();
    let n = checked_len(name, shape.raw_dim().slice())?;
    Ok(
        ndarray::Array::from_shape_vec(shape, try_vec(name, n, value)?)
            .expect("the vector has the shape's length"),
    )
}

/// An owned copy of `a` in standard (C) layout, allocated fallibly; instead of `a.to_owned()` or
/// `a.as_standard_layout()` where `a` comes from the caller.
pub fn try_to_owned<T: Clone, D: ndarray::Dimension>(
    name: &'static str,
    a: ndarray::ArrayView<'_, T, D>,
) -> Result<ndarray::Array<T, D>> {
    let v = try_collect(name, a.len(), a.iter().cloned())?;
    Ok(ndarray::Array::from_shape_vec(a.raw_dim(), v).expect("the view's elements in its shape"))
}

/// A standard-layout view of `a`: borrowed when it already is one, else a fallible copy ([`try_to_owned`]).
pub fn try_standard<'a, T: Clone, D: ndarray::Dimension>(
    name: &'static str,
    a: ndarray::ArrayView<'a, T, D>,
) -> Result<ndarray::CowArray<'a, T, D>> {
    if a.is_standard_layout() {
        Ok(ndarray::CowArray::from(a))
    } else {
        Ok(ndarray::CowArray::from(try_to_owned(name, a)?))
    }
}

/// The error of a refused allocation of `n` elements of `T`, naming the parameter whose size it was.
pub fn alloc_error<T>(name: &'static str, n: usize) -> TilesynthError {
    TilesynthError::param(
        name,
        format!("{n} elements of {} bytes", std::mem::size_of::<T>()),
        "cannot allocate that much memory (use a smaller input or tile size)",
    )
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

/// A side (elements) whose square, in any element type, exceeds every x86-64 address space (2^47 bytes of user
/// space): an allocation of that size is refused whatever the overcommit policy, so the allocation-failure
/// tests of the kernels can run anywhere without using memory.
#[cfg(test)]
pub(crate) const HUGE_SIDE: usize = 1 << 24;

/// Asserts that `r` is the error of a refused allocation (see [`try_vec`]), naming `name`.
#[cfg(test)]
pub(crate) fn assert_alloc_error<T: std::fmt::Debug>(r: Result<T>, name: &str) {
    match r {
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!("{name} = ")) && msg.contains("cannot allocate"),
                "expected an allocation error naming {name}, got: {msg}"
            );
        }
        Ok(v) => panic!("expected an allocation error naming {name}, got Ok({v:?})"),
    }
}

#[cfg(test)]
mod alloc_helper_tests {
    use super::*;
    use ndarray::{Array2, Array3};

    #[test]
    fn fallible_arrays_and_copies() {
        assert_alloc_error(try_with_capacity::<u8>("x", usize::MAX / 2), "x");
        assert_alloc_error(
            try_collect("x", usize::MAX / 4, std::iter::empty::<u32>()),
            "x",
        );
        assert_alloc_error(try_array("x", (HUGE_SIDE, HUGE_SIDE), 0u8), "x");
        let one = Array3::from_elem((1, 1, 1), 0.5f32);
        let big = one.broadcast((HUGE_SIDE, HUGE_SIDE, 3)).unwrap();
        assert_alloc_error(try_to_owned("image", big), "image");
        assert_alloc_error(try_standard("image", big), "image");
        // the successful paths: same values, standard layout, borrowed when already standard
        let a = Array2::from_shape_fn((3, 4), |(y, x)| (10 * y + x) as f32);
        let t = a.t();
        let owned = try_to_owned("a", t).unwrap();
        assert_eq!(owned, t.to_owned());
        assert!(owned.is_standard_layout());
        assert!(try_standard("a", a.view()).unwrap().is_view());
        assert!(!try_standard("a", t).unwrap().is_view());
        assert_eq!(
            try_array("a", (2, 3), 7u8).unwrap(),
            Array2::from_elem((2, 3), 7u8)
        );
        assert_eq!(try_collect("a", 3, 0..3).unwrap(), vec![0, 1, 2]);
    }
}
