//! Which goal candidates a trained model picks on the first validation maps (a debugging aid):
//! `cargo run --release -p madenet-learn --example action_histogram -- RUN_DIR/config.toml MODEL_DIR`

use madenet_learn::train::training_scenario;
use madenet_learn::{Model, TrainConfig};
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_world::rng::derive_seed;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let cfg = TrainConfig::from_toml_file(Path::new(&args[1]))?;
    let model = Model::load(Path::new(&args[2]))?;
    let mut registry = PolicyRegistry::builtin();
    model.register(&mut registry, "model", "");
    for policy in ["model", "random"] {
        let mut hist = vec![0usize; cfg.goals()];
        let mut steps = 0;
        for m in 0..4 {
            let seed = derive_seed(cfg.seed, "validation", m);
            let (map, starts) = training_scenario(&cfg, seed)?;
            let spec = TrialSpec { map, map_name: "v".into(), starts, config: cfg.scenario.clone(), policy: policy.into(), seed };
            let r = Trial::with_registry(spec, &registry)?.record_trajectory(true).run();
            steps += r.metrics.tns;
            for s in &r.trajectory {
                for (i, d) in s.decided.iter().enumerate() {
                    if *d {
                        if let Some(a) = s.actions[i] {
                            hist[a] += 1;
                        }
                    }
                }
            }
        }
        println!("{policy:<8} steps {steps:4}  decisions per candidate {hist:?}");
    }
    Ok(())
}
