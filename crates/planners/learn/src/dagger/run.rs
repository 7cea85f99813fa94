//! The loop: iterations of collect → fit → validate, the run's counters and logs
//! (`iterations.csv`), best/last models, checkpoints and resume, and the [`Learner`] contract.

use super::{collector::*, config::*, student::*, teacher::*};
use crate::error::{write_atomic, TrainError};
use crate::harness::{self, replace_dir, Clock, Learner, Progress, TrainRun};
use crate::model::{Method, Model, ModelInfo, NetConfigToml};
use crate::scenario::validate;
use madenet_sim::{PolicyRegistry, TrialSpec};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The validation set: maps and seeds of their own (`validation` stream), drawn as training
/// episodes are (sides up to `map_side_max`, teams up to `team_max`).
pub fn validation_maps(cfg: &RolloutTrainConfig) -> Result<Vec<TrialSpec>, TrainError> {
    (0..cfg.validation_maps as u64)
        .map(|m| episode_spec(cfg, "validation", m, cfg.map_side_max))
        .collect()
}

/// Counters of a run, checkpointed.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub(super) struct State {
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

/// The rows of a run's `iterations.csv` at `log`; an unreadable row is an error naming the file.
pub(super) fn read_rows(log: &Path) -> Result<Vec<IterationRow>, TrainError> {
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
pub(super) struct IterationRow {
    pub(super) iteration: u64,
    pub(super) episodes: u64,
    pub(super) decisions: usize,
    pub(super) rollouts: usize,
    pub(super) behaviour_steps: f64,
    pub(super) updates: u64,
    pub(super) loss: f64,
    pub(super) validation_steps: f64,
    #[serde(default)]
    pub(super) greedy_steps: f64,
    #[serde(default)]
    pub(super) spread_margin: Option<f32>,
    pub(super) base_steps: f64,
    /// What the teacher's continuations followed: the base rule, or `student@K` (iteration K's).
    #[serde(default)]
    pub(super) teacher_base: String,
    /// The teacher's mean gain over its base per labelled decision, steps (value of the base's
    /// own choice minus the best candidate's).
    #[serde(default)]
    pub(super) teacher_gain: f64,
    /// The student's gain over the base rule on validation, % of the base rule's steps.
    #[serde(default)]
    pub(super) student_gain_pct: f64,
    /// Share of this iteration's labelled decisions (valued alone) at which the base's own
    /// choice is among the teacher's best candidates.
    #[serde(default)]
    pub(super) base_agreement: Option<f64>,
    /// The share for the greedy student as it entered the iteration, over every labelled
    /// decision (team-valued ones too; agnostic network only).
    #[serde(default)]
    pub(super) student_agreement: Option<f64>,
    /// The correlation of that student's scores with the fresh labels' advantages (agnostic
    /// network): at most √`label_reliability` for a student that knew each candidate's
    /// expected value.
    #[serde(default)]
    pub(super) student_label_corr: Option<f64>,
    /// The same for the `spread` rule's score (agnostic network): what a student that only
    /// copied `spread`'s ranking would reach.
    #[serde(default)]
    pub(super) spread_label_corr: Option<f64>,
    /// With `teacher_check`: the share of decisions valued twice whose two valuations' best
    /// candidates agree ([`LabelCheck::self_agreement`]).
    #[serde(default)]
    pub(super) teacher_self_agreement: Option<f64>,
    /// With `teacher_check`: the correlation of the two valuations' advantages
    /// ([`LabelCheck::reliability`]).
    #[serde(default)]
    pub(super) label_reliability: Option<f64>,
    /// The updates this iteration's fit made (fewer than `updates_per_iteration` when the
    /// `fit_holdout` stopping rule ended it).
    #[serde(default)]
    pub(super) fit_updates: Option<u64>,
    /// With `fit_holdout`: the kept student's correlation with the held-out labels.
    #[serde(default)]
    pub(super) holdout_label_corr: Option<f64>,
    /// On this iteration's fresh labels, what the teacher's choice gains over `spread`'s per
    /// labelled decision ([`LabelFit::teacher_label_gain`], label units; agnostic network).
    #[serde(default)]
    pub(super) teacher_label_gain: Option<f64>,
    /// The same for the student as it entered the iteration, acting with the margin of
    /// `spread_margins` (or greedy) that gains most there ([`LabelFit::best_gain`]).
    #[serde(default)]
    pub(super) student_label_gain: Option<f64>,
    /// That margin (0: greedy, which margin 0 equals). Chosen on the labels it is reported on,
    /// so a little optimistic; the student's choice is among the candidates the teacher valued.
    #[serde(default)]
    pub(super) student_gain_margin: Option<f32>,
    pub(super) validation_completed: usize,
    pub(super) validation_trials: usize,
    pub(super) wall_s: f64,
}

pub(super) fn model_info(
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
pub(super) fn out_of_patience(cfg: &RolloutTrainConfig, state: &State) -> bool {
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
pub(super) fn time_ran_out(
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

pub(super) fn save_model(dir: &Path, net: &Student, info: &ModelInfo) -> Result<(), TrainError> {
    replace_dir(dir, |tmp| write_model(tmp, net, info))
}

/// A model folder (weights and `model.toml`) at `dir`, which must not be in use.
pub(super) fn write_model(dir: &Path, net: &Student, info: &ModelInfo) -> Result<(), TrainError> {
    std::fs::create_dir_all(dir).map_err(|e| TrainError::Io {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    net.save(&dir.join("dep0.bpk"), true)?;
    harness::write_model_toml(dir, info)
}

/// Copies the files of folder `from` into a new folder `to`.
pub(super) fn copy_dir(from: &Path, to: &Path) -> Result<(), TrainError> {
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

    crate::learner_config!(model = Model);

    fn train_loop(run: TrainRun<'_, RolloutTrainConfig>) -> Result<(), TrainError> {
        train_loop(run, &mut Collector::Local)
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
        let run = TrainRun {
            dir,
            cfg,
            resuming,
            progress,
        };
        train_loop(run, collector)
    })
}

pub(super) fn train_loop(
    run: TrainRun<'_, RolloutTrainConfig>,
    collector: &mut Collector<'_>,
) -> Result<(), TrainError> {
    let (run_dir, cfg, resuming, progress) = (run.dir, run.cfg, run.resuming, run.progress);
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
