//! Bindings of the image-file codecs: PNG (`crate::png`) and OpenEXR (`crate::openexr`). Every function
//! releases the GIL while it decodes or encodes.

use super::convert::contiguous;
use super::errors::{self, guard, layout_error};
use super::run;
use crate::{openexr, png};
use ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// Decodes PNG bytes: `(array (H, W, C) uint8 or uint16, exif bytes or None)`. Refuses more than
/// `max_pixels` pixels on the declared size, and every damaged file, with `ParameterError`.
#[pyfunction]
fn png_decode<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyBytes>,
    max_pixels: u64,
) -> PyResult<(Bound<'py, PyAny>, Option<Bound<'py, PyBytes>>)> {
    guard("png_decode", || {
        let bytes = data.as_bytes();
        let d = run(py, Some(1), || png::decode(bytes, max_pixels))?;
        let shape = (d.height, d.width, d.channels);
        let arr = match d.samples {
            png::Samples::U8(v) => Array3::from_shape_vec(shape, v)
                .map_err(|e| layout_error("png", &e.to_string()))?
                .into_pyarray(py)
                .into_any(),
            png::Samples::U16(v) => Array3::from_shape_vec(shape, v)
                .map_err(|e| layout_error("png", &e.to_string()))?
                .into_pyarray(py)
                .into_any(),
        };
        Ok((arr, d.exif.map(|e| PyBytes::new(py, &e))))
    })
}

/// Encodes a C-contiguous `(H, W, C)` uint8 or uint16 array (C = 1 to 4) as PNG bytes, compression
/// `"fast"`, `"default"` or `"best"`, parallel over row bands on `threads` workers (the bytes do not
/// depend on `threads`).
#[pyfunction]
#[pyo3(signature = (image, compression="default", threads=None))]
fn png_encode<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    compression: &str,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyBytes>> {
    guard("png_encode", || {
        let level = png::Compression::parse(compression).map_err(super::errors::to_pyerr)?;
        let file = if let Ok(a) = image.extract::<PyReadonlyArray3<'py, u8>>() {
            let (h, w, c) = (a.shape()[0], a.shape()[1], a.shape()[2]);
            let s = a
                .as_slice()
                .map_err(|_| layout_error("image", "array must be C-contiguous"))?;
            run(py, threads, || png::encode(s, w, h, c, 8, level))?
        } else if let Ok(a) = image.extract::<PyReadonlyArray3<'py, u16>>() {
            let (h, w, c) = (a.shape()[0], a.shape()[1], a.shape()[2]);
            let s = a
                .as_slice()
                .map_err(|_| layout_error("image", "array must be C-contiguous"))?;
            run(py, threads, || {
                let be: Vec<u8> = s.iter().flat_map(|v| v.to_be_bytes()).collect();
                png::encode(&be, w, h, c, 16, level)
            })?
        } else {
            return Err(layout_error(
                "image",
                "expected a 3-d uint8 or uint16 array (H, W, C)",
            ));
        };
        Ok(PyBytes::new(py, &file))
    })
}

/// Decodes OpenEXR bytes (the first layer): `(float32 (H, W, C), channel names, all channels half)`.
#[pyfunction]
#[allow(clippy::type_complexity)]
fn exr_decode<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyBytes>,
    max_pixels: u64,
) -> PyResult<(Bound<'py, PyArray3<f32>>, Vec<String>, bool)> {
    guard("exr_decode", || {
        let bytes = data.as_bytes();
        let d = run(py, Some(1), || openexr::read(bytes, max_pixels))?;
        let arr = Array3::from_shape_vec((d.height, d.width, d.names.len()), d.samples)
            .map_err(|e| layout_error("exr", &e.to_string()))?;
        Ok((arr.into_pyarray(py), d.names, d.half))
    })
}

/// Encodes a C-contiguous float32 `(H, W, C)` array as OpenEXR bytes, half or float channels, ZIP.
#[pyfunction]
#[pyo3(signature = (image, half=false))]
fn exr_encode<'py>(
    py: Python<'py>,
    image: PyReadonlyArray3<'py, f32>,
    half: bool,
) -> PyResult<Bound<'py, PyBytes>> {
    guard("exr_encode", || {
        let (h, w, c) = (image.shape()[0], image.shape()[1], image.shape()[2]);
        let s = image
            .as_slice()
            .map_err(|_| layout_error("image", "array must be C-contiguous"))?;
        let file = run(py, Some(1), || openexr::write(s, w, h, c, half))?;
        Ok(PyBytes::new(py, &file))
    })
}

/// PNG scanline unfiltering: `data` (uint8, `rows * (row_bytes + 1)` bytes: a filter byte, then the row) ->
/// the raw bytes, uint8 `(rows, row_bytes)`; `bpp` bytes per pixel (1 to 8).
#[pyfunction]
pub(super) fn png_unfilter<'py>(
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

/// Registers the functions of this file on the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(png_unfilter, m)?)?;
    m.add_function(wrap_pyfunction!(png_decode, m)?)?;
    m.add_function(wrap_pyfunction!(png_encode, m)?)?;
    m.add_function(wrap_pyfunction!(exr_decode, m)?)?;
    m.add_function(wrap_pyfunction!(exr_encode, m)?)?;
    Ok(())
}
