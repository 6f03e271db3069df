//! Wang tiles (Cohen / Burke), their population objective, and the closed cuts of strict Wang tiles.

use super::convert::contiguous;
use super::errors::guard;
use super::errors::to_pyerr;
use super::population::{evaluate_genes, EnergyArrays};
use super::run;
use crate::{seams, wang};
use numpy::{
    IntoPyArray, PyArray1, PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4,
};
use pyo3::prelude::*;

/// Parses the string options of a Wang construction.
#[allow(clippy::too_many_arguments)]
pub(super) fn wang_params(
    tile_size: usize,
    overlap: usize,
    corners: &str,
    samples: &str,
    cut: &str,
    omega: f64,
    eps: f64,
) -> PyResult<wang::WangParams> {
    Ok(wang::WangParams {
        tile_size,
        overlap,
        corners: wang::Corners::parse(corners).map_err(to_pyerr)?,
        samples: wang::Samples::parse(samples).map_err(to_pyerr)?,
        cut: wang::CutMethod::parse(cut).map_err(to_pyerr)?,
        omega,
        eps,
    })
}

/// Wang tiles (Cohen / Burke): labels `(K, N, N)` uint8 (0 N, 1 E, 2 S, 3 W) and per-cut facts `(K, 4, 6)`.
#[pyfunction]
#[pyo3(signature = (exemplar, genes, tile_samples, tile_size, overlap, corners="free", samples="diamond", cut="dp", omega=wang::DEFAULT_OMEGA, eps=seams::DEFAULT_EPS, threads=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(super) fn wang_tiles<'py>(
    py: Python<'py>,
    exemplar: PyReadonlyArray3<'py, f32>,
    genes: PyReadonlyArray2<'py, i64>,
    tile_samples: PyReadonlyArray2<'py, i64>,
    tile_size: usize,
    overlap: usize,
    corners: &str,
    samples: &str,
    cut: &str,
    omega: f64,
    eps: f64,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyArray3<u8>>, Bound<'py, PyArray3<f64>>)> {
    guard("wang_tiles", || {
        contiguous("exemplar", &exemplar)?;
        contiguous("genes", &genes)?;
        contiguous("tile_samples", &tile_samples)?;
        let p = wang_params(tile_size, overlap, corners, samples, cut, omega, eps)?;
        let (ex, g, t) = (
            exemplar.as_array(),
            genes.as_array(),
            tile_samples.as_array(),
        );
        let built = run(py, threads, || wang::wang_tiles(ex, g, t, &p))?;
        Ok((built.labels.into_pyarray(py), built.stats.into_pyarray(py)))
    })
}

/// The objective of 001 for populations: E = ω·ΣD_sum + (1−ω)·Var(D_sum) and D_sum of every tile.
#[pyclass(name = "WangEvaluator", module = "tilesynth._core", frozen)]
pub(super) struct PyWangEvaluator {
    inner: wang::WangEvaluator,
}

#[pymethods]
impl PyWangEvaluator {
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (exemplar, tile_samples, n_samples, tile_size, overlap, corners="free", samples="diamond", cut="dp", omega=wang::DEFAULT_OMEGA, eps=seams::DEFAULT_EPS))]
    fn new(
        py: Python<'_>,
        exemplar: PyReadonlyArray3<'_, f32>,
        tile_samples: PyReadonlyArray2<'_, i64>,
        n_samples: usize,
        tile_size: usize,
        overlap: usize,
        corners: &str,
        samples: &str,
        cut: &str,
        omega: f64,
        eps: f64,
    ) -> PyResult<Self> {
        guard("WangEvaluator", || {
            contiguous("exemplar", &exemplar)?;
            contiguous("tile_samples", &tile_samples)?;
            let p = wang_params(tile_size, overlap, corners, samples, cut, omega, eps)?;
            let (ex, t) = (exemplar.as_array(), tile_samples.as_array());
            let inner = run(py, Some(1), || {
                wang::WangEvaluator::new(ex, t, n_samples, p)
            })?;
            Ok(PyWangEvaluator { inner })
        })
    }

    /// E (float64 `(P,)`) and D_sum (float64 `(P, m)`) of `P` gene vectors `(P, n, 2)` int64.
    #[pyo3(signature = (genes, threads=None))]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        genes: PyReadonlyArray3<'py, i64>,
        threads: Option<usize>,
    ) -> PyResult<EnergyArrays<'py>> {
        evaluate_genes(py, "WangEvaluator.evaluate", genes, threads, |g| {
            self.inner.evaluate(g)
        })
    }

    /// `(sample_size, n_samples, n_tiles)`.
    #[getter]
    fn dims(&self) -> (usize, usize, usize) {
        self.inner.dims()
    }
}

/// 004's closed cuts for K tiles: bool masks `(K, N, N)` (True = supplementary patch) and float64 costs.
#[pyfunction]
#[pyo3(signature = (initial, supplementary, eps=seams::DEFAULT_EPS, threads=None, initial_grad=None))]
#[allow(clippy::type_complexity)]
pub(super) fn swang_cuts<'py>(
    py: Python<'py>,
    initial: PyReadonlyArray4<'py, f32>,
    supplementary: PyReadonlyArray4<'py, f32>,
    eps: f64,
    threads: Option<usize>,
    initial_grad: Option<PyReadonlyArray4<'py, f64>>,
) -> PyResult<(Bound<'py, PyArray3<bool>>, Bound<'py, PyArray1<f64>>)> {
    guard("swang_cuts", || {
        contiguous("initial", &initial)?;
        contiguous("supplementary", &supplementary)?;
        if let Some(g) = &initial_grad {
            contiguous("initial_grad", g)?;
        }
        let (i, o) = (initial.as_array(), supplementary.as_array());
        let g = initial_grad.as_ref().map(|g| g.as_array());
        let (masks, costs) = run(py, threads, || wang::swang_cuts(i, o, eps, g))?;
        Ok((masks.into_pyarray(py), costs.into_pyarray(py)))
    })
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyWangEvaluator>()?;
    m.add_function(wrap_pyfunction!(wang_tiles, m)?)?;
    m.add_function(wrap_pyfunction!(swang_cuts, m)?)?;
    Ok(())
}
