//! `cargo bench -p madenet-learn`: the networks on the `flex` CPU device (no autodiff).
//!
//! * `cep_act_b1` — one CEP decision: `act` on batch 1 (20×20 map, 3 robots, 4 candidates),
//!   with a carried LSTM state.
//! * `cep_forward_b16_t20` — one CEP `forward` over 16 sequences × 20 macro steps (the paper's
//!   batch of 16), no gradient.
//! * `dep_act_b1` — one DEP decision, for comparison.

use criterion::{criterion_group, criterion_main, Criterion};
use madenet_learn::{cpu, NetConfig, Tensor};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let device = cpu();
    device.seed(1);
    let cep = NetConfig::cep(20, 20, 3, 4);
    let cep_net = cep.init(&device).expect("CEP");
    let maps = Tensor::<4>::ones([1, 4, 20, 20], &device);
    let obs = Tensor::<2>::ones([1, cep.obs_dim], &device);
    let (_, state) = cep_net.act(maps.clone(), obs.clone(), None);
    c.bench_function("cep_act_b1", |b| {
        b.iter(|| {
            let (q, s) = cep_net.act(maps.clone(), obs.clone(), Some(state.clone()));
            black_box((q.into_data(), s));
        })
    });

    let seq_maps = Tensor::<5>::ones([16, 20, 4, 20, 20], &device);
    let seq_obs = Tensor::<3>::ones([16, 20, cep.obs_dim], &device);
    let mut group = c.benchmark_group("sequence");
    group.sample_size(20);
    group.bench_function("cep_forward_b16_t20", |b| {
        b.iter(|| {
            let (q, _) = cep_net.forward(seq_maps.clone(), seq_obs.clone(), None);
            black_box(q.into_data());
        })
    });
    group.finish();

    let dep = NetConfig::dep(20, 20, 3, 4);
    let dep_net = dep.init(&device).expect("DEP");
    let obs = Tensor::<2>::ones([1, dep.obs_dim], &device);
    c.bench_function("dep_act_b1", |b| {
        b.iter(|| {
            let (q, s) = dep_net.act(maps.clone(), obs.clone(), None);
            black_box((q.into_data(), s));
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
