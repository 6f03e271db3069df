//! Poisson smoothing.

use super::convert::contiguous;
use super::errors::guard;
use super::run;
use crate::poisson;
use ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray4, PyReadonlyArray3, PyReadonlyArray4};
use pyo3::prelude::*;

/// Smoothed tiles, iterations `(K,)`, residuals `(K, C)` and unknowns `(K,)` of [`poisson_smooth`].
pub(super) type PoissonArrays<'py> = (
    Bound<'py, PyArray4<f32>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
);

/// Poisson smoothing (guided interpolation) of K tiles: `dst`, `src` `(K, N, M, C)` float32, `region`
/// `(K, N, M)` bool (True = unknown). Returns the smoothed tiles, the PCG iterations per tile, the final relative
/// residual per tile and channel, and the number of unknowns per tile.
#[pyfunction]
#[pyo3(signature = (dst, src, region, tol=poisson::DEFAULT_TOL, threads=None))]
pub(super) fn poisson_smooth<'py>(
    py: Python<'py>,
    dst: PyReadonlyArray4<'py, f32>,
    src: PyReadonlyArray4<'py, f32>,
    region: PyReadonlyArray3<'py, bool>,
    tol: f64,
    threads: Option<usize>,
) -> PyResult<PoissonArrays<'py>> {
    guard("poisson_smooth", || {
        contiguous("dst", &dst)?;
        contiguous("src", &src)?;
        contiguous("region", &region)?;
        let (d, s, r) = (dst.as_array(), src.as_array(), region.as_array());
        let (out, infos) = run(py, threads, || poisson::poisson_smooth_batch(d, s, r, tol))?;
        let c = out.dim().3;
        let iterations: Vec<i64> = infos.iter().map(|i| i.iterations as i64).collect();
        let unknowns: Vec<i64> = infos.iter().map(|i| i.unknowns as i64).collect();
        let residual = Array2::from_shape_fn((infos.len(), c), |(t, k)| infos[t].residual[k]);
        Ok((
            out.into_pyarray(py),
            iterations.into_pyarray(py),
            residual.into_pyarray(py),
            unknowns.into_pyarray(py),
        ))
    })
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(poisson_smooth, m)?)?;
    Ok(())
}
