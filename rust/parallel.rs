//! Thread control. Every parallel kernel runs inside [`install`], which uses a local rayon pool of the
//! requested size, so a `threads` argument never changes the global pool of an embedding application.
//!
//! Determinism: kernels split work into fixed chunks that do not depend on the thread count and combine
//! results in a fixed order, so the same inputs give bit-identical outputs at any number of threads.

use crate::error::{Result, TilesynthError};
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

/// Environment variable read when no explicit thread count is given.
pub const THREADS_ENV: &str = "TILESYNTH_NUM_THREADS";

/// Resolves the thread count: the explicit value if any, else `TILESYNTH_NUM_THREADS`, else all cores.
pub fn resolve_threads(threads: Option<usize>) -> Result<usize> {
    match threads {
        Some(0) => Err(TilesynthError::param(
            "threads",
            0,
            "must be at least 1 (or None for all cores)",
        )),
        Some(n) => Ok(n),
        None => match std::env::var(THREADS_ENV) {
            Ok(s) if !s.trim().is_empty() => match s.trim().parse::<usize>() {
                Ok(n) if n >= 1 => Ok(n),
                _ => Err(TilesynthError::param(
                    THREADS_ENV,
                    format!("{s:?}"),
                    "must be a positive integer",
                )),
            },
            _ => Ok(std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)),
        },
    }
}

/// Runs `f` on a local pool of `threads` workers (see [`resolve_threads`]). Pools are created once per
/// thread count and kept, so a kernel call does not pay for spawning threads.
pub fn install<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    let n = resolve_threads(threads)?;
    let pool = {
        let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
        match pools.get(&n) {
            Some(p) => Arc::clone(p),
            None => {
                let p = Arc::new(
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(n)
                        .thread_name(|i| format!("tilesynth-{i}"))
                        .build()
                        .map_err(|e| {
                            TilesynthError::param(
                                "threads",
                                n,
                                format!("cannot start thread pool: {e}"),
                            )
                        })?,
                );
                pools.insert(n, Arc::clone(&p));
                p
            }
        }
    };
    Ok(pool.install(f))
}

static POOLS: Mutex<BTreeMap<usize, Arc<rayon::ThreadPool>>> = Mutex::new(BTreeMap::new());

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explicit_counts() {
        assert_eq!(resolve_threads(Some(3)).unwrap(), 3);
        assert!(resolve_threads(Some(0)).is_err());
        assert_eq!(install(Some(2), rayon::current_num_threads).unwrap(), 2);
        assert_eq!(install(Some(1), rayon::current_num_threads).unwrap(), 1);
    }
}
