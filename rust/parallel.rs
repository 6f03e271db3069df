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

/// The largest thread count accepted (explicit or from [`THREADS_ENV`]). More than any machine tilesynth is
/// meant for; a larger count is a mistake (a typo, an unsigned wrap-around) that would otherwise try to spawn
/// that many threads, each reserving a stack.
pub const MAX_THREADS: usize = 1024;

/// How many thread pools (one per distinct thread count) are kept alive between calls; the least recently
/// used one is dropped beyond that, so a caller cycling through thread counts cannot accumulate threads.
pub const MAX_POOLS: usize = 4;

/// Stack size of every pool worker: the default of Rust's threads (2 MiB), given explicitly so that spawning
/// a worker never reads `RUST_MIN_STACK` from the environment (an environment read is not safe while another
/// thread of the embedding process may be changing it; see `py::run`).
pub const WORKER_STACK_BYTES: usize = 2 << 20;

/// Resolves the thread count: the explicit value if any, else `TILESYNTH_NUM_THREADS`, else all cores.
pub fn resolve_threads(threads: Option<usize>) -> Result<usize> {
    match threads {
        Some(0) => Err(TilesynthError::param(
            "threads",
            0,
            "must be at least 1 (or None for all cores)",
        )),
        Some(n) if n > MAX_THREADS => Err(TilesynthError::param(
            "threads",
            n,
            format!("must be at most {MAX_THREADS}"),
        )),
        Some(n) => Ok(n),
        None => match std::env::var(THREADS_ENV) {
            Ok(s) if !s.trim().is_empty() => match s.trim().parse::<usize>() {
                Ok(n) if (1..=MAX_THREADS).contains(&n) => Ok(n),
                _ => Err(TilesynthError::param(
                    THREADS_ENV,
                    format!("{s:?}"),
                    format!("must be an integer in [1, {MAX_THREADS}]"),
                )),
            },
            _ => Ok(std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)),
        },
    }
}

/// Runs `f` on a local pool of `threads` workers (see [`resolve_threads`]). Pools are created once per
/// thread count and kept (at most [`MAX_POOLS`] of them, least recently used dropped first), so a kernel
/// call does not pay for spawning threads.
pub fn install<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    let n = resolve_threads(threads)?;
    let pool = {
        let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
        forget_pools_of_parent(&mut pools);
        pools.tick += 1;
        let tick = pools.tick;
        match pools.map.get_mut(&n) {
            Some((p, used)) => {
                *used = tick;
                Arc::clone(p)
            }
            None => {
                if pools.map.len() >= MAX_POOLS {
                    let oldest = pools
                        .map
                        .iter()
                        .min_by_key(|(_, (_, used))| *used)
                        .map(|(&k, _)| k);
                    if let Some(k) = oldest {
                        // Dropping our handle; a pool still running another call lives until it ends.
                        pools.map.remove(&k);
                    }
                }
                let p = Arc::new(
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(n)
                        .stack_size(WORKER_STACK_BYTES)
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
                pools.map.insert(n, (Arc::clone(&p), tick));
                p
            }
        }
    };
    Ok(pool.install(f))
}

/// The kept pools: thread count -> (pool, last use), the use counter, and the id of the process that
/// created them.
struct Pools {
    map: BTreeMap<usize, (Arc<rayon::ThreadPool>, u64)>,
    tick: u64,
    pid: u32,
}

static POOLS: Mutex<Pools> = Mutex::new(Pools {
    map: BTreeMap::new(),
    tick: 0,
    pid: 0,
});

/// Fork safety: a child created by `fork` (the default start method of Python's `multiprocessing` on Linux
/// before 3.14, Celery's prefork pool, ...) inherits the cache but not the pools' worker threads, so a job
/// sent to an inherited pool would wait forever. The cache is keyed by process id: in a new process the
/// inherited pools are forgotten (leaked, not dropped: dropping would signal threads that do not exist in
/// this process, through locks whose state was copied mid-use) and new ones are built on first use. The
/// leak is the inherited pool structures only, once per fork.
fn forget_pools_of_parent(pools: &mut Pools) {
    let pid = std::process::id();
    if pools.pid != pid {
        let inherited = std::mem::take(&mut pools.map);
        std::mem::forget(inherited);
        pools.pid = pid;
    }
}

/// Number of thread pools currently kept (for tests).
pub fn pools_kept() -> usize {
    let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
    forget_pools_of_parent(&mut pools);
    pools.map.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explicit_counts() {
        assert_eq!(resolve_threads(Some(3)).unwrap(), 3);
        assert!(resolve_threads(Some(0)).is_err());
        assert_eq!(install(Some(2), rayon::current_num_threads).unwrap(), 2);
        assert_eq!(install(Some(1), rayon::current_num_threads).unwrap(), 1);
        assert!(resolve_threads(Some(MAX_THREADS)).is_ok());
        let e = resolve_threads(Some(MAX_THREADS + 1)).unwrap_err();
        assert!(e.to_string().contains("at most 1024"), "{e}");
        assert!(install(Some(usize::MAX), || ()).is_err());
    }

    #[test]
    fn pool_cache_is_bounded() {
        for n in 1..=(MAX_POOLS + 3) {
            assert_eq!(install(Some(n), rayon::current_num_threads).unwrap(), n);
            assert!(pools_kept() <= MAX_POOLS);
        }
        // an evicted count is simply rebuilt
        assert_eq!(install(Some(1), rayon::current_num_threads).unwrap(), 1);
        assert!(pools_kept() <= MAX_POOLS);
    }
}
