//! `cargo bench -p madenet-baselines`: the classical baselines on the paper's maps.
//!
//! * `paper_40/{nf,ub,pb}` — the 40 trials of one CSP (10 paper maps × 4 corners, CSP 1.0,
//!   seed 1) per method, one process, one core: the figure compared with the authors' Python
//!   code (12.6 s NF, 19.7 s UB, ≈ 480 s PB on this machine per the study issue).
//! * `trial/{nf,ub,pb}` — one full trial on test_5 from the top-left.
//! * `pb_decision` — one PB decision of robot 0 in the middle of a trial (both teammates in
//!   view), i.e. two value iterations over the map.

use criterion::{criterion_group, criterion_main, Criterion};
use madenet_baselines::registry;
use madenet_map::paper::{paper_map, Corner, PAPER_MAP_COUNT};
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_world::ScenarioConfig;
use std::hint::black_box;

fn spec(n: usize, corner: Corner, policy: &str) -> TrialSpec {
    TrialSpec {
        map: paper_map(n).expect("paper map"),
        map_name: format!("test_{n}"),
        starts: corner.start_cells(20, 20).to_vec(),
        config: ScenarioConfig::default(),
        policy: policy.into(),
        seed: 1,
    }
}

fn run_all(specs: &[TrialSpec], reg: &PolicyRegistry) {
    for s in specs {
        black_box(Trial::with_registry(s.clone(), reg).expect("trial").run());
    }
}

fn bench(c: &mut Criterion) {
    let reg = registry();
    let mut group = c.benchmark_group("paper_40");
    group.sample_size(10);
    for method in ["nf", "ub", "pb"] {
        let specs: Vec<TrialSpec> = (1..=PAPER_MAP_COUNT)
            .flat_map(|n| Corner::ALL.map(|corner| spec(n, corner, method)))
            .collect();
        group.bench_function(method, |b| b.iter(|| run_all(&specs, &reg)));
    }
    group.finish();
    let mut group = c.benchmark_group("trial");
    for method in ["nf", "ub", "pb"] {
        let s = spec(5, Corner::TopLeft, method);
        group.bench_function(method, |b| {
            b.iter(|| black_box(Trial::with_registry(s.clone(), &reg).expect("trial").run()))
        });
    }
    group.finish();
    let mut trial = Trial::with_registry(spec(5, Corner::TopLeft, "pb"), &reg).expect("trial");
    for _ in 0..10 {
        trial.step();
    }
    c.bench_function("pb_decision", |b| b.iter(|| trial.agent_mut(0).decide()));
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = bench
}
criterion_main!(benches);
