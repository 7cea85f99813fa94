//! `cargo bench -p madenet-runtime --bench lockstep`: one trial with the world, the radio and the
//! robots as message-passing nodes on their own threads, over in-memory channels
//! (`lockstep/nodes`) and over Zenoh on loopback TCP, each node its own session
//! (`lockstep/zenoh`, sessions opened outside the timing), against the same trial in one process
//! (`lockstep/in_process`, the anchor): NF, paper map 3 from the top-left, CSP 1 and 0.5, seed 1.
//! The traffic of each run (messages and bytes per β exchange) is printed once.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use madenet_map::paper::{paper_map, Corner};
use madenet_runtime::zenoh_bus::{free_port_block, loopback_endpoints};
use madenet_runtime::{nodes_of, run_lockstep, run_threads, ZenohBus};
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_world::ScenarioConfig;
use std::time::Duration;

fn spec(csp: f64) -> TrialSpec {
    TrialSpec {
        map: paper_map(3).expect("paper map"),
        map_name: "paper:3".into(),
        starts: Corner::TopLeft.start_cells(20, 20).to_vec(),
        config: ScenarioConfig {
            comm_success_prob: csp,
            ..Default::default()
        },
        policy: "nf".into(),
        seed: 1,
    }
}

fn bench(c: &mut Criterion) {
    let registry = PolicyRegistry::builtin();
    let mut g = c.benchmark_group("lockstep");
    // A Zenoh run takes a fraction of a second: 20 samples keep the bench to a few minutes.
    g.sample_size(20);
    for csp in [1.0, 0.5] {
        let r = run_lockstep(spec(csp), &registry, Duration::from_secs(10)).expect("run");
        let t = Trial::new(spec(csp))
            .expect("trial")
            .record_trajectory(true)
            .run();
        let exchanges: usize = t.trajectory.iter().map(|s| s.exchanges.len()).sum();
        eprintln!(
            "csp {csp}: {} steps, {exchanges} exchanges; world sent {} messages / {} B, robots {} / {} B, of which robot to robot {} / {} B ({:.0} B per exchange), radio {} / {} B; latency {:.1} µs mean, {:.1} µs longest",
            t.metrics.tns,
            r.world_sent.messages,
            r.world_sent.bytes,
            r.robots_sent.messages,
            r.robots_sent.bytes,
            r.between_robots.messages,
            r.between_robots.bytes,
            r.between_robots.bytes as f64 / exchanges.max(1) as f64,
            r.radio_sent.messages,
            r.radio_sent.bytes,
            1e6 * r.latency.mean_s,
            1e6 * r.latency.max_s
        );
        // One run over Zenoh: the world's time from its first message to the stop (sessions
        // connected), and the robots' latency.
        let base = free_port_block(5).expect("free ports");
        let buses: Vec<ZenohBus> = nodes_of(3)
            .into_iter()
            .map(|node| {
                let ep = loopback_endpoints(base, 3, node).expect("ports");
                ZenohBus::open(&format!("probe{csp}"), node, &ep).expect("session")
            })
            .collect();
        let timeouts = madenet_runtime::Timeouts::new(Duration::from_secs(10));
        let z = run_threads(spec(csp), &registry, timeouts, buses).expect("run");
        eprintln!(
            "csp {csp} over zenoh: {:.2} ms from the world's first message to the stop; latency {:.1} µs mean, {:.1} µs longest",
            1e3 * z.timing.trial_s,
            1e6 * z.latency.mean_s,
            1e6 * z.latency.max_s
        );
        g.bench_with_input(BenchmarkId::new("in_process", csp), &csp, |b, &csp| {
            b.iter(|| Trial::new(spec(csp)).expect("trial").run())
        });
        g.bench_with_input(BenchmarkId::new("nodes", csp), &csp, |b, &csp| {
            b.iter(|| run_lockstep(spec(csp), &registry, Duration::from_secs(10)).expect("run"))
        });
        let base = free_port_block(5).expect("free ports");
        let mut round = 0;
        g.bench_with_input(BenchmarkId::new("zenoh", csp), &csp, |b, &csp| {
            b.iter_batched(
                || {
                    // A fresh run name per iteration: no message of one run reaches the next.
                    round += 1;
                    nodes_of(3)
                        .into_iter()
                        .map(|node| {
                            let ep = loopback_endpoints(base, 3, node).expect("ports");
                            ZenohBus::open(&format!("bench{round}"), node, &ep).expect("session")
                        })
                        .collect::<Vec<_>>()
                },
                |buses| {
                    run_threads(
                        spec(csp),
                        &registry,
                        madenet_runtime::Timeouts::new(Duration::from_secs(10)),
                        buses,
                    )
                    .expect("run")
                },
                criterion::BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
