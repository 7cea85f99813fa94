//! The continuous world as a step-wise environment ([`ContinuousEnv`]): differential-drive
//! robots, lidar maps and a local planner ([`madenet_sim::continuous::ContinuousTrial`]), stopping
//! whenever some robot's macro action ends to take its next one from the caller.
//!
//! Observations and actions are those of [`crate::ExplorationEnv`]'s macro mode — each robot's
//! own 4-channel map image, macro observation vector and mask over its |G| goal candidates —
//! because the agents are the same; only the world under them moves in continuous time. A
//! step takes one action per robot (only the deciding robots' count; `None` lets the robot's
//! own policy, [`ContinuousSpec::policy`], decide) and advances control periods until a robot
//! decides again or the episode ends. With every action `None`, an episode is exactly the
//! trial `madenet run --world continuous` runs (tested). The reward is the number of
//! explorable cells the team newly knows, per step; the step also says how many simulated
//! seconds it took (the paper's exploration time is their sum).

use crate::driver::{Driver, Stepped};
use crate::EnvError;
use madenet_agent::{AgentView, Decision};
use madenet_sim::continuous::{ContinuousResult, ContinuousSpec, ContinuousTrial};
use madenet_sim::PolicyRegistry;

/// What one [`ContinuousEnv::step`] returns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContinuousStep {
    /// Explorable cells the team newly knows.
    pub team_reward: f64,
    /// Simulated seconds advanced.
    pub seconds: f64,
    /// Every explorable cell is known.
    pub terminated: bool,
    /// The trial ended otherwise: the time cap, or no robot had a reachable frontier left.
    pub truncated: bool,
}

/// One continuous-world environment.
pub struct ContinuousEnv {
    spec: ContinuousSpec,
    registry: PolicyRegistry,
    driver: Driver<ContinuousTrial>,
    goal_count: usize,
    /// Rows and columns of the agents' cells.
    size: (usize, usize),
}

impl ContinuousEnv {
    /// An environment of `spec`'s trial, its robots' own policy from `registry`; checked by
    /// building one trial (bad scenarios and starts are errors).
    pub fn new(spec: ContinuousSpec, registry: &PolicyRegistry) -> Result<Self, EnvError> {
        let probe = ContinuousTrial::new(spec.clone(), registry)?;
        let (h, w) = probe.world().map(0).coarse_size();
        let n = probe.agents().len();
        Ok(ContinuousEnv {
            goal_count: spec.config.goal_count_for(h * w),
            size: (h, w),
            spec,
            registry: registry.clone(),
            driver: Driver::new(n, h, w),
        })
    }

    /// Team size |I|.
    pub fn num_robots(&self) -> usize {
        self.driver.scratch.len()
    }
    /// Rows of the agents' cells.
    pub fn height(&self) -> usize {
        self.size.0
    }
    /// Columns of the agents' cells.
    pub fn width(&self) -> usize {
        self.size.1
    }
    /// Actions per robot: |G|.
    pub fn action_count(&self) -> usize {
        self.goal_count
    }
    /// Length of the macro observation vector.
    pub fn vector_len(&self) -> usize {
        AgentView::macro_observation_len(self.num_robots(), self.goal_count)
    }
    /// Length of the map image: 4 · H · W.
    pub fn map_len(&self) -> usize {
        4 * self.height() * self.width()
    }

    /// Starts an episode with `seed` (sensors, radio and the robots' own policies) and runs
    /// it to its first decision point.
    pub fn reset(&mut self, seed: u64) -> Result<(), EnvError> {
        let spec = ContinuousSpec {
            seed,
            ..self.spec.clone()
        };
        let trial = ContinuousTrial::new(spec, &self.registry)?.with_external_decisions(true);
        self.driver.start(trial);
        Ok(())
    }

    /// The trial (its world, agents, planners), for pictures and checks.
    pub fn current(&self) -> Option<&ContinuousTrial> {
        self.driver.trial.as_ref()
    }

