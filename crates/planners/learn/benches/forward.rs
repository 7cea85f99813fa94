//! `cargo bench -p madenet-learn`: the networks on the `flex` CPU device (no autodiff).
//!
//! * `cep_act_b1` — one CEP decision: `act` on batch 1 (20×20 map, 3 robots, 4 candidates),
//!   with a carried LSTM state.
//! * `cep_forward_b16_t20` — one CEP `forward` over 16 sequences × 20 macro steps (the paper's
//!   batch of 16), no gradient.
//! * `dep_act_b1` — one DEP decision, for comparison.
//! * `agnostic_decide/{20,60}` — one decision of the size- and team-agnostic DEP
//!   (`made-net-any`) mid-trial on a generated 20 × 20 map with 3 robots and a 60 × 60 map with
//!   5 (|G| = 4 and 8): inputs, forward pass and choice; `agnostic_inputs/*` and
//!   `agnostic_scores/*` (the decision-time `AgnosticScorer`) are its two parts;
//!   `agnostic_scores_burn/*` is the same forward pass through burn (the anchor).

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

/// A trial on a generated `side` × `side` map with `team` robots, stopped mid-trial at a
/// timestep where robot 0 decides among two or more candidates (its view is then ready).
fn mid_trial(side: usize, team: usize) -> madenet_sim::Trial {
    use madenet_learn::scenario::ScenarioDraw;
    use madenet_sim::{Trial, TrialSpec};
    let config = madenet_world::ScenarioConfig {
        num_robots: team,
        step_cap: 2000,
        ..Default::default()
    };
    let draw = ScenarioDraw::new(side, side, (0.15, 0.3), team, config.movement);
    let (map, starts) = draw.draw(3).expect("a generated scenario");
    let spec = TrialSpec {
        map,
        map_name: format!("bench{side}"),
        starts,
        config,
        policy: "spread".into(),
        seed: 1,
    };
    let mut trial = Trial::new(spec).expect("trial");
    let mut choices = 0;
    while trial.begin_step() {
        if trial.deciding()[0] && trial.agent_mut(0).view(true).candidates().cells.len() >= 2 {
            choices += 1;
            if choices == 4 {
                return trial;
            }
        }
        trial.decide_with(&[]);
        trial.finish_step();
    }
    panic!("robot 0 never chose four times on the {side} × {side} bench map");
}

fn agnostic(c: &mut Criterion) {
    use madenet_agent::Policy;
    use madenet_learn::agnostic::{inputs, AgnosticConfig, AgnosticPolicy, AgnosticScorer};
    let device = cpu();
    device.seed(1);
    let cfg = AgnosticConfig::new();
    let net = cfg.init(&device).expect("agnostic DEP");
    let scorer = std::sync::Arc::new(AgnosticScorer::new(&net));
    for (side, team) in [(20, 3), (60, 5)] {
        let mut trial = mid_trial(side, team);
        let mut policy = AgnosticPolicy::new("any", scorer.clone(), &cfg);
        c.bench_function(&format!("agnostic_decide/{side}"), |b| {
            b.iter(|| black_box(policy.decide(&mut trial.agent_mut(0).view(true))))
        });
        c.bench_function(&format!("agnostic_inputs/{side}"), |b| {
            b.iter(|| black_box(inputs(&mut trial.agent_mut(0).view(true), cfg.crop_radius)))
        });
        let input = inputs(&mut trial.agent_mut(0).view(true), cfg.crop_radius);
        c.bench_function(&format!("agnostic_scores/{side}"), |b| {
            b.iter(|| black_box(scorer.scores(&input)))
        });
        c.bench_function(&format!("agnostic_scores_burn/{side}"), |b| {
            b.iter(|| black_box(net.scores(&input)))
        });
    }
}

criterion_group!(benches, bench, agnostic);
criterion_main!(benches);
