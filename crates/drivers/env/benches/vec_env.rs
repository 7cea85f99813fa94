//! Robot-steps per second through `VecEnv` (the Python `VectorEnv`'s core) and through one
//! environment, primitive mode on paper map 3, observations written every step.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use madenet_env::{ActionMode, ExplorationEnv, VecBuffers, VecEnv};
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
        let e = v.first();
        let (r, ml, vl, al) = (
            e.num_robots(),
            e.map_len(),
            e.vector_len(),
            e.action_count(),
        );
        let mut maps = vec![0.0; n * r * ml];
        let mut vectors = vec![0.0; n * r * vl];
        let mut masks = vec![0u8; n * r * al];
        let mut rewards = vec![0.0; n * r];
        let mut needs = vec![false; n * r];
        let mut term = vec![false; n];
        let mut trunc = vec![false; n];
        macro_rules! buffers {
            () => {
                VecBuffers {
                    maps: &mut maps,
                    vectors: &mut vectors,
                    masks: &mut masks,
                    rewards: &mut rewards,
                    needs_action: &mut needs,
                    terminated: &mut term,
                    truncated: &mut trunc,
                }
            };
        }
        v.reset(buffers!()).unwrap();
        let mut rng = madenet_world::rng::stream(1, "bench/actions", 0);
        group.throughput(Throughput::Elements((n * r) as u64));
        group.bench_function(format!("primitive_vec{n}_robot_steps"), |b| {
            b.iter(|| {
                let actions: Vec<usize> = (0..n * r).map(|_| rng.random_range(0..9)).collect();
                v.step(&actions, buffers!()).unwrap();
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
