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
use madenet_learn::env::{ActorNets, EnvKind, Episode};
use madenet_learn::learner::{cep_update, dep_update, target_of, RobotWindow, Window};
use madenet_learn::{cpu_autodiff, TrainConfig};
use madenet_world::rng::stream;
use rand::RngExt;

#[path = "../tests/support/fixture.rs"]
mod fixture;
use fixture::{episodes, params};

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
        let p = params(&cfg);
        let mut cep = Some(cfg.cep_config().init(&device).expect("CEP"));
        let mut dep = Some(cfg.dep_config().init(&device).expect("DEP"));
        let nets = ActorNets {
            cep: cep.as_ref().map(target_of),
            deps: vec![target_of(dep.as_ref().expect("DEP"))],
        };
        let names = ["bench", "bench-actor"];
        let (maps, s) = ((1000, 8), &cfg.scenario);
        let cen = episodes(&cfg, s, &nets, EnvKind::Centralized, maps, names);
        let dec = episodes(&cfg, s, &nets, EnvKind::Decentralized, maps, names);
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
        // The shared DEP's update (targets from the CEP), then MADE-Net-DT's (no CEP).
        for (id, cep, batch) in [
            ("dep_update_b16_t24", Some(&cep_plain), &dec_r),
            ("dt_update_b16_t24", None, &dt_r),
        ] {
            let mut optim = AdamConfig::new().init();
            group.bench_function(id, |b| {
                b.iter(|| {
                    let (next, loss) = dep_update(
                        dep.take().expect("DEP"),
                        &dep_target,
                        &mut optim,
                        cep,
                        batch,
                        &p,
                    );
                    dep = Some(next);
                    loss
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
