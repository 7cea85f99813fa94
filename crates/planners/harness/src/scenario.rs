//! What every learner trains and validates on: generated scenarios drawn from a seed
//! ([`ScenarioDraw::draw`]), and the one validator ([`validate`]) that plays a policy on a
//! fixed set of them.
//!
//! ```
//! use madenet_harness::scenario::ScenarioDraw;
//! use madenet_map::Movement;
//!
//! let draw = ScenarioDraw::new(20, 20, (0.1, 0.3), 3, Movement::default());
//! let (map, starts) = draw.draw(7).unwrap();
//! assert_eq!((map.height(), map.width(), starts.len()), (20, 20, 3));
//! assert_eq!(draw.draw(7).unwrap().1, starts); // same seed, same scenario
//! ```

use crate::error::TrainError;
use madenet_map::floorplan::{floor_plan_with_movement, varied};
use madenet_map::generate::{generate_with_movement, random_starts, GeneratorConfig};
use madenet_map::paper::Corner;
use madenet_map::{Movement, OccGrid, Pos};
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_world::rng::{derive_seed, stream};
use madenet_world::ScenarioConfig;
use rand::RngExt;
use rayon::prelude::*;

/// How a learner draws its generated scenarios: a map of `height` × `width` at an obstacle
/// fraction in `density`, and the team's start cells.
#[derive(Clone, Debug, PartialEq)]
pub struct ScenarioDraw {
    /// Map height in cells.
    pub height: usize,
    /// Map width in cells.
    pub width: usize,
    /// Obstacle fraction range (min, max) of the generator.
    pub density: (f64, f64),
    /// Robots.
    pub team: usize,
    /// The scenario's movement rule (maps are connected under it).
    pub movement: Movement,
    /// Probability that a team of at most 3 starts in a shared corner (kept free by the
    /// generator; the paper's start cells) rather than on the free cells nearest (by moves) to
    /// a random free cell. Default 0.
    pub corner_start_prob: f64,
    /// The named RNG stream the random start cells come from. Each learner keeps the stream it
    /// always used, so its maps and runs stay reproducible: `"scenario"` (the default) for
    /// MADE-Net, MADE-Net-DT and DME-DRL; `"starts"` for the rollout learner, whose
    /// `"scenario"` stream decides the corner.
    pub starts_stream: &'static str,
    /// Probability that the map is a generated floor plan (rooms, doors, corridors;
    /// [`madenet_map::floorplan::varied`]) instead of clutter; its team starts around a random
    /// free cell. Default 0 (never drawn then, so runs without floor plans stay as they were).
    pub floorplan_prob: f64,
}

impl ScenarioDraw {
    /// Random starts around a random free cell, from the `"scenario"` stream.
    pub fn new(
        height: usize,
        width: usize,
        density: (f64, f64),
        team: usize,
        movement: Movement,
    ) -> Self {
        ScenarioDraw {
            height,
            width,
            density,
            team,
            movement,
            corner_start_prob: 0.0,
            starts_stream: "scenario",
            floorplan_prob: 0.0,
        }
    }

    /// Why maps cannot be drawn this way, naming the config field: sides in
    /// [`crate::MIN_MAP_SIDE`]..=[`crate::MAX_TRAIN_MAP_SIDE`] (the networks' bounds),
    /// `0 ≤ density_min ≤ density_max < 0.9`. MADE-Net's and DME-DRL's configs check their
    /// maps with it; the rollout learner's config checks its curriculum's sides itself.
    pub fn check(&self) -> Result<(), String> {
        if self.height < crate::MIN_MAP_SIDE || self.width < crate::MIN_MAP_SIDE {
            return Err(format!(
                "field `map_height/map_width`: must be at least {}",
                crate::MIN_MAP_SIDE
            ));
        }
        let max = crate::MAX_TRAIN_MAP_SIDE;
        for (field, side) in [("map_height", self.height), ("map_width", self.width)] {
            if side > max {
                return Err(format!(
                    "field `{field}`: must lie in 1..={max}, got {side}"
                ));
            }
        }
        let (lo, hi) = self.density;
        if !(0.0 <= lo && lo <= hi && hi < 0.9) {
            return Err(
                "field `density_min/density_max`: need 0 ≤ density_min ≤ density_max < 0.9".into(),
            );
        }
        if !(0.0..=1.0).contains(&self.floorplan_prob) {
            return Err("field `floorplan_prob`: must be in [0, 1]".into());
        }
        Ok(())
    }

