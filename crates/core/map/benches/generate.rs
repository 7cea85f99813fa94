//! `cargo bench -p madenet-map`: the seeded map generator.
//!
//! * `generate/N` — one N × N map at the default densities (15–40 %), seed 1 (what
//!   `madenet map generate --height N --width N` does).
//! * `generate_wide/N` — one N × N map at [`WIDE_DENSITY`] (15–60 %), seed 1.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use madenet_map::generate::{generate, GeneratorConfig, WIDE_DENSITY};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("generate");
    g.sample_size(10);
    for n in [20, 100, 500] {
        let cfg = GeneratorConfig::for_size(n, n);
        g.bench_with_input(BenchmarkId::from_parameter(n), &cfg, |b, cfg| {
            b.iter(|| black_box(generate(cfg, 1).expect("generate")))
        });
    }
    g.finish();
    let mut g = c.benchmark_group("generate_wide");
    g.sample_size(10);
    for n in [20, 100, 500] {
        let cfg = GeneratorConfig {
            density_min: WIDE_DENSITY.0,
            density_max: WIDE_DENSITY.1,
            ..GeneratorConfig::for_size(n, n)
        };
        g.bench_with_input(BenchmarkId::from_parameter(n), &cfg, |b, cfg| {
            b.iter(|| black_box(generate(cfg, 1).expect("generate")))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
