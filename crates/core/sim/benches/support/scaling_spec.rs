//! The trial of the `scaling` bench, shared with the `footprint` example.

use madenet_map::generate::{generate_with_movement, random_starts, GeneratorConfig};
use madenet_sim::TrialSpec;
use madenet_world::ScenarioConfig;

/// A generated `side × side` map (nothing kept free) with `team` robots around a random cell
/// running `spread`.
pub fn spec(side: usize, team: usize) -> TrialSpec {
    let gen = GeneratorConfig {
        keep_free: Vec::new(),
        ..GeneratorConfig::for_size(side, side)
    };
    let config = ScenarioConfig {
        num_robots: team,
        step_cap: 100_000,
        ..ScenarioConfig::default()
    };
    let map = generate_with_movement(&gen, 11, config.movement).expect("map");
    let starts = random_starts(&map, team, config.movement, 11).expect("starts");
    TrialSpec {
        map,
        map_name: format!("g{side}"),
        starts,
        config,
        policy: "spread".into(),
        seed: 1,
    }
}
