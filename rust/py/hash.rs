//! Bindings of the hashed lookup (`rust/hash.rs`, `HASH-SPEC.md`); the windowed tile copy is in `synth.rs`.

use super::convert::{aligned, numpy_shape};
use super::errors::{guard, to_pyerr};
use super::run;
use crate::error::TilesynthError;
use crate::hash;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

/// A seed in [0, 2^32): any other int is a `ParameterError` naming `seed` (no silent masking).
fn seed_arg(seed: &Bound<'_, PyAny>) -> PyResult<u32> {
    if let Ok(s) = seed.extract::<u32>() {
        return Ok(s);
    }
    if seed.is_instance_of::<pyo3::types::PyInt>() {
        return Err(to_pyerr(TilesynthError::param(
            "seed",
            seed.str()?.to_string(),
            "must be an integer in [0, 2^32)",
        )));
    }
    Err(PyTypeError::new_err(format!(
        "seed: expected an int, got {}",
        seed.get_type().name()?
    )))
}

/// The lookup scheme from its kind (`"corner"`: `colours = [k]`, `"edge"`: `colours = [kh, kv]`).
fn scheme_arg(kind: &str, colours: &[u32], variants: u32) -> PyResult<hash::Scheme> {
    let s = match (kind, colours) {
        ("corner", [k]) => hash::Scheme::Corner { k: *k, v: variants },
        ("edge", [kh, kv]) => hash::Scheme::Edge {
            kh: *kh,
            kv: *kv,
            v: variants,
        },
        _ => {
            return Err(to_pyerr(TilesynthError::param(
                "kind/colours",
                format!("{kind:?} with {colours:?}"),
                "expected \"corner\" with [k] or \"edge\" with [kh, kv]",
            )))
        }
    };
    s.validate().map_err(to_pyerr)?;
    Ok(s)
}

/// `ts_hash(x, y, seed, role)` of every pair of int32 arrays `x`, `y` (same length): uint32.
#[pyfunction]
#[pyo3(signature = (x, y, seed, role))]
fn ts_hash<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, i32>,
    y: PyReadonlyArray1<'py, i32>,
    seed: &Bound<'py, PyAny>,
    role: u32,
) -> PyResult<Bound<'py, PyArray1<u32>>> {
    guard("ts_hash", || {
        let seed = seed_arg(seed)?;
        aligned("x", &x)?;
        aligned("y", &y)?;
        let (x, y) = (x.as_array(), y.as_array());
        if x.len() != y.len() {
            return Err(to_pyerr(TilesynthError::shape(
                "y",
                format!("({},) (the length of x)", x.len()),
                format!("({},)", y.len()),
            )));
        }
        let out: Vec<u32> = py.detach(|| {
            x.iter()
                .zip(y.iter())
                .map(|(&a, &b)| hash::ts_hash(a, b, seed, role))
                .collect()
        });
        Ok(out.into_pyarray(py))
    })
}

/// The int32 `(rows, cols)` tile index map of the cells `cx0 .. cx0 + cols`, `cy0 .. cy0 + rows` of a complete
/// set (`kind` `"corner"` with `colours = [k]` or `"edge"` with `[kh, kv]`, `variants` per tuple). Pairs are
/// x first, as in the spec: `origin = (cx0, cy0)`, `size = (cols, rows)`, `wrap = (tx, ty)` cells (periodic).
#[pyfunction]
#[pyo3(signature = (kind, colours, variants, seed, origin, size, wrap=None, threads=None))]
#[allow(clippy::too_many_arguments)]
fn hashed_index_map<'py>(
    py: Python<'py>,
    kind: &str,
    colours: Vec<u32>,
    variants: u32,
    seed: &Bound<'py, PyAny>,
    origin: (i64, i64),
    size: (usize, usize),
    wrap: Option<(u32, u32)>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray2<i32>>> {
    guard("hashed_index_map", || {
        let seed = seed_arg(seed)?;
        let scheme = scheme_arg(kind, &colours, variants)?;
        let (cols, rows) = size;
        // 2^28 cells (1 GiB of int32) is a map for a ~10^12-pixel texture: anything larger is a mistake, and
        // an allocation failure would abort the process instead of raising. Each side is bounded too: an
        // empty map of shape (2^62, 0) has no cells, but numpy refuses to make it, and rust-numpy 0.30's
        // `into_pyarray` does not check for that refusal (it sets the base object of a null array: the
        // SIGSEGV "inside hashed_index_map" of issue 16, `size = (0, 2**63 - 1)` from the fuzzer).
        if rows.saturating_mul(cols) > 1 << 28 || rows.max(cols) > 1 << 28 {
            return Err(to_pyerr(TilesynthError::param(
                "size",
                format!("({cols}, {rows})"),
                "more than 2^28 cells in one index map, or a side longer than 2^28 cells",
            )));
        }
        let map = run(py, threads, || {
            hash::index_map(scheme, seed, origin.0, origin.1, rows, cols, wrap)
        })?;
        numpy_shape("size", map.shape(), std::mem::size_of::<i32>())?;
        Ok(map.into_pyarray(py))
    })
}

/// Registers the functions and the hash's name and constants (`HASH_NAME`, `HASH_PCG_MUL`, `HASH_PCG_INC`,
/// `HASH_ROLE_MUL`, `HASH_ROLES`).
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("HASH_NAME", hash::HASH_NAME)?;
    m.add("HASH_PCG_MUL", hash::PCG_MUL)?;
    m.add("HASH_PCG_INC", hash::PCG_INC)?;
    m.add("HASH_ROLE_MUL", hash::ROLE_MUL)?;
    m.add(
        "HASH_ROLES",
        (
            hash::ROLE_VERTEX,
            hash::ROLE_HEDGE,
            hash::ROLE_VEDGE,
            hash::ROLE_VARIANT,
        ),
    )?;
    m.add_function(wrap_pyfunction!(ts_hash, m)?)?;
    m.add_function(wrap_pyfunction!(hashed_index_map, m)?)?;
    Ok(())
}
