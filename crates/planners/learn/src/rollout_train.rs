//! MADE-Net's DEP trained from a centralized **rollout teacher** (`method = "made-net-rollout"`),
//! read top to bottom like a CleanRL script. A departure from the paper's CEP/DEP Q-learning
//! (which ships as `made-net-paper`), chosen because that learner ends no better than "always
//! take candidate 0" within an hour.
//!
//! 1. **Scenarios**: generated maps at obstacle fractions across `density_min..density_max`
//!    (15–60 % by default: the paper's training maps are 40–60 %, its evaluation maps 18–36 %),
//!    the team in a shared corner or around a random cell, CSP drawn per episode. With
//!    `network = "agnostic"` a curriculum: square maps whose largest side grows over the
//!    iterations up to `map_side_max`, teams up to `team_max`; with `floorplan_prob`, generated
//!    floor plans (rooms, doors, corridors) among the clutter.
//! 2. **Behaviour** (DAgger): iteration 0 follows the base rule (`spread`), later iterations the
//!    DEP being trained (greedy); both take a random valid candidate with probability
//!    `behaviour_epsilon`.
//! 3. **Teacher** (centralized training: it sees the simulator): at each decision of a robot
//!    with two or more candidates, every candidate k is scored by continuing the trial from this
//!    very state ([`Trial::fork`]) with the robot taking k and everyone following the base rule
//!    afterwards — by default once, in the noiseless future (no sensor misses, no slips;
//!    communication keeps the trial's own draws), or with `futures = "salted"` over `rollouts`
//!    other futures of the noise ([`madenet_world::World::reseed_noise`]; the same for every k),
//!    or with `futures = "redrawn"` over `rollouts` noiseless futures whose unseen cells are
//!    redrawn from the episode's map distribution (labels the team's knowledge can predict).
//!    The label of k is the mean number of steps left until the map is explored (`value =
//!    "mean-discovery"`: the mean over cells of the steps until each is known, capped at
//!    `horizon`): one step of policy improvement over the base rule. With `expert_iteration`, once a student beats the
//!    base rule on validation the best student so far (with its margin) is the base of the
//!    continuations, so the improvements can compound; each iteration logs the teacher's gain
//!    over its base (per labelled decision) and the student's over the base rule (validation),
//!    and `patience` stops the run when validation stops improving. With `team_rounds`, robots
//!    choosing at the same timestep are valued by coordinate descent over the robots, each
//!    beside the others' current choices. With `horizon`,
//!    continuations stop after that many steps and the rest is estimated; `label_prob` thins
//!    the labelled decisions on large maps.
//! 4. **Student**: the paper's DEP (MFE, F3, LSTM, F6; `observation` may add per-candidate
//!    features), or the size- and team-agnostic DEP ([`crate::agnostic`]), regresses the
//!    labels' *advantages* (label minus its mean over the valid candidates) with Adam, or
//!    (`loss = "listwise"`) matches softmax(scores / τ) to softmax(advantages / τ) — by default
//!    on single decisions from zero LSTM state (`recurrent = false`), else on windows of each
//!    robot's decision sequence.
//! 5. **Validation** after every iteration on generated trials of their own seeds (210 by
//!    default), the DEP acting greedily and with each `spread_margins` margin (the `spread` rule's
//!    candidate unless the DEP values another more by the margin); the best (iteration, margin)
//!    is kept in `best/`, the last iteration in `last/`.
//!
//! Checkpoints are written after every iteration (dataset, net, optimizer, counters, the
//! teacher's base student), so a killed run resumes at its last iteration boundary and ends as
//! an uninterrupted one would.
//!
//! Steps 1–3 of an iteration are one [`CollectRequest`] — plain data: episode indices, the
//! curriculum's side, the behaviour's and the teacher's base students as model files' bytes
//! (the behaviour's written to `RUN/.behaviour/`) — collected here or by a [`Collector`]
//! elsewhere ([`train_with`]; the Python package's `madenet.ray.train` hands batches to Ray
//! tasks that run [`collect_bytes`]), with the same episodes either way.

use crate::agnostic::{AgnosticInput, AgnosticNet, Batch, CONTEXT_FEATURES};
use crate::episode::{self, Recorder};
use crate::error::{write_atomic, TrainError};
use crate::harness::{self, replace_dir, Clock, Learner, Progress, RunFields};
use crate::learner::adam_step;
use crate::model::{Method, Model, ModelInfo, NetConfigToml};
use crate::obs::{action_mask, pack_bits, unpack_bits, Observation};
use crate::scenario::{validate, ScenarioDraw};
use crate::{cpu_autodiff, NetConfig, QNet};
use burn::module::Module;
use burn::optim::grad_clipping::GradientClippingConfig;
use burn::optim::{AdamConfig, ModuleOptimizer};
use burn::tensor::{Tensor, TensorData};
use madenet_agent::{AgentView, Decision, DecisionMode, Policy};
use madenet_sim::rollout::{candidate_values_by, plan_values, Lookahead, Value};
use madenet_sim::{Future, PolicyRegistry, Trial, TrialSpec};
use madenet_world::rng::{derive_seed, stream, Rng};
use madenet_world::ScenarioConfig;
use rand::RngExt;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

/// The `method` of this learner's config and `model.toml`.
pub const METHOD: &str = Method::MadeNetRollout.name();

/// The futures the teacher scores candidates in ([`RolloutTrainConfig::futures`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Futures {
    /// One continuation without sensor misses and slips.
    Noiseless,
    /// `rollouts` continuations, each in another future of the noise.
    Salted,
    /// `rollouts` noiseless continuations on worlds whose cells the team has not seen are
    /// redrawn from the episode's own map distribution (its size, density range and floor-plan
    /// share; [`madenet_sim::Future::Redrawn`]): labels that depend only on what the team
    /// knows, so a student that sees the team's knowledge can learn them.
    Redrawn,
}

/// What the teacher values a candidate by ([`RolloutTrainConfig::teacher`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Teacher {
    /// Continuations under the base rule, over `futures`, cut and valued by `horizon` and
    /// `value`: one step of policy improvement over the base.
    #[default]
    Rollout,
    /// The team plan ([`madenet_sim::rollout::plan_values`]): over `rollouts` redrawn futures
    /// (`futures = "redrawn"`), the known-map reference plans the whole team's routes from where
    /// it stands, and a candidate is valued by its moves to the robot's first viewpoint — a
    /// team-wide, multi-step teacher; no base rule enters the values.
    Plan,
}

/// Which DEP network the teacher trains ([`RolloutTrainConfig::network`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Network {
    /// The paper's DEP ([`QNet`]): one map size, team size and |G|.
    #[default]
    Grid,
    /// The size- and team-agnostic DEP ([`crate::agnostic`]): any map, team and |G|.
    Agnostic,
}

/// What the student fits to the teacher's labels ([`RolloutTrainConfig::loss`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Loss {
    /// Masked squared error between the scores centred over the valid candidates and the
    /// teacher's advantages: every candidate's value matters as much as the best one's.
    #[default]
    Advantage,
    /// Cross-entropy between softmax(scores / τ) and softmax(advantages / τ) over the valid
    /// candidates (τ = `listwise_temperature`): a ranking loss that spends the network on which
    /// candidate is best rather than on how bad the others are; scores stay in label units.
    Listwise,
}

/// How a decision's advantages are scaled before the fit ([`RolloutTrainConfig::label_norm`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LabelNorm {
    /// × `label_scale` alone: on a curriculum a 60-m map's advantages (moves, which grow with
    /// the side) are about three times a 20-m map's and weigh nine times as much in the
    /// squared loss.
    #[default]
    None,
    /// × `label_scale` × `map_height` / the episode map's larger side: every map size weighs
    /// alike, and the student's scores (and so the acting margin) are in 20-m-map steps.
    Side,
}

/// Every knob of a rollout-teacher run, with its default (`configs/train-rollout.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RolloutTrainConfig {
    /// Always `made-net-rollout`.
    pub method: String,
    /// Master seed of every stream (maps, starts, CSP, behaviour, futures, sampling, init).
    pub seed: u64,
    /// Labelled episodes in all (split evenly over the iterations).
    pub episodes: u64,
    /// Wall-time budget of one call, minutes; 0 = none. Checked before each episode and update
    /// and at iteration boundaries: a call stops at the boundary after it (with a checkpoint), or
    /// inside an iteration, dropping that iteration (the checkpoint is at its start) — an error
    /// when it is the call's first (one iteration takes longer than the budget).
    pub max_minutes: f64,
    /// DAgger iterations: collect, then train on everything collected so far.
    pub iterations: u64,
    /// The simulated world; its `comm_success_prob` is unused (CSP is drawn per episode).
    pub scenario: ScenarioConfig,
    /// Training map height in cells (the paper: 20); the curriculum's smallest side.
    pub map_height: usize,
    /// Training map width in cells (the paper: 20).
    pub map_width: usize,
    /// With the agnostic network: the largest map side of the curriculum (square maps of sides
    /// `map_height..=map_side_max`, the upper end growing linearly over the iterations from
    /// `map_height` to this). 0: every map is `map_height × map_width`.
    pub map_side_max: usize,
    /// With the agnostic network: the largest team (teams of `scenario.num_robots..=team_max`
    /// robots, drawn per episode). 0: every team has `scenario.num_robots`.
    pub team_max: usize,
    /// Lowest obstacle fraction of the generated maps (ours: 0.15; the paper: 0.4).
    pub density_min: f64,
    /// Highest obstacle fraction of the generated maps (ours and the paper: 0.6).
    pub density_max: f64,
    /// Probability that the team starts in a shared corner (else around a random free cell).
    pub corner_start_prob: f64,
    /// CSP per episode: 0 or 1 with probability `csp_extreme_prob / 2` each, else U(0, 1).
    pub csp_extreme_prob: f64,
    /// The rule the teacher's continuations follow and iteration 0 behaves by.
    pub base_policy: String,
    /// Expert iteration: from iteration 2 on, the teacher's continuations follow the best
    /// student validated so far (acting with its margin) instead of `base_policy`, once that
    /// student beats `base_policy` on validation — so the teacher's one step of improvement
    /// lands on the student's level, not on the base rule's.
    pub expert_iteration: bool,
    /// Approximate policy iteration: from iteration 1 on, the teacher's continuations follow the
    /// student the iteration behaves by (greedy, as of the iteration's start), whether or not it
    /// beats `base_policy` — so a label values a candidate with the teammates and the robot's
    /// later decisions acting as the current student does, not as the base rule would (a
    /// one-step label over `spread` assumes teammates keep to `spread`'s nearest frontiers;
    /// robots that all deviate alike herd); each fit then uses only its iteration's labels
    /// (earlier ones value earlier students). Excludes `expert_iteration`.
    #[serde(default)]
    pub policy_iteration: bool,
    /// Stop rule: the run ends after this many iterations in a row without a new best on
    /// validation; 0: run all `iterations`.
    pub patience: u64,
    /// Probability that a training or validation map is a generated floor plan (rooms, doors,
    /// corridors) instead of clutter ([`ScenarioDraw::floorplan_prob`]).
    pub floorplan_prob: f64,
    /// Which futures the teacher scores a candidate in: `noiseless` (default: one continuation
    /// without sensor misses and slips — no luck), `salted` (`rollouts` futures of the noise)
    /// or `redrawn` (`rollouts` noiseless futures on redrawn unseen cells: [`Futures::Redrawn`]).
    pub futures: Futures,
    /// What the teacher values a candidate by: `rollout` (default: continuations under the
    /// base rule) or `plan` (the team plan on redrawn maps, [`Teacher::Plan`]; needs
    /// `futures = "redrawn"`, excludes `expert_iteration`, `policy_iteration` and `team_rounds`).
    pub teacher: Teacher,
    /// Steps after which a continuation is cut (with `value = "steps-left"` its rest estimated at
    /// the trial's exploration rate so far, [`madenet_sim::rollout::Value::StepsLeft`]; with
    /// `mean-discovery` the cells still unknown count the horizon); 0: run to the end.
    pub horizon: usize,
    /// What a continuation's value measures ([`madenet_sim::rollout::Value`]): `steps-left`
    /// (default: steps until the map is explored) or `mean-discovery` (the mean over cells of
    /// the steps until each is known, capped at `horizon`: every discovery counts).
    pub value: Value,
    /// The team teacher: when two or more robots choose together and one is labelled, all of
    /// them are valued by at most this many passes of coordinate descent over the robots (each
    /// valued with the others at their current choices, starting from the base's; a pass that
    /// changes nothing ends it); 0: each labelled robot valued with the others asking the base.
    pub team_rounds: usize,
    /// Probability that a decision with a choice is labelled, at 400 cells (20 × 20); on a map
    /// of n cells it is `label_prob · 400 / n` (capped at 1), so a large map costs the teacher
    /// about what a small one does.
    pub label_prob: f64,
    /// Continuations per candidate and decision with `futures = "salted"` or `"redrawn"`.
    pub rollouts: usize,
    /// A diagnostic of the labels' noise: the share of labelled decisions valued alone that the
    /// teacher values a second time, over `rollouts` futures of their own (other seeds), never
    /// trained on; each iteration logs how often the two valuations' best candidates agree
    /// (`teacher_self_agreement`) and the correlation of their advantages (`label_reliability`).
    /// 0 (default): no second valuation. Decisions the team teacher values (`team_rounds`) are
    /// not checked; with `futures = "noiseless"` the second valuation repeats the first exactly
    /// (agreement 1), and under `max_minutes` its continuations count against the budget
    /// without being counted in `rollouts`.
    pub teacher_check: f64,
    /// Probability of a random valid candidate in the behaviour.
    pub behaviour_epsilon: f64,
    /// The DEP network: `grid` (the paper's, one scenario size) or `agnostic` (any map and team).
    pub network: Network,
    /// With the agnostic network: cells from a candidate to its crop's edge.
    pub crop_radius: usize,
    /// With the agnostic network: four more inputs per candidate about what lies beyond its
    /// crop ([`crate::agnostic::inputs_for`]).
    pub wide_inputs: bool,
    /// With the agnostic network: three more inputs per candidate about the robot's share of the
    /// whole map's unknown space, split among the team by geodesic distance
    /// ([`crate::agnostic::inputs_for`]): what a team plan hands each robot.
    pub territory_inputs: bool,
    /// With the agnostic network: two more inputs per candidate from the team plan on the
    /// robot's own belief — its moves to the robot's first viewpoint and whether it is the plan's
    /// choice ([`crate::agnostic::inputs_for`]; the `belief-plan` policy's plan).
    pub plan_inputs: bool,
    /// With the agnostic network: a model folder whose weights a fresh run's student starts from
    /// (a warm start; an agnostic model of this run's sizes, its digests checked; a path relative
    /// to the working directory). Empty (default): fresh weights. A resumed run reads its own
    /// checkpoint instead.
    pub init_model: String,
    /// The DEP's observation vector (ours: `candidate-features`; the paper: `paper`).
    pub observation: Observation,
    /// Adam steps after each iteration's collection (at most, with `fit_holdout`).
    pub updates_per_iteration: u64,
    /// The fit's stopping rule (agnostic network): this share of each iteration's new robot
    /// sequences (the last collected: other maps but at the cut) is held out of that iteration's fit, the
    /// student is scored against their labels every `fit_check_every` updates
    /// ([`LabelFit::label_corr`]), and the fit stops after `fit_patience` checks without a
    /// better score, keeping the best-scoring student (Adam's moments as they are); the held-out
    /// sequences join the training data from the next iteration on. The share is counted in
    /// robot sequences, rounded down (an iteration with none held out fits every update), so the
    /// episode at the cut may have robots on both sides. 0 (default): every update of
    /// `updates_per_iteration`, no check.
    pub fit_holdout: f64,
    /// Updates between two checks of the stopping rule (`fit_holdout`).
    pub fit_check_every: u64,
    /// Checks in a row without a better held-out score that end the fit (`fit_holdout`).
    pub fit_patience: u64,
    /// Robot sequences per batch (the paper: 16).
    pub batch_size: usize,
    /// Decisions per sampled window, unrolled from zero LSTM state.
    pub trace_len: usize,
    /// Whether the DEP is trained on windows of decisions and carries its LSTM state when
    /// acting (the paper's), or on single decisions from zero state and acts from zero state at
    /// every decision (ours, default: a batch of 128 single decisions costs what 16 windows of 8
    /// do, and in pilots of 400 episodes neither variant beat the base rule). Without it
    /// `trace_len` is 1.
    pub recurrent: bool,
    /// Adam step size.
    pub learning_rate: f64,
    /// Gradient norm clip.
    pub grad_clip_norm: f32,
    /// Labels (steps) are multiplied by this (0.1: advantages of a few units).
    pub label_scale: f32,
    /// How advantages are scaled per episode: `none` or `side` ([`LabelNorm`]).
    pub label_norm: LabelNorm,
    /// The student's loss: `advantage` (regression) or `listwise` (ranking; [`Loss`]).
    pub loss: Loss,
    /// τ of the `listwise` loss, in label units (0.1 with `label_scale = 0.1`: one step).
    pub listwise_temperature: f32,
    /// Margins of conservative acting tried at each validation (the DEP's choice replaces the
    /// `spread` rule's only when valued higher by this much, in label units; [`Model`]'s
    /// `spread_margin`); the greedy DEP is always tried too, and the best on validation is kept.
    pub spread_margins: Vec<f32>,
    /// Generated validation maps (seeds of their own, never the paper's), each run at every
    /// validation CSP.
    pub validation_maps: usize,
    /// CSPs each validation map is run at.
    pub validation_csp: Vec<f64>,
    /// Threads (episodes are collected in parallel; burn's kernels use the same pool).
    pub threads: usize,
}

