//! PNG scanline unfiltering for the Python PNG reader.

use super::convert::contiguous;
use super::errors::{self, guard};
use super::run;
use crate::png;
use ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;

/// PNG scanline unfiltering: `data` (uint8, `rows * (row_bytes + 1)` bytes: a filter byte, then the row) ->
/// the raw bytes, uint8 `(rows, row_bytes)`; `bpp` bytes per pixel (1 to 8).
#[pyfunction]
pub(super) fn png_unfilter<'py>(
    py: Python<'py>,
    data: PyReadonlyArray1<'py, u8>,
    rows: usize,
    row_bytes: usize,
    bpp: usize,
) -> PyResult<Bound<'py, PyArray2<u8>>> {
    guard("png_unfilter", || {
        contiguous("data", &data)?;
        let d = data
            .as_slice()
            .map_err(|_| errors::layout_error("data", "array must be C-contiguous"))?;
        let raw = run(py, Some(1), || png::unfilter(d, rows, row_bytes, bpp))?;
        let arr = Array2::from_shape_vec((rows, row_bytes), raw)
            .map_err(|e| errors::layout_error("data", &e.to_string()))?;
        Ok(arr.into_pyarray(py))
    })
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(png_unfilter, m)?)?;
    Ok(())
}
