//! Robot-steps per second through `VecEnv` (the Python `VectorEnv`'s core) and through one
//! environment, primitive mode on paper map 3, observations written every step.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use madenet_env::{ActionMode, ExplorationEnv, VecEnv};
use madenet_map::paper::{paper_map, Corner};
use madenet_world::ScenarioConfig;
use rand::RngExt;

fn env(mode: ActionMode) -> ExplorationEnv {
    let map = paper_map(3).unwrap();
    let starts = Corner::TopLeft
        .start_cells(map.height(), map.width())
        .to_vec();
    ExplorationEnv::new(map, "paper_3", starts, ScenarioConfig::default(), mode).unwrap()
}

fn bench(c: &mut Criterion) {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .ok();
    let mut group = c.benchmark_group("env");
    for n in [1usize, 64] {
        let mut v = VecEnv::new(env(ActionMode::Primitive), n, 1).unwrap();
        let r = v.first().num_robots();
        let mut out = v.outputs();
        v.reset(out.buffers()).unwrap();
        let mut rng = madenet_world::rng::stream(1, "bench/actions", 0);
        group.throughput(Throughput::Elements((n * r) as u64));
        group.bench_function(format!("primitive_vec{n}_robot_steps"), |b| {
            b.iter(|| {
                let actions: Vec<usize> = (0..n * r).map(|_| rng.random_range(0..9)).collect();
                v.step(&actions, out.buffers()).unwrap();
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
