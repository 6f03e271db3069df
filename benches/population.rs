//! Population evaluation of the ω-tile objective: P = 40 individuals of the N2-sized problem (n = 6 patches,
//! m = 38 tiles, deterministic 4-tuples over the 6 patches), RGB exemplar/tile sizes 128/80 and 256/128, at 1
//! and 2 threads:
//!
//! - `warm`: every partial map cached (the same population again; the cost of the sums, minima and exact
//!   re-evaluations). Divide by 40 for the cost of one individual.
//! - `cold`: the cache cleared before each evaluation (960 FFT partial maps, then the same as `warm`).
//! - `ga_step`: one GA-like generation: one random gene of every individual moves, then the population is
//!   evaluated (up to 160 new partial maps per call; the rest come from the cache).

use _core::parallel::install;
use _core::population::{PopulationEvaluator, DEFAULT_CACHE_BYTES};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use ndarray::{Array2, Array3};
use std::hint::black_box;
use std::time::Duration;

const SIZES: &[(usize, usize)] = &[(128, 80), (256, 128)];
const P: usize = 40;
const N_PATCHES: usize = 6;
const M_TILES: usize = 38;

/// splitmix64.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

fn exemplar(size: usize, rng: &mut Rng) -> Array3<f32> {
    Array3::from_shape_simple_fn((size, size, 3), || {
        (rng.next() >> 40) as f32 / (1u64 << 24) as f32
    })
}

/// 38 distinct 4-tuples over 6 patches, deterministic.
fn tiles(rng: &mut Rng) -> Array2<i64> {
    let mut out: Vec<[i64; 4]> = Vec::new();
    while out.len() < M_TILES {
        let t = [0; 4].map(|_| rng.below(N_PATCHES) as i64);
        if !out.contains(&t) {
            out.push(t);
        }
    }
    Array2::from_shape_fn((M_TILES, 4), |(j, q)| out[j][q])
}

fn genes(rng: &mut Rng, range: usize) -> Array3<i64> {
    Array3::from_shape_simple_fn((P, N_PATCHES, 2), || rng.below(range + 1) as i64)
}

fn bench_population(c: &mut Criterion) {
    let mut group = c.benchmark_group("population");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(4));
    for &(size, n) in SIZES {
        let mut rng = Rng(size as u64);
        let img = exemplar(size, &mut rng);
        let tp = tiles(&mut rng);
        let g = genes(&mut rng, size - n);
        let label = format!("{size}/{n}");
        for threads in [1usize, 2] {
            let ev = PopulationEvaluator::new(
                img.view(),
                n,
                tp.view(),
                N_PATCHES,
                0.8,
                false,
                DEFAULT_CACHE_BYTES,
            )
            .expect("valid problem");
            install(Some(threads), || ev.evaluate(g.view()).unwrap()).unwrap();
            group.bench_with_input(
                BenchmarkId::new(format!("warm_{threads}thr"), &label),
                &(),
                |b, _| {
                    b.iter(|| {
                        install(Some(threads), || {
                            black_box(ev.evaluate(black_box(g.view())).unwrap())
                        })
                        .unwrap()
                    })
                },
            );
            group.bench_with_input(
                BenchmarkId::new(format!("cold_{threads}thr"), &label),
                &(),
                |b, _| {
                    b.iter(|| {
                        ev.clear_cache();
                        install(Some(threads), || {
                            black_box(ev.evaluate(black_box(g.view())).unwrap())
                        })
                        .unwrap()
                    })
                },
            );
            let mut pop = g.clone();
            let mut step_rng = Rng(99);
            ev.clear_cache();
            install(Some(threads), || ev.evaluate(pop.view()).unwrap()).unwrap();
            group.bench_with_input(
                BenchmarkId::new(format!("ga_step_{threads}thr"), &label),
                &(),
                |b, _| {
                    b.iter(|| {
                        for i in 0..P {
                            let k = step_rng.below(N_PATCHES);
                            pop[[i, k, 0]] = step_rng.below(size - n + 1) as i64;
                            pop[[i, k, 1]] = step_rng.below(size - n + 1) as i64;
                        }
                        install(Some(threads), || {
                            black_box(ev.evaluate(black_box(pop.view())).unwrap())
                        })
                        .unwrap()
                    })
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench_population);
criterion_main!(benches);
