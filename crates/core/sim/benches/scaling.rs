//! `cargo bench -p madenet-sim --bench scaling`: how a timestep's cost grows with the map and
//! the team (issue 15). On generated maps of sides 20, 60, 200, 500 (15–40 % obstacles) with
//! teams of 2, 6, 16, 64 starting around a random cell, `spread` (macro decisions, prioritized
//! planning), CSP 1:
//!
//! * `timestep/<side>/<team>` — one whole timestep of a trial (sensing, belief merges, message
//!   exchange, decisions, navigation, motion), averaged over the trial's first steps (the trial
//!   is rebuilt outside the timer when it ends);
//! * `world_step/<side>/<team>` — the world's part alone (motion, sensing, contacts, comms).
//!
//! Memory is measured apart (one process per size, see BENCHMARKS.md):
//! `cargo run --release -p madenet-sim --example footprint -- <side> <team> <steps>`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use madenet_sim::Trial;
use madenet_world::{Move, World};
use scaling_spec::spec;
use std::hint::black_box;
use std::time::{Duration, Instant};

#[path = "support/scaling_spec.rs"]
mod scaling_spec;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("timestep");
    for side in [20, 60, 200, 500] {
        for team in [2, 6, 16, 64] {
            let s = spec(side, team);
            g.bench_with_input(BenchmarkId::new(side.to_string(), team), &s, |b, s| {
                let mut trial = Trial::new(s.clone()).expect("trial");
                b.iter_custom(|iters| {
                    let mut spent = Duration::ZERO;
                    for _ in 0..iters {
                        if trial.is_done() {
                            trial = Trial::new(s.clone()).expect("trial");
                        }
                        let t0 = Instant::now();
                        black_box(trial.step());
                        spent += t0.elapsed();
                    }
                    spent
                })
            });
        }
    }
    g.finish();
    let mut g = c.benchmark_group("world_step");
    for side in [20, 60, 200, 500] {
        for team in [2, 6, 16, 64] {
            let s = spec(side, team);
            let world = World::new(s.map.clone(), &s.starts, s.config.clone(), 1).expect("world");
            let moves: Vec<Move> = (0..team).map(|i| Move::ALL[1 + i % 8]).collect();
            g.bench_with_input(BenchmarkId::new(side.to_string(), team), &world, |b, w| {
                b.iter_batched_ref(
                    || w.clone(),
                    |w| w.step(black_box(&moves)),
                    criterion::BatchSize::LargeInput,
                )
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = bench
}
criterion_main!(benches);