impl Default for RolloutTrainConfig {
    fn default() -> Self {
        RolloutTrainConfig {
            method: METHOD.into(),
            seed: 1,
            episodes: 6000,
            max_minutes: 55.0,
            iterations: 6,
            scenario: ScenarioConfig::default(),
            map_height: 20,
            map_width: 20,
            map_side_max: 0,
            team_max: 0,
            density_min: 0.15,
            density_max: 0.60,
            corner_start_prob: 0.5,
            csp_extreme_prob: 0.5,
            base_policy: "spread".into(),
            expert_iteration: false,
            policy_iteration: false,
            patience: 0,
            floorplan_prob: 0.0,
            futures: Futures::Noiseless,
            teacher: Teacher::Rollout,
            horizon: 0,
            value: Value::StepsLeft,
            team_rounds: 0,
            label_prob: 1.0,
            rollouts: 4,
            teacher_check: 0.0,
            behaviour_epsilon: 0.1,
            network: Network::Grid,
            crop_radius: crate::agnostic::AgnosticConfig::new().crop_radius,
            wide_inputs: false,
            territory_inputs: false,
            plan_inputs: false,
            init_model: String::new(),
            observation: Observation::CandidateFeatures,
            updates_per_iteration: 4000,
            fit_holdout: 0.0,
            fit_check_every: 250,
            fit_patience: 2,
            batch_size: 128,
            trace_len: 24,
            recurrent: false,
            learning_rate: 1e-3,
            grad_clip_norm: 10.0,
            label_scale: 0.1,
            label_norm: LabelNorm::None,
            loss: Loss::Advantage,
            listwise_temperature: 0.1,
            spread_margins: vec![0.05, 0.1, 0.2, 0.4],
            validation_maps: 70,
            validation_csp: vec![1.0, 0.5, 0.0],
            threads: 2,
        }
    }
}

impl RolloutTrainConfig {
    /// Reads a TOML config; errors name the file and the field.
    pub fn from_toml_file(path: &Path) -> Result<Self, TrainError> {
        harness::read_config(path, Self::validate)
    }

    /// [`Self::from_toml_file`] on `text`, already read from `path`.
    pub fn from_toml_text(path: &Path, text: &str) -> Result<Self, TrainError> {
        harness::parse_config(path, text, Self::validate)
    }

    /// Checks every field; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        self.scenario
            .validate()
            .map_err(|e| format!("scenario: {e}"))?;
        let unit = |x: f64| (0.0..=1.0).contains(&x);
        let curriculum = self.map_side_max > 0 || self.team_max > 0;
        let checks: [(bool, &str, &str); 20] = [
            (
                !curriculum || self.network == Network::Agnostic,
                "map_side_max/team_max",
                "a curriculum over map sides or teams needs `network = \"agnostic\"`",
            ),
            (
                self.map_side_max == 0
                    || (self.map_side_max >= self.map_height
                        && self.map_side_max <= crate::MAX_TRAIN_MAP_SIDE
                        && self.map_height == self.map_width),
                "map_side_max",
                "0, or in map_height..=200 with square maps (map_height = map_width)",
            ),
            (
                self.team_max == 0
                    || (self.team_max >= self.scenario.num_robots
                        && self.team_max <= madenet_world::MAX_ROBOTS),
                "team_max",
                "0, or in scenario.num_robots..=256",
            ),
            (
                self.method == METHOD,
                "method",
                "must be `made-net-rollout` in this config",
            ),
            (
                self.episodes >= self.iterations.max(1),
                "episodes",
                "must be at least `iterations`",
            ),
            (
                self.iterations >= 1 && self.iterations <= 1000,
                "iterations",
                "must be in 1..=1000",
            ),
            (
                self.max_minutes >= 0.0 && self.max_minutes.is_finite(),
                "max_minutes",
                "must be ≥ 0",
            ),
            (
                self.map_height >= crate::MIN_MAP_SIDE
                    && self.map_width >= crate::MIN_MAP_SIDE
                    && self.map_height <= crate::MAX_TRAIN_MAP_SIDE
                    && self.map_width <= crate::MAX_TRAIN_MAP_SIDE,
                "map_height/map_width",
                "must be in 12..=200",
            ),
            (
                0.0 <= self.density_min
                    && self.density_min <= self.density_max
                    && self.density_max < 0.9,
                "density_min/density_max",
                "need 0 ≤ density_min ≤ density_max < 0.9",
            ),
            (
                unit(self.corner_start_prob)
                    && unit(self.floorplan_prob)
                    && unit(self.csp_extreme_prob)
                    && unit(self.behaviour_epsilon)
                    && unit(self.label_prob)
                    && unit(self.teacher_check)
                    && self.label_prob > 0.0,
                "corner_start_prob/floorplan_prob/csp_extreme_prob/behaviour_epsilon/label_prob/teacher_check",
                "must be in [0, 1] (label_prob above 0)",
            ),
            (
                !(self.policy_iteration && self.expert_iteration),
                "policy_iteration/expert_iteration",
                "choose one: both set the teacher's base",
            ),
            (
                self.teacher == Teacher::Rollout
                    || (self.futures == Futures::Redrawn
                        && !self.expert_iteration
                        && !self.policy_iteration
                        && self.team_rounds == 0),
                "teacher",
                "`plan` needs futures = \"redrawn\" and no expert_iteration, policy_iteration (its values have no base rule) or team_rounds (its plan is the team's already and would ignore the teammates' choices)",
            ),
            (
                self.rollouts >= 1 && self.rollouts <= 64,
                "rollouts",
                "must be in 1..=64",
            ),
            (
                self.batch_size >= 1
                    && self.batch_size <= 1024
                    && self.trace_len >= 1
                    && self.trace_len <= 1024,
                "batch_size/trace_len",
                "must be in 1..=1024",
            ),
            (
                self.learning_rate > 0.0 && self.learning_rate.is_finite(),
                "learning_rate",
                "must be positive",
            ),
            (
                self.grad_clip_norm > 0.0 && self.label_scale > 0.0 && self.label_scale.is_finite(),
                "grad_clip_norm/label_scale",
                "must be positive",
            ),
            (
                self.listwise_temperature >= 1e-3 && self.listwise_temperature <= 1e3,
                "listwise_temperature",
                "must be in [0.001, 1000]",
            ),
            (
                self.validation_csp.iter().all(|&p| unit(p))
                    && self
                        .spread_margins
                        .iter()
                        .all(|m| m.is_finite() && *m >= 0.0)
                    && self.spread_margins.len() <= 32,
                "validation_csp/spread_margins",
                "CSPs must be in [0, 1], margins finite and ≥ 0 (at most 32)",
            ),
            (
                self.threads >= 1 && self.threads <= 256,
                "threads",
                "must be in 1..=256",
            ),
            (
                self.validation_maps >= 1
                    && self.validation_maps <= 100_000
                    && !self.validation_csp.is_empty(),
                "validation_maps/validation_csp",
                "need at least one map and one CSP",
            ),
        ];
        for (ok, field, msg) in checks {
            if !ok {
                return Err(format!("field `{field}`: {msg}"));
            }
        }
        harness::check_sizes(&[
            ("episodes", self.episodes, 1, 10_000_000),
            (
                "updates_per_iteration",
                self.updates_per_iteration,
                0,
                1_000_000,
            ),
            ("horizon", self.horizon as u64, 0, 100_000),
            ("patience", self.patience, 0, 1000),
            ("fit_check_every", self.fit_check_every, 1, 1_000_000),
            ("fit_patience", self.fit_patience, 1, 1000),
            ("team_rounds", self.team_rounds as u64, 0, 8),
        ])?;
        if !(0.0..=0.5).contains(&self.fit_holdout) {
            return Err("field `fit_holdout`: must be in [0, 0.5]".into());
        }
        if self.wide_inputs && self.network != Network::Agnostic {
            return Err("field `wide_inputs`: inputs of the agnostic network only; set network = \"agnostic\" or wide_inputs = false".into());
        }
        if self.territory_inputs && self.network != Network::Agnostic {
            return Err("field `territory_inputs`: inputs of the agnostic network only; set network = \"agnostic\" or territory_inputs = false".into());
        }
        if self.plan_inputs && self.network != Network::Agnostic {
            return Err("field `plan_inputs`: inputs of the agnostic network only; set network = \"agnostic\" or plan_inputs = false".into());
        }
        if !self.init_model.is_empty() && self.network != Network::Agnostic {
            return Err("field `init_model`: warm starts of the agnostic network only; set network = \"agnostic\" or init_model = \"\"".into());
        }
        if self.fit_holdout > 0.0 && self.network != Network::Agnostic {
            return Err("field `fit_holdout`: the stopping rule scores the agnostic network only; set network = \"agnostic\" or fit_holdout = 0".into());
        }
        if self.network == Network::Agnostic && self.recurrent {
            return Err(
                "field `recurrent`: the agnostic network scores single decisions; set false".into(),
            );
        }
        if self.network == Network::Agnostic {
            crate::agnostic::AgnosticConfig::new()
                .with_crop_radius(self.crop_radius)
                .validate()?;
        }
        if self.scenario.num_robots > 3 && self.corner_start_prob > 0.0 && self.team_max == 0 {
            return Err(
                "field `corner_start_prob`: corner starts hold 3 robots; set 0 for larger teams"
                    .into(),
            );
        }
        let builtin = PolicyRegistry::builtin();
        if !builtin.names().contains(&self.base_policy) {
            return Err(format!(
                "field `base_policy`: unknown `{}`; known: {}",
                self.base_policy,
                builtin.names().join(", ")
            ));
        }
        let ctx = madenet_sim::PolicyContext {
            seed: 0,
            robot: 0,
            config: &self.scenario,
            height: self.map_height,
            width: self.map_width,
        };
        if builtin
            .make(&self.base_policy, &ctx)
            .map_err(|e| format!("field `base_policy`: {e}"))?
            .mode()
            != DecisionMode::OnTermination
        {
            return Err(format!("field `base_policy`: `{}` re-decides every step; the teacher needs a rule that chooses among goal candidates (e.g. spread)", self.base_policy));
        }
        if self.goals() < 2 {
            return Err(format!(
                "field `scenario.goal_count`: |G| = {} leaves no choice to learn; need at least 2",
                self.goals()
            ));
        }
        harness::check_memory(&self.memory_needs(), harness::physical_memory())
    }

    /// The allocation that grows with the sizes at once: a grid network's minibatch,
    /// `batch_size` sequences of `trace_len` + 1 decisions (one when not recurrent) of a
    /// 4-channel map image as f32, on the host and in a tensor. (The agnostic network's
    /// crops do not grow with the map; the collected episodes grow with the run, not counted.)
    pub fn memory_needs(&self) -> Vec<(String, u64)> {
        if self.network == Network::Agnostic {
            return Vec::new();
        }
        let (h, w) = (self.map_height as u64, self.map_width as u64);
        let time = if self.recurrent {
            self.trace_len as u64 + 1
        } else {
            1
        };
        let bytes = 2 * self.batch_size as u64 * time * crate::MAP_CHANNELS as u64 * h * w * 4;
        vec![(
            format!(
                "a minibatch (`batch_size` {} × {time} decisions (`trace_len` + 1 when `recurrent`) × {h} × {w} map images, host and tensor)",
                self.batch_size
            ),
            bytes,
        )]
    }

    /// The agnostic network's sizes.
    pub fn agnostic(&self) -> crate::agnostic::AgnosticConfig {
        crate::agnostic::AgnosticConfig::new()
            .with_crop_radius(self.crop_radius)
            .with_wide_inputs(self.wide_inputs.then_some(true))
            .with_territory_inputs(self.territory_inputs.then_some(true))
            .with_plan_inputs(self.plan_inputs.then_some(true))
    }

    /// The largest map side of iteration `iteration`'s curriculum (growing linearly from
    /// `map_height` to `map_side_max` over the iterations).
    fn side_max_at(&self, iteration: u64) -> usize {
        if self.map_side_max == 0 {
            return self.map_height;
        }
        let span = (self.map_side_max - self.map_height) as u64;
        self.map_height + (span * (iteration + 1)).div_ceil(self.iterations) as usize
    }

    /// |G| on the training maps (Eq. 3 unless the scenario sets it).
    pub fn goals(&self) -> usize {
        self.scenario
            .goal_count_for(self.map_height * self.map_width)
    }

    fn net_config(&self) -> NetConfig {
        let (team, goals) = (self.scenario.num_robots, self.goals());
        NetConfig {
            obs_dim: self.observation.dim(team, goals),
            ..NetConfig::dep(self.map_height, self.map_width, team, goals)
        }
    }

    fn episodes_per_iteration(&self) -> u64 {
        self.episodes / self.iterations
    }
}

