//! Max-flow / min-cut on a 4- or 8-connected grid.

use super::convert::aligned;
use super::errors::guard;
use super::run;
use crate::maxflow;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;

/// Min-cut on a 4-connected grid: bool `(H, W)` labels (True = sink side) and the flow (= cut cost).
#[pyfunction]
#[pyo3(signature = (wx, wy, source_hard, sink_hard, source_cap=None, sink_cap=None))]
pub(super) fn grid_mincut<'py>(
    py: Python<'py>,
    wx: PyReadonlyArray2<'py, f64>,
    wy: PyReadonlyArray2<'py, f64>,
    source_hard: PyReadonlyArray2<'py, bool>,
    sink_hard: PyReadonlyArray2<'py, bool>,
    source_cap: Option<PyReadonlyArray2<'py, f64>>,
    sink_cap: Option<PyReadonlyArray2<'py, f64>>,
) -> PyResult<(Bound<'py, PyArray2<bool>>, f64)> {
    guard("grid_mincut", || {
        aligned("wx", &wx)?;
        aligned("wy", &wy)?;
        if let Some(a) = &source_cap {
            aligned("source_cap", a)?;
        }
        if let Some(a) = &sink_cap {
            aligned("sink_cap", a)?;
        }
        let (wx, wy) = (wx.as_array(), wy.as_array());
        let (src, snk) = (source_hard.as_array(), sink_hard.as_array());
        let sc = source_cap.as_ref().map(|a| a.as_array());
        let kc = sink_cap.as_ref().map(|a| a.as_array());
        let cut = run(py, Some(1), || {
            maxflow::grid_mincut(wx, wy, src, snk, sc, kc)
        })?;
        Ok((cut.sink_side.into_pyarray(py), cut.flow))
    })
}

/// Min-cut on an 8-connected grid (`wd` down-right, `wa` down-left edge capacities too): labels and flow.
#[pyfunction]
#[pyo3(signature = (wx, wy, wd, wa, source_hard, sink_hard, source_cap=None, sink_cap=None))]
#[allow(clippy::too_many_arguments)]
pub(super) fn grid_mincut8<'py>(
    py: Python<'py>,
    wx: PyReadonlyArray2<'py, f64>,
    wy: PyReadonlyArray2<'py, f64>,
    wd: PyReadonlyArray2<'py, f64>,
    wa: PyReadonlyArray2<'py, f64>,
    source_hard: PyReadonlyArray2<'py, bool>,
    sink_hard: PyReadonlyArray2<'py, bool>,
    source_cap: Option<PyReadonlyArray2<'py, f64>>,
    sink_cap: Option<PyReadonlyArray2<'py, f64>>,
) -> PyResult<(Bound<'py, PyArray2<bool>>, f64)> {
    guard("grid_mincut8", || {
        for (name, a) in [("wx", &wx), ("wy", &wy), ("wd", &wd), ("wa", &wa)] {
            aligned(name, a)?;
        }
        if let Some(a) = &source_cap {
            aligned("source_cap", a)?;
        }
        if let Some(a) = &sink_cap {
            aligned("sink_cap", a)?;
        }
        let (wx, wy, wd, wa) = (wx.as_array(), wy.as_array(), wd.as_array(), wa.as_array());
        let (src, snk) = (source_hard.as_array(), sink_hard.as_array());
        let sc = source_cap.as_ref().map(|a| a.as_array());
        let kc = sink_cap.as_ref().map(|a| a.as_array());
        let cut = run(py, Some(1), || {
            maxflow::grid_mincut8(wx, wy, wd, wa, src, snk, sc, kc)
        })?;
        Ok((cut.sink_side.into_pyarray(py), cut.flow))
    })
}

/// Min-cuts of `K` 4-connected grids sharing their hard masks, in parallel: bool `(K, H, W)` labels and the
/// `K` flows, each grid's as `grid_mincut` gives it.
#[pyfunction]
#[pyo3(signature = (wx, wy, source_hard, sink_hard, sink_cap=None, threads=None))]
#[allow(clippy::type_complexity)]
pub(super) fn grid_mincuts<'py>(
    py: Python<'py>,
    wx: PyReadonlyArray3<'py, f64>,
    wy: PyReadonlyArray3<'py, f64>,
    source_hard: PyReadonlyArray2<'py, bool>,
    sink_hard: PyReadonlyArray2<'py, bool>,
    sink_cap: Option<PyReadonlyArray3<'py, f64>>,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyArray3<bool>>, Bound<'py, PyArray1<f64>>)> {
    guard("grid_mincuts", || {
        aligned("wx", &wx)?;
        aligned("wy", &wy)?;
        if let Some(a) = &sink_cap {
            aligned("sink_cap", a)?;
        }
        let (wx, wy) = (wx.as_array(), wy.as_array());
        let (src, snk) = (source_hard.as_array(), sink_hard.as_array());
        let kc = sink_cap.as_ref().map(|a| a.as_array());
        let cuts = run(py, threads, || maxflow::grid_mincuts(wx, wy, src, snk, kc))?;
        Ok((cuts.labels.into_pyarray(py), cuts.flows.into_pyarray(py)))
    })
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(grid_mincut, m)?)?;
    m.add_function(wrap_pyfunction!(grid_mincut8, m)?)?;
    m.add_function(wrap_pyfunction!(grid_mincuts, m)?)?;
    Ok(())
}
