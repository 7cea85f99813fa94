//! Step-wise multi-agent environments over madenet's simulator: the Rust core of the Python
//! package's PettingZoo and Gymnasium environments, usable from Rust as well.
//!
//! An [`ExplorationEnv`] runs one [`Trial`] of the real world (same motion, sensing,
//! communication and navigation as `madenet run`) and stops at every decision point to take
//! the robots' actions from the caller:
//!
//! * [`ActionMode::Macro`] — the paper's macro actions: action k = go to goal candidate k
//!   (|G| actions, the invalid ones masked; a robot with no candidate left may take slot 0
//!   alone, which means "stay", as in MADE-Net's training, [`madenet_agent::action_mask`]). A step applies the actions of the robots whose
//!   macro action terminated ([`ExplorationEnv::needs_action`]; the others' are ignored), then
//!   advances primitive timesteps until some robot's macro action terminates or the episode
//!   ends; rewards are summed over those timesteps.
//! * [`ActionMode::Primitive`] — one of 9 moves ([`Move::ALL`]: stay, N, NE, …) for every robot
//!   every timestep; a move into a cell the robot does not know to be free, or where it sees a
//!   teammate, is masked (taken anyway, the robot stays).
//!
//! Observations are the robot's own ([`AgentView`]): the paper's 4-channel map image, the macro
//! observation vector and the action mask, written into caller-provided slices so that batched
//! callers allocate nothing per step. Rewards are Eq. (7) per robot and Eq. (8) for the team.
//! Invalid actions are tolerated (a robot given an invalid candidate stays and decides again).
//! With the same seed and the same decisions, the trajectory is the one `madenet run` produces.
//!
//! Around that core:
//!
//! * [`ExplorationEnv::step_decisions`] takes any [`Decision`] (candidate, goal cell, idle), and
//!   [`ExplorationEnv::policy_decisions`] asks a shipped policy for them — each robot deciding
//!   from its own view, reproducing the policy's own trial;
//! * [`ExplorationEnv::observe_joint_into`] / [`ExplorationEnv::step_joint`]: the whole team as
//!   one agent (merged observation, joint action |G|^|I|), for centralized learners;
//! * [`VecEnv`]: N environments stepped together (on rayon, or in turn on the calling thread
//!   when rayon has one thread) into flat buffers, auto-resetting;
//! * [`ExplorationEnv::frame`]: the picture of the current state, as `madenet run --render`
//!   draws it ([`madenet_render::trial_frame`]).

#![deny(missing_docs)]

pub mod continuous;
mod driver;
pub mod vector;

pub use continuous::{ContinuousEnv, ContinuousStep};
pub use vector::{VecBuffers, VecEnv, VecOutputs};

pub use madenet_agent::Decision;

use driver::{Driver, Stepped};
use madenet_agent::{
    action_mask, write_joint_map_image, AgentView, Belief, DecisionMode, Policy, TeammateRecord,
};
use madenet_map::{OccGrid, Pos};
use madenet_render::Frame;
use madenet_sim::{
    PolicyContext, PolicyRegistry, RewardConfig, SimError, Trial, TrialResult, TrialSpec,
};
use madenet_world::{Move, ScenarioConfig};

/// Whether primitive move `mv` is allowed for a robot at `pos` with this belief and teammates: staying always is; a move
/// needs a target cell the robot knows to be free and where it sees no teammate.
fn primitive_allowed(pos: Pos, belief: &Belief, teammates: &[TeammateRecord], mv: Move) -> bool {
    if mv == Move::Stay {
        return true;
    }
    let to = mv.apply(pos);
    belief.is_free(to)
        && !teammates
            .iter()
            .any(|r| r.detected && r.seen_pos == Some(to))
}

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
    /// The simulator refused to set up the trial or a policy (an invalid scenario config or
    /// start cells; an unknown or unavailable policy).
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The caller misused the environment (wrong buffer lengths or counts; an action, robot or
    /// goal out of range; a call before `reset` or after the episode's end; a mode mismatch);
    /// the message says which.
    #[error("{0}")]
    Usage(String),
}

