//! The classical policies on the training config's validation set (generated maps, never the
//! paper's): the reference a validation curve should be read against.
//!
//! `cargo run --release -p madenet-learn --example validation_reference [-- train.toml [run_dir/best]]`

use madenet_learn::scenario;
use madenet_learn::{Model, TrainConfig};
use madenet_sim::PolicyRegistry;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let cfg = match args.get(1) {
        Some(p) => TrainConfig::from_toml_file(Path::new(p))?,
        None => TrainConfig::default(),
    };
    let mut registry = PolicyRegistry::builtin();
    let mut names = vec!["nf".to_string(), "random".to_string()];
    if let Some(dir) = args.get(2) {
        Model::load(Path::new(dir))?.register(&mut registry, "model", "the given model");
        names.push("model".into());
    }
    let maps = cfg.validation_maps()?;
    for name in names {
        let v = scenario::validate(&maps, &cfg.validation_csp, &registry, &name)?;
        let (steps, ret, done, n) = (v.mean_steps, v.mean_team_return, v.completed, v.trials);
        println!(
            "{name:<8} mean steps {steps:6.1}  mean team reward {ret:8.0}  completed {done}/{n}"
        );
    }
    Ok(())
}
