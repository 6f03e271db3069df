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
use ndarray::{s, Array2, Array3};
use std::hint::black_box;

fn texture(h: usize, w: usize, seed: u64) -> Array3<f32> {
    let mut state = seed.wrapping_mul(0x9E3779B97F4A7C15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let cell = 12;
    let (gh, gw) = (h / cell + 2, w / cell + 2);
    let grid: Vec<[f32; 3]> = (0..gh * gw).map(|_| [next(), next(), next()]).collect();
    Array3::from_shape_fn((h, w, 3), |(y, x, c)| {
        let (fy, fx) = (y as f32 / cell as f32, x as f32 / cell as f32);
        let (iy, ix) = (fy as usize, fx as usize);
        let (ty, tx) = (fy - iy as f32, fx - ix as f32);
        let g = |a: usize, b: usize| grid[a * gw + b][c];
        let v = g(iy, ix) * (1.0 - ty) * (1.0 - tx)
            + g(iy + 1, ix) * ty * (1.0 - tx)
            + g(iy, ix + 1) * (1.0 - ty) * tx
            + g(iy + 1, ix + 1) * ty * tx;
        (0.8 * v + 0.2 * next()).clamp(0.0, 1.0)
    })
}

/// Intermediate tile I (four quadrants of four crops) and matching patch O (another crop).
fn omega_pair(n: usize) -> (Array3<f32>, Array3<f32>) {
    let ex = texture(2 * n + 8, 2 * n + 8, n as u64);
    let h = n / 2;
    let mut a = Array3::<f32>::zeros((n, n, 3));
    let corners = [(0, 0), (3, n + 5), (n + 2, 7), (n + 6, n + 1)];
    for (q, &(r, c)) in corners.iter().enumerate() {
        let (ty, tx) = ((q / 2) * h, (q % 2) * h);
        a.slice_mut(s![ty..ty + h, tx..tx + h, ..])
            .assign(&ex.slice(s![r..r + h, c..c + h, ..]));
    }
    let b = ex
        .slice(s![n / 3..n / 3 + n, n / 2..n / 2 + n, ..])
        .to_owned();
    (a, b)
}

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
