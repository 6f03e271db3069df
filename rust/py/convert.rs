//! Borrowing numpy arrays as ndarray views. Non-contiguous input is rejected (the Python layer makes arrays
//! contiguous explicitly; the core never copies silently).

use super::errors::layout_error;
use numpy::{Element, PyReadonlyArray, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Fails with `TypeError` unless `arr` is C-contiguous.
pub fn contiguous<'py, T: Element, D: ndarray::Dimension>(
    name: &str,
    arr: &PyReadonlyArray<'py, T, D>,
) -> PyResult<()> {
    if arr.is_c_contiguous() {
        Ok(())
    } else {
        Err(layout_error(
            name,
            "array must be C-contiguous (use numpy.ascontiguousarray)",
        ))
    }
}
