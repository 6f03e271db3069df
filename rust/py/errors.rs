//! Maps [`TilesynthError`] to the Python exception classes defined in `tilesynth/errors.py`
//! (`ShapeError` and `ParameterError`, both subclasses of `TilesynthError` and `ValueError`).

use crate::error::TilesynthError;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
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

/// The text of a panic payload (`&str` or `String`; anything else is "unknown panic").
fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_string())
}

/// `tilesynth.errors.InternalError` (a `RuntimeError`) for a panic caught in the binding `what`.
pub fn panic_error(what: &str, payload: &(dyn std::any::Any + Send)) -> PyErr {
    let msg = format!(
        "internal error in {what}: {} (a bug in tilesynth {}: please report it with the inputs that caused it)",
        panic_text(payload),
        env!("CARGO_PKG_VERSION"),
    );
    Python::attach(|py| {
        let ty = py
            .import("tilesynth.errors")
            .and_then(|m| m.getattr("InternalError"))
            .and_then(|c| c.cast_into::<PyType>().map_err(PyErr::from));
        match ty {
            Ok(ty) => PyErr::from_type(ty, msg),
            Err(_) => PyRuntimeError::new_err(msg),
        }
    })
}

/// Runs a binding body, turning a Rust panic anywhere below it (the core kernels, a worker thread of the
/// pool, the conversions) into [`panic_error`] instead of pyo3's `PanicException`, a `BaseException` that
/// `except Exception` does not catch. Defence in depth: the core returns errors for every bad input it
/// knows of and is fuzzed for panics; this keeps an unknown one a clear, catchable Python exception.
pub fn guard<R>(what: &str, f: impl FnOnce() -> PyResult<R>) -> PyResult<R> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => Err(panic_error(what, payload.as_ref())),
    }
}
