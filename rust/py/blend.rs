//! Bindings of [`crate::blend`]: the seam blend of smooth material maps over a window of a tiling.

use super::convert::{aligned, contiguous};
use super::errors::{self, guard};
use super::run;
use crate::blend::{self, Bands, Kind, MapBlend, Samples, SamplesMut};
use crate::error::try_to_owned;
use numpy::{
    Element, PyArray3, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyReadwriteArray3,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// A map's samples and window, borrowed in one of the sample types.
enum Borrowed<'py> {
    U8(PyReadonlyArray3<'py, u8>, PyReadwriteArray3<'py, u8>),
    U16(PyReadonlyArray3<'py, u16>, PyReadwriteArray3<'py, u16>),
    F32(PyReadonlyArray3<'py, f32>, PyReadwriteArray3<'py, f32>),
}

/// `codes` and `out` as arrays of `T`, borrowed (None when either is not one), checked C-contiguous and
/// aligned.
fn borrow<'py, T: Element>(
    codes: &Bound<'py, PyAny>,
    out: &Bound<'py, PyAny>,
) -> PyResult<Option<(PyReadonlyArray3<'py, T>, PyReadwriteArray3<'py, T>)>> {
    let (Ok(c), Ok(o)) = (codes.cast::<PyArray3<T>>(), out.cast::<PyArray3<T>>()) else {
        return Ok(None);
    };
    let c = c
        .try_readonly()
        .map_err(|_| errors::layout_error("codes", "array is being written elsewhere"))?;
    let o = o.try_readwrite().map_err(|_| {
        errors::layout_error(
            "out",
            "array is borrowed elsewhere (another map's codes or out, or not writeable)",
        )
    })?;
    contiguous("codes", &c)?;
    if !o.is_c_contiguous() {
        return Err(errors::layout_error("out", "array must be C-contiguous"));
    }
    aligned("out", &o)?;
    Ok(Some((c, o)))
}

/// The maps of a blend as the Python tuples give them.
type MapArgs<'py> = (
    String,
    Option<PyReadonlyArray3<'py, f64>>,
    Option<PyReadonlyArray3<'py, f64>>,
    Vec<f64>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
);

