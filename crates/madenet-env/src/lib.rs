//! Step-wise multi-agent environments over madenet's simulator: the Rust core of the Python
//! package's PettingZoo and Gymnasium environments, usable from Rust as well.
//!
//! An [`ExplorationEnv`] runs one [`Trial`] of the real world (same motion, sensing,
//! communication and navigation as `madenet run`) and stops at every decision point to take
//! the robots' actions from the caller:
//!
//! * [`ActionMode::Macro`] — the paper's macro actions: action k = go to goal candidate k
//!   (|G| actions, the invalid ones masked). A step applies the actions of the robots whose
//!   macro action terminated ([`ExplorationEnv::needs_action`]; the others' are ignored), then
//!   advances primitive timesteps until some robot's macro action terminates or the episode
//!   ends; rewards are summed over those timesteps.
//! * [`ActionMode::Primitive`] — one of 9 moves ([`Move::ALL`]: stay, N, NE, …) for every robot
//!   every timestep; a move into a cell the robot does not know to be free, or where it sees a
//!   teammate, is masked (taken anyway, the robot stays or is blocked).
//!
//! Observations are the robot's own ([`AgentView`]): the paper's 4-channel map image, the macro
//! observation vector and the action mask, written into caller-provided slices so that batched
//! callers allocate nothing per step. Rewards are Eq. (7) per robot and Eq. (8) for the team.
//! Invalid actions are tolerated (a robot given an invalid candidate stays and decides again).
//! With the same seed and the same decisions, the trajectory is the one `madenet run` produces.

pub mod vector;

pub use vector::{VecBuffers, VecEnv};

use madenet_agent::{AgentView, Decision, DecisionMode, Policy, ViewScratch};
use madenet_map::{OccGrid, Pos};
use madenet_sim::{PolicyRegistry, RewardConfig, SimError, Trial, TrialResult, TrialSpec};
use madenet_world::{Move, ScenarioConfig};

/// What an action means.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ActionMode {
    /// Choose goal candidate k (|G| actions) when the macro action terminates.
    #[default]
    Macro,
    /// Choose one of the 9 moves every timestep.
    Primitive,
}

/// Why an environment cannot be built or stepped.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error("{0}")]
    Usage(String),
}

/// The stand-in policy of every robot: decisions come from the caller.
struct Driven(DecisionMode);

impl Policy for Driven {
    fn name(&self) -> &str {
        "env"
    }
    fn mode(&self) -> DecisionMode {
        self.0
    }
    fn decide(&mut self, _view: &mut AgentView<'_>) -> Decision {
        Decision::Idle
    }
}

/// What one [`ExplorationEnv::step`] returns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepResult {
    /// Eq. (7) per robot, summed over the timesteps advanced.
    pub rewards: Vec<f64>,
    /// Eq. (8), summed over the timesteps advanced.
    pub team_reward: f64,
    /// Timesteps advanced.
    pub steps: usize,
    /// The map is explored.
    pub terminated: bool,
    /// The step cap was reached first.
    pub truncated: bool,
}

/// One environment: a trial driven step by step.
pub struct ExplorationEnv {
    map: OccGrid,
    map_name: String,
    starts: Vec<Pos>,
    scenario: ScenarioConfig,
    mode: ActionMode,
    rewards: RewardConfig,
    record: bool,
    trial: Option<Trial>,
    scratch: ViewScratch,
    decisions: Vec<Decision>,
}

impl ExplorationEnv {
    /// An environment on `map` with the team starting at `starts`; checked by building one
    /// trial (bad scenarios, starts off free cells or a wrong number of starts are errors).
    pub fn new(map: OccGrid, map_name: &str, starts: Vec<Pos>, scenario: ScenarioConfig, mode: ActionMode) -> Result<Self, EnvError> {
        if starts.len() != scenario.num_robots {
            return Err(EnvError::Usage(format!("{} start cells for {} robots (`num_robots`)", starts.len(), scenario.num_robots)));
        }
        let (h, w) = (map.height(), map.width());
        let mut env = ExplorationEnv {
            map,
            map_name: map_name.to_string(),
            starts,
            scenario,
            mode,
            rewards: RewardConfig::default(),
            record: false,
            trial: None,
            scratch: ViewScratch::new(h, w),
            decisions: Vec::new(),
        };
        env.build(0)?;
        env.trial = None;
        Ok(env)
    }

