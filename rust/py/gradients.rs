//! Binding of [`crate::gradients`]: the gradient norms of the exemplar at given positions.

use super::convert::contiguous;
use super::errors::guard;
use super::run;
use crate::gradients;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;

/// `(M, 2)` float64 gradient norms `[‖E(r, c+1) − E(r, c)‖, ‖E(r+1, c) − E(r, c)‖]` of a float32 image
/// `(H, W, C)` (`C < 8`) at int64 positions `(M, 2)` (0 past the edge). Single-threaded, GIL released.
#[pyfunction]
fn patch_gradients<'py>(
    py: Python<'py>,
    exemplar: PyReadonlyArray3<'py, f32>,
    source: PyReadonlyArray2<'py, i64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard("patch_gradients", || {
        contiguous("exemplar", &exemplar)?;
        contiguous("source", &source)?;
        let (e, s) = (exemplar.as_array(), source.as_array());
        let g = run(py, Some(1), || gradients::patch_gradients(e, s))?;
        Ok(g.into_pyarray(py))
    })
}

/// Registers the gradient functions.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(patch_gradients, m)?)?;
    Ok(())
}