/// Blends the maps `maps` over the window of the tiling by `index_map` at pixel `offset = (oy, ox)` into its
/// first cell (`tilesynth.synth.seams`: the formula), writing each map's window. `maps`: a list of `(kind,
/// values, low, mu, codes, out)`: `kind` "scalar", "normal" or "normal-snorm" (a float normal map whose
/// samples are the vectors themselves); `codes` `(H, W, C)` the map's samples (uint8, uint16 or float32), what
/// the copies read and, over their maximum (255, 65535, 1), what a scalar map blends; `values` a normal map's
/// slopes `(H, W, 2)` float64 (None for a scalar map); `low` `(H, W, C)` float64 the low band of what a scalar
/// map blends at every pixel (when `low_level` is given, else None); `mu` the mean per channel of what is
/// blended; `out` `(h, w, C)` the window, the dtype of `codes`.
/// Every map is aligned with the exemplar (the same H, W). `high`: the high band's level (every map's);
/// `low_level` / `reach`: the low band's (scalar maps'), or None. `turns`: None, or one entry per map, None or
/// a normal map's vector turns `(8, 2, 2)` int8 (`tilesynth.builder.matching.augment.vector_turns`): its
/// entries' slopes and copied codes are turned with their symmetry; a rotated or mirrored entry needs them for
/// every normal map. GIL released.
#[pyfunction]
#[pyo3(signature = (maps, labels, table, index_map, offset, high, low_level, reach, threads=None, turns=None))]
#[allow(clippy::too_many_arguments)]
fn seam_blend<'py>(
    py: Python<'py>,
    maps: Vec<MapArgs<'py>>,
    labels: PyReadonlyArray3<'py, u8>,
    table: PyReadonlyArray3<'py, i32>,
    index_map: PyReadonlyArray2<'py, i32>,
    offset: (usize, usize),
    high: f64,
    low_level: Option<f64>,
    reach: usize,
    threads: Option<usize>,
    turns: Option<Vec<Option<PyReadonlyArray3<'py, i8>>>>,
) -> PyResult<()> {
    guard("seam_blend", || {
        let turns: Vec<Option<blend::Turns>> = match turns {
            None => vec![None; maps.len()],
            Some(t) if t.len() == maps.len() => t
                .iter()
                .map(|x| {
                    x.as_ref()
                        .map(|a| {
                            let m = super::provenance::vector_turns(a)?;
                            crate::provenance::VectorTurn::<f64>::new(&m, |v| -v)
                                .map(|v| v.sel)
                                .map_err(errors::to_pyerr)
                        })
                        .transpose()
                })
                .collect::<PyResult<_>>()?,
            Some(t) => {
                return Err(errors::to_pyerr(crate::error::TilesynthError::shape(
                    "turns",
                    format!("{} entries (one per map)", maps.len()),
                    format!("{} entries", t.len()),
                )))
            }
        };
        contiguous("labels", &labels)?;
        contiguous("table", &table)?;
        contiguous("index_map", &index_map)?;
        // owned copies of the small inputs: the values checked are the values used, whatever other Python
        // threads write while the GIL is released
        let map = try_to_owned("index_map", index_map.as_array()).map_err(errors::to_pyerr)?;
        let tab = try_to_owned("table", table.as_array()).map_err(errors::to_pyerr)?;
        let mut kinds = Vec::with_capacity(maps.len());
        let mut held = Vec::with_capacity(maps.len());
        let mut window: Option<(usize, usize)> = None;
        for (kind, values, low, _, codes, out) in &maps {
            kinds.push(match kind.as_str() {
                "scalar" => Kind::Scalar,
                "normal" => Kind::Normal { snorm: false },
                "normal-snorm" => Kind::Normal { snorm: true },
                _ => {
                    return Err(errors::to_pyerr(crate::error::TilesynthError::param(
                        "kind",
                        format!("{kind:?}"),
                        "must be \"scalar\", \"normal\" or \"normal-snorm\"",
                    )))
                }
            });
            if let Some(v) = values {
                contiguous("values", v)?;
            }
            if let Some(l) = low {
                contiguous("low", l)?;
            }
            let got = if let Some((c, o)) = borrow::<u8>(codes, out)? {
                Borrowed::U8(c, o)
            } else if let Some((c, o)) = borrow::<u16>(codes, out)? {
                Borrowed::U16(c, o)
            } else if let Some((c, o)) = borrow::<f32>(codes, out)? {
                Borrowed::F32(c, o)
            } else {
                return Err(errors::layout_error(
                    "codes/out",
                    "expected 3-d arrays of the same native-endian dtype, uint8, uint16 or float32",
                ));
            };
            let (c_dims, o_dims) = match &got {
                Borrowed::U8(c, o) => (c.dims(), o.dims()),
                Borrowed::U16(c, o) => (c.dims(), o.dims()),
                Borrowed::F32(c, o) => (c.dims(), o.dims()),
            };
            if c_dims[2] != o_dims[2] {
                return Err(errors::to_pyerr(crate::error::TilesynthError::shape(
                    "codes/out",
                    "(H, W, C) and (h, w, C) (one C)",
                    format!("{:?} and {:?}", c_dims, o_dims),
                )));
            }
            if *window.get_or_insert((o_dims[0], o_dims[1])) != (o_dims[0], o_dims[1]) {
                return Err(errors::to_pyerr(crate::error::TilesynthError::shape(
                    "out",
                    format!("{:?} (the first map's window)", window.unwrap_or_default()),
                    format!("{:?}", o_dims),
                )));
            }
            held.push(got);
        }
        let mut blends = Vec::with_capacity(maps.len());
        for ((((_, values, low, mu, _, _), got), &kind), turn) in
            maps.iter().zip(held.iter_mut()).zip(&kinds).zip(turns)
        {
            let (codes, dims, out) = match got {
                Borrowed::U8(c, o) => (
                    Samples::U8(c.as_slice()?),
                    c.dims(),
                    SamplesMut::U8(o.as_slice_mut()?),
                ),
                Borrowed::U16(c, o) => (
                    Samples::U16(c.as_slice()?),
                    c.dims(),
                    SamplesMut::U16(o.as_slice_mut()?),
                ),
                Borrowed::F32(c, o) => (
                    Samples::F32(c.as_slice()?),
                    c.dims(),
                    SamplesMut::F32(o.as_slice_mut()?),
                ),
            };
            blends.push(MapBlend {
                kind,
                size: (dims[0], dims[1]),
                values: values.as_ref().map(|v| v.as_array()),
                low: low.as_ref().map(|l| l.as_array()),
                mu: mu.clone(),
                codes,
                channels: dims[2],
                out,
                turn,
            });
        }
        let lab = labels.as_array();
        let bands = Bands {
            high,
            low: low_level.map(|lv| (lv, reach)),
        };
        let size = window.unwrap_or((0, 0));
        run(py, threads, || {
            blend::blend_maps(
                &mut blends,
                lab,
                tab.view(),
                map.view(),
                offset,
                bands,
                size,
            )
        })
    })
}

/// Registers the blend function.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(seam_blend, m)?)?;
    Ok(())
}
