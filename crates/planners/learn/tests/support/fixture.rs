//! The fixture of `tests/update.rs` and `benches/update.rs` (included there by path): the
//! update parameters and recorded training episodes of random actors (ε = 1).

use madenet_learn::env::{run_episode, Actor, ActorNets, EnvKind, Episode};
use madenet_learn::learner::UpdateParams;
use madenet_learn::TrainConfig;
use madenet_sim::TrialSpec;
use madenet_world::rng::stream;
use madenet_world::ScenarioConfig;

/// The updates' parameters: γ = 1, learning rate 1e-3, reward scale 0.01, 20 × 20 maps, three
/// robots, the config's goal candidates.
pub fn params(cfg: &TrainConfig) -> UpdateParams {
    UpdateParams {
        gamma: 1.0,
        learning_rate: 1e-3,
        reward_scale: 0.01,
        map_height: 20,
        map_width: 20,
        team: 3,
        goals: cfg.goals(),
    }
}

/// `n` episodes of `kind`, episode k on the training map of seed `first_map + k` under
/// `scenario` at CSP 0.5, with trial seed k; `names`: the maps' name and the actors' stream.
pub fn episodes(
    cfg: &TrainConfig,
    scenario: &ScenarioConfig,
    nets: &ActorNets,
    kind: EnvKind,
    (first_map, n): (u64, u64),
    [map_name, actor_stream]: [&str; 2],
) -> Vec<Episode> {
    (0..n)
        .map(|k| {
            let (map, starts) = cfg
                .scenario_draw()
                .draw(first_map + k)
                .expect("training map");
            let spec = TrialSpec {
                map,
                map_name: map_name.into(),
                starts,
                config: ScenarioConfig {
                    comm_success_prob: 0.5,
                    ..scenario.clone()
                },
                policy: String::new(),
                seed: k,
            };
            let actor = Actor::new(
                kind,
                nets.clone(),
                1.0,
                false,
                cfg.goals(),
                3,
                stream(k, actor_stream, 0),
            );
            run_episode(spec, actor).expect("episode")
        })
        .collect()
}
