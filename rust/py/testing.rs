//! Test hooks shipped in the wheel on purpose. `_raise_panic` panics inside the kernel runner, so the Python
//! tests can check that a panic in the *shipped* binary becomes `tilesynth.InternalError` (a `cfg(test)` build
//! would not test the wheel's panic guard). It is private by name (leading underscore), absent from `__all__`
//! of the Python package and from every public wrapper.

use super::errors::guard;
use super::run;
use pyo3::prelude::*;

/// Panics with `message` inside the kernel runner (on a pool worker). Exists only to test that a panic
/// comes out of the bindings as `tilesynth.InternalError` with a clear message (see `errors::guard`).
#[pyfunction]
pub(super) fn _raise_panic(py: Python<'_>, message: &str) -> PyResult<()> {
    let message = message.to_string();
    guard("_raise_panic", || {
        run(py, Some(1), move || -> crate::Result<()> {
            panic!("{message}");
        })
    })
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_raise_panic, m)?)?;
    Ok(())
}
