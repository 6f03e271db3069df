//! The synthesis tile copy: the whole tiling, or a window of it at a pixel offset (the hashed lookup's random
//! access).

use super::convert::{aligned, contiguous};
use super::errors::{self, guard};
use super::run;
use crate::error::{fmt_shape, try_to_owned, TilesynthError};
use crate::synth;
use numpy::{
    PyArrayMethods, PyReadonlyArray2, PyReadonlyArray4, PyReadwriteArray3, PyUntypedArrayMethods,
};
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
        let map_span = byte_span(&index_map);
        // An owned copy (a map has one cell per tile): the values the kernel validates are the ones it uses,
        // even if another Python thread writes into the caller's map while the GIL is released.
        let map = try_to_owned("index_map", index_map.as_array()).map_err(errors::to_pyerr)?;
        let map = map.view();
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
                    aligned("out", &o)?;
                    refuse_overlap(o.shape(), byte_span(&o), &[
                        ("atlas", byte_span(&a)),
                        ("index_map", map_span),
                    ])?;
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

/// The bytes `[start, end)` of a C-contiguous array's data (empty for an empty array).
fn byte_span<T: numpy::Element, D: ndarray::Dimension>(
    a: &numpy::PyReadonlyArray<'_, T, D>,
) -> std::ops::Range<usize> {
    let start = a.data() as usize;
    start..start + a.len() * std::mem::size_of::<T>()
}

/// A `ParameterError` if `out`'s bytes overlap those of an input. rust-numpy's borrow checking refuses a
/// mutable borrow of an array sharing its base object with a borrowed input, but two arrays made from the
/// same buffer through different objects (`numpy.frombuffer` of two memoryviews of one bytearray, an
/// mmap, ...) have different bases and pass it; copying from an input into memory that overlaps it would
/// alias a `&[T]` with a `&mut [T]` (undefined behaviour), so the addresses are compared here.
fn refuse_overlap(
    out_shape: &[usize],
    out: std::ops::Range<usize>,
    inputs: &[(&'static str, std::ops::Range<usize>)],
) -> PyResult<()> {
    for (name, span) in inputs {
        if !out.is_empty() && !span.is_empty() && out.start < span.end && span.start < out.end {
            return Err(errors::to_pyerr(TilesynthError::param(
                "out",
                format!("{} array", fmt_shape(out_shape)),
                format!("shares memory with {name}: write into a separate array"),
            )));
        }
    }
    Ok(())
}

/// Adds this family's bindings to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(tile_copy, m)?)?;
    m.add_function(wrap_pyfunction!(tile_copy_window, m)?)?;
    Ok(())
}
