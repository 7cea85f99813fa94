//! A student among `spread` teammates: does a model that plays worse than `spread` as a whole
//! team play as well as `spread` when it is one robot of the team and its teammates keep to
//! `spread`, as the rollout teacher's labels assume? Mean steps per CSP of `spread`, of robot 0
//! playing the model beside `spread` teammates (`one`) and of the whole team playing it (`all`),
//! on MAPS maps drawn as a run's validation maps are but from the run's seed + 777 (neither its
//! training nor its validation maps; the held-out set is other generated maps).
//!
//! ```text
//! cargo run --release -p madenet-learn --example mixed_team -- RUN_DIR MODEL_DIR [MAPS [CSP,…]]
//! ```
//!
//! `MODEL_DIR` acts as its `model.toml` says (delete its `spread_margin` line for the greedy
//! DEP); `MAPS` defaults to 200, the CSPs to `1,0`.

use madenet_learn::dagger::{validation_maps, RolloutTrainConfig};
use madenet_learn::scenario::validate;
use madenet_learn::Model;
use madenet_sim::PolicyRegistry;
use std::path::Path;
use std::sync::Arc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: mixed_team RUN_DIR MODEL_DIR [MAPS [CSP,…]]";
    let (Some(run), Some(model)) = (args.first(), args.get(1)) else {
        return Err(usage.into());
    };
    let model = Arc::new(Model::load(Path::new(model))?);
    let maps: usize = args.get(2).map_or(Ok(200), |a| {
        a.parse()
            .map_err(|_| format!("MAPS `{a}`: not a whole number ({usage})"))
    })?;
    let csps: Vec<f64> = args.get(3).map_or(Ok(vec![1.0, 0.0]), |a| {
        a.split(',')
            .map(|x| x.parse().map_err(|_| format!("CSP `{x}`: not a number")))
            .collect::<Result<_, String>>()
    })?;
    let mut cfg = RolloutTrainConfig::from_toml_file(&Path::new(run).join("config.toml"))?;
    if maps == 0 {
        return Err(format!("MAPS 0: at least one map ({usage})").into());
    }
    (cfg.validation_maps, cfg.seed) = (maps, cfg.seed.wrapping_add(777));
    let maps = validation_maps(&cfg)?;
    let mut registry = PolicyRegistry::builtin();
    let m = Arc::clone(&model);
    registry.register("all", "the model for every robot", move |ctx| {
        m.policy("all", ctx.robot)
    });
    let builtin = PolicyRegistry::builtin();
    registry.register(
        "one",
        "the model for robot 0, spread for the rest",
        move |ctx| match ctx.robot {
            0 => model.policy("one", 0),
            _ => builtin.make("spread", ctx).expect("spread is a built-in"),
        },
    );
    println!("csp,policy,mean_steps,completed,trials");
    for csp in csps {
        for policy in ["spread", "one", "all"] {
            let v = validate(&maps, &[csp], &registry, policy)?;
            println!(
                "{csp},{policy},{:.2},{},{}",
                v.mean_steps, v.completed, v.trials
            );
        }
    }
    Ok(())
}
