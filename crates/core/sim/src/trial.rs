//! One trial: world + agents + recorder.

use crate::registry::{PolicyContext, PolicyRegistry};
use crate::rewards::{RewardConfig, StepRewards};
use crate::stepping::{present_grid_world, Present, RobotShown, Stepping};
use crate::SimError;
use madenet_agent::{Agent, AgentConfig, Beta, Decision, External, JointPolicy, PlanMessage};
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_metrics::{MetricsRecorder, Timing, TrialMetrics};
use madenet_world::{Move, ScenarioConfig, World};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::time::Instant;

/// Everything that defines a trial.
#[derive(Clone, Debug)]
pub struct TrialSpec {
    /// The ground-truth map.
    pub map: OccGrid,
    /// A label for outputs (e.g. `test_3`).
    pub map_name: String,
    /// Start cells, robot i at `starts[i]`; cells beyond `config.num_robots` are ignored.
    pub starts: Vec<Pos>,
    /// The scenario's parameters (d_s, CSP, noise, step cap, …).
    pub config: ScenarioConfig,
    /// Every robot's policy, by its name in the [`PolicyRegistry`] (e.g. `nf`, `spread`).
    pub policy: String,
    /// Seed of the world's random streams and of the robots' policies.
    pub seed: u64,
}

impl TrialSpec {
    /// A trial on the paper's map `map` (1–10) from `corner`, at CSP `csp`, the rest of the
    /// scenario at the paper's defaults.
    pub fn paper(
        map: usize,
        corner: madenet_map::paper::Corner,
        policy: &str,
        csp: f64,
        seed: u64,
    ) -> Result<Self, madenet_map::MapError> {
        let grid = madenet_map::paper::paper_map(map)?;
        let starts = corner.start_cells(grid.height(), grid.width()).to_vec();
        Ok(TrialSpec {
            map: grid,
            map_name: madenet_map::paper::paper_map_name(map),
            starts,
            config: ScenarioConfig {
                comm_success_prob: csp,
                ..Default::default()
            },
            policy: policy.to_string(),
            seed,
        })
    }
}

/// One timestep of a trajectory (state after the step).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepRecord {
    /// Timestep reached by this step (1 for the first).
    pub t: usize,
    /// Every robot's cell x_i after the step.
    pub positions: Vec<Pos>,
    /// The moves executed (slips and conflicts applied, so not necessarily those intended).
    pub moves: Vec<Move>,
    /// Every robot's goal g_i in force (None: it had none and stayed).
    pub goals: Vec<Option<Pos>>,
    /// Robots that took a decision in this step (their macro action had terminated).
    pub decided: Vec<bool>,
    /// Each robot's macro action in force (goal candidate index), if it chose one.
    pub actions: Vec<Option<usize>>,
    /// Pairs (i < j) whose exchange succeeded at this step's contact stage (the trial
    /// delivers their β at the start of the next step).
    pub exchanges: Vec<(usize, usize)>,
    /// The team's explored fraction after the step, 0..=1.
    pub explored: f64,
    /// Rewards of the step (Eq. 7 per robot, Eq. 8 for the team).
    pub rewards: StepRewards,
}

/// The outcome of a trial.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialResult {
    /// The map's label ([`TrialSpec::map_name`]).
    pub map: String,
    /// The policy's registry name, or the joint policy's name ([`Trial::with_joint_policy`]).
    pub policy: String,
    /// The trial's seed.
    pub seed: u64,
    /// CSP, the communication success probability of the scenario.
    pub comm_success_prob: f64,
    /// The start cells of the robots that ran (one per robot).
    pub starts: Vec<Pos>,
    /// The paper's metrics (TNS, TTD, NOLI, OFV, exploration curve).
    pub metrics: TrialMetrics,
    /// Empty unless recording was requested.
    pub trajectory: Vec<StepRecord>,
    /// Wall-clock times (CT): the steps and the robots' decisions.
    pub timing: Timing,
}