/// The map distribution of the run's `height` × `width` episodes with `team` robots.
fn scenario_draw(
    cfg: &RolloutTrainConfig,
    height: usize,
    width: usize,
    team: usize,
) -> ScenarioDraw {
    ScenarioDraw {
        corner_start_prob: cfg.corner_start_prob,
        floorplan_prob: cfg.floorplan_prob,
        starts_stream: "starts",
        ..ScenarioDraw::new(
            height,
            width,
            (cfg.density_min, cfg.density_max),
            team,
            cfg.scenario.movement,
        )
    }
}

/// Episode `index`'s trial spec (policy left empty): its map (square of a side up to `side_max`
/// with a curriculum), team, starts, CSP and seed.
fn episode_spec(
    cfg: &RolloutTrainConfig,
    name: &str,
    index: u64,
    side_max: usize,
) -> Result<TrialSpec, TrainError> {
    let seed = derive_seed(cfg.seed, name, index);
    let mut rng = stream(seed, "size", 0);
    let (height, width) = if cfg.map_side_max > 0 {
        let side = rng.random_range(cfg.map_height..=side_max.max(cfg.map_height));
        (side, side)
    } else {
        (cfg.map_height, cfg.map_width)
    };
    let team = if cfg.team_max > 0 {
        rng.random_range(cfg.scenario.num_robots..=cfg.team_max)
    } else {
        cfg.scenario.num_robots
    };
    let (map, starts) = scenario_draw(cfg, height, width, team).draw(seed)?;
    let mut rng = stream(seed, "csp", 0);
    let u = rng.random::<f64>();
    let csp = if u < cfg.csp_extreme_prob / 2.0 {
        0.0
    } else if u < cfg.csp_extreme_prob {
        1.0
    } else {
        rng.random::<f64>()
    };
    Ok(TrialSpec {
        map,
        map_name: format!("{name}_{index}"),
        starts,
        config: ScenarioConfig {
            comm_success_prob: csp,
            num_robots: team,
            ..cfg.scenario.clone()
        },
        policy: String::new(),
        seed,
    })
}

/// The behaviour of data collection: `inner`'s choice, or with probability `epsilon` a random
/// valid candidate (`inner` is asked every time, so a recurrent policy's state advances).
struct Behaviour {
    inner: Box<dyn Policy>,
    epsilon: f64,
    rng: Rng,
}

impl Policy for Behaviour {
    fn name(&self) -> &str {
        "behaviour"
    }
    fn mode(&self) -> DecisionMode {
        DecisionMode::OnTermination
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let d = self.inner.decide(view);
        let n = view.candidates().cells.len();
        if n > 1 && self.rng.random::<f64>() < self.epsilon {
            return Decision::Candidate(self.rng.random_range(0..n));
        }
        d
    }
}

/// One labelled decision of one robot.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Labelled {
    /// Grid network: the map image; agnostic network: the candidates' crops
    /// ([`AgnosticInput::crops`]). Bit-packed.
    pub map: Vec<u64>,
    /// Grid network: the observation vector; agnostic network: the context followed by the
    /// candidate inputs ([`AgnosticInput`]).
    pub vec: Vec<f32>,
    /// Candidates that enter the loss (valid, and the decision had a choice).
    pub train_mask: Vec<bool>,
    /// The teacher's advantage per slot (scaled; 0 outside `train_mask`).
    pub target: Vec<f32>,
}

/// What one collected episode adds: each robot's decision sequence, and how it went.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Collected {
    /// The episode's index.
    #[serde(default)]
    pub episode: u64,
    /// Each robot's decisions in time order (grid network: every decision, labelled or not;
    /// agnostic network: the labelled ones only).
    pub robots: Vec<Vec<Labelled>>,
    /// Timesteps the episode lasted under the behaviour policy.
    pub steps: usize,
    /// Continuations the teacher ran to label it (candidates valued × futures).
    pub rollouts: usize,
    /// Σ of the teacher's gain over its base: per labelled decision, the value of the base's own
    /// choice minus the best candidate's; per team-valued timestep (`team_rounds`), once, the
    /// value of everyone at the base's choices minus everyone at the final ones.
    #[serde(default)]
    pub teacher_gain: f64,
    /// Labelled decisions and team-valued timesteps (what `teacher_gain` sums over).
    #[serde(default)]
    pub labelled: usize,
    /// Labelled decisions valued alone (not by the team teacher), and how many of them the
    /// base's own choice is among the teacher's best candidates.
    #[serde(default)]
    pub base_agreement: (usize, usize),
    /// The labels' reproducibility (`teacher_check`): the decisions valued twice.
    #[serde(default)]
    pub check: LabelCheck,
}

/// Labelled decisions valued a second time over futures of their own (`teacher_check`): how
/// often the two valuations' best candidates agree, and the pooled sums of their advantages'
/// correlation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LabelCheck {
    /// Decisions valued twice.
    pub decisions: usize,
    /// Of them, those at which the first valuation's best candidate is among the second's best.
    pub agree: usize,
    /// The candidates' advantages in the first valuation against the second's (steps).
    pub advantages: Correlation,
}

/// How a student (and the `spread` rule's score) compare with labels it was not trained on:
/// the per-iteration diagnostics of `iterations.csv`, and [`refit`]'s curve.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LabelFit {
    /// Share of the labelled decisions at which the greedy student's choice is among the
    /// teacher's best candidates.
    pub agreement: Option<f64>,
    /// Pooled Pearson correlation of the student's scores (less their mean over the valid
    /// candidates) with the labels' advantages.
    pub label_corr: Option<f64>,
    /// The same for the `spread` rule's score (negated: lower is better there).
    pub spread_label_corr: Option<f64>,
    /// What the teacher's own choice gains on the labels over `spread`'s: the mean over the
    /// labelled decisions of the best candidate's advantage less that of `spread`'s choice
    /// (label units; the ceiling of the gains below).
    pub teacher_label_gain: Option<f64>,
    /// What the student gains on the labels over `spread`'s choice as it acts, per margin
    /// (`None`: greedy; then the margins given, in their order): the mean over the labelled
    /// decisions of the advantage of the choice it makes ([`crate::policy::conservative`]) less
    /// that of `spread`'s. The offline counterpart of the validation's gain over `spread`.
    pub student_gains: Vec<(Option<f32>, f64)>,
}

impl LabelFit {
    /// The margin whose [`LabelFit::student_gains`] is largest, and that gain.
    pub fn best_gain(&self) -> Option<(Option<f32>, f64)> {
        self.student_gains
            .iter()
            .copied()
            .reduce(|a, b| if b.1 > a.1 { b } else { a })
    }
}

/// Pooled sums of a Pearson correlation: Σ 1, a, b, a², b², a·b over the pairs (a, b) added.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Correlation {
    sums: [f64; 6],
}

impl Correlation {
    fn add(&mut self, a: f64, b: f64) {
        for (sum, x) in self.sums.iter_mut().zip([1.0, a, b, a * a, b * b, a * b]) {
            *sum += x;
        }
    }

    fn merge(&mut self, other: &Correlation) {
        for (s, o) in self.sums.iter_mut().zip(other.sums) {
            *s += o;
        }
    }

    /// The correlation of the pairs added; `None` below two pairs or without variance.
    pub fn value(&self) -> Option<f64> {
        let [n, a, b, aa, bb, ab] = self.sums;
        let cov = ab - a * b / n;
        let (va, vb) = (aa - a * a / n, bb - b * b / n);
        // Clamped: rounding in the pooled sums can step just outside [−1, 1].
        (n >= 2.0 && va > 0.0 && vb > 0.0).then(|| (cov / (va * vb).sqrt()).clamp(-1.0, 1.0))
    }
}

impl LabelCheck {
    /// Adds one decision's two valuations (the same candidates valid in both).
    fn add(&mut self, first: &[Option<f64>], second: &[Option<f64>]) {
        let (Some(a_best), Some(Decision::Candidate(k))) =
            (min_value(second), best_candidate(first, None))
        else {
            return;
        };
        self.decisions += 1;
        self.agree += (second.get(k).copied().flatten() == Some(a_best)) as usize;
        let (ma, mb) = (mean_value(first), mean_value(second));
        for (a, b) in first.iter().zip(second) {
            if let (Some(a), Some(b)) = (a, b) {
                self.advantages.add(ma - a, mb - b);
            }
        }
    }

    /// Adds another episode's check.
    fn merge(&mut self, other: &LabelCheck) {
        self.decisions += other.decisions;
        self.agree += other.agree;
        self.advantages.merge(&other.advantages);
    }

    /// Share of the decisions valued twice whose best candidates agree.
    pub fn self_agreement(&self) -> Option<f64> {
        (self.decisions > 0).then(|| self.agree as f64 / self.decisions as f64)
    }

    /// Pearson correlation of the two valuations' advantages over every valued candidate: the
    /// share of a label's variance that is signal rather than the futures' luck.
    pub fn reliability(&self) -> Option<f64> {
        self.advantages.value()
    }
}

/// The lowest of `values` (the best: fewest steps left).
fn min_value(values: &[Option<f64>]) -> Option<f64> {
    values.iter().flatten().copied().reduce(f64::min)
}

/// The mean of `values`' valued candidates.
fn mean_value(values: &[Option<f64>]) -> f64 {
    let known: Vec<f64> = values.iter().flatten().copied().collect();
    known.iter().sum::<f64>() / known.len().max(1) as f64
}

/// The rule the teacher's continuations follow: policy `name` of `registry` (the base rule, or
/// with expert iteration the best student so far, with policy iteration the current greedy one).
pub struct TeacherBase {
    /// Holds `name`.
    pub registry: PolicyRegistry,
    /// The policy continuations follow.
    pub name: String,
}

impl TeacherBase {
    /// The config's `base_policy`.
    pub fn rule(cfg: &RolloutTrainConfig) -> Self {
        TeacherBase {
            registry: PolicyRegistry::builtin(),
            name: cfg.base_policy.clone(),
        }
    }

    /// A student (with its margin) as the base: registered as `student`.
    pub fn student(model: &Model) -> Self {
        let mut registry = PolicyRegistry::default();
        model.register(&mut registry, "student", "the teacher's base: a student");
        TeacherBase {
            registry,
            name: "student".into(),
        }
    }
}

/// The rollout teacher as an episode recorder: at each timestep, before the behaviour policy
/// decides, it labels the decisions with a choice (with probability `label_prob`) by the
/// values of their candidates.
struct Labelling<'a> {
    cfg: &'a RolloutTrainConfig,
    seed: u64,
    label_prob: f64,
    /// The factor on this episode's advantages: `label_scale` and `label_norm`'s.
    label_scale: f32,
    label_rng: Rng,
    horizon: Option<usize>,
    base: &'a TeacherBase,
    robots: Vec<Vec<Labelled>>,
    rollouts: usize,
    teacher_gain: f64,
    labelled: usize,
    base_agreement: (usize, usize),
    /// Which labelled decisions are valued twice (`teacher_check`), a stream of its own.
    check_rng: Rng,
    check: LabelCheck,
}

/// Which set of futures a valuation uses: the labels' own, or the check's (other seeds).
#[derive(Clone, Copy, PartialEq)]
enum FutureSet {
    Label,
    Check,
}

impl Labelling<'_> {
    /// The futures robot `i`'s candidates are scored in at timestep `t` (`set`: the labels' or
    /// the check's seeds).
    fn futures(&self, trial: &Trial, i: usize, set: FutureSet) -> Result<Vec<Future>, TrainError> {
        let t = trial.world().t() as u64;
        let salt = |s: u64| (t * 64 + i as u64) * 64 + s;
        let (future, redraw) = match set {
            FutureSet::Label => ("future", "redraw"),
            FutureSet::Check => ("future-check", "redraw-check"),
        };
        Ok(match self.cfg.futures {
            Futures::Noiseless => vec![Future::Noiseless],
            Futures::Salted => (0..self.cfg.rollouts as u64)
                .map(|s| Future::Salted(derive_seed(self.seed, future, salt(s))))
                .collect(),
            Futures::Redrawn => {
                let truth = trial.world().truth();
                let draw = scenario_draw(
                    self.cfg,
                    truth.height(),
                    truth.width(),
                    trial.agents().len(),
                );
                (0..self.cfg.rollouts as u64)
                    .map(|s| {
                        let (map, _) = draw.draw(derive_seed(self.seed, redraw, salt(s)))?;
                        Ok(Future::Redrawn(std::sync::Arc::new(map)))
                    })
                    .collect::<Result<_, TrainError>>()?
            }
        })
    }

    /// Robot `i`'s candidate values, the deciding robots with a decision in `fixed` taking it.
    fn values(
        &mut self,
        trial: &Trial,
        i: usize,
        fixed: &[Option<Decision>],
    ) -> Result<Vec<Option<f64>>, TrainError> {
        self.values_in(trial, i, fixed, FutureSet::Label)
    }

    /// [`Labelling::values`] over the futures of `set`; the check's continuations are not
    /// counted in `rollouts` (what the labels cost).
    fn values_in(
        &mut self,
        trial: &Trial,
        i: usize,
        fixed: &[Option<Decision>],
        set: FutureSet,
    ) -> Result<Vec<Option<f64>>, TrainError> {
        let futures = self.futures(trial, i, set)?;
        let look = Lookahead {
            horizon: self.horizon,
            value: self.cfg.value,
        };
        let (name, registry) = (&self.base.name, &self.base.registry);
        let (values, runs) = match self.cfg.teacher {
            Teacher::Rollout => {
                let values = candidate_values_by(trial, i, fixed, name, registry, &futures, look)
                    .map_err(|e| TrainError::Other(e.to_string()))?;
                let runs = values.iter().flatten().count() * futures.len();
                (values, runs)
            }
            // One team plan per future, whatever the candidates.
            Teacher::Plan => (plan_values(trial, i, &futures), futures.len()),
        };
        if set == FutureSet::Label {
            self.rollouts += runs;
        }
        Ok(values)
    }

    /// What the teacher's base would decide for robot `i` now (an instance made as a fork
    /// makes its).
    fn base_choice(&self, trial: &mut Trial, i: usize) -> Result<Decision, TrainError> {
        let ctx = madenet_sim::PolicyContext {
            seed: self.seed,
            robot: i,
            config: trial.world().config(),
            height: trial.world().truth().height(),
            width: trial.world().truth().width(),
        };
        let mut base = self
            .base
            .registry
            .make(&self.base.name, &ctx)
            .map_err(|e| TrainError::Other(e.to_string()))?;
        Ok(base.decide(&mut trial.agent_mut(i).view(true)))
    }
}

