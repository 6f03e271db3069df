//! SSD bindings: the cached exhaustive SSD index and 000's eq. 2 map.

use super::convert::{aligned, contiguous};
use super::errors::guard;
use super::run;
use crate::ssd;
use ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4,
};
use pyo3::prelude::*;

/// The k best matches of every template, packed as `(K, k, 2)` offsets and `(K, k)` exact SSD values.
pub(super) type MatchArrays<'py> = (Bound<'py, PyArray3<i64>>, Bound<'py, PyArray2<f64>>);

pub(super) fn pack_matches<'py>(py: Python<'py>, found: Vec<Vec<ssd::Match>>) -> MatchArrays<'py> {
    let n = found.len();
    let got = found.iter().map(|v| v.len()).min().unwrap_or(0);
    let mut offsets = Array3::<i64>::zeros((n, got, 2));
    let mut values = Array2::<f64>::zeros((n, got));
    for (t, list) in found.iter().enumerate() {
        for (j, m) in list.iter().take(got).enumerate() {
            offsets[(t, j, 0)] = m.row as i64;
            offsets[(t, j, 1)] = m.col as i64;
            values[(t, j)] = m.ssd;
        }
    }
    (offsets.into_pyarray(py), values.into_pyarray(py))
}

/// The cached part of the exhaustive SSD for one image (its spectra and box sums): build once, then match any
/// number of templates against it.
#[pyclass(name = "SsdIndex", module = "tilesynth._core", frozen)]
pub(super) struct PySsdIndex {
    inner: ssd::SsdIndex,
}

#[pymethods]
impl PySsdIndex {
    #[new]
    #[pyo3(signature = (image, threads=None))]
    fn new(
        py: Python<'_>,
        image: PyReadonlyArray3<'_, f32>,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        guard("SsdIndex", || {
            contiguous("image", &image)?;
            let image = image.as_array();
            let inner = run(py, threads, || ssd::SsdIndex::new(image))?;
            Ok(PySsdIndex { inner })
        })
    }

    /// `(H, W, C)` of the indexed image.
    #[getter]
    fn shape(&self) -> (usize, usize, usize) {
        self.inner.shape()
    }

    /// SSD maps of K templates `(K, h, w, C)`: float32 `(K, H-h+1, W-w+1)`.
    #[pyo3(signature = (templates, mask=None, threads=None))]
    fn ssd_maps<'py>(
        &self,
        py: Python<'py>,
        templates: PyReadonlyArray4<'py, f32>,
        mask: Option<PyReadonlyArray2<'py, bool>>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        guard("SsdIndex.ssd_maps", || {
            contiguous("templates", &templates)?;
            if let Some(m) = &mask {
                contiguous("mask", m)?;
            }
            let templates = templates.as_array();
            let mask = mask.as_ref().map(|m| m.as_array());
            let maps = run(py, threads, || ssd::ssd_maps(&self.inner, templates, mask))?;
            Ok(maps.into_pyarray(py))
        })
    }

    /// The k best translations of each template (exact SSD): int64 `(K, k, 2)` (row, col), float64 `(K, k)`.
    #[pyo3(signature = (templates, k=1, exclude_radius=0, mask=None, threads=None))]
    fn best_matches<'py>(
        &self,
        py: Python<'py>,
        templates: PyReadonlyArray4<'py, f32>,
        k: usize,
        exclude_radius: usize,
        mask: Option<PyReadonlyArray2<'py, bool>>,
        threads: Option<usize>,
    ) -> PyResult<MatchArrays<'py>> {
        let how = ssd::best_matches_many;
        matches_of(
            "SsdIndex.best_matches",
            py,
            &self.inner,
            templates,
            k,
            exclude_radius,
            mask,
            threads,
            how,
        )
    }
}

/// The `f32` FFT map of one quadrant template for `best_matches_quadrants`: `(map, bound, max)`
/// (see `ssd::quadrant_map`).
#[pyfunction]
#[pyo3(signature = (index, quad, threads=None))]
fn quadrant_map<'py>(
    py: Python<'py>,
    index: &PySsdIndex,
    quad: PyReadonlyArray3<'py, f32>,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyArray2<f32>>, f64, f64)> {
    guard("quadrant_map", || {
        contiguous("quad", &quad)?;
        let q = quad.as_array();
        let (map, bound, mx) = run(py, threads, || ssd::quadrant_map(&index.inner, q))?;
        Ok((map.into_pyarray(py), bound, mx))
    })
}