/// Which future a [`Trial::fork`] lives.
#[derive(Clone, Debug, PartialEq)]
pub enum Future {
    /// This trial's own: the same noise draws (a replay, which knows the luck to come).
    Own,
    /// Another future of the same present: noise streams from this salt
    /// ([`madenet_world::World::reseed_noise`]).
    Salted(u64),
    /// No sensor misses and no slips from now on ([`madenet_world::World::set_noiseless`]):
    /// the certainty-equivalent future, free of the luck of sensing and motion (communication
    /// keeps this trial's own draws, so at a CSP strictly between 0 and 1 it knows which
    /// exchanges will succeed).
    Noiseless,
    /// The noiseless future on another world that agrees with what the team knows: the cells
    /// nobody has seen yet are those of this map (a draw of the map generator; the same size;
    /// [`madenet_world::World::redraw_unseen`]). Averaged over several draws, a rollout's value
    /// is an expectation over what the team cannot know — a label its belief can predict, where
    /// the noiseless future's value knows the true map.
    Redrawn(std::sync::Arc<OccGrid>),
}

/// A trial in progress.
pub struct Trial {
    spec_map: String,
    policy: String,
    starts: Vec<Pos>,
    seed: u64,
    world: World,
    agents: Vec<Agent>,
    recorder: MetricsRecorder,
    trajectory: Vec<StepRecord>,
    record: bool,
    /// Wall time spent inside `step` (when `timed`).
    elapsed: std::time::Duration,
    timed: bool,
    decided: Vec<bool>,
    moves: Vec<Move>,
    /// A centralized policy deciding for every robot, if any (else each agent's own).
    joint: Option<Box<dyn JointPolicy>>,
    reward_config: RewardConfig,
    /// Consecutive timesteps each robot has been in local interaction (ρ of Eq. 7).
    interaction_steps: Vec<u32>,
    rewards: StepRewards,
    /// Messages of the current step, kept to reuse their allocations: each robot's β
    /// (`composed` = written this step) and the plan being announced.
    outbox: Vec<Beta>,
    composed: Vec<bool>,
    plan_message: PlanMessage,
    /// Decisions come from outside through [`Stepping`] ([`Trial::with_external_decisions`]).
    external: bool,
    /// Robots waiting for an outside decision ([`Stepping::deciding`]).
    awaiting: Vec<bool>,
    /// A timestep is half done: begun, its decisions given, its moves still to come.
    mid_step: bool,
}

/// The world and the agents of `spec`, each agent with its own policy from `registry` (seeded
/// by the trial seed and the robot's index): what [`Trial`] runs in one process and what the
/// runtime runs as separate nodes.
pub fn build(spec: TrialSpec, registry: &PolicyRegistry) -> Result<(World, Vec<Agent>), SimError> {
    let agents = (0..spec.config.num_robots.min(spec.starts.len()))
        .map(|i| build_agent(&spec, registry, i))
        .collect::<Result<Vec<_>, _>>()?;
    let world = World::new(spec.map, &spec.starts, spec.config, spec.seed)?;
    Ok((world, agents))
}

/// Robot `robot`'s agent of the trial `spec`, as [`build`] makes it: what a robot's own process
/// needs (of the map only its size; the agent never sees the ground truth).
pub fn build_agent(
    spec: &TrialSpec,
    registry: &PolicyRegistry,
    robot: usize,
) -> Result<Agent, SimError> {
    let (h, w) = (spec.map.height(), spec.map.width());
    let cfg = &spec.config;
    let ctx = PolicyContext {
        seed: spec.seed,
        robot,
        config: cfg,
        height: h,
        width: w,
    };
    let policy = registry.make(&spec.policy, &ctx)?;
    Ok(Agent::new(
        AgentConfig::from_scenario(cfg, robot, h, w),
        spec.starts[robot],
        policy,
    ))
}

/// Records the timestep `world` just took in `recorder` (explored fraction, team distance, pairs
/// in contact and, of those, strictly closer than d_s).
pub fn record_step(recorder: &mut MetricsRecorder, world: &World) {
    let team_distance: f64 = world.distances().iter().sum();
    let (pos, ds) = (world.positions(), world.config().sensing_range);
    let closer = world
        .contacts()
        .iter()
        .filter(|&&(i, j)| pos[i].chebyshev(pos[j]) < ds)
        .count();
    recorder.record(
        world.explored_fraction(),
        team_distance,
        world.contacts().len(),
        closer,
    );
}

