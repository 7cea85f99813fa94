//! Scenario TOML (`madenet run --config`, and the `[scenario]` table of study and training
//! configs): `ScenarioConfig::from_toml_str` parses and validates. A config that validates must
//! write back to TOML that reads as the same config (runs save it so), and must build a world
//! on a small map, with the robots on its first free cells, and step it once.
#![no_main]

use libfuzzer_sys::fuzz_target;
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_world::{Move, ScenarioConfig, World};
use std::sync::LazyLock;

/// A 20 × 20 map with walls on every fourth row: 320 free cells, room for the largest team.
static MAP: LazyLock<OccGrid> = LazyLock::new(|| {
    let cells = (0..20 * 20)
        .map(|i| match (i / 20 % 4, i % 20 % 5) {
            (2, c) if c != 0 => Occupancy::Obstacle,
            _ => Occupancy::Free,
        })
        .collect();
    OccGrid::from_cells(20, 20, cells)
});

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(cfg) = ScenarioConfig::from_toml_str(text) else { return };

    let saved = toml::to_string(&cfg).expect("a validated config serializes");
    let again = ScenarioConfig::from_toml_str(&saved).expect("a saved config reads back");
    assert_eq!(again, cfg, "saved as:\n{saved}");

    let map = &*MAP;
    let _ = cfg.goal_count_for(map.len());
    let starts: Vec<Pos> = (0..map.len())
        .map(|i| map.pos(i))
        .filter(|&p| map.is_free(p))
        .take(cfg.num_robots)
        .collect();
    let n = cfg.num_robots;
    let mut world = World::new(map.clone(), &starts, cfg, 7).expect("a validated config builds a world");
    world.step(&vec![Move::Stay; n]);
});