/// The macro action mask of `view` into `mask` (1 = valid candidate).
pub(crate) fn write_action_mask(view: &AgentView<'_>, mask: &mut [u8]) {
    for (m, v) in mask.iter_mut().zip(action_mask(view)) {
        *m = v as u8;
    }
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
    observe_candidates: bool,
    /// The episode's trial, driven through the stepping contract.
    driver: Driver<Trial>,
    seed: u64,
    /// The decisions of a step (reused, no allocation per step).
    decisions: Vec<Option<Decision>>,
    /// Shipped policies acting in this episode ([`ExplorationEnv::policy_decisions`]), one
    /// instance per robot, built with the episode's seed.
    policies: Vec<(String, Vec<Box<dyn Policy>>)>,
    /// Cast rays shared with the other environments of a [`VecEnv`].
    visibility: Option<std::sync::Arc<madenet_world::Visibility>>,
    /// |G| (Eq. 3 unless configured), computed once.
    goal_count: usize,
    /// Eq. (7) per robot summed over the last step's timesteps (reused, no allocation per step).
    step_rewards: Vec<f64>,
}

/// What [`ExplorationEnv::advance`] reports besides the per-robot rewards.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Advanced {
    team_reward: f64,
    steps: usize,
    pub(crate) terminated: bool,
    pub(crate) truncated: bool,
}

impl ExplorationEnv {
    /// An environment on `map` with the team starting at `starts`; checked by building one
    /// trial (bad scenarios, starts off free cells or a wrong number of starts are errors).
    pub fn new(
        map: OccGrid,
        map_name: &str,
        starts: Vec<Pos>,
        scenario: ScenarioConfig,
        mode: ActionMode,
    ) -> Result<Self, EnvError> {
        if starts.len() != scenario.num_robots {
            return Err(EnvError::Usage(format!(
                "{} start cells for {} robots (`num_robots`)",
                starts.len(),
                scenario.num_robots
            )));
        }
        let (h, w, starts_len) = (map.height(), map.width(), starts.len());
        let mut env = ExplorationEnv {
            map,
            map_name: map_name.to_string(),
            starts,
            scenario,
            mode,
            rewards: RewardConfig::default(),
            record: false,
            observe_candidates: mode == ActionMode::Macro,
            driver: Driver::new(starts_len, h, w),
            seed: 0,
            decisions: Vec::new(),
            policies: Vec::new(),
            visibility: None,
            goal_count: 0,
            step_rewards: vec![0.0; starts_len],
        };
        env.goal_count = env.scenario.goal_count_for(h * w);
        env.build(0)?;
        Ok(env)
    }

    /// A fresh environment with the same map, starts, scenario, mode and rewards (no episode).
    pub fn clone_config(&self) -> Result<Self, EnvError> {
        Ok(ExplorationEnv::new(
            self.map.clone(),
            &self.map_name,
            self.starts.clone(),
            self.scenario.clone(),
            self.mode,
        )?
        .with_rewards(self.rewards.clone())
        .recording(self.record)
        .observing_candidates(self.observe_candidates))
    }

    /// This environment's cast rays, to share with copies of it ([`ExplorationEnv::share_visibility`]).
    pub fn visibility(&mut self) -> Result<std::sync::Arc<madenet_world::Visibility>, EnvError> {
        if self.visibility.is_none() {
            let mut probe = self.build(0)?;
            self.visibility = Some(probe.visibility());
        }
        Ok(self.visibility.clone().expect("set above"))
    }

    /// Senses with `v` (from [`ExplorationEnv::visibility`] of an environment with the same
    /// map and scenario) from the next episode on: the same observations, one copy of the rays
    /// for a whole batch of environments.
    pub fn share_visibility(&mut self, v: std::sync::Arc<madenet_world::Visibility>) {
        self.visibility = Some(v);
        self.driver.trial = None;
    }