/// `SsdIndex.best_matches` of templates assembled from quadrants, on their `quadrant_map`s (see
/// `ssd::best_matches_quadrants`): the same results, one FFT per distinct quadrant instead of one per
/// template.
#[pyfunction]
#[pyo3(signature = (index, quads, maps, bounds, maxes, templates, assign, k=1, exclude_radius=0, threads=None))]
#[allow(clippy::too_many_arguments)]
fn best_matches_quadrants<'py>(
    py: Python<'py>,
    index: &PySsdIndex,
    quads: PyReadonlyArray4<'py, f32>,
    maps: PyReadonlyArray3<'py, f32>,
    bounds: Vec<f64>,
    maxes: Vec<f64>,
    templates: PyReadonlyArray4<'py, f32>,
    assign: PyReadonlyArray2<'py, i64>,
    k: usize,
    exclude_radius: usize,
    threads: Option<usize>,
) -> PyResult<MatchArrays<'py>> {
    guard("best_matches_quadrants", || {
        contiguous("quads", &quads)?;
        contiguous("maps", &maps)?;
        contiguous("templates", &templates)?;
        let (q, m, t, a) = (
            quads.as_array(),
            maps.as_array(),
            templates.as_array(),
            assign.as_array(),
        );
        let found = run(py, threads, || {
            ssd::best_matches_quadrants(
                &index.inner,
                q,
                m,
                &bounds,
                &maxes,
                t,
                a,
                k,
                exclude_radius,
            )
        })?;
        Ok(pack_matches(py, found))
    })
}

/// 000's eq. 2 distance over every translation (direct sums).
#[pyfunction]
#[pyo3(signature = (image, image_grad, template, template_grad, mu, eps, threads=None))]
#[allow(clippy::too_many_arguments)]
pub(super) fn weighted_ssd_map<'py>(
    py: Python<'py>,
    image: PyReadonlyArray3<'py, f32>,
    image_grad: PyReadonlyArray2<'py, f64>,
    template: PyReadonlyArray3<'py, f32>,
    template_grad: PyReadonlyArray2<'py, f64>,
    mu: f64,
    eps: f64,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard("weighted_ssd_map", || {
        contiguous("image", &image)?;
        contiguous("template", &template)?;
        aligned("image_grad", &image_grad)?;
        aligned("template_grad", &template_grad)?;
        let (i, t) = (image.as_array(), template.as_array());
        let (ig, tg) = (image_grad.as_array(), template_grad.as_array());
        let map = run(py, threads, || ssd::weighted_ssd_map(i, ig, t, tg, mu, eps))?;
        Ok(map.into_pyarray(py))
    })
}

// Bench-only (hidden, underscore name): the baseline that benches/matching_scan.py runs side by side with
// the current path. Not part of the public API.
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
    let how = ssd::best_matches_many_sorting;
    matches_of(
        "_best_matches_sorting",
        py,
        &index.inner,
        templates,
        k,
        exclude_radius,
        mask,
        threads,
        how,
    )
}

/// The core function of a best-matches call: index, templates, mask, k, exclusion radius.
type MatchesFn = fn(
    &ssd::SsdIndex,
    ndarray::ArrayView4<f32>,
    Option<ndarray::ArrayView2<bool>>,
    usize,
    usize,
) -> crate::error::Result<Vec<Vec<ssd::Match>>>;

/// Both best-matches bindings: borrow, run `how` without the GIL, pack the result.
#[allow(clippy::too_many_arguments)]
fn matches_of<'py>(
    what: &str,
    py: Python<'py>,
    index: &ssd::SsdIndex,
    templates: PyReadonlyArray4<'py, f32>,
    k: usize,
    exclude_radius: usize,
    mask: Option<PyReadonlyArray2<'py, bool>>,
    threads: Option<usize>,
    how: MatchesFn,
) -> PyResult<MatchArrays<'py>> {
    guard(what, || {
        contiguous("templates", &templates)?;
        if let Some(m) = &mask {
            contiguous("mask", m)?;
        }
        let templates = templates.as_array();
        let mask = mask.as_ref().map(|m| m.as_array());
        let found = run(py, threads, || {
            how(index, templates, mask, k, exclude_radius)
        })?;
        Ok(pack_matches(py, found))
    })
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySsdIndex>()?;
    m.add_function(wrap_pyfunction!(weighted_ssd_map, m)?)?;
    m.add_function(wrap_pyfunction!(_best_matches_sorting, m)?)?;
    m.add_function(wrap_pyfunction!(quadrant_map, m)?)?;
    m.add_function(wrap_pyfunction!(best_matches_quadrants, m)?)?;
    Ok(())
}
