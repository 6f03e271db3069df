//! The synthesis tile copy: the whole tiling, or a window of it at a pixel offset (the hashed lookup's random
//! access).

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
    copy_window("tile_copy", py, atlas, index_map, (0, 0), out, threads)
}

/// Writes the window of the tiling by `index_map` whose top-left pixel is `offset = (oy, ox)` pixels into the
/// first cell into `out` `(H, W, C)` (same dtype as `atlas`: uint8, uint16, float32 or int32).
#[pyfunction]
#[pyo3(signature = (atlas, index_map, offset, out, threads=None))]
pub(super) fn tile_copy_window<'py>(
    py: Python<'py>,
    atlas: &Bound<'py, PyAny>,
    index_map: PyReadonlyArray2<'py, i32>,
    offset: (usize, usize),
    out: &Bound<'py, PyAny>,
    threads: Option<usize>,
) -> PyResult<()> {
    copy_window(
        "tile_copy_window",
        py,
        atlas,
        index_map,
        offset,
        out,
        threads,
    )
}

/// The dtype dispatch of both copies ([`synth::tile_copy_window_into`]; offset (0, 0) is the plain copy).
fn copy_window<'py>(
    what: &str,
    py: Python<'py>,
    atlas: &Bound<'py, PyAny>,
    index_map: PyReadonlyArray2<'py, i32>,
    offset: (usize, usize),
    out: &Bound<'py, PyAny>,
    threads: Option<usize>,
) -> PyResult<()> {
    guard(what, || {
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
                    if o.len() == 0 {
                        // numpy may give an empty array zero strides, which a mutable view refuses (a
                        // debug assertion of the numpy crate); an owned empty array of the same shape gets
                        // the same shape checks and writes nothing either way.
                        let sh = o.shape();
                        let mut empty = ndarray::Array3::<$t>::zeros((sh[0], sh[1], sh[2]));
                        return run(py, threads, || {
                            synth::tile_copy_window_into(a, map, offset, empty.view_mut())
                        });
                    }
                    let o = o.as_array_mut();
                    return run(py, threads, || {
                        synth::tile_copy_window_into(a, map, offset, o)
                    });
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
    m.add_function(wrap_pyfunction!(tile_copy_window, m)?)?;
    Ok(())
}
