//! Exhaustive SSD: one 3-channel template against a prebuilt index, at (image, template) sizes
//! (128, 80), (256, 128), (512, 256). Compare with `cv2.matchTemplate(I, T, cv2.TM_SQDIFF)` run on the same
//! machine (the target is at least 2x faster).

use _core::parallel::install;
use _core::ssd::SsdIndex;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use ndarray::Array3;
use std::hint::black_box;

const SIZES: &[(usize, usize)] = &[(128, 80), (256, 128), (512, 256)];
const CHANNELS: usize = 3;

/// Deterministic pseudo-random values in [0, 1) (splitmix64).
fn random(shape: (usize, usize, usize), seed: u64) -> Array3<f32> {
    let mut state = seed;
    Array3::from_shape_simple_fn(shape, || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    })
}

fn bench_ssd(c: &mut Criterion) {
    let mut group = c.benchmark_group("ssd");
    for &(n, m) in SIZES {
        let image = random((n, n, CHANNELS), 1 + n as u64);
        let template = random((m, m, CHANNELS), 2 + m as u64);
        let label = format!("{n}/{m}");
        let index = SsdIndex::new(image.view()).expect("valid image");
        // Build the lazily computed spectra (f32 for maps, f64 for best matches) before timing.
        index
            .ssd_map(template.view(), None)
            .expect("valid template");
        index
            .best_matches(template.view(), None, 1, 0)
            .expect("valid template");

        group.bench_with_input(BenchmarkId::new("ssd_map", &label), &(), |b, _| {
            b.iter(|| black_box(index.ssd_map(black_box(template.view()), None).unwrap()))
        });
        group.bench_with_input(BenchmarkId::new("ssd_map_t1", &label), &(), |b, _| {
            b.iter(|| {
                install(Some(1), || {
                    black_box(index.ssd_map(black_box(template.view()), None).unwrap())
                })
                .unwrap()
            })
        });
        group.bench_with_input(BenchmarkId::new("best_matches_k1", &label), &(), |b, _| {
            b.iter(|| {
                black_box(
                    index
                        .best_matches(black_box(template.view()), None, 1, 0)
                        .unwrap(),
                )
            })
        });
        group.bench_with_input(BenchmarkId::new("index_new", &label), &(), |b, _| {
            b.iter(|| black_box(SsdIndex::new(black_box(image.view())).unwrap()))
        });
        // One-shot use: build the index, then one map (the spectra are built lazily by the map).
        group.bench_with_input(BenchmarkId::new("new_plus_map_t1", &label), &(), |b, _| {
            b.iter(|| {
                install(Some(1), || {
                    let idx = SsdIndex::new(black_box(image.view())).unwrap();
                    black_box(idx.ssd_map(black_box(template.view()), None).unwrap())
                })
                .unwrap()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_ssd);
criterion_main!(benches);
