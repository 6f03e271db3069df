//! ω cutting-curve min-cut at tile sizes 80, 160, 256: Kwatra weights alone, and weights + graph + solve
//! (the whole `omega_cut`, the figure compared with PyMaxflow's pipeline in benches/compare.py), on one
//! thread and on two.
//!
//! Inputs are deterministic procedural textures (smooth value noise plus grain), arranged like the real case:
//! the intermediate tile is four quadrants of four different crops, the candidate another crop.

use _core::omega::{circle_mask, kwatra_weights, omega_cut, DEFAULT_EPS};
use _core::parallel::install;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;

mod common;
use common::omega_pair;

fn bench_cut(c: &mut Criterion) {
    let mut group = c.benchmark_group("omega_cut");
    for n in [80usize, 160, 256] {
        let (a, b) = omega_pair(n);
        let inside = circle_mask(n);
        group.bench_with_input(BenchmarkId::new("weights", n), &n, |bench, _| {
            bench.iter(|| {
                kwatra_weights(
                    black_box(a.view()),
                    b.view(),
                    Some(inside.view()),
                    DEFAULT_EPS,
                    None,
                )
                .unwrap()
            })
        });
        group.bench_with_input(
            BenchmarkId::new("weights+build+solve", n),
            &n,
            |bench, _| {
                bench.iter(|| {
                    install(Some(1), || {
                        omega_cut(black_box(a.view()), b.view(), DEFAULT_EPS, None, false).unwrap()
                    })
                    .unwrap()
                })
            },
        );
        // The four quadrants of the cut are independent networks, solved in parallel.
        group.bench_with_input(
            BenchmarkId::new("weights+build+solve threads=2", n),
            &n,
            |bench, _| {
                bench.iter(|| {
                    install(Some(2), || {
                        omega_cut(black_box(a.view()), b.view(), DEFAULT_EPS, None, false).unwrap()
                    })
                    .unwrap()
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, bench_cut);
criterion_main!(benches);
