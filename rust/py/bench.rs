//! Bench-only bindings (hidden, underscore names): the baselines that benches run side by side with the
//! current code paths. Not part of the public API.

use super::{contiguous, guard, pack_matches, run, MatchArrays, PySsdIndex};
use crate::ssd;
use numpy::{PyReadonlyArray2, PyReadonlyArray4};
use pyo3::prelude::*;

/// `SsdIndex.best_matches` by the first implementation (every translation sorted by its FFT value up
/// front): the baseline of `benches/matching_scan.py`. Same results as `SsdIndex.best_matches`.
#[pyfunction]
#[pyo3(signature = (index, templates, k=1, exclude_radius=0, mask=None, threads=None))]
fn _best_matches_sorting<'py>(
    py: Python<'py>,
    index: &PySsdIndex,
    templates: PyReadonlyArray4<'py, f32>,
    k: usize,
    exclude_radius: usize,
    mask: Option<PyReadonlyArray2<'py, bool>>,
    threads: Option<usize>,
) -> PyResult<MatchArrays<'py>> {
    guard("_best_matches_sorting", || {
        contiguous("templates", &templates)?;
        if let Some(m) = &mask {
            contiguous("mask", m)?;
        }
        let templates = templates.as_array();
        let mask = mask.as_ref().map(|m| m.as_array());
        let found = run(py, threads, || {
            ssd::best_matches_many_sorting(&index.inner, templates, mask, k, exclude_radius)
        })?;
        Ok(pack_matches(py, found))
    })
}

/// Registers the bench-only functions.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_best_matches_sorting, m)?)?;
    Ok(())
}
