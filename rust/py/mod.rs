//! The Python extension module `tilesynth._core`. Each function borrows its arrays, releases the GIL around the
//! core kernel (`py.detach`) inside a local thread pool, and converts the result. Nothing here may panic.

mod bench;
mod convert;
mod errors;
mod gradients;

use crate::{maxflow, omega, parallel, png, poisson, population, ssd, synth, wang};
use convert::contiguous;
use errors::{guard, to_pyerr};
use ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyArray4, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArray3, PyReadonlyArray4, PyReadwriteArray3, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Runs a core kernel without the GIL on a pool of `threads` workers and maps its error.
fn run<R: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    f: impl FnOnce() -> crate::Result<R> + Send,
) -> PyResult<R> {
    py.detach(|| parallel::install(threads, f).and_then(|r| r))
        .map_err(to_pyerr)
}

/// The k best matches of every template, packed as `(K, k, 2)` offsets and `(K, k)` exact SSD values.
type MatchArrays<'py> = (Bound<'py, PyArray3<i64>>, Bound<'py, PyArray2<f64>>);

fn pack_matches<'py>(py: Python<'py>, found: Vec<Vec<ssd::Match>>) -> MatchArrays<'py> {
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
struct PySsdIndex {
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
        guard("SsdIndex.best_matches", || {
            contiguous("templates", &templates)?;
            if let Some(m) = &mask {
                contiguous("mask", m)?;
            }
            let templates = templates.as_array();
            let mask = mask.as_ref().map(|m| m.as_array());
            let found = run(py, threads, || {
                ssd::best_matches_many(&self.inner, templates, mask, k, exclude_radius)
            })?;
            Ok(pack_matches(py, found))
        })
    }
}

/// `E` `(P,)` and `D` `(P, m)` of a population.
type EnergyArrays<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray2<f64>>);

/// The ω-tile objective E = λ·ΣD_j + (1−λ)·Var(D_j) for whole populations of gene vectors, exact, with the
/// per-(patch position, role) SSD maps cached across calls (bounded by `cache_bytes`).
#[pyclass(name = "PopulationEvaluator", module = "tilesynth._core", frozen)]
struct PyPopulationEvaluator {
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
        guard("PopulationEvaluator.evaluate", || {
            contiguous("genes", &genes)?;
            let genes = genes.as_array();
            let (e, d) = run(py, threads, || self.inner.evaluate(genes))?;
            Ok((e.into_pyarray(py), d.into_pyarray(py)))
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

/// Min-cut on a 4-connected grid: bool `(H, W)` labels (True = sink side) and the flow (= cut cost).
#[pyfunction]
#[pyo3(signature = (wx, wy, source_hard, sink_hard, source_cap=None, sink_cap=None))]
fn grid_mincut<'py>(
    py: Python<'py>,
    wx: PyReadonlyArray2<'py, f64>,
    wy: PyReadonlyArray2<'py, f64>,
    source_hard: PyReadonlyArray2<'py, bool>,
    sink_hard: PyReadonlyArray2<'py, bool>,
    source_cap: Option<PyReadonlyArray2<'py, f64>>,
    sink_cap: Option<PyReadonlyArray2<'py, f64>>,
) -> PyResult<(Bound<'py, PyArray2<bool>>, f64)> {
    guard("grid_mincut", || {
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

/// Kwatra edge weights `(wx, wy)` between `a` and `b` (`(H, W, C)`), optionally restricted to `region`.
#[pyfunction]
#[pyo3(signature = (a, b, region=None, eps=omega::DEFAULT_EPS, a_grad=None))]
#[allow(clippy::type_complexity)]
fn kwatra_weights<'py>(
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
        let a_grad = a_grad.as_ref().map(|g| g.as_array());
        let (wx, wy) = run(py, Some(1), || {
            omega::kwatra_weights(a, b, region, eps, a_grad)
        })?;
        Ok((wx.into_pyarray(py), wy.into_pyarray(py)))
    })
}

/// ω cutting curves for K tiles: bool masks `(K, N, N)` (True = takes the matching patch) and float64 costs.
#[pyfunction]
#[pyo3(signature = (intermediate, matching, eps=omega::DEFAULT_EPS, threads=None, intermediate_grad=None, keep_border=true))]
#[allow(clippy::type_complexity)]
fn omega_cuts<'py>(
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
        let g = intermediate_grad.as_ref().map(|g| g.as_array());
        let (masks, costs) = run(py, threads, || omega::omega_cuts(i, o, eps, g, keep_border))?;
        Ok((masks.into_pyarray(py), costs.into_pyarray(py)))
    })
}