    /// Whether the episode is over (or none was started).
    pub fn is_done(&self) -> bool {
        self.driver.is_done()
    }

    /// Which robots' actions the next [`ContinuousEnv::step`] uses.
    pub fn needs_action(&self) -> Vec<bool> {
        self.driver.needs_action()
    }

    /// Simulated seconds since the episode started.
    pub fn time(&self) -> f64 {
        self.driver.trial.as_ref().map_or(0.0, |t| t.world().time())
    }

    /// Robot `robot`'s observation written into `map` (4·H·W, 0/1), `vector`
    /// ([`ContinuousEnv::vector_len`]) and `mask` ([`ContinuousEnv::action_count`], 1 = valid),
    /// as [`crate::ExplorationEnv::observe_into`] in macro mode. Reading observations never
    /// changes the trajectory.
    pub fn observe_into(
        &mut self,
        robot: usize,
        map: &mut [f32],
        vector: &mut [f32],
        mask: &mut [u8],
    ) -> Result<(), EnvError> {
        let lengths = (self.map_len(), self.vector_len(), self.action_count());
        let view = self
            .driver
            .observe_into(robot, true, lengths, (map, vector, mask))?;
        crate::write_action_mask(&view, mask);
        Ok(())
    }

    /// Applies one action per robot — `Some(k)`: goal candidate k; `None`: the robot's own
    /// policy decides — to the robots in [`ContinuousEnv::needs_action`] (the others' are
    /// ignored), then advances to the next decision point or the episode's end. A candidate
    /// that is not valid leaves the robot in place to decide again.
    pub fn step(&mut self, actions: &[Option<usize>]) -> Result<ContinuousStep, EnvError> {
        let count = self.action_count();
        if let Some(a) = actions.iter().flatten().find(|&&a| a >= count) {
            return Err(EnvError::Usage(format!(
                "action {a}: the action space has {count} actions"
            )));
        }
        let decisions: Vec<Option<Decision>> =
            actions.iter().map(|a| a.map(Decision::Candidate)).collect();
        self.step_decisions(&decisions)
    }

    /// [`ContinuousEnv::step`] with any [`Decision`] (a candidate, a goal cell, idling), or
    /// `None` for the robot's own policy.
    pub fn step_decisions(
        &mut self,
        decisions: &[Option<Decision>],
    ) -> Result<ContinuousStep, EnvError> {
        let n = self.num_robots();
        if decisions.len() != n {
            return Err(EnvError::Usage(format!(
                "{} actions for {n} robots",
                decisions.len()
            )));
        }
        let (h, w) = self.size;
        if let Some(Some(Decision::Goal(p))) = decisions.iter().find(|d| {
            matches!(d, Some(Decision::Goal(p)) if p.row < 0 || p.col < 0 || p.row as usize >= h || p.col as usize >= w)
        }) {
            return Err(EnvError::Usage(format!(
                "goal ({}, {}) lies outside the {h} × {w} cells",
                p.row, p.col
            )));
        }
        let known = |t: &ContinuousTrial| {
            t.world().explored_fraction() * t.world().explorable_count() as f64
        };
        let trial = self.driver.trial("step()")?;
        let (known_before, time_before) = (known(trial), trial.world().time());
        match self.driver.step(decisions, &mut |_| {})? {
            Stepped::Ended { terminated } => Ok(ContinuousStep {
                terminated,
                truncated: !terminated,
                ..Default::default()
            }),
            Stepped::Advanced {
                terminated,
                truncated,
            } => {
                let trial = self.driver.trial("step()")?;
                Ok(ContinuousStep {
                    team_reward: (known(trial) - known_before).round(),
                    seconds: trial.world().time() - time_before,
                    terminated,
                    truncated,
                })
            }
        }
    }

    /// The episode's result (ET, TTD, collisions, …); ends the episode.
    pub fn finish(&mut self) -> Option<ContinuousResult> {
        self.driver.trial.take().map(ContinuousTrial::finish)
    }
}