impl Trial {
    /// Builds the world and the agents with the built-in policies.
    pub fn new(spec: TrialSpec) -> Result<Self, SimError> {
        Self::with_registry(spec, &PolicyRegistry::builtin())
    }

    /// Builds the world and the agents with the policies of `registry`.
    pub fn with_registry(spec: TrialSpec, registry: &PolicyRegistry) -> Result<Self, SimError> {
        let (map_name, policy, seed) = (spec.map_name.clone(), spec.policy.clone(), spec.seed);
        let mut starts = spec.starts.clone();
        let (world, agents) = build(spec, registry)?;
        let n = agents.len();
        starts.truncate(n);
        Ok(Trial {
            recorder: MetricsRecorder::new(world.explored_fraction()),
            starts,
            spec_map: map_name,
            policy,
            seed,
            world,
            agents,
            trajectory: Vec::new(),
            record: false,
            elapsed: std::time::Duration::ZERO,
            timed: true,
            decided: vec![false; n],
            moves: vec![Move::Stay; n],
            joint: None,
            reward_config: RewardConfig::default(),
            interaction_steps: vec![0; n],
            rewards: StepRewards {
                robots: vec![0.0; n],
                team: 0.0,
            },
            outbox: (0..n)
                .map(|i| Beta {
                    from: i,
                    t: 0,
                    prev_goal: None,
                    pos: Pos::new(0, 0),
                    goal: None,
                    map: Vec::new(),
                    explored: 0,
                })
                .collect(),
            composed: vec![false; n],
            plan_message: PlanMessage {
                from: 0,
                t: 0,
                start: Pos::new(0, 0),
                path: Vec::new(),
            },
            external: false,
            awaiting: vec![false; n],
            mid_step: false,
        })
    }

    /// The trial `with_registry` would build for the same spec with `seed` (policy instances
    /// made anew from `registry`), reusing this trial's world (its allocations and cast rays):
    /// how an environment starts its next episode cheaply. Recording and reward settings are
    /// kept; a joint policy is dropped.
    pub fn restart(mut self, seed: u64, registry: &PolicyRegistry) -> Result<Self, SimError> {
        let cfg = self.world.config().clone();
        let (h, w) = (self.world.truth().height(), self.world.truth().width());
        let n = self.agents.len();
        let old = std::mem::take(&mut self.agents);
        for (i, agent) in old.into_iter().enumerate() {
            let ctx = PolicyContext {
                seed,
                robot: i,
                config: &cfg,
                height: h,
                width: w,
            };
            let policy = registry.make(&self.policy, &ctx)?;
            self.agents.push(agent.restarted(self.starts[i], policy));
        }
        self.world.restart(seed);
        self.recorder = MetricsRecorder::new(self.world.explored_fraction());
        self.seed = seed;
        self.trajectory.clear();
        self.elapsed = std::time::Duration::ZERO;
        self.decided.fill(false);
        self.moves.fill(Move::Stay);
        self.joint = None;
        self.awaiting.fill(false);
        self.mid_step = false;
        self.interaction_steps.fill(0);
        self.rewards = StepRewards {
            robots: vec![0.0; n],
            team: 0.0,
        };
        Ok(self)
    }

