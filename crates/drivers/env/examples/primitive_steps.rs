//! Steps a `VecEnv` with random actions and prints robot-steps per second: a target for
//! profilers (`valgrind --tool=callgrind`, `perf`), beside `cargo bench -p madenet-env`.
//! Primitive mode (random moves) unless the third argument is `macro` (random candidate slots;
//! an invalid one keeps the robot in place to decide again).
//!
//! `cargo run --release -p madenet-env --example primitive_steps -- [ENVS] [STEPS] [primitive|macro]`

use madenet_env::{ActionMode, ExplorationEnv, VecEnv};
use madenet_map::paper::{paper_map, Corner};
use madenet_world::ScenarioConfig;
use rand::RngExt;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(64);
    let steps: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(2000);
    let mode = match args.next().as_deref() {
        Some("macro") => ActionMode::Macro,
        _ => ActionMode::Primitive,
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .ok();
    let map = paper_map(3).unwrap();
    let starts = Corner::TopLeft
        .start_cells(map.height(), map.width())
        .to_vec();
    let env = ExplorationEnv::new(map, "paper_3", starts, ScenarioConfig::default(), mode).unwrap();
    let mut v = VecEnv::new(env, n, 1).unwrap();
    let (r, al) = (v.first().num_robots(), v.first().action_count());
    let mut out = v.outputs();
    v.reset(out.buffers()).unwrap();
    let mut rng = madenet_world::rng::stream(1, "example/actions", 0);
    let actions: Vec<Vec<usize>> = (0..256)
        .map(|_| (0..n * r).map(|_| rng.random_range(0..al)).collect())
        .collect();
    let start = std::time::Instant::now();
    for s in 0..steps {
        v.step(&actions[s % 256], out.buffers()).unwrap();
    }
    let dt = start.elapsed().as_secs_f64();
    println!("{mode:?}: {n} envs x {r} robots, {steps} steps: {:.0} robot-steps/s ({:.2} µs per robot-step)", (steps * n * r) as f64 / dt, 1e6 * dt / (steps * n * r) as f64);
}
