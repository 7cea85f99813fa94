//! `cargo bench -p madenet-ros2 --bench record`: what `--record` costs a paper trial (issue 30
//! asks ≤ 25 % of the trial's own time) — the same trial (test_3, top-right, `spread`, seed 1)
//! run alone and run recorded into a bag (written, finished, then removed).
//!
//! * `paper_trial/plain`
//! * `paper_trial/recorded`
//! * `paper_trial/empty_bag` (the fixed cost: the true map and the first timestep only)

use criterion::{criterion_group, criterion_main, Criterion};
use madenet_map::paper::{paper_map, Corner};
use madenet_ros2::record::Recorder;
use madenet_sim::{Trial, TrialSpec};

fn spec() -> TrialSpec {
    let map = paper_map(3).expect("paper map 3");
    let starts = Corner::TopRight
        .start_cells(map.height(), map.width())
        .to_vec();
    TrialSpec {
        map,
        map_name: "test_3".into(),
        starts,
        config: Default::default(),
        policy: "spread".into(),
        seed: 1,
    }
}

fn bench(c: &mut Criterion) {
    let spec = spec();
    let dir = std::env::temp_dir().join(format!("madenet-bench-record-{}", std::process::id()));
    let mut g = c.benchmark_group("paper_trial");
    g.bench_function("plain", |b| {
        b.iter(|| {
            let mut trial = Trial::new(spec.clone()).expect("trial");
            while trial.step() {}
            trial.finish()
        })
    });
    g.bench_function("recorded", |b| {
        b.iter(|| {
            let mut trial = Trial::new(spec.clone()).expect("trial");
            let mut bag = Recorder::start(&dir, &trial).expect("bag");
            while trial.step() {
                bag.step(&trial).expect("recorded");
            }
            let (at, _) = bag.finish().expect("finished").expect("a bag");
            std::fs::remove_dir_all(at).expect("removed");
            trial.finish()
        })
    });
    g.bench_function("empty_bag", |b| {
        b.iter(|| {
            let trial = Trial::new(spec.clone()).expect("trial");
            let bag = Recorder::start(&dir, &trial).expect("bag");
            let (at, _) = bag.finish().expect("finished").expect("a bag");
            std::fs::remove_dir_all(at).expect("removed");
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