/// The best candidate of `values` (lowest value; ties keep `current`, then the lower slot).
fn best_candidate(values: &[Option<f64>], current: Option<Decision>) -> Option<Decision> {
    let min = min_value(values)?;
    if let Some(Decision::Candidate(k)) = current {
        if values.get(k).copied().flatten() == Some(min) {
            return current;
        }
    }
    let k = values.iter().position(|v| *v == Some(min))?;
    Some(Decision::Candidate(k))
}

impl Recorder for Labelling<'_> {
    type Error = TrainError;

    fn decide(&mut self, trial: &mut Trial) -> Result<(), TrainError> {
        let cfg = self.cfg;
        let ds = cfg.scenario.sensing_range;
        let n = trial.agents().len();
        // 1. A decision with a choice is labelled with probability `label_prob` (scaled by the
        //    area), drawn in robot order.
        let mut choosers = Vec::new();
        let mut labelled = vec![false; n];
        for (i, label) in labelled.iter_mut().enumerate() {
            if !trial.deciding()[i] {
                continue;
            }
            if trial.agent_mut(i).view(true).candidates().cells.len() >= 2 {
                choosers.push(i);
                *label = self.label_rng.random::<f64>() < self.label_prob;
            }
        }
        // 2. The teacher values the labelled robots' candidates: each with the other deciding
        //    robots asking the base; with `team_rounds`, when two or more robots choose together,
        //    by coordinate descent — each robot's candidates valued with the others at their
        //    current choices (the base's to begin with), its best taken, for `team_rounds`
        //    passes over the robots — so a label says what is best beside what the teammates do.
        let mut values: Vec<Option<Vec<Option<f64>>>> = vec![None; n];
        let team = cfg.team_rounds > 0 && choosers.len() >= 2;
        if team && choosers.iter().any(|&i| labelled[i]) {
            let mut fixed = vec![None; n];
            for &i in &choosers {
                fixed[i] = Some(self.base_choice(trial, i)?);
            }
            // The value of everyone at the base's choices (the first robot's first valuation
            // at its base choice); passes end early when one changes nothing.
            let mut at_base = None;
            let mut first_valuation = true;
            let mut changed = true;
            for _ in 0..cfg.team_rounds {
                if !changed {
                    break;
                }
                changed = false;
                for &i in &choosers {
                    let v = self.values(trial, i, &fixed)?;
                    if let (true, Some(Decision::Candidate(k))) = (first_valuation, fixed[i]) {
                        at_base = v.get(k).copied().flatten();
                    }
                    first_valuation = false;
                    let next = best_candidate(&v, fixed[i]);
                    changed |= next != fixed[i];
                    fixed[i] = next;
                    values[i] = Some(v);
                }
            }
            // The team's gain, counted once: everyone at the base's choices against everyone at
            // the final ones (the last robot's best, valued beside the others' final choices).
            // With `futures = "salted"` or `"redrawn"` the two come from different robots'
            // futures, so the gain carries their luck.
            let last = choosers[choosers.len() - 1];
            let at_final = min_value(values[last].as_deref().unwrap_or(&[]));
            if let (Some(at_base), Some(at_final)) = (at_base, at_final) {
                self.teacher_gain += at_base - at_final;
                self.labelled += 1;
            }
        } else {
            for &i in choosers.iter().filter(|&&i| labelled[i]) {
                let v = self.values(trial, i, &[])?;
                // The teacher's gain over its base here: what the base's own choice leaves
                // minus what the best candidate leaves.
                let best = min_value(&v);
                if let Decision::Candidate(k) = self.base_choice(trial, i)? {
                    if let (Some(own), Some(best)) = (v.get(k).copied().flatten(), best) {
                        self.teacher_gain += own - best;
                        self.labelled += 1;
                        self.base_agreement.0 += 1;
                        self.base_agreement.1 += (own == best) as usize;
                    }
                }
                // The diagnostic: the same decision valued again over futures of its own.
                if self.cfg.teacher_check > 0.0
                    && self.check_rng.random::<f64>() < self.cfg.teacher_check
                {
                    let again = self.values_in(trial, i, &[], FutureSet::Check)?;
                    self.check.add(&v, &again);
                }
                values[i] = Some(v);
            }
        }
        // 3. Each labelled decision (the grid network: every decision, its recurrent windows
        //    need them) with its inputs and the candidates' advantages.
        for (i, &is_labelled) in labelled.iter().enumerate() {
            if !trial.deciding()[i] || (!is_labelled && cfg.network == Network::Agnostic) {
                continue;
            }
            let (map, vec, mask) = {
                let mut view = trial.agent_mut(i).view(true);
                match cfg.network {
                    Network::Grid => (
                        pack_bits(&view.map_image()),
                        cfg.observation.vector(&mut view, ds),
                        action_mask(&view),
                    ),
                    Network::Agnostic => {
                        let x = crate::agnostic::inputs_for(&mut view, ds, &cfg.agnostic());
                        let mut vec = x.context;
                        vec.extend(x.features);
                        (x.crops, vec, x.mask)
                    }
                }
            };
            let mut target = vec![0.0; mask.len()];
            let mut train_mask = vec![false; mask.len()];
            if let (true, Some(values)) = (is_labelled, &values[i]) {
                let mean = mean_value(values);
                for (k, v) in values.iter().enumerate() {
                    if let Some(v) = v {
                        // Fewer steps left is better: the advantage is mean − value.
                        target[k] = ((mean - v) as f32) * self.label_scale;
                        train_mask[k] = true;
                    }
                }
            }
            self.robots[i].push(Labelled {
                map,
                vec,
                train_mask,
                target,
            });
        }
        trial.decide_with(&vec![None; n]);
        Ok(())
    }
}

/// The factor on the advantages of an episode on a `height × width` map: `label_scale`, and
/// [`RolloutTrainConfig::label_norm`]'s.
fn label_scale(cfg: &RolloutTrainConfig, height: usize, width: usize) -> f32 {
    match cfg.label_norm {
        LabelNorm::None => cfg.label_scale,
        LabelNorm::Side => cfg.label_scale * cfg.map_height as f32 / height.max(width) as f32,
    }
}

/// Runs training episode `index` under `behaviour` (a registry holding policy "behaviour") and
/// labels every decision with a choice.
fn collect_episode(
    cfg: &RolloutTrainConfig,
    index: u64,
    side_max: usize,
    behaviour: &PolicyRegistry,
    base: &TeacherBase,
) -> Result<Collected, TrainError> {
    let spec = TrialSpec {
        policy: "behaviour".into(),
        ..episode_spec(cfg, "train", index, side_max)?
    };
    let seed = spec.seed;
    let (height, width) = (spec.map.height(), spec.map.width());
    let cells = height * width;
    let mut trial = Trial::with_registry(spec, behaviour)
        .map_err(|e| TrainError::Other(e.to_string()))?
        .timed(false);
    let mut teacher = Labelling {
        cfg,
        seed,
        label_prob: (cfg.label_prob * 400.0 / cells as f64).min(1.0),
        label_scale: label_scale(cfg, height, width),
        label_rng: stream(seed, "label", 0),
        horizon: (cfg.horizon > 0).then_some(cfg.horizon),
        base,
        robots: vec![Vec::new(); trial.agents().len()],
        rollouts: 0,
        teacher_gain: 0.0,
        labelled: 0,
        base_agreement: (0, 0),
        check_rng: stream(seed, "teacher-check", 0),
        check: LabelCheck::default(),
    };
    let end = episode::run(&mut trial, &mut teacher)?;
    Ok(Collected {
        episode: index,
        robots: teacher.robots,
        steps: end.steps,
        rollouts: teacher.rollouts,
        teacher_gain: teacher.teacher_gain,
        labelled: teacher.labelled,
        base_agreement: teacher.base_agreement,
        check: teacher.check,
    })
}

/// A model as plain data: its `model.toml` text and its one weight file's bytes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelBytes {
    /// The `model.toml` text.
    pub model_toml: String,
    /// The weight file (`dep0.bpk`).
    pub weights: Vec<u8>,
}

impl ModelBytes {
    /// Reads the model folder `dir` (written by [`write_model`]: `model.toml`, `dep0.bpk`).
    fn read(dir: &Path) -> Result<Self, TrainError> {
        let read = |f: &str| {
            let p = dir.join(f);
            std::fs::read(&p).map_err(|e| TrainError::Io {
                path: p.display().to_string(),
                message: e.to_string(),
            })
        };
        let model_toml = String::from_utf8(read("model.toml")?)
            .map_err(|e| TrainError::Other(format!("{}: {e}", dir.display())))?;
        Ok(ModelBytes {
            model_toml,
            weights: read("dep0.bpk")?,
        })
    }

    fn model(&self, label: &str) -> Result<Model, TrainError> {
        Model::from_bytes(&self.model_toml, &[&self.weights], label)
    }
}

/// Episodes of one iteration to collect, as plain data (postcard): given the run's config, a
/// worker anywhere collects from it exactly the episodes a local run does ([`collect`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CollectRequest {
    /// The madenet version that made the request: a worker of another version refuses it.
    pub version: String,
    /// The episodes' indices (each episode's scenario and seeds follow from its index).
    pub episodes: Vec<u64>,
    /// The curriculum's largest map side this iteration.
    pub side_max: usize,
    /// The behaviour's student (greedy, ε-random); none while the behaviour is the base rule.
    pub student: Option<ModelBytes>,
    /// The teacher's base student (expert or policy iteration); none while it is the base rule.
    pub base: Option<ModelBytes>,
}

/// Collects the episodes of `req`, in its order, in parallel on the current thread pool; `None`
/// when `stop` said so before an episode started.
pub fn collect(
    cfg: &RolloutTrainConfig,
    req: &CollectRequest,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<Option<Vec<Collected>>, TrainError> {
    let student = match &req.student {
        Some(m) => Some(m.model("the behaviour's student")?),
        None => None,
    };
    let behaviour = behaviour_registry(cfg, student);
    let teacher = match &req.base {
        Some(m) => TeacherBase::student(&m.model("the teacher's base")?),
        None => TeacherBase::rule(cfg),
    };
    let collected: Vec<Option<Collected>> = req
        .episodes
        .par_iter()
        .map(|&e| match stop() {
            true => Ok(None),
            false => collect_episode(cfg, e, req.side_max, &behaviour, &teacher).map(Some),
        })
        .collect::<Result<_, _>>()?;
    Ok(collected.into_iter().collect())
}

/// [`collect`] for a worker in another process (the Python package's Ray tasks): the run's
/// config as TOML text and a postcard [`CollectRequest`] in, the postcard `Vec<Collected>` out,
/// on `threads` threads.
pub fn collect_bytes(
    config_toml: &str,
    request: &[u8],
    threads: usize,
) -> Result<Vec<u8>, TrainError> {
    let cfg = RolloutTrainConfig::from_toml_text(Path::new("the run's config"), config_toml)?;
    cfg.validate()
        .map_err(|m| TrainError::Other(format!("the run's config: {m}")))?;
    let req: CollectRequest = postcard::from_bytes(request)
        .map_err(|e| TrainError::Other(format!("a collect request: {e}")))?;
    if req.version != env!("CARGO_PKG_VERSION") {
        return Err(TrainError::Other(format!(
            "a collect request of madenet {}: this worker is madenet {} (run the same version everywhere)",
            req.version,
            env!("CARGO_PKG_VERSION")
        )));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|e| TrainError::Other(format!("thread pool: {e}")))?;
    let collected = pool
        .install(|| collect(&cfg, &req, &|| false))?
        .expect("never stopped");
    postcard::to_allocvec(&collected).map_err(|e| TrainError::Other(e.to_string()))
}

/// A function collecting batches: the run's config as TOML and each batch's postcard
/// [`CollectRequest`] in, each batch's [`collect_bytes`] output out, in order.
pub type BatchCollector<'a> =
    dyn FnMut(&str, Vec<Vec<u8>>) -> Result<Vec<Vec<u8>>, TrainError> + Send + 'a;

/// Where an iteration's episodes are collected.
pub enum Collector<'a> {
    /// Here, on the run's thread pool ([`collect`]); an episode not started within the time
    /// budget cuts the iteration.
    Local,
    /// By the caller: the iteration's request split into batches of `batch` episodes, each a
    /// postcard [`CollectRequest`], handed to `run` with the run's config as TOML; `run`
    /// returns each batch's [`collect_bytes`] output, in order (e.g. Ray tasks: `madenet.ray.train`).
    Batches {
        /// Episodes per batch (≥ 1).
        batch: usize,
        /// Collects the batches.
        run: &'a mut BatchCollector<'a>,
    },
}