    /// A fresh environment with the same map, starts, scenario, mode and rewards (no episode).
    pub fn clone_config(&self) -> Result<Self, EnvError> {
        Ok(ExplorationEnv::new(self.map.clone(), &self.map_name, self.starts.clone(), self.scenario.clone(), self.mode)?
            .with_rewards(self.rewards.clone())
            .recording(self.record))
    }

    /// Use these reward constants (default: the paper's).
    pub fn with_rewards(mut self, rewards: RewardConfig) -> Self {
        self.rewards = rewards;
        self
    }

    /// Keep the trajectory (for [`ExplorationEnv::finish`]).
    pub fn recording(mut self, on: bool) -> Self {
        self.record = on;
        self
    }

    fn build(&mut self, seed: u64) -> Result<Trial, EnvError> {
        let mode = match self.mode {
            ActionMode::Macro => DecisionMode::OnTermination,
            ActionMode::Primitive => DecisionMode::EveryStep,
        };
        let mut registry = PolicyRegistry::default();
        registry.register("env", "decisions from the environment's caller", move |_| Box::new(Driven(mode)));
        let spec = TrialSpec {
            map: self.map.clone(),
            map_name: self.map_name.clone(),
            starts: self.starts.clone(),
            config: self.scenario.clone(),
            policy: "env".into(),
            seed,
        };
        Ok(Trial::with_registry(spec, &registry)?.reward_config(self.rewards.clone()).record_trajectory(self.record))
    }

    pub fn num_robots(&self) -> usize {
        self.starts.len()
    }
    pub fn height(&self) -> usize {
        self.map.height()
    }
    pub fn width(&self) -> usize {
        self.map.width()
    }
    pub fn mode(&self) -> ActionMode {
        self.mode
    }
    /// |G| (macro) or 9 (primitive).
    pub fn action_count(&self) -> usize {
        match self.mode {
            ActionMode::Macro => self.goal_count(),
            ActionMode::Primitive => Move::ALL.len(),
        }
    }
    /// |G| for this map (Eq. 3 unless configured).
    pub fn goal_count(&self) -> usize {
        self.scenario.goal_count_for(self.map.height() * self.map.width())
    }
    /// Length of the observation vector ([`AgentView::macro_observation`]).
    pub fn vector_len(&self) -> usize {
        AgentView::macro_observation_len(self.num_robots(), self.goal_count())
    }
    /// Length of the map image (4 channels × H × W).
    pub fn map_len(&self) -> usize {
        4 * self.map.height() * self.map.width()
    }

    /// Starts an episode with `seed` (world noise, dropouts) and runs to the first decision point.
    pub fn reset(&mut self, seed: u64) -> Result<(), EnvError> {
        let mut trial = self.build(seed)?;
        trial.begin_step();
        self.trial = Some(trial);
        Ok(())
    }

    fn trial(&self) -> Result<&Trial, EnvError> {
        self.trial.as_ref().ok_or_else(|| EnvError::Usage("call reset() before step()".into()))
    }

    /// The episode has ended (explored or at the cap).
    pub fn is_done(&self) -> bool {
        self.trial.as_ref().is_none_or(|t| t.is_done())
    }

    /// Which robots' actions the next [`ExplorationEnv::step`] uses.
    pub fn needs_action(&self) -> Vec<bool> {
        match &self.trial {
            Some(t) if !t.is_done() => t.deciding().to_vec(),
            _ => vec![false; self.num_robots()],
        }
    }

    /// The current timestep.
    pub fn t(&self) -> usize {
        self.trial.as_ref().map_or(0, |t| t.world().t())
    }

