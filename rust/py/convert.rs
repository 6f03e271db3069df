//! Borrowing numpy arrays as ndarray views. Non-contiguous input is rejected (the Python layer makes arrays
//! contiguous explicitly; the core never copies silently).

use super::errors::layout_error;
use numpy::{Element, PyReadonlyArray, PyUntypedArrayMethods};
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
    if arr.len() == 0 || arr.is_aligned() {
        Ok(())
    } else {
        Err(layout_error(
            name,
            "array data must be aligned for its dtype (numpy.require(a, requirements='CA') makes an aligned copy)",
        ))
    }
}
