//! The learner's one config ([`RolloutTrainConfig`]): every knob with its default, and its
//! validation (each refusal names the field).

use crate::harness::{self};
use crate::model::Method;
use crate::obs::Observation;
use crate::NetConfig;
use madenet_agent::DecisionMode;
use madenet_baselines::rollout::Value;
use madenet_sim::PolicyRegistry;
use madenet_world::ScenarioConfig;
use serde::{Deserialize, Serialize};

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
    /// The team plan ([`madenet_baselines::rollout::plan_values`]): over `rollouts` redrawn futures
    /// (`futures = "redrawn"`), the known-map reference plans the whole team's routes from where
    /// it stands, and a candidate is valued by its moves to the robot's first viewpoint — a
    /// team-wide, multi-step teacher; no base rule enters the values.
    Plan,
}

/// Which DEP network the teacher trains ([`RolloutTrainConfig::network`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Network {
    /// The paper's DEP ([`crate::QNet`]): one map size, team size and |G|.
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
    /// corridors) instead of clutter ([`crate::scenario::ScenarioDraw::floorplan_prob`]).
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
    /// the trial's exploration rate so far, [`madenet_baselines::rollout::Value::StepsLeft`]; with
    /// `mean-discovery` the cells still unknown count the horizon); 0: run to the end.
    pub horizon: usize,
    /// What a continuation's value measures ([`madenet_baselines::rollout::Value`]): `steps-left`
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
    /// ([`super::LabelFit::label_corr`]), and the fit stops after `fit_patience` checks without a
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
    /// `spread` rule's only when valued higher by this much, in label units; [`crate::Model`]'s
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
    crate::toml_config_readers!();

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
    pub(super) fn side_max_at(&self, iteration: u64) -> usize {
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

    pub(super) fn net_config(&self) -> NetConfig {
        let (team, goals) = (self.scenario.num_robots, self.goals());
        NetConfig {
            obs_dim: self.observation.dim(team, goals),
            ..NetConfig::dep(self.map_height, self.map_width, team, goals)
        }
    }

    pub(super) fn episodes_per_iteration(&self) -> u64 {
        self.episodes / self.iterations
    }
}
