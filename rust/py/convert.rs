//! Borrowing numpy arrays as ndarray views. Non-contiguous input is rejected (the Python layer makes arrays
//! contiguous explicitly; the core never copies silently).

use super::errors::layout_error;
use crate::error::TilesynthError;
use numpy::{Element, PyArrayMethods, PyReadonlyArray, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Fails with `TypeError` unless `arr` is C-contiguous and aligned (see [`aligned`]).
pub fn contiguous<'py, T: Element, D: ndarray::Dimension>(
    name: &str,
    arr: &PyReadonlyArray<'py, T, D>,
) -> PyResult<()> {
    aligned(name, arr)?;
    if arr.is_c_contiguous() {
        Ok(())
    } else {
        Err(layout_error(
            name,
            "array must be C-contiguous (use numpy.ascontiguousarray)",
        ))
    }
}

/// Fails with `TypeError` unless `arr`'s data is aligned for its dtype. rust-numpy's `as_array` does not check
/// it, and a view (or slice) over a misaligned pointer is undefined behaviour (ndarray asserts alignment only
/// under debug assertions). numpy makes misaligned arrays from a buffer at an odd offset
/// (`numpy.frombuffer(buf, numpy.float32, offset=1)`) or from a field of a packed structured array. Every
/// non-bool, non-byte array a binding views goes through this check (or [`contiguous`], which includes it).
pub fn aligned<'py, T: Element, D: ndarray::Dimension>(
    name: &str,
    arr: &PyReadonlyArray<'py, T, D>,
) -> PyResult<()> {
    // The pointer itself too, empty arrays included: numpy may flag an empty array aligned whatever its
    // pointer, and a view (or an empty slice) over a misaligned pointer is still undefined behaviour (found
    // by fuzzing a debug-asserting build: ndarray's alignment assertion on empty misaligned arrays).
    if arr.is_aligned() && (arr.data() as usize) % std::mem::align_of::<T>() == 0 {
        Ok(())
    } else {
        Err(layout_error(
            name,
            "array data must be aligned for its dtype (numpy.require(a, requirements='CA') makes an aligned copy)",
        ))
    }
}

/// Fails with `ParameterError` naming `name` unless numpy can make an array of `shape` with `itemsize`-byte
/// elements: the product of the non-zero sides times the item size must fit an `isize` (numpy's rule, zero
/// sides included: it refuses `(2^62, 0)` of int32). Call before `into_pyarray` on a shape that comes from
/// the caller's numbers: rust-numpy 0.30 does not check numpy's refusal there and dereferences the null
/// array it gets back (a SIGSEGV, not an exception).
pub fn numpy_shape(name: &'static str, shape: &[usize], itemsize: usize) -> PyResult<()> {
    let fits = shape
        .iter()
        .filter(|&&d| d != 0)
        .try_fold(itemsize.max(1), |acc, &d| acc.checked_mul(d))
        .is_some_and(|n| n <= isize::MAX as usize);
    if fits {
        Ok(())
    } else {
        Err(super::errors::to_pyerr(TilesynthError::param(
            name,
            crate::error::fmt_shape(shape),
            "too large for a numpy array (the non-zero sides times the item size exceed 2^63 bytes)",
        )))
    }
}
