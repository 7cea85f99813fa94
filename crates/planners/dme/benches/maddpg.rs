//! DME-DRL's costs: one MADDPG update (3 critics + 3 actors, each on a minibatch of 100 of
//! its robot's transitions, the original's batch) and one actor decision (batch 1), on 1 learner thread.

use burn::tensor::{Device, Tensor, TensorData};
use criterion::{criterion_group, criterion_main, Criterion};
use madenet_dme::maddpg::{Batch, Maddpg, UpdateParams};
use madenet_dme::nets::DmeConfig;
use madenet_dme::SECTORS;
use rand::RngExt;

fn batch(cfg: &DmeConfig, b: usize, seed: u64) -> Batch {
    let mut rng = madenet_world::rng::stream(seed, "bench", 0);
    let n = cfg.team_size;
    let maps = n * cfg.robot_channels() * cfg.map_height * cfg.map_width;
    let mut bits = |len: usize| {
        (0..len)
            .map(|_| (rng.random::<f32>() < 0.3) as u8 as f32)
            .collect::<Vec<f32>>()
    };
    let maps_a = bits(b * maps);
    let maps_b = bits(b * maps);
    let masks = vec![1.0; b * n * SECTORS];
    let mut actions = vec![0.0; b * n * SECTORS];
    for k in 0..b * n {
        actions[k * SECTORS + k % SECTORS] = 1.0;
    }
    Batch {
        size: b,
        maps: maps_a,
        next_maps: maps_b,
        poses: vec![0.5; b * n * cfg.pose_len()],
        next_poses: vec![0.5; b * n * cfg.pose_len()],
        next_actions: actions.clone(),
        actions,
        masks: masks.clone(),
        next_masks: masks,
        next_deciding: vec![1.0; b * n],
        rewards: vec![0.01; b],
        discounts: vec![0.9; b],
    }
}

fn bench(c: &mut Criterion) {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .ok();
    let cfg = DmeConfig::new();
    let device = Device::flex().autodiff();
    device.seed(1);
    let mut nets = Maddpg::new(&cfg, &device);
    let params = UpdateParams {
        tau: 0.01,
        actor_lr: 1e-3,
        critic_lr: 1e-3,
        temperature: 1.0,
        logit_penalty: 1e-3,
    };
    let b: Vec<Batch> = (0..cfg.team_size)
        .map(|i| batch(&cfg, 100, i as u64))
        .collect();
    let mut rng = madenet_world::rng::stream(1, "bench/noise", 0);
    c.bench_function("maddpg_update_b100", |bench| {
        bench.iter(|| nets.update(&b, &mut rng, &params))
    });
    let actor = nets.acting_actor(0);
    let plain = Device::flex();
    let (h, w) = (cfg.map_height, cfg.map_width);
    let maps = vec![0.0f32; cfg.robot_channels() * h * w];
    c.bench_function("dme_actor_decision", |bench| {
        bench.iter(|| {
            let m = Tensor::<4>::from_data(
                TensorData::new(maps.clone(), [1, cfg.robot_channels(), h, w]),
                &plain,
            );
            let p = Tensor::<2>::from_data(
                TensorData::new(vec![0.5; cfg.pose_len()], [1, cfg.pose_len()]),
                &plain,
            );
            actor.forward(m, p).into_data()
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