    /// A copy of this trial in its present state — between timesteps, or between
    /// [`Trial::begin_step`] and the decisions (then finish the copy's step with
    /// [`Trial::decide_with`] and [`Trial::finish_step`]) — whose robots are driven
    /// from now on by registry policy `policy` (instances made with this trial's seed), without
    /// recording, living `future` (see [`Future`]). Metrics continue from the present (TNS
    /// counts from t = 0). How rollouts evaluate a decision.
    pub fn fork(
        &self,
        policy: &str,
        registry: &PolicyRegistry,
        future: Future,
    ) -> Result<Self, SimError> {
        let cfg = self.world.config();
        let (h, w) = (self.world.truth().height(), self.world.truth().width());
        let mut agents = Vec::with_capacity(self.agents.len());
        for (i, a) in self.agents.iter().enumerate() {
            let ctx = PolicyContext {
                seed: self.seed,
                robot: i,
                config: cfg,
                height: h,
                width: w,
            };
            agents.push(a.fork(registry.make(policy, &ctx)?));
        }
        let mut world = self.world.clone();
        match future {
            Future::Own => {}
            Future::Salted(salt) => world.reseed_noise(self.seed, salt),
            Future::Noiseless => world.set_noiseless(),
            Future::Redrawn(map) => {
                world.set_noiseless();
                world.redraw_unseen(&map);
            }
        }
        Ok(Trial {
            spec_map: self.spec_map.clone(),
            policy: policy.to_string(),
            starts: self.starts.clone(),
            seed: self.seed,
            world,
            agents,
            recorder: self.recorder.clone(),
            trajectory: Vec::new(),
            record: false,
            elapsed: std::time::Duration::ZERO,
            timed: false,
            decided: self.decided.clone(),
            moves: self.moves.clone(),
            joint: None,
            reward_config: self.reward_config.clone(),
            interaction_steps: self.interaction_steps.clone(),
            rewards: self.rewards.clone(),
            outbox: self.outbox.clone(),
            composed: self.composed.clone(),
            plan_message: self.plan_message.clone(),
            external: false,
            awaiting: vec![false; self.awaiting.len()],
            mid_step: false,
        })
    }

    /// Replaces the world's noise streams by those of future `salt`
    /// ([`madenet_world::World::reseed_noise`]) from now on.
    pub fn reseed_noise(&mut self, salt: u64) {
        self.world.reseed_noise(self.seed, salt);
    }

    /// Shares the world's cast rays ([`madenet_world::World::visibility`]) with other trials
    /// on the same map and scenario; see [`Trial::use_visibility`].
    pub fn visibility(&mut self) -> std::sync::Arc<madenet_world::Visibility> {
        self.world.visibility()
    }

    /// Senses with `v` (cast by a trial on the same map and scenario) instead of this world's
    /// own cache: same observations, less memory when many trials run side by side.
    pub fn use_visibility(&mut self, v: std::sync::Arc<madenet_world::Visibility>) {
        self.world.use_visibility(v);
    }

    /// A trial whose robots are driven by one centralized policy (e.g. the CEP of centralized
    /// training): at each step the robots whose macro action terminated get their decision
    /// from `joint`, which sees every robot's view and the team's merged map.
    pub fn with_joint_policy(
        spec: TrialSpec,
        joint: Box<dyn JointPolicy>,
    ) -> Result<Self, SimError> {
        let mut trial = Self::driven_from_outside(spec, joint.name())?;
        trial.joint = Some(joint);
        Ok(trial)
    }

    /// A trial whose robots decide only from outside: each robot's policy is the
    /// [`External`] stand-in (it decides at macro terminations and idles if asked itself), so
    /// a caller gives the decisions with [`Trial::decide_jointly`] or
    /// [`Trial::apply_decisions`] between [`Trial::begin_step`] and [`Trial::finish_step`].
    /// `policy` names the deciding policy in the result.
    pub fn driven_from_outside(spec: TrialSpec, policy: &str) -> Result<Self, SimError> {
        let mut registry = PolicyRegistry::default();
        registry.register("external", "decisions from outside", |_| Box::new(External));
        let mut trial = Self::with_registry(
            TrialSpec {
                policy: "external".into(),
                ..spec
            },
            &registry,
        )?;
        trial.policy = policy.to_string();
        Ok(trial)
    }

    /// Use these reward constants (default: the paper's).
    pub fn reward_config(mut self, cfg: RewardConfig) -> Self {
        self.reward_config = cfg;
        self
    }

    /// The rewards of the last timestep (Eq. 7 and 8).
    pub fn rewards(&self) -> &StepRewards {
        &self.rewards
    }

