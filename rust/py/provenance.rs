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
/// needs more than 255 entries; `orient` `(K, N, N)` uint8, optional: the symmetry each pixel's entry must
/// have (the turn of a rotated or mirrored patch). GIL released.
#[pyfunction]
#[pyo3(signature = (source, threads=None, orient=None))]
#[allow(clippy::type_complexity)]
fn provenance_factorise<'py>(
    py: Python<'py>,
    source: PyReadonlyArray4<'py, i32>,
    threads: Option<usize>,
    orient: Option<PyReadonlyArray3<'py, u8>>,
) -> PyResult<Option<(Bound<'py, PyArray3<u8>>, Bound<'py, PyArray3<i32>>)>> {
    guard("provenance_factorise", || {
        contiguous("source", &source)?;
        let s = source.as_array();
        let o = orient.as_ref().map(|o| o.as_array());
        let r = run(py, threads, || provenance::factorise(s, o))?;
        Ok(r.map(|(l, t)| (l.into_pyarray(py), t.into_pyarray(py))))
    })
}

/// Writes the window of the tiling by `index_map` at pixel `offset = (oy, ox)` into its first cell into `out`
/// `(H, W, C)`, every pixel read from `exemplar` `(EH, EW, C)` (same dtype as `out`: uint8, uint16, float32 or
/// int32) through `labels` / `table`. With `turns` `(8, 2, 2)` int8 (a normal map: the vector turn of every
/// symmetry, `tilesynth.builder.matching.augment.vector_turns`) the x and y of every pixel of a rotated or
/// mirrored entry are turned with it, exactly in the sample type (`snorm`: float samples are the vectors,
/// negated as `-c`; else `1 - c` for floats, `max - c` for codes; not for int32). GIL released.
#[pyfunction]
#[pyo3(signature = (exemplar, labels, table, index_map, offset, out, threads=None, turns=None, snorm=false))]
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
    turns: Option<PyReadonlyArray3<'py, i8>>,
    snorm: bool,
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
        let turns = turns.map(|t| vector_turns(&t)).transpose()?;
        macro_rules! dispatch {
            ($t:ty, $neg:expr) => {
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
                    let neg: Option<fn($t) -> $t> = $neg;
                    let turn = match (&turns, neg) {
                        (None, _) => None,
                        (Some(mt), Some(f)) => {
                            Some(provenance::VectorTurn::new(mt, f).map_err(errors::to_pyerr)?)
                        }
                        (Some(_), None) => {
                            return Err(errors::to_pyerr(crate::error::TilesynthError::param(
                                "turns",
                                "given for int32 samples",
                                "vectors are turned in uint8, uint16 or float32 samples",
                            )))
                        }
                    };
                    return run(py, threads, || {
                        provenance::gather_window_into(e, lab, t, m, offset, o, turn.as_ref())
                    });
                }
            };
        }
        dispatch!(u8, Some(|c: u8| u8::MAX - c));
        dispatch!(u16, Some(|c: u16| u16::MAX - c));
        if snorm {
            dispatch!(f32, Some(|c: f32| -c));
        } else {
            dispatch!(f32, Some(|c: f32| 1.0 - c));
        }
        dispatch!(i32, None);
        Err(errors::layout_error(
            "exemplar/out",
            "expected a 3-d exemplar and a 3-d writable out of the same native-endian dtype, uint8, uint16, \
             float32 or int32",
        ))
    })
}

/// The `(8, 2, 2)` vector turns of `turns`, or an error naming it.
pub(super) fn vector_turns(turns: &PyReadonlyArray3<'_, i8>) -> PyResult<[[[i8; 2]; 2]; 8]> {
    let t = turns.as_array();
    if t.dim() != (8, 2, 2) {
        return Err(errors::to_pyerr(crate::error::TilesynthError::shape(
            "turns",
            "(8, 2, 2) (a 2x2 turn per symmetry)",
            crate::error::fmt_shape(t.shape()),
        )));
    }
    let mut m = [[[0i8; 2]; 2]; 8];
    for ((s, r, c), &v) in t.indexed_iter() {
        m[s][r][c] = v;
    }
    Ok(m)
}

/// Registers the provenance functions.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(provenance_factorise, m)?)?;
    m.add_function(wrap_pyfunction!(provenance_gather, m)?)?;
    Ok(())
}