    /// Robot `robot`'s observation written into `map` (4·H·W, 0/1), `vector`
    /// ([`ExplorationEnv::vector_len`]) and `mask` ([`ExplorationEnv::action_count`], 1 = valid).
    /// Reading observations never changes the trajectory.
    pub fn observe_into(&mut self, robot: usize, map: &mut [f32], vector: &mut [f32], mask: &mut [u8]) -> Result<(), EnvError> {
        let n = self.num_robots();
        if robot >= n {
            return Err(EnvError::Usage(format!("robot {robot}: the team has {n}")));
        }
        if map.len() != self.map_len() || vector.len() != self.vector_len() || mask.len() != self.action_count() {
            return Err(EnvError::Usage("observation buffers of the wrong length".into()));
        }
        let mode = self.mode;
        let trial = self.trial.as_ref().ok_or_else(|| EnvError::Usage("call reset() before observing".into()))?;
        let view = trial.agents()[robot].peek_view(true, &mut self.scratch);
        for (o, v) in map.iter_mut().zip(view.map_image()) {
            *o = f32::from(v);
        }
        vector.copy_from_slice(&view.macro_observation());
        match mode {
            ActionMode::Macro => {
                for (m, v) in mask.iter_mut().zip(view.candidates().valid_mask()) {
                    *m = v as u8;
                }
            }
            ActionMode::Primitive => {
                let held: Vec<Pos> = view.teammates.iter().filter(|r| r.detected).filter_map(|r| r.seen_pos).collect();
                for (m, mv) in mask.iter_mut().zip(Move::ALL) {
                    let to = mv.apply(view.pos);
                    *m = (mv == Move::Stay || (view.belief.is_free(to) && !held.contains(&to))) as u8;
                }
            }
        }
        Ok(())
    }

    /// Applies `actions` (one per robot; only those of robots in
    /// [`ExplorationEnv::needs_action`] count) and advances to the next decision point or the
    /// episode's end.
    pub fn step(&mut self, actions: &[usize]) -> Result<StepResult, EnvError> {
        let n = self.num_robots();
        if actions.len() != n {
            return Err(EnvError::Usage(format!("{} actions for {n} robots", actions.len())));
        }
        let count = self.action_count();
        if let Some(a) = actions.iter().find(|&&a| a >= count) {
            return Err(EnvError::Usage(format!("action {a}: the action space has {count} actions")));
        }
        self.trial()?;
        let mode = self.mode;
        let trial = self.trial.as_mut().expect("checked above");
        if trial.is_done() {
            return Err(EnvError::Usage("the episode has ended; call reset()".into()));
        }
        self.decisions.clear();
        for (i, &a) in actions.iter().enumerate() {
            let deciding = trial.deciding()[i];
            let d = match mode {
                // The robot's own candidates, extracted as its own policy would see them.
                ActionMode::Macro if deciding => {
                    let _ = trial.agent_mut(i).view(true);
                    Decision::Candidate(a)
                }
                ActionMode::Primitive if deciding => {
                    let _ = trial.agent_mut(i).view(false);
                    match Move::ALL[a] {
                        Move::Stay => Decision::Idle,
                        mv => Decision::Goal(mv.apply(trial.agents()[i].pos())),
                    }
                }
                _ => Decision::Idle,
            };
            self.decisions.push(d);
        }
        trial.apply_decisions(&self.decisions);
        let mut out = StepResult { rewards: vec![0.0; n], ..StepResult::default() };
        loop {
            trial.finish_step();
            out.steps += 1;
            for (o, r) in out.rewards.iter_mut().zip(&trial.rewards().robots) {
                *o += r;
            }
            out.team_reward += trial.rewards().team;
            if !trial.begin_step() || trial.deciding().contains(&true) {
                break;
            }
        }
        out.terminated = trial.world().is_complete();
        out.truncated = trial.is_done() && !out.terminated;
        Ok(out)
    }

    /// The trial so far (metrics, and the trajectory if recording).
    pub fn finish(&mut self) -> Option<TrialResult> {
        self.trial.take().map(Trial::finish)
    }
}