    /// Measure the wall time of the steps (`timing.trial_s`; on by default). Off, the result's
    /// `trial_s` is 0 and [`Trial::begin_step`] / [`Trial::finish_step`] read no clock (the
    /// robots' own policies, when they decide, still time their decisions): for callers that
    /// time (or do not need) the steps themselves, such as step-wise environments, where
    /// reading the clock was 7 % of a step.
    pub fn timed(mut self, on: bool) -> Self {
        self.timed = on;
        self
    }

    /// The clock when timing, to add the time since to `elapsed` with [`Trial::add_elapsed`].
    fn clock(&self) -> Option<Instant> {
        self.timed.then(Instant::now)
    }

    fn add_elapsed(&mut self, started: Option<Instant>) {
        if let Some(s) = started {
            self.elapsed += s.elapsed();
        }
    }

    /// This trial taking its decisions from outside through [`Stepping`]: a timestep whose
    /// robots decide stops at the decision point ([`Stepping::deciding`]); after
    /// [`Stepping::apply_decisions`] the next [`Stepping::step`] finishes it — the continuous
    /// world's protocol. (The grid's own halves, [`Trial::begin_step`] and
    /// [`Trial::finish_step`], stay for rollouts and learners.)
    pub fn with_external_decisions(mut self, on: bool) -> Self {
        self.external = on;
        self
    }

    /// Keep a [`StepRecord`] per timestep in the result.
    pub fn record_trajectory(mut self, on: bool) -> Self {
        self.record = on;
        self
    }

    /// The world (ground truth, true poses, team map).
    pub fn world(&self) -> &World {
        &self.world
    }
    /// The agents, robot i at index i.
    pub fn agents(&self) -> &[Agent] {
        &self.agents
    }
    /// Robot `i`'s agent, e.g. to ask its policy again (benchmarks, debugging).
    pub fn agent_mut(&mut self, i: usize) -> &mut Agent {
        &mut self.agents[i]
    }
    /// The team has explored everything explorable, or the step cap is reached.
    pub fn is_done(&self) -> bool {
        self.world.is_done()
    }

    /// Runs one timestep (stages 1–5 of the crate docs). Returns false once done.
    pub fn step(&mut self) -> bool {
        if !self.begin_step() {
            return false;
        }
        self.decide();
        self.finish_step();
        true
    }

    /// The first half of a timestep, up to the decision point: every robot observes (stage 1),
    /// β is exchanged along successful links (stage 2), and each robot finds whether it decides
    /// now ([`Trial::deciding`]). Returns false once done (nothing happens then). Complete the
    /// timestep with [`Trial::finish_step`], after [`Trial::apply_decisions`] for robots driven
    /// from outside (e.g. a Python environment); [`Trial::step`] does all three with the robots'
    /// own policies.
    pub fn begin_step(&mut self) -> bool {
        if self.world.is_done() {
            return false;
        }
        let started = self.clock();
        // 1. observe
        for (i, a) in self.agents.iter_mut().enumerate() {
            a.observe(self.world.observation(i));
        }
        // 2. exchange β along successful links; messages are composed before delivery.
        let exchanges = self.world.exchanges();
        if !exchanges.is_empty() {
            // The outbox's messages are reused from step to step (no allocation per message).
            self.composed.fill(false);
            for &(i, j) in exchanges {
                for k in [i, j] {
                    if !self.composed[k] {
                        self.agents[k].beta_into(&mut self.outbox[k]);
                        self.composed[k] = true;
                    }
                }
            }
            for &(i, j) in exchanges {
                self.agents[j].receive_beta(&self.outbox[i]);
                self.agents[i].receive_beta(&self.outbox[j]);
            }
        }
        // 3a. who decides now (each robot's own state only)
        for (i, a) in self.agents.iter_mut().enumerate() {
            self.decided[i] = a.needs_decision();
        }
        self.add_elapsed(started);
        true
    }

    /// Which robots decide at this timestep (valid between [`Trial::begin_step`] and
    /// [`Trial::finish_step`]).
    pub fn deciding(&self) -> &[bool] {
        &self.decided
    }

    /// 3b. The deciding robots ask their own policies, or the joint policy decides for them.
    fn decide(&mut self) {
        let started = self.clock();
        match self.joint.take() {
            None => {
                for (i, a) in self.agents.iter_mut().enumerate() {
                    if self.decided[i] {
                        a.decide();
                    }
                }
            }
            Some(mut joint) => {
                self.decide_jointly(joint.as_mut());
                self.joint = Some(joint);
            }
        }
        self.add_elapsed(started);
    }

