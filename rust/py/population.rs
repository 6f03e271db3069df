//! Population objectives: the ω-tile evaluator (and the evaluate wrapper shared with the Wang evaluator).

use super::convert::contiguous;
use super::errors::guard;
use super::run;
use crate::population;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `E` `(P,)` and `D` `(P, m)` of a population.
pub(super) type EnergyArrays<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray2<f64>>);

/// The ω-tile objective E = λ·ΣD_j + (1−λ)·Var(D_j) for whole populations of gene vectors, exact, with the
/// per-(patch position, role) SSD maps cached across calls (bounded by `cache_bytes`).
#[pyclass(name = "PopulationEvaluator", module = "tilesynth._core", frozen)]
pub(super) struct PyPopulationEvaluator {
    inner: population::PopulationEvaluator,
}

#[pymethods]
impl PyPopulationEvaluator {
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (exemplar, tile_size, tile_patches, n_patches, lam=population::DEFAULT_LAMBDA, normalise=false, cache_bytes=population::DEFAULT_CACHE_BYTES))]
    fn new(
        py: Python<'_>,
        exemplar: PyReadonlyArray3<'_, f32>,
        tile_size: usize,
        tile_patches: PyReadonlyArray2<'_, i64>,
        n_patches: usize,
        lam: f64,
        normalise: bool,
        cache_bytes: usize,
    ) -> PyResult<Self> {
        guard("PopulationEvaluator", || {
            contiguous("exemplar", &exemplar)?;
            contiguous("tile_patches", &tile_patches)?;
            let (exemplar, tile_patches) = (exemplar.as_array(), tile_patches.as_array());
            let inner = run(py, None, || {
                population::PopulationEvaluator::new(
                    exemplar,
                    tile_size,
                    tile_patches,
                    n_patches,
                    lam,
                    normalise,
                    cache_bytes,
                )
            })?;
            Ok(PyPopulationEvaluator { inner })
        })
    }

    /// E (float64 `(P,)`) and D (float64 `(P, m)`) of `P` gene vectors `(P, n, 2)` int64.
    #[pyo3(signature = (genes, threads=None))]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        genes: PyReadonlyArray3<'py, i64>,
        threads: Option<usize>,
    ) -> PyResult<EnergyArrays<'py>> {
        evaluate_genes(py, "PopulationEvaluator.evaluate", genes, threads, |g| {
            self.inner.evaluate(g)
        })
    }

    /// Cache counters: entries, bytes, limit, hits, misses.
    fn cache_stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard("PopulationEvaluator.cache_stats", || {
            let s = self.inner.cache_stats();
            let d = PyDict::new(py);
            d.set_item("entries", s.entries)?;
            d.set_item("bytes", s.bytes)?;
            d.set_item("limit", s.limit)?;
            d.set_item("hits", s.hits)?;
            d.set_item("misses", s.misses)?;
            Ok(d)
        })
    }

    /// Drops every cached map (the counters are kept).
    fn clear_cache(&self) -> PyResult<()> {
        guard("PopulationEvaluator.clear_cache", || {
            self.inner.clear_cache();
            Ok(())
        })
    }

    /// `(tile_size, n_patches, n_tiles)`.
    #[getter]
    fn dims(&self) -> (usize, usize, usize) {
        (
            self.inner.tile_size(),
            self.inner.n_patches(),
            self.inner.n_tiles(),
        )
    }
}

/// The `evaluate` method of both population objectives (ω: [`PyPopulationEvaluator`], Wang:
/// `PyWangEvaluator`): checks `genes` `(P, n, 2)` int64, runs `evaluate` without the GIL on `threads`
/// workers, and returns `E` `(P,)` and `D` `(P, m)`.
pub(super) fn evaluate_genes<'py>(
    py: Python<'py>,
    name: &str,
    genes: PyReadonlyArray3<'py, i64>,
    threads: Option<usize>,
    evaluate: impl FnOnce(ndarray::ArrayView3<i64>) -> crate::Result<(Vec<f64>, ndarray::Array2<f64>)>
        + Send,
) -> PyResult<EnergyArrays<'py>> {
    guard(name, || {
        contiguous("genes", &genes)?;
        let genes = genes.as_array();
        let (e, d) = run(py, threads, || evaluate(genes))?;
        Ok((e.into_pyarray(py), d.into_pyarray(py)))
    })
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyPopulationEvaluator>()?;
    Ok(())
}
