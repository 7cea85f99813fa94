//! Reference points for DME-DRL's validation score (the numbers in `models/README.md`): the
//! actors as initialised by seed 1 (what a run starts from), greedy and sampling (a nearly
//! uniform random sector at each decision), and optionally a trained model directory, all on
//! the default config's generated validation set (36 trials; never the paper's maps).
//!
//! `cargo run --release -p madenet-dme --example dme_validation_reference [MODEL_DIR]`

use burn::tensor::Device;
use madenet_dme::maddpg::Maddpg;
use madenet_dme::model::Model;
use madenet_dme::policy::DmePolicy;
use madenet_dme::train::{validate, DmeTrainConfig};
use madenet_harness::scenario;
use madenet_sim::PolicyRegistry;
use std::sync::{Arc, RwLock};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let cfg = DmeTrainConfig::default();
    let device = Device::flex().autodiff();
    device.seed(cfg.seed);
    let nets = Maddpg::new(&cfg.nets(), &device);
    let v = validate(&cfg, &nets)?;
    let (steps, done, n) = (v.mean_steps, v.completed, v.trials);
    println!("initial actors, greedy:   {steps:.1} mean steps, {done}/{n} complete");
    let actors: Vec<_> = (0..cfg.scenario.num_robots)
        .map(|i| Arc::new(RwLock::new(nets.acting_actor(i))))
        .collect();
    let mut registry = PolicyRegistry::default();
    let history = cfg.history;
    registry.register("sampling", "initial actors, sampling", move |ctx| {
        let rng = madenet_world::rng::stream(ctx.seed, "reference/sample", ctx.robot as u64);
        Box::new(
            DmePolicy::new(
                "sampling",
                ctx.robot,
                Arc::clone(&actors[ctx.robot]),
                history,
            )
            .sampling(rng),
        )
    });
    let maps = cfg.validation_maps()?;
    let v = scenario::validate(&maps, &cfg.validation_csp, &registry, "sampling")?;
    let (steps, done, n) = (v.mean_steps, v.completed, v.trials);
    println!("initial actors, sampling: {steps:.1} mean steps, {done}/{n} complete");
    if let Some(dir) = std::env::args().nth(1) {
        let model = Model::load(std::path::Path::new(&dir))?;
        let mut registry = PolicyRegistry::default();
        model.register(&mut registry, "model", "the given model");
        let v = scenario::validate(&maps, &cfg.validation_csp, &registry, "model")?;
        let (steps, done, n) = (v.mean_steps, v.completed, v.trials);
        println!("{dir}: {steps:.1} mean steps, {done}/{n} complete");
    }
    Ok(())
}