    /// 3b by a centralized policy: if any robot decides now, `joint` sees every robot's view
    /// and the team's merged map, and each deciding robot takes its decision.
    pub fn decide_jointly(&mut self, joint: &mut dyn JointPolicy) {
        if !self.decided.contains(&true) {
            return;
        }
        let n = self.agents.len();
        let mut views: Vec<_> = self.agents.iter_mut().map(|a| a.view(true)).collect();
        let decisions = joint.decide(&mut views, &self.decided, self.world.team_map());
        drop(views);
        for (i, d) in decisions.into_iter().enumerate().take(n) {
            if self.decided[i] {
                self.agents[i].apply_decision(d);
            }
        }
    }

    /// 3b from outside: `decisions[i]` for each deciding robot i (the others' entries are
    /// ignored), in place of the robots' own policies.
    pub fn apply_decisions(&mut self, decisions: &[Decision]) {
        for (i, &d) in decisions.iter().enumerate().take(self.agents.len()) {
            if self.decided[i] {
                self.agents[i].apply_decision(d);
            }
        }
    }

    /// 3b with some decisions fixed from outside: each deciding robot i takes `fixed[i]` if
    /// given, else asks its own policy (a rollout's first step: one robot's candidate under
    /// evaluation, the others as their policies would decide).
    pub fn decide_with(&mut self, fixed: &[Option<Decision>]) {
        for (i, a) in self.agents.iter_mut().enumerate() {
            if self.decided[i] {
                match fixed.get(i).copied().flatten() {
                    Some(d) => a.apply_decision(d),
                    None => a.decide(),
                }
            }
        }
    }

    /// The second half of a timestep: planning (stage 4), the moves (stage 5), metrics,
    /// rewards and the trajectory record.
    pub fn finish_step(&mut self) {
        let started = self.clock();
        let n = self.agents.len();
        // 4. plan in priority order; plans go to lower-priority robots this one exchanged with.
        for i in 0..n {
            self.agents[i].plan();
            if self.agents[i].exchanged_with().iter().any(|&j| j > i) {
                self.agents[i].plan_message_into(&mut self.plan_message);
                for k in 0..self.agents[i].exchanged_with().len() {
                    let j = self.agents[i].exchanged_with()[k];
                    if j > i {
                        self.agents[j].receive_plan(&self.plan_message);
                    }
                }
            }
        }
        // 5. act
        for (i, a) in self.agents.iter().enumerate() {
            self.moves[i] = a.next_move();
        }
        self.world.step(&self.moves);
        record_step(&mut self.recorder, &self.world);
        self.compute_rewards();
        self.add_elapsed(started);
        if self.record {
            self.trajectory.push(StepRecord {
                t: self.world.t(),
                positions: self.world.positions().to_vec(),
                moves: self.world.executed_moves().to_vec(),
                goals: self.agents.iter().map(|a| a.goal()).collect(),
                decided: self.decided.clone(),
                actions: self.agents.iter().map(|a| a.action()).collect(),
                exchanges: self.world.exchanges().to_vec(),
                explored: self.world.explored_fraction(),
                rewards: self.rewards.clone(),
            });
        }
    }

    /// Eq. (7) and (8) for the step just taken: what each robot observed against what it had
    /// explored before (its belief has not taken the observation in yet), its run of
    /// consecutive local interactions, and the team's observations against the team map.
    fn compute_rewards(&mut self) {
        let n = self.agents.len();
        for i in 0..n {
            let belief = self.agents[i].belief();
            let seen = &self.world.observation(i).seen;
            // Seen cells lie on the map: index the belief directly (no bounds test per cell).
            let (map, w) = (belief.map(), belief.width());
            let new = seen
                .iter()
                .filter(|(p, _)| {
                    map[p.row as usize * w + p.col as usize] == madenet_map::Occupancy::Unknown
                })
                .count();
            let interacting = self.world.contacts().iter().any(|&(a, b)| a == i || b == i);
            self.interaction_steps[i] = if interacting {
                self.interaction_steps[i] + 1
            } else {
                0
            };
            self.rewards.robots[i] =
                self.reward_config
                    .robot(new, seen.len() - new, self.interaction_steps[i]);
        }
        let new = self.world.team_newly_observed();
        let seen = self.world.team_observed();
        self.rewards.team = self
            .reward_config
            .team(new, seen - new, self.world.is_complete());
    }

