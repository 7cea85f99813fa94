//! `cargo bench -p madenet-learn --bench update`: one DDRQN update of MADE-Net on one core —
//! the paper's batch of 16 sequences, each a window of 24 (+1) joint decisions of recorded
//! training episodes (random actors on generated 40–60 % maps):
//!
//! * `cep_update_b16_t24` — Eq. (5): CEP forward + backward (autodiff), target-net forward,
//!   conditional double-Q targets, one Adam step;
//! * `dep_update_b16_t24` — Eq. (6) for the shared DEP: 16 robot sequences forward +
//!   backward, target forward, and the CEP's forward for the target actions;
//! * `dt_update_b16_t24` — MADE-Net-DT's update of one robot's DEP (no CEP).
//!
//! The learner's thread count is set explicitly (1) through rayon's global pool (`madenet train` uses
//! its own pool of `threads`).

use burn::optim::AdamConfig;
use criterion::{criterion_group, criterion_main, Criterion};
use madenet_learn::env::{run_episode, Actor, ActorNets, EnvKind, Episode};
use madenet_learn::learner::{
    cep_update, dep_update, target_of, RobotWindow, UpdateParams, Window,
};
use madenet_learn::{cpu_autodiff, TrainConfig};
use madenet_sim::TrialSpec;
use madenet_world::rng::stream;
use rand::RngExt;

fn episodes(cfg: &TrainConfig, nets: &ActorNets, kind: EnvKind, n: u64) -> Vec<Episode> {
    (0..n)
        .map(|k| {
            let (map, starts) = cfg.scenario_draw().draw(1000 + k).expect("training map");
            let spec = TrialSpec {
                map,
                map_name: "bench".into(),
                starts,
                config: madenet_world::ScenarioConfig {
                    comm_success_prob: 0.5,
                    ..cfg.scenario.clone()
                },
                policy: String::new(),
                seed: k,
            };
            let actor = Actor::new(
                kind,
                nets.clone(),
                1.0,
                false,
                cfg.goals(),
                3,
                stream(k, "bench-actor", 0),
            );
            run_episode(spec, actor).expect("episode")
        })
        .collect()
}

fn windows(eps: &[Episode], n: usize, trace: usize) -> Vec<Window<'_>> {
    let mut rng = stream(5, "bench-windows", 0);
    (0..n)
        .map(|k| {
            let e = &eps[k % eps.len()];
            Window::new(
                e,
                rng.random_range(0..e.decisions.len().saturating_sub(trace).max(1)),
                trace,
            )
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    // Criterion is not Send, so the one-thread pool is the global one here.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global();
    {
        let cfg = TrainConfig::default();
        let device = cpu_autodiff();
        device.seed(3);
        let p = UpdateParams {
            gamma: 1.0,
            learning_rate: 1e-3,
            reward_scale: 0.01,
            map_height: 20,
            map_width: 20,
            team: 3,
            goals: cfg.goals(),
        };
        let mut cep = Some(cfg.cep_config().init(&device).expect("CEP"));
        let mut dep = Some(cfg.dep_config().init(&device).expect("DEP"));
        let nets = ActorNets {
            cep: cep.as_ref().map(target_of),
            deps: vec![target_of(dep.as_ref().expect("DEP"))],
        };
        let cen = episodes(&cfg, &nets, EnvKind::Centralized, 8);
        let dec = episodes(&cfg, &nets, EnvKind::Decentralized, 8);
        let cen_w = windows(&cen, 16, cfg.trace_len);
        let dec_r: Vec<RobotWindow<'_>> = (0..16)
            .map(|k| RobotWindow::new(&dec[k % dec.len()], k % 3, k % 5, cfg.trace_len))
            .collect();
        let dt_r: Vec<RobotWindow<'_>> = (0..16)
            .map(|k| RobotWindow::new(&dec[k % dec.len()], 0, k % 5, cfg.trace_len))
            .collect();
        let cep_target = target_of(cep.as_ref().expect("CEP"));
        let dep_target = target_of(dep.as_ref().expect("DEP"));
        let mut group = c.benchmark_group("ddrqn");
        group.sample_size(10);
        let mut optim = AdamConfig::new().init();
        group.bench_function("cep_update_b16_t24", |b| {
            b.iter(|| {
                let (next, loss) = cep_update(
                    cep.take().expect("CEP"),
                    &cep_target,
                    &mut optim,
                    &cen_w,
                    &p,
                );
                cep = Some(next);
                loss
            })
        });
        let cep_plain = target_of(cep.as_ref().expect("CEP"));
        let mut optim = AdamConfig::new().init();
        group.bench_function("dep_update_b16_t24", |b| {
            b.iter(|| {
                let (next, loss) = dep_update(
                    dep.take().expect("DEP"),
                    &dep_target,
                    &mut optim,
                    Some(&cep_plain),
                    &dec_r,
                    &p,
                );
                dep = Some(next);
                loss
            })
        });
        let mut optim = AdamConfig::new().init();
        group.bench_function("dt_update_b16_t24", |b| {
            b.iter(|| {
                let (next, loss) = dep_update(
                    dep.take().expect("DEP"),
                    &dep_target,
                    &mut optim,
                    None,
                    &dt_r,
                    &p,
                );
                dep = Some(next);
                loss
            })
        });
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
