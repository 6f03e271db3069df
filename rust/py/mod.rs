//! The Python extension module `tilesynth._core`, one binding file per kernel family (ssd, maxflow, omega,
//! population, poisson, synth, wang, io, testing). Each function borrows its arrays, releases the GIL around
//! the core kernel (`py.detach`) inside a local thread pool, and converts the result. Nothing here may panic.
//!
//! Constants that Python needs (default eps, Poisson tolerance, λ, ω, the thread cap, the Wang side indices)
//! are exported once from here (see [`add_constants`]); the Python layer imports them.

mod blend;
mod convert;
mod errors;
mod gradients;
mod hash;
mod io;
mod maxflow;
mod omega;
mod poisson;
mod population;
mod provenance;
mod ssd;
mod synth;
mod testing;
mod wang;

use crate::parallel;
use errors::{guard, to_pyerr};
use pyo3::prelude::*;

/// Runs a core kernel without the GIL on a pool of `threads` workers and maps its error.
///
/// The thread count is resolved before the GIL is released: without an explicit count it comes from
/// `TILESYNTH_NUM_THREADS`, read with `getenv`, and Python threads change the environment
/// (`os.environ[...] = ...`, i.e. `setenv`, which may move and free the `environ` array) holding the GIL. A
/// `getenv` without the GIL could race with that in a threaded caller (a `ThreadPoolExecutor` or Dask worker
/// running jobs that set the variable, as `build_many` does) and read freed memory.
fn run<R: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    f: impl FnOnce() -> crate::Result<R> + Send,
) -> PyResult<R> {
    let n = parallel::resolve_threads(threads).map_err(to_pyerr)?;
    py.detach(|| parallel::install(Some(n), f).and_then(|r| r))
        .map_err(to_pyerr)
}

/// Resolved thread count (explicit value, else TILESYNTH_NUM_THREADS, else all cores).
#[pyfunction]
#[pyo3(signature = (threads=None))]
fn resolve_threads(threads: Option<usize>) -> PyResult<usize> {
    guard("resolve_threads", || {
        parallel::resolve_threads(threads).map_err(to_pyerr)
    })
}

/// The constants shared with the Python layer (defined once, in the core).
fn add_constants(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("DEFAULT_EPS", crate::seams::DEFAULT_EPS)?;
    m.add("DEFAULT_POISSON_TOL", crate::poisson::DEFAULT_TOL)?;
    m.add("DEFAULT_LAMBDA", crate::population::DEFAULT_LAMBDA)?;
    m.add("DEFAULT_OMEGA", crate::wang::DEFAULT_OMEGA)?;
    m.add(
        "DEFAULT_CACHE_BYTES",
        crate::population::DEFAULT_CACHE_BYTES,
    )?;
    m.add("MAX_THREADS", parallel::MAX_THREADS)?;
    m.add("THREADS_ENV", parallel::THREADS_ENV)?;
    m.add(
        "WANG_SIDES",
        (
            crate::wang::NORTH,
            crate::wang::EAST,
            crate::wang::SOUTH,
            crate::wang::WEST,
        ),
    )?;
    Ok(())
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    add_constants(m)?;
    ssd::register(m)?;
    population::register(m)?;
    wang::register(m)?;
    maxflow::register(m)?;
    omega::register(m)?;
    poisson::register(m)?;
    synth::register(m)?;
    m.add_function(wrap_pyfunction!(resolve_threads, m)?)?;
    io::register(m)?;
    hash::register(m)?;
    testing::register(m)?;
    gradients::register(m)?;
    provenance::register(m)?;
    blend::register(m)?;
    Ok(())
}
