//! Bindings of [`crate::blend`]: the seam blend of a smooth material map over a window of a tiling.

use super::convert::{aligned, contiguous};
use super::errors::{self, guard};
use super::run;
use crate::blend::{self, Bands};
use crate::error::try_to_owned;
use numpy::{
    PyReadonlyArray2, PyReadonlyArray3, PyReadwriteArray2, PyReadwriteArray3, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// Fills `out` `(h, w, C)` float64 with the seam blend of the map `values` `(H, W, C)` float64 over the
/// window of the tiling by `index_map` at pixel `offset = (oy, ox)` into its first cell, and `single` `(h, w)`
/// uint8 with 1 where one entry has every weight (`tilesynth.synth.seams`: the formula). `low` `(H, W, C)`:
/// the map's low band at every pixel, `mu`: its mean per channel (both unused when `low_level` is None);
/// `reach`: the low band's border labels. Untransformed entries only. GIL released.
#[pyfunction]
#[pyo3(signature = (values, low, mu, labels, table, index_map, offset, high, low_level, reach, out, single, threads=None))]
#[allow(clippy::too_many_arguments)]
fn seam_blend<'py>(
    py: Python<'py>,
    values: PyReadonlyArray3<'py, f64>,
    low: PyReadonlyArray3<'py, f64>,
    mu: Vec<f64>,
    labels: PyReadonlyArray3<'py, u8>,
    table: PyReadonlyArray3<'py, i32>,
    index_map: PyReadonlyArray2<'py, i32>,
    offset: (usize, usize),
    high: f64,
    low_level: Option<f64>,
    reach: usize,
    mut out: PyReadwriteArray3<'py, f64>,
    mut single: PyReadwriteArray2<'py, u8>,
    threads: Option<usize>,
) -> PyResult<()> {
    guard("seam_blend", || {
        contiguous("values", &values)?;
        contiguous("low", &low)?;
        contiguous("labels", &labels)?;
        contiguous("table", &table)?;
        contiguous("index_map", &index_map)?;
        if !out.is_c_contiguous() || !single.is_c_contiguous() {
            return Err(errors::layout_error(
                "out/single",
                "array must be C-contiguous",
            ));
        }
        aligned("out", &out)?;
        let map = try_to_owned("index_map", index_map.as_array()).map_err(errors::to_pyerr)?;
        let tab = try_to_owned("table", table.as_array()).map_err(errors::to_pyerr)?;
        let (v, l, lab) = (values.as_array(), low.as_array(), labels.as_array());
        let bands = Bands {
            high,
            low: low_level.map(|lv| (lv, reach)),
        };
        let (o, s) = (out.as_array_mut(), single.as_array_mut());
        run(py, threads, || {
            blend::blend_window(v, l, &mu, lab, tab.view(), map.view(), offset, bands, o, s)
        })
    })
}

/// Registers the blend function.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(seam_blend, m)?)?;
    Ok(())
}