    /// The scenario of `seed`: its map (stream `"map"`) and start cells. Training, validation
    /// and held-out sets differ only in their seeds.
    pub fn draw(&self, seed: u64) -> Result<(OccGrid, Vec<Pos>), TrainError> {
        let (height, width, team) = (self.height, self.width, self.team);
        if self.floorplan_prob > 0.0
            && stream(seed, "layout", 0).random::<f64>() < self.floorplan_prob
        {
            let s = derive_seed(seed, "floorplan", 0);
            let map = floor_plan_with_movement(&varied(height, width, s), s, self.movement)
                .map_err(|e| TrainError::Other(format!("floor-plan generator: {e}")))?;
            return self.around_random_cell(map, seed);
        }
        let mut rng = stream(seed, "scenario", 0);
        let corner = (self.corner_start_prob > 0.0
            && team <= 3
            && rng.random::<f64>() < self.corner_start_prob)
            .then(|| Corner::ALL[rng.random_range(0..4)]);
        let keep_free = corner.map_or(Vec::new(), |c| {
            c.start_cells(height, width)[..team].to_vec()
        });
        let gen = GeneratorConfig {
            height,
            width,
            density_min: self.density.0,
            density_max: self.density.1,
            keep_free: keep_free.clone(),
        };
        // Connected under the movement rule, so any free anchor reaches the whole team.
        let map = generate_with_movement(&gen, derive_seed(seed, "map", 0), self.movement)
            .map_err(|e| TrainError::Other(format!("map generator: {e}")))?;
        if !keep_free.is_empty() {
            return Ok((map, keep_free));
        }
        self.around_random_cell(map, seed)
    }

    /// `map` with the team on the free cells nearest to a random free cell.
    fn around_random_cell(
        &self,
        map: OccGrid,
        seed: u64,
    ) -> Result<(OccGrid, Vec<Pos>), TrainError> {
        let team = self.team;
        random_starts(
            &map,
            team,
            self.movement,
            derive_seed(seed, self.starts_stream, 0),
        )
        .map(|starts| (map, starts))
        .ok_or_else(|| {
            TrainError::Other(format!(
                "generated map {seed}: fewer than {team} connected free cells"
            ))
        })
    }

    /// The validation maps of a run seeded `run_seed`: `maps` scenarios, map m drawn from
    /// `derive_seed(run_seed, "validation", m)` and named `validation_m`, under `scenario`
    /// (policy left empty, CSP as `scenario` has it: [`validate`] sets both).
    pub fn validation_maps(
        &self,
        run_seed: u64,
        maps: usize,
        scenario: &ScenarioConfig,
    ) -> Result<Vec<TrialSpec>, TrainError> {
        (0..maps as u64)
            .map(|m| {
                let seed = derive_seed(run_seed, "validation", m);
                let (map, starts) = self.draw(seed)?;
                Ok(TrialSpec {
                    map,
                    map_name: format!("validation_{m}"),
                    starts,
                    config: scenario.clone(),
                    policy: String::new(),
                    seed,
                })
            })
            .collect()
    }
}

/// What [`validate`] measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Validation {
    /// Mean primitive steps (TNS) over the trials.
    pub mean_steps: f64,
    /// Mean team return (Σ r over the trial, Eq. 8).
    pub mean_team_return: f64,
    /// Trials that explored the whole map.
    pub completed: usize,
    /// Trials played.
    pub trials: usize,
}

