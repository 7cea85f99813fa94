//! `cargo bench -p madenet-sim`: the simulator's hot paths on the paper's maps.
//!
//! * `nf_40_trials` — the 40 NF trials of one CSP (10 paper maps × 4 corner starts), the
//!   figure compared with the authors' Python simulator (12.6 s on this machine).
//! * `nf_trial/test_5` — one NF trial.
//! * `world_step` — one world timestep (motion, sensing, contact & comms) of 3 robots.

use criterion::{criterion_group, criterion_main, Criterion};
use madenet_map::paper::{paper_map, Corner, PAPER_MAP_COUNT};
use madenet_sim::{Trial, TrialSpec};
use madenet_world::{Move, ScenarioConfig, World};
use std::hint::black_box;

fn specs(csp: f64) -> Vec<TrialSpec> {
    let mut v = Vec::new();
    for n in 1..=PAPER_MAP_COUNT {
        let map = paper_map(n).expect("paper map");
        for c in Corner::ALL {
            v.push(TrialSpec {
                starts: c.start_cells(20, 20).to_vec(),
                map: map.clone(),
                map_name: format!("test_{n}"),
                config: ScenarioConfig {
                    comm_success_prob: csp,
                    ..Default::default()
                },
                policy: "nf".into(),
                seed: 1,
            });
        }
    }
    v
}

fn bench(c: &mut Criterion) {
    let all = specs(1.0);
    c.bench_function("nf_40_trials", |b| {
        b.iter(|| {
            for s in &all {
                black_box(Trial::new(s.clone()).expect("trial").run());
            }
        })
    });
    let one = all[4 * 4].clone(); // test_5, top-left
    c.bench_function("nf_trial/test_5", |b| {
        b.iter(|| black_box(Trial::new(one.clone()).expect("trial").run()))
    });
    let world = World::new(
        paper_map(5).expect("map"),
        &Corner::TopLeft.start_cells(20, 20),
        ScenarioConfig::default(),
        1,
    )
    .expect("world");
    let moves = [Move::E, Move::S, Move::SE];
    c.bench_function("world_step", |b| {
        b.iter_batched_ref(
            || world.clone(),
            |w| w.step(black_box(&moves)),
            criterion::BatchSize::SmallInput,
        )
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = bench
}
criterion_main!(benches);
