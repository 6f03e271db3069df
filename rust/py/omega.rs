//! Seam weights and the ω cutting curves.

use super::convert::{aligned, contiguous};
use super::errors::guard;
use super::run;
use crate::{omega, seams};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4,
};
use pyo3::prelude::*;

/// Kwatra edge weights `(wx, wy)` between `a` and `b` (`(H, W, C)`), optionally restricted to `region`.
#[pyfunction]
#[pyo3(signature = (a, b, region=None, eps=seams::DEFAULT_EPS, a_grad=None))]
#[allow(clippy::type_complexity)]
pub(super) fn kwatra_weights<'py>(
    py: Python<'py>,
    a: PyReadonlyArray3<'py, f32>,
    b: PyReadonlyArray3<'py, f32>,
    region: Option<PyReadonlyArray2<'py, bool>>,
    eps: f64,
    a_grad: Option<PyReadonlyArray3<'py, f64>>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>)> {
    guard("kwatra_weights", || {
        contiguous("a", &a)?;
        contiguous("b", &b)?;
        let (a, b) = (a.as_array(), b.as_array());
        let region = region.as_ref().map(|r| r.as_array());
        if let Some(g) = &a_grad {
            aligned("a_grad", g)?;
        }
        let a_grad = a_grad.as_ref().map(|g| g.as_array());
        let (wx, wy) = run(py, Some(1), || {
            omega::kwatra_weights(a, b, region, eps, a_grad)
        })?;
        Ok((wx.into_pyarray(py), wy.into_pyarray(py)))
    })
}

/// ω cutting curves for K tiles: bool masks `(K, N, N)` (True = takes the matching patch) and float64 costs.
#[pyfunction]
#[pyo3(signature = (intermediate, matching, eps=seams::DEFAULT_EPS, threads=None, intermediate_grad=None, keep_border=true))]
#[allow(clippy::type_complexity)]
pub(super) fn omega_cuts<'py>(
    py: Python<'py>,
    intermediate: PyReadonlyArray4<'py, f32>,
    matching: PyReadonlyArray4<'py, f32>,
    eps: f64,
    threads: Option<usize>,
    intermediate_grad: Option<PyReadonlyArray4<'py, f64>>,
    keep_border: bool,
) -> PyResult<(Bound<'py, PyArray3<bool>>, Bound<'py, PyArray1<f64>>)> {
    guard("omega_cuts", || {
        contiguous("intermediate", &intermediate)?;
        contiguous("matching", &matching)?;
        let (i, o) = (intermediate.as_array(), matching.as_array());
        if let Some(g) = &intermediate_grad {
            aligned("intermediate_grad", g)?;
        }
        let g = intermediate_grad.as_ref().map(|g| g.as_array());
        let (masks, costs) = run(py, threads, || omega::omega_cuts(i, o, eps, g, keep_border))?;
        Ok((masks.into_pyarray(py), costs.into_pyarray(py)))
    })
}

/// Sums of Kwatra weights over selected edges between `template` and every translation of `image`.
#[pyfunction]
#[pyo3(signature = (template, image, wx_mask, wy_mask, eps=seams::DEFAULT_EPS, template_grad=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub(super) fn edge_weight_sums<'py>(
    py: Python<'py>,
    template: PyReadonlyArray3<'py, f32>,
    image: PyReadonlyArray3<'py, f32>,
    wx_mask: PyReadonlyArray2<'py, bool>,
    wy_mask: PyReadonlyArray2<'py, bool>,
    eps: f64,
    template_grad: Option<PyReadonlyArray3<'py, f64>>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard("edge_weight_sums", || {
        contiguous("template", &template)?;
        contiguous("image", &image)?;
        let (t, img) = (template.as_array(), image.as_array());
        let (mx, my) = (wx_mask.as_array(), wy_mask.as_array());
        if let Some(g) = &template_grad {
            aligned("template_grad", g)?;
        }
        let g = template_grad.as_ref().map(|g| g.as_array());
        let map = run(py, threads, || {
            omega::edge_weight_sums(t, g, img, mx, my, eps)
        })?;
        Ok(map.into_pyarray(py))
    })
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(kwatra_weights, m)?)?;
    m.add_function(wrap_pyfunction!(omega_cuts, m)?)?;
    m.add_function(wrap_pyfunction!(edge_weight_sums, m)?)?;
    Ok(())
}
