//! Bindings of [`crate::provenance`]: the factorisation of a provenance array into labels and a source table,
//! and the gather of a tiling's window straight from the exemplar (or any pixel-aligned map).

use super::convert::{aligned, contiguous};
use super::errors::{self, guard};
use super::run;
use crate::error::try_to_owned;
use crate::provenance;
use numpy::{
    IntoPyArray, PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4, PyReadwriteArray3,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// `(labels (K, N, N) uint8, table (K, L, 3) int32)` of an int32 provenance `(K, N, N, 2)`, or None when a tile
/// needs more than 255 entries. GIL released.
#[pyfunction]
#[pyo3(signature = (source, threads=None))]
#[allow(clippy::type_complexity)]
fn provenance_factorise<'py>(
    py: Python<'py>,
    source: PyReadonlyArray4<'py, i32>,
    threads: Option<usize>,
) -> PyResult<Option<(Bound<'py, PyArray3<u8>>, Bound<'py, PyArray3<i32>>)>> {
    guard("provenance_factorise", || {
        contiguous("source", &source)?;
        let s = source.as_array();
        let r = run(py, threads, || provenance::factorise(s))?;
        Ok(r.map(|(l, t)| (l.into_pyarray(py), t.into_pyarray(py))))
    })
}

/// Writes the window of the tiling by `index_map` at pixel `offset = (oy, ox)` into its first cell into `out`
/// `(H, W, C)`, every pixel read from `exemplar` `(EH, EW, C)` (same dtype as `out`: uint8, uint16, float32 or
/// int32) through `labels` / `table`. GIL released.
#[pyfunction]
#[pyo3(signature = (exemplar, labels, table, index_map, offset, out, threads=None))]
#[allow(clippy::too_many_arguments)]
fn provenance_gather<'py>(
    py: Python<'py>,
    exemplar: &Bound<'py, PyAny>,
    labels: PyReadonlyArray3<'py, u8>,
    table: PyReadonlyArray3<'py, i32>,
    index_map: PyReadonlyArray2<'py, i32>,
    offset: (usize, usize),
    out: &Bound<'py, PyAny>,
    threads: Option<usize>,
) -> PyResult<()> {
    guard("provenance_gather", || {
        contiguous("labels", &labels)?;
        contiguous("table", &table)?;
        contiguous("index_map", &index_map)?;
        // owned copies of the small inputs: the values checked are the values used, whatever other Python
        // threads write while the GIL is released
        let map = try_to_owned("index_map", index_map.as_array()).map_err(errors::to_pyerr)?;
        let tab = try_to_owned("table", table.as_array()).map_err(errors::to_pyerr)?;
        let lab = labels.as_array();
        macro_rules! dispatch {
            ($t:ty) => {
                if let (Ok(e), Ok(mut o)) = (
                    exemplar.extract::<PyReadonlyArray3<'py, $t>>(),
                    out.extract::<PyReadwriteArray3<'py, $t>>(),
                ) {
                    contiguous("exemplar", &e)?;
                    if !o.is_c_contiguous() {
                        return Err(errors::layout_error("out", "array must be C-contiguous"));
                    }
                    aligned("out", &o)?;
                    let e = e.as_array();
                    if o.len() == 0 {
                        return Ok(());
                    }
                    let o = o.as_array_mut();
                    let (m, t) = (map.view(), tab.view());
                    return run(py, threads, || {
                        provenance::gather_window_into(e, lab, t, m, offset, o)
                    });
                }
            };
        }
        dispatch!(u8);
        dispatch!(u16);
        dispatch!(f32);
        dispatch!(i32);
        Err(errors::layout_error(
            "exemplar/out",
            "expected a 3-d exemplar and a 3-d writable out of the same native-endian dtype, uint8, uint16, \
             float32 or int32",
        ))
    })
}

/// Registers the provenance functions.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(provenance_factorise, m)?)?;
    m.add_function(wrap_pyfunction!(provenance_gather, m)?)?;
    Ok(())
}
