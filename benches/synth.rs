//! Synthesis copy throughput: 8192x8192 RGB8 output from 16 tiles of 64x64 (the P5 anchor's case), plus a size
//! sweep, at 1 and 2 threads. The output buffer is allocated once (as with a preallocated numpy array).

use _core::parallel::install;
use _core::synth::tile_copy_into;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use ndarray::{Array2, Array3, Array4};
use std::hint::black_box;

fn bench_copy(c: &mut Criterion) {
    let mut group = c.benchmark_group("tile_copy_rgb8");
    group.sample_size(20);
    let tile = 64;
    let atlas = Array4::from_shape_fn((16, tile, tile, 3), |(k, y, x, ch)| {
        (k * 13 + y * 7 + x * 3 + ch) as u8
    });
    for size in [1024usize, 4096, 8192] {
        let cells = size / tile;
        let map = Array2::from_shape_fn((cells, cells), |(i, j)| ((i * 31 + j * 17) % 16) as i32);
        let mut out = Array3::<u8>::zeros((size, size, 3));
        group.throughput(Throughput::Bytes((size * size * 3) as u64));
        for threads in [1usize, 2] {
            group.bench_with_input(
                BenchmarkId::new(format!("{threads}thr"), size),
                &size,
                |b, _| {
                    b.iter(|| {
                        install(Some(threads), || {
                            tile_copy_into(atlas.view(), black_box(map.view()), out.view_mut())
                        })
                        .unwrap()
                        .unwrap()
                    })
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench_copy);
criterion_main!(benches);