    /// Runs to completion or the step cap.
    pub fn run(mut self) -> TrialResult {
        crate::stepping::run_to_end(&mut self);
        self.finish()
    }

    /// The result so far.
    pub fn finish(self) -> TrialResult {
        let decisions: usize = self.agents.iter().map(|a| a.stats().decisions).sum();
        let decision_s: f64 = self
            .agents
            .iter()
            .map(|a| a.stats().decision_time.as_secs_f64())
            .sum();
        TrialResult {
            map: self.spec_map,
            policy: self.policy,
            seed: self.seed,
            comm_success_prob: self.world.config().comm_success_prob,
            starts: self.starts,
            metrics: self.recorder.finish(self.world.is_complete()),
            trajectory: self.trajectory,
            timing: Timing {
                trial_s: self.elapsed.as_secs_f64(),
                decisions,
                per_decision_s: if decisions > 0 {
                    decision_s / decisions as f64
                } else {
                    0.0
                },
            },
        }
    }
}

impl Present for Trial {
    present_grid_world!();
    fn robots(&self) -> usize {
        self.agents.len()
    }
    fn robot(&self, i: usize) -> RobotShown<'_> {
        RobotShown::of(&self.agents[i])
    }
    /// What the robot knows now: its belief and this timestep's observation, which its agent
    /// takes in at the start of the next timestep (or never, at the end), as
    /// `Belief::observe` takes it in: unknown cells learn, free ones may turn out obstacles.
    fn belief(&self, i: usize) -> Option<Cow<'_, [Occupancy]>> {
        let width = self.world.truth().width();
        let mut cells = self.agents[i].belief().map().to_vec();
        for &(p, occ) in &self.world.observation(i).seen {
            let c = &mut cells[p.row as usize * width + p.col as usize];
            match (*c, occ) {
                (_, Occupancy::Unknown) => {}
                (Occupancy::Unknown, o) => *c = o,
                (Occupancy::Free, Occupancy::Obstacle) => *c = Occupancy::Obstacle,
                _ => {}
            }
        }
        Some(Cow::Owned(cells))
    }
    fn exchanges(&self) -> &[(usize, usize)] {
        self.world.exchanges()
    }
}

impl Stepping for Trial {
    type Outcome = TrialResult;

    fn step(&mut self) -> bool {
        if !self.external {
            return Trial::step(self);
        }
        if self.awaiting.contains(&true) {
            return true;
        }
        if std::mem::take(&mut self.mid_step) {
            self.finish_step();
            return true;
        }
        if !self.begin_step() {
            return false;
        }
        if self.decided.contains(&true) {
            self.awaiting.copy_from_slice(&self.decided);
            self.mid_step = true;
        } else {
            self.finish_step();
        }
        true
    }
    fn is_done(&self) -> bool {
        Trial::is_done(self)
    }
    fn is_complete(&self) -> bool {
        self.world.is_complete()
    }
    fn deciding(&self) -> &[bool] {
        &self.awaiting
    }
    fn apply_decisions(&mut self, decisions: &[Option<Decision>]) {
        for i in 0..self.agents.len() {
            if !std::mem::take(&mut self.awaiting[i]) {
                continue;
            }
            match decisions.get(i).copied().flatten() {
                Some(d) => self.agents[i].apply_decision(d),
                None => self.agents[i].decide(),
            }
        }
    }
    fn agents(&self) -> &[Agent] {
        &self.agents
    }
    fn agent_mut(&mut self, i: usize) -> &mut Agent {
        &mut self.agents[i]
    }
    fn finish(self) -> TrialResult {
        Trial::finish(self)
    }
}