/// The one validator of every learner: `policy` (from `registry`) plays each of `maps` at each
/// of `csps` (map-major), trials in parallel on the current thread pool, summed in that order,
/// so the result does not depend on the number of threads.
pub fn validate(
    maps: &[TrialSpec],
    csps: &[f64],
    registry: &PolicyRegistry,
    policy: &str,
) -> Result<Validation, TrainError> {
    // Trial k is map k / |csps| at CSP k % |csps|; its spec is built when it runs, so at most
    // one copy of a map per worker exists beside `maps`.
    let results: Vec<(usize, f64, bool)> = (0..maps.len() * csps.len())
        .into_par_iter()
        .map(|k| {
            let s = &maps[k / csps.len()];
            let spec = TrialSpec {
                config: ScenarioConfig {
                    comm_success_prob: csps[k % csps.len()],
                    ..s.config.clone()
                },
                policy: policy.to_string(),
                ..s.clone()
            };
            let mut trial = Trial::with_registry(spec, registry)
                .map_err(|e| TrainError::Other(e.to_string()))?
                .timed(false);
            let mut team = 0.0;
            while trial.step() {
                team += trial.rewards().team;
            }
            let m = trial.finish().metrics;
            Ok((m.tns, team, m.completed))
        })
        .collect::<Result<_, TrainError>>()?;
    let n = results.len().max(1) as f64;
    Ok(Validation {
        mean_steps: results.iter().fold(0.0, |s, r| s + r.0 as f64) / n,
        mean_team_return: results.iter().fold(0.0, |s, r| s + r.1) / n,
        completed: results.iter().filter(|r| r.2).count(),
        trials: results.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The validator's result is the same on one thread as on several (trials are summed in
    /// plan order), and counts every map at every CSP.
    #[test]
    fn validation_does_not_depend_on_threads() {
        let draw = ScenarioDraw::new(20, 20, (0.1, 0.3), 3, Movement::default());
        let maps = draw
            .validation_maps(5, 3, &ScenarioConfig::default())
            .unwrap();
        assert_eq!(maps[2].map_name, "validation_2");
        let registry = PolicyRegistry::builtin();
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| validate(&maps, &[0.0, 1.0], &registry, "spread").unwrap())
        };
        let one = run(1);
        assert_eq!(one.trials, 6);
        assert!(one.mean_steps > 0.0 && one.mean_team_return != 0.0);
        assert_eq!(run(2), one);
    }

    /// A corner start keeps the corner's cells free and starts the team there; otherwise the
    /// starts come from the named stream.
    #[test]
    fn corner_starts_and_start_streams() {
        let base = ScenarioDraw::new(20, 20, (0.2, 0.3), 3, Movement::default());
        let corner = ScenarioDraw {
            corner_start_prob: 1.0,
            ..base.clone()
        };
        let (map, starts) = corner.draw(11).unwrap();
        assert!(Corner::ALL
            .iter()
            .any(|c| c.start_cells(20, 20)[..3] == starts[..]));
        assert!(starts.iter().all(|&p| map.is_free(p)));
        let other = ScenarioDraw {
            starts_stream: "starts",
            ..base.clone()
        };
        let seeds_differ = (0..8).any(|s| base.draw(s).unwrap().1 != other.draw(s).unwrap().1);
        assert!(seeds_differ, "the stream name picks the starts");
        assert_eq!(
            base.draw(3).unwrap().0,
            other.draw(3).unwrap().0,
            "same maps"
        );
    }

    /// With `floorplan_prob` the draw mixes floor plans (their rooms leave long straight walls:
    /// a wall run the clutter generator does not make) with clutter, each seed the same map
    /// every time; without it the maps are the clutter they always were.
    #[test]
    fn floor_plans_join_the_draw_only_when_asked() {
        let clutter = ScenarioDraw::new(24, 24, (0.15, 0.3), 3, Movement::default());
        let mixed = ScenarioDraw {
            floorplan_prob: 0.5,
            ..clutter.clone()
        };
        let plans = (0..12u64)
            .filter(|&s| mixed.draw(s).unwrap().0 != clutter.draw(s).unwrap().0)
            .collect::<Vec<_>>();
        assert!(!plans.is_empty() && plans.len() < 12, "{plans:?}");
        for &s in &plans {
            let (map, starts) = mixed.draw(s).unwrap();
            assert_eq!(mixed.draw(s).unwrap().1, starts);
            assert!(starts.iter().all(|&p| map.is_free(p)));
            let s2 = derive_seed(s, "floorplan", 0);
            let plan =
                floor_plan_with_movement(&varied(24, 24, s2), s2, Movement::default()).unwrap();
            assert_eq!(map, plan, "seed {s}: the floor plan of its own stream");
        }
        let bad = ScenarioDraw {
            floorplan_prob: 1.5,
            ..clutter
        };
        assert!(bad.check().unwrap_err().contains("floorplan_prob"));
    }
}