/// 000's eq. 2 distance over every translation (direct sums).
#[pyfunction]
#[pyo3(signature = (image, image_grad, template, template_grad, mu, eps, threads=None))]
#[allow(clippy::too_many_arguments)]
fn weighted_ssd_map<'py>(
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
        let (i, t) = (image.as_array(), template.as_array());
        let (ig, tg) = (image_grad.as_array(), template_grad.as_array());
        let map = run(py, threads, || ssd::weighted_ssd_map(i, ig, t, tg, mu, eps))?;
        Ok(map.into_pyarray(py))
    })
}

/// Sums of Kwatra weights over selected edges between `template` and every translation of `image`.
#[pyfunction]
#[pyo3(signature = (template, image, wx_mask, wy_mask, eps=omega::DEFAULT_EPS, template_grad=None, threads=None))]
#[allow(clippy::too_many_arguments)]
fn edge_weight_sums<'py>(
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
        let g = template_grad.as_ref().map(|g| g.as_array());
        let map = run(py, threads, || {
            omega::edge_weight_sums(t, g, img, mx, my, eps)
        })?;
        Ok(map.into_pyarray(py))
    })
}

/// Smoothed tiles, iterations `(K,)`, residuals `(K, C)` and unknowns `(K,)` of [`poisson_smooth`].
type PoissonArrays<'py> = (
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
fn poisson_smooth<'py>(
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

/// Writes tiles into `out` `(H, W, C)` by `index_map`; `atlas` `(K, th, tw, C)` and `out` share a dtype
/// (uint8, uint16, float32 or int32).
#[pyfunction]
#[pyo3(signature = (atlas, index_map, out, threads=None))]
fn tile_copy<'py>(
    py: Python<'py>,
    atlas: &Bound<'py, PyAny>,
    index_map: PyReadonlyArray2<'py, i32>,
    out: &Bound<'py, PyAny>,
    threads: Option<usize>,
) -> PyResult<()> {
    guard("tile_copy", || {
        contiguous("index_map", &index_map)?;
        let map = index_map.as_array();
        macro_rules! dispatch {
            ($t:ty) => {
                if let (Ok(a), Ok(mut o)) = (
                    atlas.extract::<PyReadonlyArray4<'py, $t>>(),
                    out.extract::<PyReadwriteArray3<'py, $t>>(),
                ) {
                    contiguous("atlas", &a)?;
                    if !o.is_c_contiguous() {
                        return Err(errors::layout_error("out", "array must be C-contiguous"));
                    }
                    let a = a.as_array();
                    let o = o.as_array_mut();
                    return run(py, threads, || synth::tile_copy_into(a, map, o));
                }
            };
        }
        dispatch!(u8);
        dispatch!(u16);
        dispatch!(f32);
        dispatch!(i32);
        Err(errors::layout_error(
            "atlas/out",
            "expected a 4-d atlas and a 3-d writable out (not sharing memory with atlas) of the same \
             native-endian dtype, uint8, uint16, float32 or int32",
        ))
    })
}

