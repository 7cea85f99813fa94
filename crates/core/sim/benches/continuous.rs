//! `cargo bench -p madenet-sim --bench continuous`: one simulated second (20 control periods)
//! of a continuous trial, NF agents, default sensor (360 beams at 5 Hz, 4 m), on generated
//! cluttered worlds. Real-time factor = 1 s / the time per iteration; issue 26 asks ≥ 500×
//! for 3 robots on 20 m and ≥ 100× for 6 robots on 60 m, on one core.
//!
//! * `sim_second/3_robots_20m`
//! * `sim_second/6_robots_60m`

use criterion::{criterion_group, criterion_main, Criterion};
use madenet_continuous::{scene::generate_cluttered, ContinuousConfig};
use madenet_map::Pos;
use madenet_sim::continuous::{ContinuousSpec, ContinuousTrial};
use madenet_sim::PolicyRegistry;
use madenet_world::ScenarioConfig;
use std::sync::Arc;

fn trial(side: f64, robots: usize, registry: &PolicyRegistry) -> ContinuousTrial {
    let n = side as i32;
    // Bottom-left, the paper's BL start: a row of cells one apart.
    let starts = (0..robots as i32)
        .map(|k| Pos::new(n - 2 - k % 2, 1 + k))
        .collect();
    let spec = ContinuousSpec {
        scene: Arc::new(generate_cluttered(side, 0.1, 1)),
        starts,
        config: ScenarioConfig {
            num_robots: robots,
            ..Default::default()
        },
        continuous: ContinuousConfig::default(),
        policy: "nf".into(),
        seed: 1,
    };
    let mut t = ContinuousTrial::new(spec, registry).expect("trial");
    // Into the trial: robots spread, maps filling.
    for _ in 0..200 {
        t.step();
    }
    t
}

fn bench(c: &mut Criterion) {
    let registry = PolicyRegistry::builtin();
    let mut g = c.benchmark_group("sim_second");
    g.sample_size(20);
    for (name, side, robots) in [("3_robots_20m", 20.0, 3), ("6_robots_60m", 60.0, 6)] {
        let mut t = trial(side, robots, &registry);
        g.bench_function(name, |b| {
            b.iter(|| {
                for _ in 0..20 {
                    if !t.step() {
                        t = trial(side, robots, &registry);
                    }
                }
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
