//! Steps 1–3 of an iteration: the scenarios, the behaviour that plays them (the base rule, then
//! the student, ε-random), and the teachers that label each decision with a choice — the
//! rollout teacher (continuations of the base rule from the very state) and the plan teacher
//! (the known-map reference's team plan on redrawn maps).

use super::config::*;
use crate::episode::{self, Recorder};
use crate::error::TrainError;
use crate::model::Model;
use crate::obs::{action_mask, pack_bits};
use crate::scenario::ScenarioDraw;
use madenet_agent::{AgentView, Decision, Policy};
use madenet_baselines::rollout::{candidate_values_by, plan_values, Lookahead};
use madenet_sim::{Future, PolicyRegistry, Trial, TrialSpec};
use madenet_world::rng::{derive_seed, stream, Rng};
use madenet_world::ScenarioConfig;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// The map distribution of the run's `height` × `width` episodes with `team` robots.
pub(super) fn scenario_draw(
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
pub(super) fn episode_spec(
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
pub(super) struct Behaviour {
    pub(super) inner: Box<dyn Policy>,
    pub(super) epsilon: f64,
    pub(super) rng: Rng,
}

impl Policy for Behaviour {
    fn name(&self) -> &str {
        "behaviour"
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
    /// ([`crate::agnostic::AgnosticInput::crops`]). Bit-packed.
    pub map: Vec<u64>,
    /// Grid network: the observation vector; agnostic network: the context followed by the
    /// candidate inputs ([`crate::agnostic::AgnosticInput`]).
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
/// the per-iteration diagnostics of `iterations.csv`, and [`super::refit`]'s curve.
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
    /// decisions of the advantage of the choice it makes (`policy::conservative`) less
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
    pub(super) fn add(&mut self, a: f64, b: f64) {
        for (sum, x) in self.sums.iter_mut().zip([1.0, a, b, a * a, b * b, a * b]) {
            *sum += x;
        }
    }

    pub(super) fn merge(&mut self, other: &Correlation) {
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
    pub(super) fn add(&mut self, first: &[Option<f64>], second: &[Option<f64>]) {
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
    pub(super) fn merge(&mut self, other: &LabelCheck) {
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
pub(super) fn min_value(values: &[Option<f64>]) -> Option<f64> {
    values.iter().flatten().copied().reduce(f64::min)
}

/// The mean of `values`' valued candidates.
pub(super) fn mean_value(values: &[Option<f64>]) -> f64 {
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
pub(super) struct Labelling<'a> {
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
pub(super) enum FutureSet {
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
pub(super) fn best_candidate(
    values: &[Option<f64>],
    current: Option<Decision>,
) -> Option<Decision> {
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
                        cfg.observation.vector(&mut view),
                        action_mask(&view),
                    ),
                    Network::Agnostic => {
                        let x = crate::agnostic::inputs_for(&mut view, &cfg.agnostic());
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
pub(super) fn label_scale(cfg: &RolloutTrainConfig, height: usize, width: usize) -> f32 {
    match cfg.label_norm {
        LabelNorm::None => cfg.label_scale,
        LabelNorm::Side => cfg.label_scale * cfg.map_height as f32 / height.max(width) as f32,
    }
}

/// Runs training episode `index` under `behaviour` (a registry holding policy "behaviour") and
/// labels every decision with a choice.
pub(super) fn collect_episode(
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
