//! The synthesis tile copy.

use super::convert::contiguous;
use super::errors::{self, guard};
use super::run;
use crate::synth;
use numpy::{PyReadonlyArray2, PyReadonlyArray4, PyReadwriteArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Writes tiles into `out` `(H, W, C)` by `index_map`; `atlas` `(K, th, tw, C)` and `out` share a dtype
/// (uint8, uint16, float32 or int32).
#[pyfunction]
#[pyo3(signature = (atlas, index_map, out, threads=None))]
pub(super) fn tile_copy<'py>(
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

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(tile_copy, m)?)?;
    Ok(())
}