    /// Whether observations carry the goal candidates (map channel 3, the vector's candidate
    /// slots). Always in macro mode (the actions are candidates); off by default in primitive
    /// mode, where extracting them (a Dijkstra and a clustering per robot per step) would cost
    /// more than the step itself.
    pub fn observing_candidates(mut self, on: bool) -> Self {
        self.observe_candidates = on || self.mode == ActionMode::Macro;
        self
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

    /// The registry of the stand-in policy.
    fn registry(&self) -> PolicyRegistry {
        let mode = match self.mode {
            ActionMode::Macro => DecisionMode::OnTermination,
            ActionMode::Primitive => DecisionMode::EveryStep,
        };
        let mut registry = PolicyRegistry::default();
        registry.register(
            "env",
            "decisions from the environment's caller",
            move |_| Box::new(Driven(mode)),
        );
        registry
    }

    fn build(&mut self, seed: u64) -> Result<Trial, EnvError> {
        let registry = self.registry();
        let spec = TrialSpec {
            map: self.map.clone(),
            map_name: self.map_name.clone(),
            starts: self.starts.clone(),
            config: self.scenario.clone(),
            policy: "env".into(),
            seed,
        };
        Ok(Trial::with_registry(spec, &registry)?
            .reward_config(self.rewards.clone())
            .record_trajectory(self.record)
            .timed(false)
            .with_external_decisions(true))
    }

    /// Team size |I|.
    pub fn num_robots(&self) -> usize {
        self.starts.len()
    }
    /// Map height H in cells.
    pub fn height(&self) -> usize {
        self.map.height()
    }
    /// Map width W in cells.
    pub fn width(&self) -> usize {
        self.map.width()
    }
    /// What an action means in this environment.
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
        self.goal_count
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
        // The next episode reuses the last one's world (its cast rays): same result as new.
        let trial = match self.driver.trial.take() {
            Some(old) => old.restart(seed, &self.registry())?,
            None => {
                let mut t = self.build(seed)?;
                if let Some(v) = &self.visibility {
                    t.use_visibility(v.clone());
                }
                t
            }
        };
        self.driver.start(trial);
        self.seed = seed;
        self.policies.clear();
        Ok(())
    }