impl Collector<'_> {
    /// The episodes of `req` ([`None`]: the time budget ran out first).
    fn collect(
        &mut self,
        cfg: &RolloutTrainConfig,
        req: &CollectRequest,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Option<Vec<Collected>>, TrainError> {
        let (batch, run) = match self {
            Collector::Local => return collect(cfg, req, stop),
            Collector::Batches { batch, run } => (*batch, run),
        };
        let text = toml::to_string(cfg).map_err(|e| TrainError::Other(e.to_string()))?;
        let batches = req
            .episodes
            .chunks(batch.max(1))
            .map(|episodes| {
                postcard::to_allocvec(&CollectRequest {
                    episodes: episodes.to_vec(),
                    ..req.clone()
                })
                .map_err(|e| TrainError::Other(e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let n = batches.len();
        let results = run(&text, batches)?;
        if results.len() != n {
            return Err(TrainError::Other(format!(
                "the collector returned {} batches for {n}",
                results.len()
            )));
        }
        let mut all = Vec::with_capacity(req.episodes.len());
        for (k, (r, want)) in results
            .iter()
            .zip(req.episodes.chunks(batch.max(1)))
            .enumerate()
        {
            let bad = |why: String| TrainError::Other(format!("the collector's batch {k}: {why}"));
            let (part, rest): (Vec<Collected>, _) =
                postcard::take_from_bytes(r).map_err(|e| bad(e.to_string()))?;
            if !rest.is_empty() {
                return Err(bad(format!("{} bytes after the episodes", rest.len())));
            }
            let got: Vec<u64> = part.iter().map(|c| c.episode).collect();
            if got != want {
                return Err(bad(format!("episodes {got:?}, asked for {want:?}")));
            }
            all.extend(part);
        }
        Ok(Some(all))
    }
}

/// A registry whose policy "behaviour" is the base rule (no student yet) or the student DEP
/// (greedy), each with ε-random candidates from a stream of the episode's seed and robot.
fn behaviour_registry(cfg: &RolloutTrainConfig, student: Option<Model>) -> PolicyRegistry {
    let mut r = PolicyRegistry::default();
    let (base, eps) = (PolicyRegistry::builtin(), cfg.behaviour_epsilon);
    let name = cfg.base_policy.clone();
    r.register("behaviour", "data collection", move |ctx| {
        let inner: Box<dyn Policy> = match &student {
            Some(model) => model.policy("student", ctx.robot, ctx.config.sensing_range),
            None => base
                .make(&name, ctx)
                .expect("the base policy is a built-in (validated)"),
        };
        Box::new(Behaviour {
            inner,
            epsilon: eps,
            rng: stream(ctx.seed, "behaviour", ctx.robot as u64),
        })
    });
    r
}

/// The DEP being trained (on the autodiff device).
#[derive(Clone)]
#[allow(clippy::large_enum_variant)] // one per run, never moved in a loop
enum Student {
    Grid(QNet),
    Agnostic(AgnosticNet),
}

impl Student {
    fn init(cfg: &RolloutTrainConfig, device: &burn::tensor::Device) -> Result<Self, TrainError> {
        Ok(match cfg.network {
            Network::Grid => Student::Grid(cfg.net_config().init(device)?),
            Network::Agnostic => {
                Student::Agnostic(cfg.agnostic().init(device).map_err(TrainError::Other)?)
            }
        })
    }

    /// Share of `labelled` decisions (those with targets) at which the greedy student's choice
    /// is among the teacher's best candidates, and the correlation of its scores (less their
    /// mean over the valid candidates) with the labels' advantages, and the same for the
    /// `spread` rule's score (negated: lower is better there; read from the candidate inputs),
    /// and what the teacher's and the student's choices (greedy and with each of `margins`)
    /// gain on the labels over `spread`'s; `None` for the grid network or no decision.
    fn imitation<'a>(
        &self,
        labelled: impl Iterator<Item = &'a Labelled>,
        margins: &[f32],
    ) -> LabelFit {
        let Student::Agnostic(net) = self else {
            return LabelFit::default();
        };
        let net = crate::agnostic::AgnosticScorer::new(&net.valid());
        let (mut n, mut agree) = (0usize, 0usize);
        let (mut corr, mut spread_corr) = (Correlation::default(), Correlation::default());
        let acting: Vec<Option<f32>> = std::iter::once(None)
            .chain(margins.iter().map(|&m| Some(m)))
            .collect();
        // Over the decisions where `spread`'s choice is known: their count, Σ of the teacher's
        // gain, Σ of the student's per margin of `acting`.
        let (mut anchored, mut teacher_sum) = (0usize, 0.0);
        let mut student_sums = vec![0.0; acting.len()];
        for l in labelled.filter(|l| l.train_mask.iter().any(|&m| m)) {
            let input = AgnosticInput {
                context: l.vec[..CONTEXT_FEATURES].to_vec(),
                features: l.vec[CONTEXT_FEATURES..].to_vec(),
                crops: l.map.clone(),
                mask: l.train_mask.clone(),
            };
            let q = net.scores(&input);
            let valid = || (0..q.len()).filter(|&k| l.train_mask[k]);
            let mean = valid().map(|k| q[k] as f64).sum::<f64>() / valid().count() as f64;
            for k in valid() {
                corr.add(q[k] as f64 - mean, l.target[k] as f64);
            }
            // `spread`'s score of k / (height + width), from the candidate's inputs.
            let width = (l.vec.len() - CONTEXT_FEATURES) / l.train_mask.len().max(1);
            let spread = |k: usize| {
                -l.vec[CONTEXT_FEATURES + k * width + AgentView::SPREAD_SCORE_FEATURE] as f64
            };
            let spread_mean = valid().map(spread).sum::<f64>() / valid().count() as f64;
            for k in valid() {
                spread_corr.add(spread(k) - spread_mean, l.target[k] as f64);
            }
            let masked = |v: &[f32], k: usize| {
                if l.train_mask[k] {
                    v[k]
                } else {
                    f32::NEG_INFINITY
                }
            };
            // The choice the acting policy makes greedily.
            let Some(pick) = crate::actions::masked_argmax_slice(&q, &l.train_mask) else {
                continue;
            };
            let best = (0..l.train_mask.len())
                .map(|k| masked(&l.target, k))
                .fold(f32::NEG_INFINITY, f32::max);
            n += 1;
            agree += (l.target[pick] == best) as usize;
            if let Some((teacher, students)) = label_gains(l, &q, &acting) {
                anchored += 1;
                teacher_sum += teacher;
                for (sum, gain) in student_sums.iter_mut().zip(students) {
                    *sum += gain;
                }
            }
        }
        let mean = |sum: f64| sum / anchored as f64;
        LabelFit {
            agreement: (n > 0).then(|| agree as f64 / n as f64),
            label_corr: corr.value(),
            spread_label_corr: spread_corr.value(),
            teacher_label_gain: (anchored > 0).then(|| mean(teacher_sum)),
            student_gains: if anchored > 0 {
                acting
                    .into_iter()
                    .zip(student_sums.into_iter().map(mean))
                    .collect()
            } else {
                Vec::new()
            },
        }
    }

    /// The student on the plain CPU device as a model acting with `info`'s margin.
    fn model(&self, info: ModelInfo) -> Model {
        match self {
            Student::Grid(net) => {
                Model::with_grid(info, vec![Arc::new(net.valid())]).expect("one DEP")
            }
            Student::Agnostic(net) => Model::with_agnostic(info, net.valid()),
        }
    }

    /// Saves the weights (of the plain copy when `plain`) to `path`.
    fn save(&self, path: &Path, plain: bool) -> Result<(), TrainError> {
        let result = match (self, plain) {
            (Student::Grid(n), true) => n.valid().into_record().save(path),
            (Student::Grid(n), false) => n.clone().into_record().save(path),
            (Student::Agnostic(n), true) => n.valid().into_record().save(path),
            (Student::Agnostic(n), false) => n.clone().into_record().save(path),
        };
        result.map_err(|e| TrainError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }

    fn load(self, path: &Path) -> Result<Self, TrainError> {
        Ok(match self {
            Student::Grid(n) => Student::Grid(harness::load_weights(n, path)?),
            Student::Agnostic(n) => Student::Agnostic(harness::load_weights(n, path)?),
        })
    }

    /// One Adam step on `windows` (single decisions for the agnostic network).
    fn update(
        self,
        optim: &mut ModuleOptimizer,
        cfg: &RolloutTrainConfig,
        windows: &[&[Labelled]],
    ) -> (Self, f32) {
        match self {
            Student::Grid(net) => {
                let (net, loss) = update(net, optim, cfg, windows);
                (Student::Grid(net), loss)
            }
            Student::Agnostic(net) => {
                let (net, loss) = update_agnostic(net, optim, cfg, windows);
                (Student::Agnostic(net), loss)
            }
        }
    }
}

/// The student's loss on scores `q` against the teacher's advantages `y` (`[rows, slots]`; `m`
/// is 1 on trained slots): [`Loss`].
fn student_loss(cfg: &RolloutTrainConfig, q: Tensor<2>, y: Tensor<2>, m: Tensor<2>) -> Tensor<1> {
    match cfg.loss {
        Loss::Advantage => advantage_loss(q, y, m),
        Loss::Listwise => listwise_loss(q, y, m, cfg.listwise_temperature),
    }
}

/// Σ over rows with a trained slot of −Σ_k softmax(y/τ)_k · log softmax(q/τ)_k over the trained
/// slots, divided by those rows' count (untrained slots pushed to −10⁹ before both softmaxes,
/// after the division by τ).
fn listwise_loss(q: Tensor<2>, y: Tensor<2>, m: Tensor<2>, tau: f32) -> Tensor<1> {
    use burn::tensor::activation::{log_softmax, softmax};
    let off = m.clone().neg().add_scalar(1.0).mul_scalar(1e9);
    let p = softmax(y.div_scalar(tau).sub(off.clone()), 1).mul(m.clone());
    let log_q = log_softmax(q.div_scalar(tau).sub(off), 1);
    let rows = m.clone().sum_dim(1).clamp_max(1.0);
    let count = rows.clone().sum().clamp_min(1.0);
    p.mul(log_q)
        .mul(m)
        .sum_dim(1)
        .mul(rows)
        .sum()
        .neg()
        .div(count)
}

/// The masked mean squared error between scores `q` centred over each row's trained slots and
/// the teacher's advantages `y` (`[rows, slots]`; `m` is 1 on trained slots).
fn advantage_loss(q: Tensor<2>, y: Tensor<2>, m: Tensor<2>) -> Tensor<1> {
    let g = q.dims()[1];
    let count = m.clone().sum().clamp_min(1.0);
    let n = m.clone().sum_dim(1).clamp_min(1.0);
    let mean = q.clone().mul(m.clone()).sum_dim(1).div(n).repeat_dim(1, g);
    let centred = (q - mean).mul(m.clone());
    (centred - y).powf_scalar(2.0).mul(m).sum().div(count)
}

/// One Adam step on a batch of robot windows: masked MSE between the DEP's centred Q values and
/// the teacher's advantages. Returns the loss.
fn update(
    net: QNet,
    optim: &mut ModuleOptimizer,
    cfg: &RolloutTrainConfig,
    windows: &[&[Labelled]],
) -> (QNet, f32) {
    let (h, w) = (cfg.map_height, cfg.map_width);
    let map_len = 4 * h * w;
    let (b, t) = (
        windows.len(),
        windows.iter().map(|s| s.len()).max().unwrap_or(1).max(1),
    );
    let g = cfg.goals();
    let d = windows
        .iter()
        .find_map(|s| s.first())
        .map_or(1, |l| l.vec.len());
    let (mut maps, mut obs) = (vec![0.0f32; b * t * map_len], vec![0.0f32; b * t * d]);
    let (mut target, mut mask) = (vec![0.0f32; b * t * g], vec![0.0f32; b * t * g]);
    for (bi, seq) in windows.iter().enumerate() {
        for (ti, l) in seq.iter().enumerate() {
            let idx = bi * t + ti;
            unpack_bits(&l.map, &mut maps[idx * map_len..(idx + 1) * map_len]);
            obs[idx * d..(idx + 1) * d].copy_from_slice(&l.vec);
            for k in 0..g {
                target[idx * g + k] = l.target[k];
                mask[idx * g + k] = l.train_mask[k] as u8 as f32;
            }
        }
    }
    let device = net.devices()[0].clone();
    let maps = Tensor::<5>::from_data(TensorData::new(maps, [b, t, 4, h, w]), &device);
    let obs = Tensor::<3>::from_data(TensorData::new(obs, [b, t, d]), &device);
    let y = Tensor::<2>::from_data(TensorData::new(target, [b * t, g]), &device);
    let m = Tensor::<2>::from_data(TensorData::new(mask, [b * t, g]), &device);
    let (q, _) = net.forward(maps, obs, None);
    let loss = student_loss(cfg, q.reshape([b * t, g]), y, m);
    adam_step(net, optim, cfg.learning_rate, loss)
}

/// One Adam step of the agnostic DEP on single decisions (the first of each window): the same
/// loss as [`update`], slots padded to the widest decision of the batch.
fn update_agnostic(
    net: AgnosticNet,
    optim: &mut ModuleOptimizer,
    cfg: &RolloutTrainConfig,
    windows: &[&[Labelled]],
) -> (AgnosticNet, f32) {
    let inputs: Vec<AgnosticInput> = windows
        .iter()
        .filter_map(|w| w.first())
        .map(|l| AgnosticInput {
            context: l.vec[..CONTEXT_FEATURES].to_vec(),
            features: l.vec[CONTEXT_FEATURES..].to_vec(),
            crops: l.map.clone(),
            mask: l.train_mask.clone(),
        })
        .collect();
    let refs: Vec<&AgnosticInput> = inputs.iter().collect();
    let device = net.devices()[0].clone();
    let batch = Batch::of(&refs, net.crop_side, &device);
    let (b, g) = (refs.len(), batch.slots);
    let mut target = vec![0.0f32; b * g];
    for (i, l) in windows.iter().filter_map(|w| w.first()).enumerate() {
        target[i * g..i * g + l.target.len()].copy_from_slice(&l.target);
    }
    let y = Tensor::<2>::from_data(TensorData::new(target, [b, g]), &device);
    let q = net.forward(
        batch.crops,
        batch.features,
        batch.context,
        batch.mask.clone(),
    );
    let loss = student_loss(cfg, q, y, batch.mask);
    adam_step(net, optim, cfg.learning_rate, loss)
}

/// Adam steps `updates` (their indices name each batch's `sample` stream, so a run resumed at
/// an iteration boundary draws what an uninterrupted one draws) on batches of windows of the
/// robots' decision sequences `data`; the trained student and the sum of the steps' losses, or
/// `None` as soon as `stop` says so.
fn fit(
    mut net: Student,
    optim: &mut ModuleOptimizer,
    cfg: &RolloutTrainConfig,
    data: &[Vec<Labelled>],
    updates: std::ops::Range<u64>,
    stop: &dyn Fn() -> bool,
) -> Option<(Student, f64)> {
    let mut loss_sum = 0.0;
    let trace_len = if cfg.recurrent { cfg.trace_len } else { 1 };
    for u in updates {
        if stop() {
            return None;
        }
        let mut rng = stream(cfg.seed, "sample", u);
        let windows: Vec<&[Labelled]> = (0..cfg.batch_size)
            .map(|_| {
                let seq = &data[rng.random_range(0..data.len())];
                let start = if seq.len() > trace_len {
                    rng.random_range(0..=seq.len() - trace_len)
                } else {
                    0
                };
                &seq[start..(start + trace_len).min(seq.len())]
            })
            .collect();
        let (next, loss) = net.update(optim, cfg, &windows);
        net = next;
        loss_sum += loss as f64;
    }
    Some((net, loss_sum))
}

/// What [`fit_checked`] ends with.
struct Fitted {
    net: Student,
    /// Σ of the losses of the updates made.
    loss_sum: f64,
    updates: u64,
    /// The kept student's correlation with the held-out labels (`fit_holdout`).
    holdout_corr: Option<f64>,
}

/// An iteration's fit: [`fit`] on `train` for `updates_per_iteration` updates numbered from
/// `first`, or with held-out sequences (`fit_holdout`) in rounds of `fit_check_every`, scoring
/// the student against their labels after each round and ending after `fit_patience` rounds
/// without a better score, with the best-scoring student. `None` when `stop` said so.
fn fit_checked(
    net: Student,
    optim: &mut ModuleOptimizer,
    cfg: &RolloutTrainConfig,
    (train, held_out): (&[Vec<Labelled>], &[Vec<Labelled>]),
    first: u64,
    stop: &dyn Fn() -> bool,
) -> Option<Fitted> {
    let all = cfg.updates_per_iteration;
    if held_out.is_empty() {
        let (net, loss_sum) = fit(net, optim, cfg, train, first..first + all, stop)?;
        return Some(Fitted {
            net,
            loss_sum,
            updates: all,
            holdout_corr: None,
        });
    }
    let (mut net, mut done, mut loss_sum, mut since_best) = (net, 0, 0.0, 0);
    let mut best: Option<(f64, Student)> = None;
    while done < all && since_best < cfg.fit_patience {
        let to = (done + cfg.fit_check_every).min(all);
        let (next, loss) = fit(net, optim, cfg, train, first + done..first + to, stop)?;
        (net, done, loss_sum) = (next, to, loss_sum + loss);
        let corr = net.imitation(held_out.iter().flatten(), &[]).label_corr;
        match (corr, &best) {
            (Some(c), Some((b, _))) if c <= *b => since_best += 1,
            (Some(c), _) => (best, since_best) = (Some((c, net.clone())), 0),
            (None, _) => since_best += 1,
        }
    }
    let holdout_corr = best.as_ref().map(|b| b.0);
    Some(Fitted {
        net: best.map_or(net, |b| b.1),
        loss_sum,
        updates: done,
        holdout_corr,
    })
}

/// A run's stored labels (`RUN/checkpoint/data.bin`: every robot's labelled decisions in
/// episode order) cut at its iterations' boundaries (`RUN/iterations.csv`'s `decisions`): entry
/// `i` holds the decision sequences iteration `i` collected.
pub fn stored_labels(run_dir: &Path) -> Result<Vec<Vec<Vec<Labelled>>>, TrainError> {
    let data: Vec<Vec<Labelled>> =
        harness::read_postcard(&run_dir.join("checkpoint").join("data.bin"))?;
    let log = run_dir.join("iterations.csv");
    let rows = read_rows(&log)?;
    let mut data = data.into_iter();
    let mut out = Vec::new();
    for row in &rows {
        let (mut seqs, mut n) = (Vec::new(), 0);
        while n < row.decisions {
            let Some(seq) = data.next() else { break };
            n += seq.len();
            seqs.push(seq);
        }
        if n != row.decisions {
            return Err(TrainError::Other(format!(
                "{}: iteration {} logs {} decisions but `checkpoint/data.bin` holds {n} there (a checkpoint and log of different runs?)",
                log.display(),
                row.iteration,
                row.decisions
            )));
        }
        out.push(seqs);
    }
    Ok(out)
}

/// The supervised half of a run alone: a fresh agnostic student of `sizes` (seeded, drawing its
/// batches and stepping as a run with `cfg` does) fitted to `train` for `updates` Adam steps,
/// measured against `test`'s labels after every `every` steps and at the end — does a larger or
/// differently trained student fit labels it never saw better? With `cfg`'s sizes and
/// `updates_per_iteration` as `updates`, `train` = a run's iteration 0 and `test` its iteration
/// 1, the last row is that run's `student_label_corr` of iteration 1 (for a run without
/// `fit_holdout`, whose iteration 0 fitted every label for every update). Rows: (updates so far,
/// mean loss since the last row, the fit).
pub fn refit(
    cfg: &RolloutTrainConfig,
    sizes: &crate::agnostic::AgnosticConfig,
    train: &[Vec<Labelled>],
    test: &[Labelled],
    updates: u64,
    every: u64,
) -> Result<Vec<(u64, f64, LabelFit)>, TrainError> {
    if train.is_empty() {
        return Err(TrainError::Other("refit: no training labels".into()));
    }
    if sizes.crop_radius != cfg.crop_radius {
        return Err(TrainError::Other(format!(
            "refit: field `crop_radius`: the labels' crops are of radius {}, not {}",
            cfg.crop_radius, sizes.crop_radius
        )));
    }
    if cfg.network != Network::Agnostic
        || sizes.wide() != cfg.wide_inputs
        || sizes.territory() != cfg.territory_inputs
        || sizes.plan() != cfg.plan_inputs
    {
        return Err(TrainError::Other(
            "refit: fields `network`/`wide_inputs`/`territory_inputs`/`plan_inputs`: the labels must be an agnostic run's, with the inputs `sizes` expects".into(),
        ));
    }
    let (mut net, mut optim) = fresh_student(cfg, Some(sizes))?;
    let (mut done, mut rows) = (0, Vec::new());
    while done < updates {
        let to = (done + every.max(1)).min(updates);
        let (next, loss) =
            fit(net, &mut optim, cfg, train, done..to, &|| false).expect("never stopped");
        net = next;
        rows.push((
            to,
            loss / (to - done) as f64,
            net.imitation(test.iter(), &cfg.spread_margins),
        ));
        done = to;
    }
    Ok(rows)
}

/// The validation set: maps and seeds of their own (`validation` stream), drawn as training
/// episodes are (sides up to `map_side_max`, teams up to `team_max`).
pub fn validation_maps(cfg: &RolloutTrainConfig) -> Result<Vec<TrialSpec>, TrainError> {
    (0..cfg.validation_maps as u64)
        .map(|m| episode_spec(cfg, "validation", m, cfg.map_side_max))
        .collect()
}

/// Counters of a run, checkpointed.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct State {
    iteration: u64,
    episodes: u64,
    updates: u64,
    best_validation: Option<f64>,
    wall_s: f64,
    /// Iterations in a row without a new best (the `patience` stop rule).
    #[serde(default)]
    since_best: u64,
    /// With expert iteration: the iteration (from 0) whose student the teacher's continuations
    /// follow (kept in `checkpoint/base/`); `None`: the base rule.
    #[serde(default)]
    teacher_base: Option<u64>,
}

/// What choosing by the labels, and by the scores `q` acting with each of `acting`'s margins
/// (`None`: greedy), gains at one labelled decision (agnostic inputs) over `spread`'s choice, in
/// label units; `None` when `spread`'s choice is not among the decision's trained candidates.
fn label_gains(l: &Labelled, q: &[f32], acting: &[Option<f32>]) -> Option<(f64, Vec<f64>)> {
    let slots = l.train_mask.len();
    let width = (l.vec.len() - CONTEXT_FEATURES) / slots.max(1);
    let anchor = crate::agnostic::spread_slot(&l.vec[CONTEXT_FEATURES..], width, &l.train_mask)?;
    let valid = || (0..slots).filter(|&k| l.train_mask[k]);
    let best = valid()
        .map(|k| l.target[k])
        .fold(f32::NEG_INFINITY, f32::max);
    let greedy = crate::actions::masked_argmax_slice(q, &l.train_mask)?;
    let over = |k: usize| (l.target[k] - l.target[anchor]) as f64;
    let students = acting
        .iter()
        .map(|&margin| over(crate::policy::conservative(q, greedy, margin, Some(anchor))))
        .collect();
    Some(((best - l.target[anchor]) as f64, students))
}

/// `net` with the weights of `cfg.init_model`, which [`crate::Model::load`] checks (digests, sizes,
/// NaN) and which must be an agnostic model of the run's sizes.
fn warm_start(cfg: &RolloutTrainConfig, net: Student) -> Result<Student, TrainError> {
    let dir = Path::new(&cfg.init_model);
    let bad = |why: String| TrainError::Config {
        path: dir.display().to_string(),
        message: format!("field `init_model`: {why}"),
    };
    let model = crate::Model::load(dir).map_err(|e| bad(e.to_string()))?;
    if model.info.agnostic.as_ref() != Some(&cfg.agnostic()) {
        return Err(bad(
            "not an agnostic model of this run's sizes (crop_radius, wide_inputs, territory_inputs, plan_inputs)".into(),
        ));
    }
    let weights = model
        .info
        .deps
        .first()
        .ok_or_else(|| bad("no weight file".into()))?;
    net.load(&dir.join(weights))
}

/// A fresh student on the seeded training device and its Adam optimizer, as every fit starts:
/// of `cfg`'s network, or agnostic of `sizes`.
fn fresh_student(
    cfg: &RolloutTrainConfig,
    sizes: Option<&crate::agnostic::AgnosticConfig>,
) -> Result<(Student, ModuleOptimizer), TrainError> {
    let device = cpu_autodiff();
    device.seed(cfg.seed);
    let net = match sizes {
        Some(sizes) => Student::Agnostic(sizes.init(&device).map_err(TrainError::Other)?),
        None => Student::init(cfg, &device)?,
    };
    let optim = AdamConfig::new()
        .with_grad_clipping(Some(GradientClippingConfig::Norm(cfg.grad_clip_norm)))
        .init();
    Ok((net, optim))
}

/// The rows of a run's `iterations.csv` at `log`; an unreadable row is an error naming the file.
fn read_rows(log: &Path) -> Result<Vec<IterationRow>, TrainError> {
    let io = |e: csv::Error| TrainError::Io {
        path: log.display().to_string(),
        message: e.to_string(),
    };
    csv::Reader::from_path(log)
        .map_err(io)?
        .deserialize()
        .collect::<Result<_, _>>()
        .map_err(io)
}

/// One row of `iterations.csv`.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct IterationRow {
    iteration: u64,
    episodes: u64,
    decisions: usize,
    rollouts: usize,
    behaviour_steps: f64,
    updates: u64,
    loss: f64,
    validation_steps: f64,
    #[serde(default)]
    greedy_steps: f64,
    #[serde(default)]
    spread_margin: Option<f32>,
    base_steps: f64,
    /// What the teacher's continuations followed: the base rule, or `student@K` (iteration K's).
    #[serde(default)]
    teacher_base: String,
    /// The teacher's mean gain over its base per labelled decision, steps (value of the base's
    /// own choice minus the best candidate's).
    #[serde(default)]
    teacher_gain: f64,
    /// The student's gain over the base rule on validation, % of the base rule's steps.
    #[serde(default)]
    student_gain_pct: f64,
    /// Share of this iteration's labelled decisions (valued alone) at which the base's own
    /// choice is among the teacher's best candidates.
    #[serde(default)]
    base_agreement: Option<f64>,
    /// The share for the greedy student as it entered the iteration, over every labelled
    /// decision (team-valued ones too; agnostic network only).
    #[serde(default)]
    student_agreement: Option<f64>,
    /// The correlation of that student's scores with the fresh labels' advantages (agnostic
    /// network): at most √`label_reliability` for a student that knew each candidate's
    /// expected value.
    #[serde(default)]
    student_label_corr: Option<f64>,
    /// The same for the `spread` rule's score (agnostic network): what a student that only
    /// copied `spread`'s ranking would reach.
    #[serde(default)]
    spread_label_corr: Option<f64>,
    /// With `teacher_check`: the share of decisions valued twice whose two valuations' best
    /// candidates agree ([`LabelCheck::self_agreement`]).
    #[serde(default)]
    teacher_self_agreement: Option<f64>,
    /// With `teacher_check`: the correlation of the two valuations' advantages
    /// ([`LabelCheck::reliability`]).
    #[serde(default)]
    label_reliability: Option<f64>,
    /// The updates this iteration's fit made (fewer than `updates_per_iteration` when the
    /// `fit_holdout` stopping rule ended it).
    #[serde(default)]
    fit_updates: Option<u64>,
    /// With `fit_holdout`: the kept student's correlation with the held-out labels.
    #[serde(default)]
    holdout_label_corr: Option<f64>,
    /// On this iteration's fresh labels, what the teacher's choice gains over `spread`'s per
    /// labelled decision ([`LabelFit::teacher_label_gain`], label units; agnostic network).
    #[serde(default)]
    teacher_label_gain: Option<f64>,
    /// The same for the student as it entered the iteration, acting with the margin of
    /// `spread_margins` (or greedy) that gains most there ([`LabelFit::best_gain`]).
    #[serde(default)]
    student_label_gain: Option<f64>,
    /// That margin (0: greedy, which margin 0 equals). Chosen on the labels it is reported on,
    /// so a little optimistic; the student's choice is among the candidates the teacher valued.
    #[serde(default)]
    student_gain_margin: Option<f32>,
    validation_completed: usize,
    validation_trials: usize,
    wall_s: f64,
}

fn model_info(
    cfg: &RolloutTrainConfig,
    state: &State,
    validation_steps: Option<f64>,
    spread_margin: Option<f32>,
) -> ModelInfo {
    ModelInfo {
        method: Method::MadeNetRollout,
        dep: (cfg.network == Network::Grid).then(|| NetConfigToml {
            map_height: cfg.map_height,
            map_width: cfg.map_width,
            team_size: cfg.scenario.num_robots,
            goal_count: cfg.goals(),
            concat_fc: false,
        }),
        agnostic: (cfg.network == Network::Agnostic).then(|| cfg.agnostic()),
        deps: vec!["dep0.bpk".into()],
        digests: Vec::new(), // filled in by `write_model_toml`
        episode: state.episodes,
        updates: state.updates,
        validation_steps,
        observation: cfg.observation,
        recurrent: cfg.recurrent,
        spread_margin,
    }
}

/// The stop rule: `patience` iterations in a row without a new best on validation.
fn out_of_patience(cfg: &RolloutTrainConfig, state: &State) -> bool {
    let stop = cfg.patience > 0 && state.since_best >= cfg.patience;
    if stop {
        tracing::info!(
            "stopping after iteration {}: no new best on validation for {} iterations (`patience`)",
            state.iteration,
            state.since_best
        );
    }
    stop
}

/// `max_minutes` ran out inside iteration `iteration` (counted from 0), whose work is dropped
/// (the checkpoint is at its start). After iterations of this call's own: a warning, the run
/// resumes from there. In the first of this call: an error — one iteration takes longer than the
/// budget, and resuming with it would drop the same iteration again.
fn time_ran_out(
    cfg: &RolloutTrainConfig,
    iteration: u64,
    first_iteration: u64,
) -> Result<(), TrainError> {
    if iteration == first_iteration && harness::stop_requested() {
        return Err(TrainError::Stopped);
    }
    if iteration == first_iteration {
        return Err(TrainError::Config {
            path: "--max-minutes".into(),
            message: format!(
                "{} min ran out inside iteration {} before it finished: nothing was trained in this call (one iteration takes longer); raise it, or 0 for no limit",
                cfg.max_minutes,
                iteration + 1
            ),
        });
    }
    let why = if harness::stop_requested() {
        "stopped on request"
    } else {
        "max_minutes ran out"
    };
    tracing::warn!(
        "{why} inside iteration {}: its work is dropped; --resume repeats it from the last checkpoint",
        iteration + 1
    );
    Ok(())
}

fn save_model(dir: &Path, net: &Student, info: &ModelInfo) -> Result<(), TrainError> {
    replace_dir(dir, |tmp| write_model(tmp, net, info))
}

/// A model folder (weights and `model.toml`) at `dir`, which must not be in use.
fn write_model(dir: &Path, net: &Student, info: &ModelInfo) -> Result<(), TrainError> {
    std::fs::create_dir_all(dir).map_err(|e| TrainError::Io {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    net.save(&dir.join("dep0.bpk"), true)?;
    harness::write_model_toml(dir, info)
}

/// Copies the files of folder `from` into a new folder `to`.
fn copy_dir(from: &Path, to: &Path) -> Result<(), TrainError> {
    let io = |p: &Path| {
        let p = p.display().to_string();
        move |e: std::io::Error| TrainError::Io {
            path: p,
            message: e.to_string(),
        }
    };
    std::fs::create_dir_all(to).map_err(io(to))?;
    for entry in std::fs::read_dir(from).map_err(io(from))? {
        let path = entry.map_err(io(from))?.path();
        if let Some(name) = path.file_name() {
            std::fs::copy(&path, to.join(name)).map_err(io(&path))?;
        }
    }
    Ok(())
}

/// The rollout teacher's learner as a [`Learner`] (`made-net-rollout`).
pub struct RolloutLearner;

impl Learner for RolloutLearner {
    type Config = RolloutTrainConfig;
    const METHODS: &'static [&'static str] = &[METHOD];
    /// The episodes per iteration define the run: a resume may change only `max_minutes`.
    const RESUME_EXTENDS_EPISODES: bool = false;
    const UNIT: &'static str = "iterations";

    fn parse_config(path: &Path, text: &str) -> Result<RolloutTrainConfig, TrainError> {
        RolloutTrainConfig::from_toml_text(path, text)
    }

    fn check(cfg: &RolloutTrainConfig) -> Result<(), String> {
        cfg.validate()
    }

    fn run_fields(cfg: &RolloutTrainConfig) -> RunFields {
        RunFields {
            episodes: cfg.episodes,
            max_minutes: cfg.max_minutes,
            seed: cfg.seed,
            threads: cfg.threads,
        }
    }

    fn set_run_fields(cfg: &mut RolloutTrainConfig, f: RunFields) {
        (cfg.episodes, cfg.max_minutes, cfg.seed, cfg.threads) =
            (f.episodes, f.max_minutes, f.seed, f.threads);
    }

    fn train_loop(
        run_dir: &Path,
        cfg: &RolloutTrainConfig,
        resuming: bool,
        progress: &mut (dyn FnMut(&Progress) + Send),
    ) -> Result<(), TrainError> {
        train_loop(run_dir, cfg, resuming, progress, &mut Collector::Local)
    }
}

/// Trains into `run_dir` ([`harness::train`]); `progress` is called after every iteration.
pub fn train(
    run_dir: &Path,
    cfg: Option<RolloutTrainConfig>,
    progress: &mut (dyn FnMut(&Progress) + Send),
) -> Result<(), TrainError> {
    harness::train::<RolloutLearner>(run_dir, cfg, progress)
}

/// [`train`] with the episodes collected by `collector`: the same run, episode for episode,
/// wherever they are collected.
pub fn train_with(
    run_dir: &Path,
    cfg: Option<RolloutTrainConfig>,
    progress: &mut (dyn FnMut(&Progress) + Send),
    collector: &mut Collector<'_>,
) -> Result<(), TrainError> {
    harness::train_with::<RolloutLearner>(run_dir, cfg, |dir, cfg, resuming| {
        train_loop(dir, cfg, resuming, progress, collector)
    })
}

fn train_loop(
    run_dir: &Path,
    cfg: &RolloutTrainConfig,
    resuming: bool,
    progress: &mut (dyn FnMut(&Progress) + Send),
    collector: &mut Collector<'_>,
) -> Result<(), TrainError> {
    let ckpt = run_dir.join("checkpoint");
    let (mut net, mut optim) = fresh_student(cfg, None)?;
    if !resuming && !cfg.init_model.is_empty() {
        net = warm_start(cfg, net)?;
    }
    let (mut state, mut data): (State, Vec<Vec<Labelled>>) = if resuming {
        let state = harness::read_json(&ckpt.join("state.json"))?;
        let data = harness::read_postcard(&ckpt.join("data.bin"))?;
        net = net.load(&ckpt.join("dep0.bpk"))?;
        let op = ckpt.join("optim.bpk");
        optim = optim.load(&op).map_err(|e| TrainError::Io {
            path: op.display().to_string(),
            message: e.to_string(),
        })?;
        (state, data)
    } else {
        (State::default(), Vec::new())
    };
    // The log keeps what the checkpoint has seen.
    let log_path = run_dir.join("iterations.csv");
    let mut rows: Vec<IterationRow> = if resuming && log_path.exists() {
        let mut rows = read_rows(&log_path)?;
        rows.retain(|r| r.iteration < state.iteration);
        rows
    } else {
        Vec::new()
    };
    // TensorBoard scalars (`iteration/*`, step = iteration), cut to the checkpoint as the CSV is.
    let seen = state.iteration as i64;
    let mut scalars = harness::Scalars::open(run_dir, |_, step| step < seen)?;
    // The base rule on the validation set: the line to beat.
    let base_registry = PolicyRegistry::builtin();
    let validation_maps = validation_maps(cfg)?;
    let base_steps = validate(
        &validation_maps,
        &cfg.validation_csp,
        &base_registry,
        &cfg.base_policy,
    )?
    .mean_steps;
    let clock = Clock::start(state.wall_s);
    let first_iteration = state.iteration;
    while state.iteration < cfg.iterations && !out_of_patience(cfg, &state) {
        // 1–3. Collect and label this iteration's episodes (behaviour: base rule, then the
        // student; the teacher's base: the base rule, with expert iteration the best student so
        // far, with policy iteration the greedy student that behaves), the models passed as
        // files' bytes so a worker elsewhere acts the same.
        let student = match state.iteration {
            0 => None,
            _ => {
                let dir = run_dir.join(".behaviour");
                save_model(&dir, &net, &model_info(cfg, &state, None, None))?;
                Some(ModelBytes::read(&dir)?)
            }
        };
        let (base, teacher_base) = match (state.teacher_base, &student) {
            (_, Some(current)) if cfg.policy_iteration => (
                Some(current.clone()),
                format!("greedy student@{}", state.iteration - 1),
            ),
            (Some(k), _) => (
                Some(ModelBytes::read(&ckpt.join("base"))?),
                format!("student@{k}"),
            ),
            (None, _) => (None, cfg.base_policy.clone()),
        };
        let per = cfg.episodes_per_iteration();
        let first = state.iteration * per;
        let side_max = cfg.side_max_at(state.iteration);
        // The time budget holds inside an iteration too: an episode not started in time is
        // skipped, and an iteration cut short is dropped whole (the checkpoint is at its start,
        // so `--resume` repeats it exactly).
        let request = CollectRequest {
            version: env!("CARGO_PKG_VERSION").into(),
            episodes: (first..first + per).collect(),
            side_max,
            student,
            base,
        };
        let Some(collected) =
            collector.collect(cfg, &request, &|| clock.out_of_time(cfg.max_minutes))?
        else {
            return time_ran_out(cfg, state.iteration, first_iteration);
        };
        let decisions: usize = collected
            .iter()
            .map(|c| c.robots.iter().map(Vec::len).sum::<usize>())
            .sum();
        let rollouts: usize = collected.iter().map(|c| c.rollouts).sum();
        let labelled: usize = collected.iter().map(|c| c.labelled).sum();
        let teacher_gain =
            collected.iter().map(|c| c.teacher_gain).sum::<f64>() / labelled.max(1) as f64;
        let behaviour_steps =
            collected.iter().map(|c| c.steps as f64).sum::<f64>() / collected.len().max(1) as f64;
        // Imitation: how often the base's choice, and the student's (as trained so far), is
        // among the teacher's best candidates on this iteration's fresh labels.
        let (valued, agree) = collected.iter().fold((0, 0), |(n, a), c| {
            (n + c.base_agreement.0, a + c.base_agreement.1)
        });
        let base_agreement = (valued > 0).then(|| agree as f64 / valued as f64);
        let imitation = net.imitation(
            collected.iter().flat_map(|c| c.robots.iter().flatten()),
            &cfg.spread_margins,
        );
        let best_gain = imitation.best_gain();
        let check = collected.iter().fold(LabelCheck::default(), |mut all, c| {
            all.merge(&c.check);
            all
        });
        let before = data.len();
        data.extend(
            collected
                .into_iter()
                .flat_map(|c| c.robots)
                .filter(|s| !s.is_empty()),
        );
        // With policy iteration only this iteration's labels are fitted.
        let fresh = if cfg.policy_iteration { before } else { 0 };
        // The stopping rule's held-out sequences: the last `fit_holdout` of the new ones.
        let fitted = data.len() - ((data.len() - before) as f64 * cfg.fit_holdout) as usize;
        if data[fresh..].is_empty() {
            let when = if cfg.policy_iteration {
                "in this iteration's episodes (policy_iteration fits only them)"
            } else {
                "in any training episode so far"
            };
            return Err(TrainError::Other(format!(
                "no robot decided {when} (are the maps seen whole from the start?)"
            )));
        }
        state.episodes += per;
        // 4. Regress the advantages on windows of the robots' decision sequences.
        let Some(done) = fit_checked(
            net,
            &mut optim,
            cfg,
            (&data[fresh..fitted], &data[fitted..]),
            state.updates,
            &|| clock.out_of_time(cfg.max_minutes),
        ) else {
            return time_ran_out(cfg, state.iteration, first_iteration);
        };
        net = done.net;
        state.updates += done.updates;
        state.iteration += 1;
        // 5. Validate the greedy DEP and each conservative margin; keep the best.
        let mut tried = Vec::new();
        for margin in std::iter::once(None).chain(cfg.spread_margins.iter().copied().map(Some)) {
            let model = net.model(model_info(cfg, &state, None, margin));
            let mut registry = PolicyRegistry::default();
            model.register(&mut registry, "candidate", "the DEP being trained");
            let v = validate(
                &validation_maps,
                &cfg.validation_csp,
                &registry,
                "candidate",
            )?;
            let (steps, completed, trials) = (v.mean_steps, v.completed, v.trials);
            tried.push((margin, steps, completed, trials));
        }
        let (margin, steps, completed, trials) = tried
            .iter()
            .copied()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("the greedy DEP is tried");
        let greedy_steps = tried[0].1;
        let best_info = model_info(cfg, &state, Some(steps), margin);
        let mut base_changed = false;
        if harness::new_best(&mut state.best_validation, steps) {
            save_model(&run_dir.join("best"), &net, &best_info)?;
            state.since_best = 0;
            // Expert iteration: a student that beats the base rule becomes the teacher's base.
            if cfg.expert_iteration && steps < base_steps {
                state.teacher_base = Some(state.iteration - 1);
                base_changed = true;
            }
        } else {
            state.since_best += 1;
        }
        state.wall_s = clock.wall();
        rows.push(IterationRow {
            iteration: state.iteration - 1,
            episodes: state.episodes,
            decisions,
            rollouts,
            behaviour_steps,
            updates: state.updates,
            loss: done.loss_sum / done.updates.max(1) as f64,
            validation_steps: steps,
            greedy_steps,
            spread_margin: margin,
            base_steps,
            teacher_base,
            teacher_gain,
            student_gain_pct: 100.0 * (base_steps - steps) / base_steps.max(1e-9),
            base_agreement,
            student_agreement: imitation.agreement,
            student_label_corr: imitation.label_corr,
            spread_label_corr: imitation.spread_label_corr,
            teacher_self_agreement: check.self_agreement(),
            label_reliability: check.reliability(),
            fit_updates: Some(done.updates),
            holdout_label_corr: done.holdout_corr,
            teacher_label_gain: imitation.teacher_label_gain,
            student_label_gain: best_gain.map(|g| g.1),
            student_gain_margin: best_gain.map(|g| g.0.unwrap_or(0.0)),
            validation_completed: completed,
            validation_trials: trials,
            wall_s: state.wall_s,
        });
        let mut w = csv::Writer::from_writer(Vec::new());
        for r in &rows {
            w.serialize(r)
                .map_err(|e| TrainError::Other(e.to_string()))?;
        }
        write_atomic(
            &log_path,
            &w.into_inner()
                .map_err(|e| TrainError::Other(e.to_string()))?,
        )?;
        let r = rows.last().expect("just pushed");
        for (tag, value) in [
            ("iteration/loss", r.loss),
            ("iteration/validation_steps", r.validation_steps),
            ("iteration/greedy_steps", r.greedy_steps),
            ("iteration/base_steps", r.base_steps),
            ("iteration/behaviour_steps", r.behaviour_steps),
            ("iteration/decisions", r.decisions as f64),
            ("iteration/teacher_gain", r.teacher_gain),
            ("iteration/student_gain_pct", r.student_gain_pct),
        ] {
            scalars.scalar(tag, value as f32, r.iteration)?;
        }
        scalars.flush()?;
        // Checkpoint: counters, dataset, net, optimizer, the teacher's base student.
        replace_dir(&ckpt, |tmp| {
            if base_changed {
                write_model(&tmp.join("base"), &net, &best_info)?;
            } else if state.teacher_base.is_some() {
                copy_dir(&ckpt.join("base"), &tmp.join("base"))?;
            }
            harness::write_postcard(&tmp.join("data.bin"), &data)?;
            net.save(&tmp.join("dep0.bpk"), false)?;
            let p = tmp.join("optim.bpk");
            optim.save(&p).map_err(|e| TrainError::Io {
                path: p.display().to_string(),
                message: e.to_string(),
            })?;
            harness::write_json(&tmp.join("state.json"), &state)
        })?;
        save_model(
            &run_dir.join("last"),
            &net,
            &model_info(cfg, &state, Some(steps), margin),
        )?;
        progress(&Progress {
            done: state.iteration,
            total: cfg.iterations,
            unit: RolloutLearner::UNIT,
            updates: state.updates,
            validation_steps: Some(steps),
            base_steps: Some(base_steps),
            figures: vec![
                ("episodes", state.episodes as f64, 0),
                ("decisions", decisions as f64, 0),
                ("loss", r.loss, 4),
                ("teacher gain", r.teacher_gain, 2),
            ],
        });
        if clock.out_of_time(cfg.max_minutes) {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `spread_label_corr` reads `spread`'s score (and negates it: lower is better there): spread
    /// scores 0.1, 0.2, 0.3 against advantages 1, 0, −1 correlate exactly 1, while `spread`'s
    /// choice flag (1, 0, 0 here) would correlate only 0.87; the empty slot 3 is not counted.
    #[test]
    fn spread_label_corr_reads_the_spread_score_negated() {
        let cfg = RolloutTrainConfig {
            network: Network::Agnostic,
            ..RolloutTrainConfig::default()
        };
        let net = Student::init(&cfg, &crate::cpu_autodiff()).unwrap();
        let (slots, s) = (4, cfg.agnostic().crop_side());
        let mut vec = vec![0.0f32; CONTEXT_FEATURES + slots * crate::agnostic::CANDIDATE_INPUTS];
        for (k, score) in [0.1f32, 0.2, 0.3].into_iter().enumerate() {
            let f = &mut vec[CONTEXT_FEATURES + k * crate::agnostic::CANDIDATE_INPUTS..];
            f[AgentView::SPREAD_SCORE_FEATURE] = score;
            f[AgentView::SPREAD_CHOICE_FEATURE] = (k == 0) as u8 as f32;
        }
        let l = Labelled {
            map: vec![0; (slots * crate::agnostic::CROP_CHANNELS * s * s).div_ceil(64)],
            vec,
            train_mask: vec![true, true, true, false],
            target: vec![1.0, 0.0, -1.0, 0.0],
        };
        let fit = net.imitation(std::iter::once(&l), &[0.5]);
        assert!(
            (fit.spread_label_corr.unwrap() - 1.0).abs() < 1e-9,
            "{fit:?}"
        );
        assert!(fit.label_corr.is_some_and(|c| (-1.0..=1.0).contains(&c)));
        // `spread` chose the best candidate here: nothing to gain, whatever the student does.
        assert_eq!(fit.teacher_label_gain, Some(0.0));
        assert_eq!(fit.student_gains.len(), 2);
        assert!(fit.student_gains.iter().all(|g| g.1 <= 0.0), "{fit:?}");
    }

    /// `label_norm = "side"` scales an episode's advantages by `map_height` / its side and
    /// changes nothing else: the same decisions, valid slots and (scaled) values.
    #[test]
    fn side_label_norm_scales_a_larger_maps_labels_by_its_side() {
        let plain = RolloutTrainConfig {
            network: Network::Agnostic,
            map_side_max: 30,
            label_prob: 0.3,
            ..RolloutTrainConfig::default()
        };
        let side = |e: u64| episode_spec(&plain, "train", e, 30).unwrap().map.height();
        let e = (0..50).find(|&e| side(e) >= 26).unwrap();
        let req = CollectRequest {
            version: env!("CARGO_PKG_VERSION").into(),
            episodes: vec![e],
            side_max: 30,
            student: None,
            base: None,
        };
        let normed = RolloutTrainConfig {
            label_norm: LabelNorm::Side,
            ..plain.clone()
        };
        let run = |cfg: &RolloutTrainConfig| collect(cfg, &req, &|| false).unwrap().unwrap();
        let (a, b) = (run(&plain), run(&normed));
        let factor = 20.0 / side(e) as f32;
        let (mut nonzero, mut decisions) = (0, 0);
        for (ra, rb) in a[0].robots.iter().zip(&b[0].robots) {
            assert_eq!(ra.len(), rb.len());
            for (la, lb) in ra.iter().zip(rb) {
                assert_eq!((&la.vec, &la.train_mask), (&lb.vec, &lb.train_mask));
                for (ta, tb) in la.target.iter().zip(&lb.target) {
                    // One rounding apart: `label_scale` and the factor are multiplied first.
                    assert!((*tb - *ta * factor).abs() <= 1e-6 * ta.abs(), "{ta} {tb}");
                    nonzero += (*ta != 0.0) as usize;
                }
                decisions += 1;
            }
        }
        assert!(decisions > 0 && nonzero > 0, "{decisions} {nonzero}");
    }

    /// The label gains by hand: `spread` chose slot 0, the labels prefer slot 1, the scores
    /// slot 2; the student's choice follows its margin.
    #[test]
    fn label_gains_follow_the_margin_by_hand() {
        let slots = 4;
        let width = crate::agnostic::CANDIDATE_INPUTS;
        let mut vec = vec![0.0f32; CONTEXT_FEATURES + slots * width];
        vec[CONTEXT_FEATURES + AgentView::SPREAD_CHOICE_FEATURE] = 1.0;
        let l = Labelled {
            map: Vec::new(),
            vec,
            train_mask: vec![true, true, true, false],
            target: vec![0.0, 1.0, -0.5, 0.0],
        };
        // Slot 3 scores highest but is not a candidate.
        let q = [0.0, 0.3, 1.0, 9.0];
        let (teacher, students) = label_gains(&l, &q, &[None, Some(0.5), Some(2.0)]).unwrap();
        assert_eq!(teacher, 1.0);
        // Greedy and margin 0.5 take slot 2 (−0.5 against spread's 0); margin 2 keeps spread's.
        assert_eq!(students, vec![-0.5, -0.5, 0.0]);
        // Without `spread`'s choice among the candidates there is nothing to compare with.
        let mut alone = l.clone();
        alone.train_mask[0] = false;
        assert!(label_gains(&alone, &q, &[None]).is_none());
    }

    /// Decisions whose advantages are a learnable function of one candidate input (its spread
    /// score, centred), drawn from `seed`.
    fn learnable(cfg: &RolloutTrainConfig, n: usize, seed: u64) -> Vec<Vec<Labelled>> {
        let mut rng = stream(seed, "test-labels", 0);
        let (slots, side) = (3, cfg.agnostic().crop_side());
        let width = crate::agnostic::CANDIDATE_INPUTS;
        (0..n)
            .map(|_| {
                let mut vec = vec![0.0f32; CONTEXT_FEATURES + slots * width];
                let x: Vec<f32> = (0..slots).map(|_| rng.random::<f32>()).collect();
                for (k, &v) in x.iter().enumerate() {
                    vec[CONTEXT_FEATURES + k * width + AgentView::SPREAD_SCORE_FEATURE] = v;
                }
                let mean = x.iter().sum::<f32>() / slots as f32;
                vec![Labelled {
                    map: vec![
                        0;
                        (slots * crate::agnostic::CROP_CHANNELS * side * side).div_ceil(64)
                    ],
                    vec,
                    train_mask: vec![true; slots],
                    target: x.iter().map(|v| mean - v).collect(),
                }]
            })
            .collect()
    }

    /// The stopping rule keeps the student it scored best on the held-out labels (its score is
    /// the one reported), makes whole rounds (or every update), and without held-out labels
    /// fits exactly as many updates as configured.
    #[test]
    fn the_fit_stopping_rule_keeps_the_best_held_out_student() {
        let cfg = RolloutTrainConfig {
            network: Network::Agnostic,
            updates_per_iteration: 40,
            fit_check_every: 4,
            fit_patience: 1,
            batch_size: 8,
            ..RolloutTrainConfig::default()
        };
        let (train, held_out) = (learnable(&cfg, 60, 1), learnable(&cfg, 30, 2));
        let (start, _) = fresh_student(&cfg, None).unwrap();
        let fresh = || start.clone();
        let adam = || -> ModuleOptimizer { AdamConfig::new().init() };
        let done = fit_checked(fresh(), &mut adam(), &cfg, (&train, &held_out), 0, &|| {
            false
        })
        .unwrap();
        assert!(
            done.updates <= 40 && done.updates.is_multiple_of(4),
            "{}",
            done.updates
        );
        let kept = done
            .net
            .imitation(held_out.iter().flatten(), &[])
            .label_corr;
        assert_eq!(kept, done.holdout_corr);
        // Learnable labels: the kept student ranks held-out candidates as the labels do.
        assert!(kept.unwrap() > 0.0, "{kept:?}");
        // The rule's rounds replayed: the kept score is the best of the rounds made, and the
        // fit ended `fit_patience` rounds after it (or at the end).
        let (mut net, mut optim, mut scores) = (fresh(), adam(), Vec::new());
        for r in 0..done.updates / 4 {
            net = fit(net, &mut optim, &cfg, &train, r * 4..r * 4 + 4, &|| false)
                .unwrap()
                .0;
            scores.push(
                net.imitation(held_out.iter().flatten(), &[])
                    .label_corr
                    .unwrap(),
            );
        }
        let best = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(Some(best), done.holdout_corr);
        let at = scores.iter().position(|&s| s == best).unwrap();
        assert!(
            at + 1 == scores.len() - 1 || done.updates == 40,
            "{scores:?}"
        );
        let plain = fit_checked(fresh(), &mut adam(), &cfg, (&train, &[]), 0, &|| false).unwrap();
        assert_eq!((plain.updates, plain.holdout_corr), (40, None));
    }

    /// The labels' check by hand: advantages (1, 0, −1) and (1, −1, 0) correlate 0.5; the
    /// first valuation's best (slot 0) is the second's best too; a decision without a valued
    /// candidate is not counted.
    #[test]
    fn label_check_agreement_and_reliability_by_hand() {
        let mut c = LabelCheck::default();
        c.add(
            &[Some(1.0), Some(2.0), Some(3.0), None],
            &[Some(1.0), Some(3.0), Some(2.0), None],
        );
        assert_eq!((c.decisions, c.agree), (1, 1));
        assert!((c.reliability().unwrap() - 0.5).abs() < 1e-12, "{c:?}");
        // A second decision whose best moves: agreement 1 of 2.
        let mut d = LabelCheck::default();
        d.add(&[Some(1.0), Some(2.0)], &[Some(2.0), Some(1.0)]);
        d.add(&[None, None], &[None, None]);
        assert_eq!((d.decisions, d.agree), (1, 0));
        c.merge(&d);
        assert_eq!(c.self_agreement(), Some(0.5));
        assert_eq!(LabelCheck::default().reliability(), None);
    }

    /// The team teacher's step: the lowest value wins; a tie keeps the robot's current choice,
    /// else goes to the lower slot; no valid candidate, no choice.
    #[test]
    fn best_candidate_keeps_the_current_choice_on_ties() {
        let c = Decision::Candidate;
        let v = [Some(3.0), None, Some(2.0), Some(2.0)];
        assert_eq!(best_candidate(&v, Some(c(0))), Some(c(2)));
        assert_eq!(best_candidate(&v, Some(c(3))), Some(c(3)));
        assert_eq!(best_candidate(&v, None), Some(c(2)));
        assert_eq!(best_candidate(&[None, None], Some(c(1))), None);
    }

    fn rows(v: &[f32], rows: usize) -> Tensor<2> {
        let cols = v.len() / rows;
        Tensor::<2>::from_data(TensorData::new(v.to_vec(), [rows, cols]), &crate::cpu())
    }

    fn value(t: Tensor<1>) -> f32 {
        t.into_data().try_to_vec::<f32>().unwrap()[0]
    }

    /// The listwise loss is lowest where the scores are the labels (up to a shift per row),
    /// ignores untrained slots and rows without any, and equals the cross-entropy by hand.
    #[test]
    fn listwise_loss_ranks_over_trained_slots_only() {
        let tau = 0.5;
        let y = [
            1.0, 0.0, -1.0, 0.0, /* row 2: */ 0.0, 0.5, 0.0, 0.0, /* row 3: */ 0.0, 0.0,
            0.0, 0.0,
        ];
        let m = [1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let loss = |q: &[f32]| value(listwise_loss(rows(q, 3), rows(&y, 3), rows(&m, 3), tau));
        let exact = loss(&[1.0, 0.0, -1.0, 7.0, 3.0, 2.5, 2.0, -9.0, 5.0, 1.0, 2.0, 3.0]);
        // Row 1: softmax of (2, 0, −2); row 2: of (1, 0) over its two trained slots.
        let ce = |z: &[f32]| {
            let s: f32 = z.iter().map(|x| x.exp()).sum();
            -z.iter().map(|x| (x.exp() / s) * (x - s.ln())).sum::<f32>()
        };
        let by_hand = (ce(&[2.0, 0.0, -2.0]) + ce(&[1.0, 0.0])) / 2.0;
        assert!((exact - by_hand).abs() < 1e-4, "{exact} vs {by_hand}");
        let wrong = loss(&[-1.0, 0.0, 1.0, 7.0, 3.0, 2.0, 2.5, -9.0, 5.0, 1.0, 2.0, 3.0]);
        assert!(wrong > exact + 0.5, "{wrong} vs {exact}");
        let flat = loss(&[0.0; 12]);
        assert!(flat > exact, "{flat} vs {exact}");
    }
}
