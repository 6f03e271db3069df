//! Poisson smoothing (guided interpolation inside the ω cutting curve) per tile, 3 channels, at tile sizes 80,
//! 160 and 256, for two regions:
//!
//! - `disc`: the disc of radius N/2 − 2 centred on the tile (the region of the shared anchor figures: 4,548
//!   unknowns at 80, 49,884 at 256);
//! - `omega`: a real cutting curve, the `takes_o` mask of `omega_cut` between an intermediate tile (four quadrants
//!   of four crops of a procedural texture) and another crop, border ring kept.
//!
//! One thread (the channels run one after another) and two (channels in parallel). The iteration counts and
//! residuals are printed once per case.

use _core::omega::{omega_cut, DEFAULT_EPS};
use _core::parallel::install;
use _core::poisson::{poisson_smooth, DEFAULT_TOL};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use ndarray::Array2;
use std::hint::black_box;

mod common;
use common::omega_pair;

fn disc(n: usize) -> Array2<bool> {
    let c = (n as f64 - 1.0) / 2.0;
    let r = n as f64 / 2.0 - 2.0;
    Array2::from_shape_fn((n, n), |(y, x)| {
        let (dy, dx) = (y as f64 - c, x as f64 - c);
        dy * dy + dx * dx <= r * r
    })
}

fn bench_poisson(c: &mut Criterion) {
    let mut group = c.benchmark_group("poisson");
    for n in [80usize, 160, 256] {
        let (i, o) = omega_pair(n);
        let omega = omega_cut(i.view(), o.view(), DEFAULT_EPS, None, true)
            .unwrap()
            .takes_o;
        for (name, region) in [("disc", disc(n)), ("omega", omega)] {
            let (_, info) = poisson_smooth(i.view(), o.view(), region.view(), DEFAULT_TOL).unwrap();
            eprintln!(
                "poisson {name} N={n}: {} unknowns, {} iterations, residuals {:?}",
                info.unknowns, info.iterations, info.residual
            );
            for threads in [1usize, 2] {
                group.bench_with_input(
                    BenchmarkId::new(format!("{name} threads={threads}"), n),
                    &n,
                    |bench, _| {
                        bench.iter(|| {
                            install(Some(threads), || {
                                poisson_smooth(
                                    black_box(i.view()),
                                    o.view(),
                                    region.view(),
                                    DEFAULT_TOL,
                                )
                                .unwrap()
                            })
                            .unwrap()
                        })
                    },
                );
            }
        }
    }
    group.finish();
}

criterion_group!(benches, bench_poisson);
criterion_main!(benches);
