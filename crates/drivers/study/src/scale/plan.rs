//! The scalability study's plan: every trial of the grid (maps, starts, teams, seeds, methods)
//! as the runner runs it, and a continuous study's grid twin.

use super::{ScaleConfig, ScaleWorld};
use crate::config::StudyError;
use crate::runner::{Planned, PlannedContinuous, TrialKey};
use madenet_baselines::rollout::OracleKind;
use madenet_continuous::scene::generate_cluttered;
use madenet_map::generate::{generate_with_movement, starts_near, GeneratorConfig};
use madenet_map::Pos;
use madenet_sim::TrialSpec;
use madenet_world::rng::derive_seed;
use madenet_world::ScenarioConfig;
use std::sync::Arc;

/// One trial's place in the grid, beside its planned run.
#[derive(Clone, Debug)]
pub struct ScalePlanned {
    /// Map side, cells.
    pub side: usize,
    /// Team size, robots.
    pub team: usize,
    /// The trial, as the runner runs it.
    pub planned: Planned,
}

impl ScaleConfig {
    /// The step cap on a side-`side` map (in the continuous world: the time cap, seconds).
    pub fn step_cap(&self, side: usize) -> usize {
        let floor = match self.world {
            ScaleWorld::Grid => self.scenario.step_cap,
            ScaleWorld::Continuous => self.continuous.time_cap.ceil() as usize,
        };
        floor.max((self.steps_per_cell * (side * side) as f64).ceil() as usize)
    }

    /// Every trial, in output order (method, side, map, start, team, seed).
    pub fn plan(&self) -> Result<Vec<ScalePlanned>, StudyError> {
        let movement = self.scenario.movement;
        let mut maps = Vec::new();
        let cell = self.scenario.cell_size;
        for &side in &self.sides {
            for k in 0..self.maps_per_side {
                if self.world == ScaleWorld::Continuous {
                    let seed = derive_seed(self.map_seed, "scale-scene", (side * 1000 + k) as u64);
                    let scene = generate_cluttered(
                        side as f64 * cell,
                        self.continuous.mapping.resolution,
                        seed,
                    );
                    let grid = scene.coarse_truth(cell, &self.scenario.discretize);
                    // Starts only where a robot's footprint fits (the world refuses others).
                    let startable = scene.start_cells(
                        cell,
                        &self.scenario.discretize,
                        self.continuous.robot.radius,
                    );
                    let planned = PlannedContinuous {
                        scene: Arc::new(scene),
                        config: madenet_continuous::ContinuousConfig {
                            time_cap: self.step_cap(side) as f64,
                            ..self.continuous
                        },
                    };
                    maps.push((
                        side,
                        format!("side{side}-map{k}"),
                        grid,
                        Some(startable),
                        Some(planned),
                    ));
                    continue;
                }
                // The start areas (3 × 3 around each anchor) stay free.
                let keep_free: Vec<Pos> = self
                    .starts
                    .iter()
                    .flat_map(|s| {
                        let a = s.anchor(side);
                        (-1..=1).flat_map(move |dr| {
                            (-1..=1).map(move |dc| Pos::new(a.row + dr, a.col + dc))
                        })
                    })
                    .filter(|p| {
                        p.row >= 0
                            && p.col >= 0
                            && (p.row as usize) < side
                            && (p.col as usize) < side
                    })
                    .collect();
                let gen = GeneratorConfig {
                    height: side,
                    width: side,
                    density_min: self.density_min,
                    density_max: self.density_max,
                    keep_free,
                };
                let seed = derive_seed(self.map_seed, "scale-map", (side * 1000 + k) as u64);
                let grid = generate_with_movement(&gen, seed, movement)
                    .map_err(|e| StudyError::Other(format!("map side {side} #{k}: {e}")))?;
                maps.push((side, format!("side{side}-map{k}"), grid, None, None));
            }
        }
        let mut v = Vec::new();
        // The methods, then the known-map reference (its "policy" only names the pairing).
        let reference = crate::config::oracle_method(OracleKind::KnownMap);
        let mut runs: Vec<(&String, Option<(OracleKind, usize)>)> =
            self.methods.iter().map(|m| (m, None)).collect();
        if self.known_map && self.world == ScaleWorld::Grid && !self.methods.is_empty() {
            runs.push((&reference, Some((OracleKind::KnownMap, 1))));
        }
        for (method, oracle) in runs {
            let policy = if oracle.is_some() {
                &self.methods[0]
            } else {
                method
            };
            for (side, name, grid, startable, continuous) in &maps {
                for start in &self.starts {
                    for &team in &self.teams {
                        let cells = starts_near(
                            startable.as_ref().unwrap_or(grid),
                            start.anchor(*side),
                            team,
                            movement,
                        )
                        .ok_or_else(|| {
                            StudyError::Other(format!(
                                "map {name}: fewer than {team} free cells connected to the {} start{}",
                                start.name(),
                                match startable {
                                    Some(_) => " where a robot's footprint fits",
                                    None => "",
                                }
                            ))
                        })?;
                        for s in 0..self.seeds {
                            let seed = self.seed_base + s;
                            let config = ScenarioConfig {
                                num_robots: team,
                                comm_success_prob: self.csp,
                                step_cap: self.step_cap(*side),
                                ..self.scenario.clone()
                            };
                            let key = TrialKey {
                                method: method.clone(),
                                map: name.clone(),
                                start: format!("{}:{team}", start.name()),
                                csp: crate::runner::csp_label(self.csp),
                                seed,
                            };
                            let spec = TrialSpec {
                                map: grid.clone(),
                                map_name: name.clone(),
                                starts: cells.clone(),
                                config,
                                policy: policy.clone(),
                                seed,
                            };
                            v.push(ScalePlanned {
                                side: *side,
                                team,
                                planned: Planned {
                                    key,
                                    spec,
                                    oracle,
                                    look: Default::default(),
                                    continuous: continuous.clone(),
                                },
                            });
                        }
                    }
                }
            }
        }
        Ok(v)
    }
}

impl ScaleConfig {
    /// The grid twin of a continuous study's plan: the same trials (the scenes read as cells
    /// by the scenario's rule, the same start cells, teams, methods and seeds) in the grid
    /// world, with the grid study's step cap — so each policy's advantage can be compared
    /// between the two worlds trial by trial (same index, same trial).
    pub fn grid_twin(&self, planned: &[ScalePlanned]) -> Vec<ScalePlanned> {
        let grid = ScaleConfig {
            world: ScaleWorld::Grid,
            ..self.clone()
        };
        planned
            .iter()
            .map(|p| {
                let mut t = p.clone();
                t.planned.continuous = None;
                t.planned.spec.config.step_cap = grid.step_cap(p.side);
                t
            })
            .collect()
    }
}