/// Parses the string options of a Wang construction.
#[allow(clippy::too_many_arguments)]
fn wang_params(
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
#[pyo3(signature = (exemplar, genes, tile_samples, tile_size, overlap, corners="free", samples="diamond", cut="dp", omega=wang::DEFAULT_OMEGA, eps=omega::DEFAULT_EPS, threads=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn wang_tiles<'py>(
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
struct PyWangEvaluator {
    inner: wang::WangEvaluator,
}

#[pymethods]
impl PyWangEvaluator {
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (exemplar, tile_samples, n_samples, tile_size, overlap, corners="free", samples="diamond", cut="dp", omega=wang::DEFAULT_OMEGA, eps=omega::DEFAULT_EPS))]
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
        guard("WangEvaluator.evaluate", || {
            contiguous("genes", &genes)?;
            let genes = genes.as_array();
            let (e, d) = run(py, threads, || self.inner.evaluate(genes))?;
            Ok((e.into_pyarray(py), d.into_pyarray(py)))
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
#[pyo3(signature = (initial, supplementary, eps=omega::DEFAULT_EPS, threads=None, initial_grad=None))]
#[allow(clippy::type_complexity)]
fn swang_cuts<'py>(
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

/// Resolved thread count (explicit value, else TILESYNTH_NUM_THREADS, else all cores).
#[pyfunction]
#[pyo3(signature = (threads=None))]
fn resolve_threads(threads: Option<usize>) -> PyResult<usize> {
    guard("resolve_threads", || {
        parallel::resolve_threads(threads).map_err(to_pyerr)
    })
}

/// PNG scanline unfiltering: `data` (uint8, `rows * (row_bytes + 1)` bytes: a filter byte, then the row) ->
/// the raw bytes, uint8 `(rows, row_bytes)`; `bpp` bytes per pixel (1 to 8).
#[pyfunction]
fn png_unfilter<'py>(
    py: Python<'py>,
    data: PyReadonlyArray1<'py, u8>,
    rows: usize,
    row_bytes: usize,
    bpp: usize,
) -> PyResult<Bound<'py, PyArray2<u8>>> {
    guard("png_unfilter", || {
        contiguous("data", &data)?;
        let d = data
            .as_slice()
            .map_err(|_| errors::layout_error("data", "array must be C-contiguous"))?;
        let raw = run(py, Some(1), || png::unfilter(d, rows, row_bytes, bpp))?;
        let arr = Array2::from_shape_vec((rows, row_bytes), raw)
            .map_err(|e| errors::layout_error("data", &e.to_string()))?;
        Ok(arr.into_pyarray(py))
    })
}

/// Panics with `message` inside the kernel runner (on a pool worker). Exists only to test that a panic
/// comes out of the bindings as `tilesynth.InternalError` with a clear message (see `errors::guard`).
#[pyfunction]
fn _raise_panic(py: Python<'_>, message: &str) -> PyResult<()> {
    let message = message.to_string();
    guard("_raise_panic", || {
        run(py, Some(1), move || -> crate::Result<()> {
            panic!("{message}");
        })
    })
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<PySsdIndex>()?;
    m.add_class::<PyPopulationEvaluator>()?;
    m.add_class::<PyWangEvaluator>()?;
    m.add_function(wrap_pyfunction!(grid_mincut, m)?)?;
    m.add_function(wrap_pyfunction!(kwatra_weights, m)?)?;
    m.add_function(wrap_pyfunction!(omega_cuts, m)?)?;
    m.add_function(wrap_pyfunction!(poisson_smooth, m)?)?;
    m.add_function(wrap_pyfunction!(tile_copy, m)?)?;
    m.add_function(wrap_pyfunction!(wang_tiles, m)?)?;
    m.add_function(wrap_pyfunction!(swang_cuts, m)?)?;
    m.add_function(wrap_pyfunction!(resolve_threads, m)?)?;
    m.add_function(wrap_pyfunction!(png_unfilter, m)?)?;
    m.add_function(wrap_pyfunction!(edge_weight_sums, m)?)?;
    m.add_function(wrap_pyfunction!(weighted_ssd_map, m)?)?;
    m.add_function(wrap_pyfunction!(_raise_panic, m)?)?;
    bench::register(m)?;
    gradients::register(m)?;
    Ok(())
}