    /// The seed of the current episode.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    fn trial(&self) -> Result<&Trial, EnvError> {
        self.driver.trial("step()")
    }

    /// The episode has ended (explored or at the cap). Right after a reset this can already be
    /// true (a map seen whole from the start cells): the next step then reports the end.
    pub fn is_done(&self) -> bool {
        self.driver.is_done()
    }

    /// Which robots' actions the next [`ExplorationEnv::step`] uses.
    pub fn needs_action(&self) -> Vec<bool> {
        self.driver.needs_action()
    }

    /// [`ExplorationEnv::needs_action`] written into `out` (one per robot).
    pub(crate) fn needs_action_into(&self, out: &mut [bool]) {
        self.driver.needs_action_into(out)
    }

    /// The current timestep.
    pub fn t(&self) -> usize {
        self.driver.trial.as_ref().map_or(0, |t| t.world().t())
    }

    /// Robot `robot`'s observation written into `map` (4·H·W, 0/1), `vector`
    /// ([`ExplorationEnv::vector_len`]) and `mask` ([`ExplorationEnv::action_count`], 1 = valid).
    /// Reading observations never changes the trajectory.
    pub fn observe_into(
        &mut self,
        robot: usize,
        map: &mut [f32],
        vector: &mut [f32],
        mask: &mut [u8],
    ) -> Result<(), EnvError> {
        let lengths = (self.map_len(), self.vector_len(), self.action_count());
        let view = self.driver.observe_into(
            robot,
            self.observe_candidates,
            lengths,
            (map, vector, mask),
        )?;
        match self.mode {
            ActionMode::Macro => write_action_mask(&view, mask),
            ActionMode::Primitive => {
                for (m, mv) in mask.iter_mut().zip(Move::ALL) {
                    *m = primitive_allowed(view.pos, view.belief, view.teammates, mv) as u8;
                }
            }
        }
        Ok(())
    }

    /// Number of joint macro actions |G|^|I| (`None` if it overflows).
    pub fn joint_action_count(&self) -> Option<usize> {
        self.goal_count()
            .checked_pow(u32::try_from(self.num_robots()).ok()?)
    }

    /// Length of the joint observation vector: every robot's vector in robot order.
    pub fn joint_vector_len(&self) -> usize {
        self.num_robots() * self.vector_len()
    }

    /// The centralized observation (what the CEP of centralized training sees, Sec. III.C.2):
    /// the merged map image ([`madenet_agent::write_joint_map_image`]) into `map` (4·H·W),
    /// every robot's vector into `vector` ([`ExplorationEnv::joint_vector_len`]), and the joint
    /// action mask into `mask` ([`ExplorationEnv::joint_action_count`]): joint action
    /// a = Σ k_i·|G|^i is valid when every deciding robot's k_i is valid for it (slot 0 = stay
    /// when it has no candidate, [`madenet_agent::action_mask`]) and k_i = 0 for the robots
    /// whose macro action is still running (their part is ignored).
    pub fn observe_joint_into(
        &mut self,
        map: &mut [f32],
        vector: &mut [f32],
        mask: &mut [u8],
    ) -> Result<(), EnvError> {
        if self.mode != ActionMode::Macro {
            return Err(EnvError::Usage(
                "the joint observation needs a macro-mode environment".into(),
            ));
        }
        let count = self
            .joint_action_count()
            .ok_or_else(|| EnvError::Usage("|G|^|I| overflows".into()))?;
        let (vl, goals) = (self.vector_len(), self.goal_count());
        if map.len() != self.map_len()
            || vector.len() != self.joint_vector_len()
            || mask.len() != count
        {
            return Err(EnvError::Usage(
                "joint observation buffers of the wrong length".into(),
            ));
        }
        let driver = &mut self.driver;
        let trial = driver
            .trial
            .as_ref()
            .ok_or_else(|| EnvError::Usage("call reset() before observing".into()))?;
        let deciding = if trial.is_done() {
            vec![false; self.starts.len()]
        } else {
            trial.deciding().to_vec()
        };
        let views: Vec<AgentView<'_>> = trial
            .agents()
            .iter()
            .zip(driver.scratch.iter_mut())
            .map(|(a, s)| a.peek_view(true, s))
            .collect();
        driver.scratch_current.fill(true);
        write_joint_map_image(&views, trial.world().team_map(), map);
        let mut masks = Vec::with_capacity(views.len());
        for (i, v) in views.iter().enumerate() {
            v.write_macro_observation(&mut vector[i * vl..(i + 1) * vl]);
            masks.push(if deciding[i] {
                action_mask(v)
            } else {
                (0..goals).map(|k| k == 0).collect()
            });
        }
        for (a, m) in mask.iter_mut().enumerate() {
            *m = masks
                .iter()
                .enumerate()
                .all(|(i, robot_mask)| robot_mask[madenet_agent::joint_digit(a, i, goals)])
                as u8;
        }
        Ok(())
    }

    /// Applies joint action a = Σ k_i·|G|^i (robot i's part k_i; see
    /// [`ExplorationEnv::observe_joint_into`]).
    pub fn step_joint(&mut self, action: usize) -> Result<StepResult, EnvError> {
        let count = self
            .joint_action_count()
            .ok_or_else(|| EnvError::Usage("|G|^|I| overflows".into()))?;
        if self.mode != ActionMode::Macro {
            return Err(EnvError::Usage(
                "joint actions need a macro-mode environment".into(),
            ));
        }
        if action >= count {
            return Err(EnvError::Usage(format!(
                "joint action {action}: the joint action space has {count} actions"
            )));
        }
        let goals = self.goal_count();
        let actions = madenet_agent::joint_decode(action, self.num_robots(), goals);
        self.step(&actions)
    }

    /// The decisions shipped policy `name` (from `registry`) makes for the robots that decide
    /// now, each from its own robot's view; [`Decision::Idle`] for the others. The policy's
    /// instances (one per robot, built with the episode's seed) keep their state through the
    /// episode, so passing these decisions to [`ExplorationEnv::step_decisions`] at every step
    /// reproduces the policy's own trial. Its decision mode must be the environment's: policies
    /// that decide every timestep (NF, UB, PB, DME-DRL) act in primitive mode, those that decide
    /// when their macro action terminates (MADE-Net, random) in macro mode.
    pub fn policy_decisions(
        &mut self,
        name: &str,
        registry: &PolicyRegistry,
    ) -> Result<Vec<Decision>, EnvError> {
        let trial = self
            .driver
            .trial
            .as_mut()
            .ok_or_else(|| EnvError::Usage("call reset() before asking a policy".into()))?;
        if trial.is_done() && self.driver.end_reported {
            return Err(EnvError::Usage(
                "the episode has ended; call reset()".into(),
            ));
        }
        let slot = match self.policies.iter().position(|(n, _)| n == name) {
            Some(k) => k,
            None => {
                let (h, w) = (self.map.height(), self.map.width());
                let built = (0..self.starts.len())
                    .map(|robot| {
                        registry.make(
                            name,
                            &PolicyContext {
                                seed: self.seed,
                                robot,
                                config: &self.scenario,
                                height: h,
                                width: w,
                            },
                        )
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                let wanted = match self.mode {
                    ActionMode::Macro => DecisionMode::OnTermination,
                    ActionMode::Primitive => DecisionMode::EveryStep,
                };
                if built[0].mode() != wanted {
                    let (its, use_mode) = match built[0].mode() {
                        DecisionMode::EveryStep => ("decides every timestep", "primitive"),
                        DecisionMode::OnTermination => {
                            ("decides when its macro action terminates", "macro")
                        }
                    };
                    return Err(EnvError::Usage(format!(
                        "policy `{name}` {its}: use it in a `{use_mode}` environment"
                    )));
                }
                self.policies.push((name.to_string(), built));
                self.policies.len() - 1
            }
        };
        let policies = &mut self.policies[slot].1;
        if trial.is_done() {
            // Over at its start: nothing to decide; the next step reports the end.
            return Ok(vec![Decision::Idle; policies.len()]);
        }
        let deciding = trial.deciding().to_vec();
        Ok((0..policies.len())
            .map(|i| {
                if !deciding[i] {
                    return Decision::Idle;
                }
                let p = &mut policies[i];
                let mut view = trial.agent_mut(i).view(p.needs_candidates());
                p.decide(&mut view)
            })
            .collect())
    }

    /// The picture `madenet run --render` draws of the current state (truth and team map,
    /// robots, paths, goals, candidates, links).
    pub fn frame(&self) -> Result<Frame, EnvError> {
        Ok(madenet_render::trial_frame(self.trial()?))
    }

    /// Applies `actions` (one per robot; only those of robots in
    /// [`ExplorationEnv::needs_action`] count) and advances to the next decision point or the
    /// episode's end. Macro: action k = goal candidate k. Primitive: [`Move::ALL`]`[k]`; a move
    /// the mask forbids keeps the robot where it is. An episode over at its start (a map seen
    /// whole from the start cells) ends at its first step: terminated, no timestep advanced.
    pub fn step(&mut self, actions: &[usize]) -> Result<StepResult, EnvError> {
        let a = self.step_in_place(actions)?;
        Ok(self.step_result(a))
    }

    /// The decisions `actions` (one per robot, checked) stand for.
    fn decide_actions(
        &self,
        actions: &[usize],
        decisions: &mut Vec<Option<Decision>>,
    ) -> Result<(), EnvError> {
        let count = self.action_count();
        if let Some(a) = actions.iter().find(|&&a| a >= count) {
            return Err(EnvError::Usage(format!(
                "action {a}: the action space has {count} actions"
            )));
        }
        let trial = self.trial()?;
        decisions.clear();
        for (i, &a) in actions.iter().enumerate() {
            decisions.push(Some(match self.mode {
                ActionMode::Macro => Decision::Candidate(a),
                ActionMode::Primitive => {
                    let agent = &trial.agents()[i];
                    match Move::ALL[a] {
                        mv if mv != Move::Stay
                            && primitive_allowed(
                                agent.pos(),
                                agent.belief(),
                                agent.teammates(),
                                mv,
                            ) =>
                        {
                            Decision::Goal(mv.apply(agent.pos()))
                        }
                        _ => Decision::Idle,
                    }
                }
            }));
        }
        Ok(())
    }

    /// [`ExplorationEnv::step`] without building a [`StepResult`]: the rewards stay in
    /// [`ExplorationEnv::step_rewards`] (the batched path allocates nothing per step).
    pub(crate) fn step_in_place(&mut self, actions: &[usize]) -> Result<Advanced, EnvError> {
        let n = self.num_robots();
        if actions.len() != n {
            return Err(EnvError::Usage(format!(
                "{} actions for {n} robots",
                actions.len()
            )));
        }
        let mut decisions = std::mem::take(&mut self.decisions);
        let r = self
            .decide_actions(actions, &mut decisions)
            .and_then(|()| self.advance(&decisions));
        self.decisions = decisions;
        r
    }

    /// Eq. (7) per robot, summed over the timesteps of the last step.
    pub(crate) fn step_rewards(&self) -> &[f64] {
        &self.step_rewards
    }

    fn step_result(&self, a: Advanced) -> StepResult {
        StepResult {
            rewards: self.step_rewards.clone(),
            team_reward: a.team_reward,
            steps: a.steps,
            terminated: a.terminated,
            truncated: a.truncated,
        }
    }

    /// Applies one [`Decision`] per robot (those of robots not in
    /// [`ExplorationEnv::needs_action`] are ignored): a candidate index, any goal cell, or
    /// idling; then advances to the next decision point or the episode's end (an episode over
    /// at its start ends here, as in [`ExplorationEnv::step`]).
    pub fn step_decisions(&mut self, decisions: &[Decision]) -> Result<StepResult, EnvError> {
        let mut buffer = std::mem::take(&mut self.decisions);
        buffer.clear();
        buffer.extend(decisions.iter().map(|&d| Some(d)));
        let a = self.advance(&buffer);
        self.decisions = buffer;
        Ok(self.step_result(a?))
    }

    /// [`ExplorationEnv::step_decisions`], the rewards left in `step_rewards`.
    fn advance(&mut self, decisions: &[Option<Decision>]) -> Result<Advanced, EnvError> {
        let n = self.num_robots();
        if decisions.len() != n {
            return Err(EnvError::Usage(format!(
                "{} decisions for {n} robots",
                decisions.len()
            )));
        }
        let (h, w) = (self.map.height() as i32, self.map.width() as i32);
        if let Some(Some(Decision::Goal(p))) = decisions.iter().find(|d| matches!(d, Some(Decision::Goal(p)) if p.row < 0 || p.col < 0 || p.row >= h || p.col >= w)) {
            return Err(EnvError::Usage(format!("goal ({}, {}) lies outside the {h} × {w} map", p.row, p.col)));
        }
        self.step_rewards.fill(0.0);
        let (mut team_reward, mut steps) = (0.0, 0);
        let rewards = &mut self.step_rewards;
        let stepped = self.driver.step(decisions, &mut |trial| {
            steps += 1;
            for (o, r) in rewards.iter_mut().zip(&trial.rewards().robots) {
                *o += r;
            }
            team_reward += trial.rewards().team;
        })?;
        let (terminated, truncated) = match stepped {
            // Over at its start (a map seen whole from the start cells): this step reports
            // the end, advancing nothing, so callers (and a VecEnv's autoreset) see it end.
            Stepped::Ended { terminated } => (terminated, !terminated),
            Stepped::Advanced {
                terminated,
                truncated,
            } => (terminated, truncated),
        };
        Ok(Advanced {
            team_reward,
            steps,
            terminated,
            truncated,
        })
    }

    /// The trial so far (metrics, and the trajectory if recording). Steps are not timed in an
    /// environment (the caller's decisions are part of its loop): `timing.trial_s` is 0.
    pub fn finish(&mut self) -> Option<TrialResult> {
        self.driver.trial.take().map(Trial::finish)
    }
}
