//! Maps [`TilesynthError`] to the Python exception classes defined in `tilesynth/errors.py`
//! (`ShapeError` and `ParameterError`, both subclasses of `TilesynthError` and `ValueError`).

use crate::error::TilesynthError;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyType;

/// Converts a core error into the matching Python exception.
pub fn to_pyerr(e: TilesynthError) -> PyErr {
    let class = match e {
        TilesynthError::Shape { .. } => "ShapeError",
        TilesynthError::Parameter { .. } => "ParameterError",
    };
    let msg = e.to_string();
    Python::attach(|py| {
        let ty = py
            .import("tilesynth.errors")
            .and_then(|m| m.getattr(class))
            .and_then(|c| c.cast_into::<PyType>().map_err(PyErr::from));
        match ty {
            Ok(ty) => PyErr::from_type(ty, msg),
            // The extension used without its Python package: still a ValueError.
            Err(_) => PyValueError::new_err(msg),
        }
    })
}

/// A `TypeError` for layout or dtype problems (rust-numpy's convention).
pub fn layout_error(name: &str, what: &str) -> PyErr {
    PyTypeError::new_err(format!("{name}: {what}"))
}
