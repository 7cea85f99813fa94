//! The training loop of MADE-Net (and MADE-Net-DT), CleanRL-style: one function,
//! [`train`], reads top to bottom — build nets, then per iteration: an episode in each
//! environment, replay, updates, target sync, logs, validation, checkpoint. Every
//! hyperparameter is a field of [`TrainConfig`] with the paper's value, or MacDec-DDRQN's
//! default, or ours (and why) beside it.
//!
//! # Randomness and resume
//!
//! Every random draw comes from a named stream derived from `seed` and a counter (the
//! iteration for maps, starts, CSP and actors; the update for batch sampling), and the nets are
//! initialised right after seeding burn's device. A checkpoint therefore needs only the
//! counters, the nets, the optimizers and the replay buffers: a run resumed from it continues
//! exactly as if it had not stopped (tested).
//!
//! # Run directory
//!
//! ```text
//! config.toml            the resolved configuration (a resume reads it back)
//! episodes.csv           one row per training episode (see `madenet-trainlog`)
//! validation.csv         one row per validation
//! updates.csv            update, cep_loss, dep_loss
//! events.out.tfevents.*  the same scalars for TensorBoard
//! checkpoint/            latest state: state.json, nets, optimizers, replay.bin
//! best/                  the weights with the best validation (fewest mean steps): model.toml + *.bpk
//! ```

use crate::env::{run_episode, Actor, ActorNets, EnvKind, Episode};
use crate::error::TrainError;
use crate::harness::{self, replace_dir, EpisodeRun, Learner, Progress, Seen, TrainRun};
use crate::learner::{cep_update, dep_update, target_of, RobotWindow, UpdateParams, Window};
use crate::model::{Method, Model, ModelInfo, NetConfigToml};
use crate::obs::Observation;
use crate::scenario::{validate, ScenarioDraw};
use crate::{cpu_autodiff, NetConfig, QNet};
use burn::module::Module;
use burn::optim::grad_clipping::GradientClippingConfig;
use burn::optim::{AdamConfig, ModuleOptimizer};
use madenet_sim::{PolicyRegistry, TrialSpec};
use madenet_trainlog::{EpisodeRow, UpdateRow};
use madenet_world::rng::{derive_seed, stream};
use madenet_world::ScenarioConfig;
use rand::RngExt;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::path::Path;
use std::sync::Arc;

/// The two methods of the paper this loop trains (the trained model's [`Method`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PaperMethod {
    /// CEP + DEPs trained together (Eq. 5 and 6), two environments.
    MadeNet,
    /// The paper's ablation: the DEPs alone on decentralized experience (double DRQN).
    MadeNetDt,
}

impl PaperMethod {
    /// Both, in the order `madenet train` lists them.
    pub const ALL: [PaperMethod; 2] = [PaperMethod::MadeNet, PaperMethod::MadeNetDt];

    /// The model's method.
    pub const fn method(self) -> Method {
        match self {
            PaperMethod::MadeNet => Method::MadeNet,
            PaperMethod::MadeNetDt => Method::MadeNetDt,
        }
    }
}

/// Every knob of a training run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// `made-net` or `made-net-dt`.
    pub method: PaperMethod,
    /// Master seed of every stream.
    pub seed: u64,
    /// Episodes per environment (the paper: ≈ 250 000 to converge, in 350 h).
    pub episodes: u64,
    /// Stop (with a checkpoint) after this many minutes of wall time; 0 = no limit.
    pub max_minutes: f64,
    /// The simulated world (team size, d_s, noise, step cap, …). Its `comm_success_prob` is
    /// used by nothing: the centralized env has full communication and the decentralized env
    /// draws CSP ~ U(0, 1) per episode (Sec. III.C.4).
    pub scenario: ScenarioConfig,
    /// Training map height in cells (the paper: 20).
    pub map_height: usize,
    /// Training map width in cells (the paper: 20).
    pub map_width: usize,
    /// Lowest obstacle density of the training maps, a fraction (the paper: 0.4).
    pub density_min: f64,
    /// Highest obstacle density of the training maps, a fraction (the paper: 0.6).
    pub density_max: f64,
    /// γ (the paper: 1), applied once per macro step.
    pub gamma: f32,
    /// Sequences per batch (the paper: 16).
    pub batch_size: usize,
    /// Joint decisions per sampled sequence, unrolled from zero LSTM state (MacDec-DDRQN's
    /// `trace_len`; the paper does not say). Each window carries one more decision for the
    /// last target.
    pub trace_len: usize,
    /// Adam step size (MacDec-DDRQN's default 1e-3; the paper does not say).
    pub learning_rate: f64,
    /// Gradient norm clip (ours: keeps early TD errors on returns of −1000s from blowing up).
    pub grad_clip_norm: f32,
    /// Rewards are multiplied by this in the targets (ours: Eq. 7/8 sum to ±1000s per episode
    /// and γ = 1; 0.01 keeps Q in tens).
    pub reward_scale: f32,
    /// Episodes kept per environment's replay (MacDec-DDRQN: 1000).
    pub replay_episodes: usize,
    /// Episodes per environment before the first update.
    pub warmup_episodes: u64,
    /// Updates (one CEP and one DEP step each) per iteration.
    pub updates_per_episode: usize,
    /// Target networks are copied from the online ones every this many updates.
    pub target_update_every: u64,
    /// ε-greedy, linear decay from `epsilon_start` to `epsilon_end` over
    /// `epsilon_decay_episodes` episodes.
    pub epsilon_start: f32,
    /// ε after the decay, held from then on.
    pub epsilon_end: f32,
    /// Episodes per environment over which ε decays ([`TrainConfig::epsilon`]).
    pub epsilon_decay_episodes: u64,
    /// In the decentralized env, explore by following the CEP's joint choice (MacDec's
    /// `cen_explore`) instead of a random candidate.
    pub cen_explore: bool,
    /// One DEP shared by all robots (ours, default: the robots are identical and sharing
    /// triples each net's samples in a 1-hour budget) or one per robot (the paper).
    pub shared_dep: bool,
    /// CONCAT as a learned layer ([`NetConfig::concat_fc`]).
    pub concat_fc: bool,
    /// Validate every this many episodes per environment; 0 = never.
    pub validate_every: u64,
    /// Generated validation maps (fixed by `seed`, never the paper's).
    pub validation_maps: usize,
    /// CSPs each validation map is run at.
    pub validation_csp: Vec<f64>,
    /// Checkpoint every this many episodes per environment.
    pub checkpoint_every: u64,
    /// Also checkpoint when this many minutes passed since the last checkpoint (so a run
    /// killed between episode checkpoints loses at most this much); 0 = by episodes only.
    pub checkpoint_minutes: f64,
    /// Learner threads (burn's CPU kernels run on this rayon pool).
    pub threads: usize,
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            method: PaperMethod::MadeNet,
            seed: 1,
            episodes: 20_000,
            max_minutes: 55.0,
            scenario: ScenarioConfig::default(),
            map_height: 20,
            map_width: 20,
            density_min: 0.40,
            density_max: 0.60,
            gamma: 1.0,
            batch_size: 16,
            trace_len: 24,
            learning_rate: 1e-3,
            grad_clip_norm: 10.0,
            reward_scale: 0.01,
            replay_episodes: 1000,
            warmup_episodes: 32,
            updates_per_episode: 1,
            target_update_every: 50,
            epsilon_start: 1.0,
            epsilon_end: 0.05,
            epsilon_decay_episodes: 1500,
            cen_explore: true,
            shared_dep: true,
            concat_fc: false,
            validate_every: 250,
            validation_maps: 12,
            validation_csp: vec![1.0, 0.5, 0.0],
            checkpoint_every: 500,
            checkpoint_minutes: 10.0,
            threads: 2,
        }
    }
}

impl TrainConfig {
    crate::toml_config_readers!();

    /// Checks every field and the memory the sizes ask for ([`Self::memory_needs`]); the
    /// message names the field.
    pub fn validate(&self) -> Result<(), String> {
        self.check_fields()?;
        harness::check_memory(&self.memory_needs(), harness::physical_memory())
    }

    /// Checks every field (not the memory).
    pub fn check_fields(&self) -> Result<(), String> {
        self.scenario
            .validate()
            .map_err(|e| format!("scenario: {e}"))?;
        self.scenario_draw().check()?;
        let checks: [(bool, &str, String); 14] = [
            (self.episodes >= 1, "episodes", "must be at least 1".into()),
            (
                self.max_minutes >= 0.0 && self.max_minutes.is_finite(),
                "max_minutes",
                "must be ≥ 0".into(),
            ),
            (
                (0.0..=1.0).contains(&self.gamma),
                "gamma",
                "must be in [0, 1]".into(),
            ),
            (
                self.batch_size >= 1 && self.trace_len >= 1,
                "batch_size/trace_len",
                "must be at least 1".into(),
            ),
            (
                self.learning_rate > 0.0 && self.learning_rate.is_finite(),
                "learning_rate",
                "must be positive".into(),
            ),
            (
                self.grad_clip_norm > 0.0,
                "grad_clip_norm",
                "must be positive".into(),
            ),
            (
                self.reward_scale > 0.0 && self.reward_scale.is_finite(),
                "reward_scale",
                "must be positive".into(),
            ),
            (
                self.replay_episodes >= self.batch_size,
                "replay_episodes",
                "must be at least batch_size".into(),
            ),
            (
                self.target_update_every >= 1,
                "target_update_every",
                "must be at least 1".into(),
            ),
            (
                (0.0..=1.0).contains(&self.epsilon_start)
                    && (0.0..=1.0).contains(&self.epsilon_end),
                "epsilon_start/epsilon_end",
                "must be in [0, 1]".into(),
            ),
            (
                self.validation_csp.iter().all(|p| (0.0..=1.0).contains(p)),
                "validation_csp",
                "every CSP must be in [0, 1]".into(),
            ),
            (
                (1..=256).contains(&self.threads),
                "threads",
                format!("must be in 1..=256, got {}", self.threads),
            ),
            (
                self.checkpoint_every >= 1,
                "checkpoint_every",
                "must be at least 1".into(),
            ),
            (
                self.checkpoint_minutes.is_finite() && self.checkpoint_minutes >= 0.0,
                "checkpoint_minutes",
                "must be ≥ 0 (0 = by episodes only)".into(),
            ),
        ];
        for (ok, field, msg) in checks {
            if !ok {
                return Err(format!("field `{field}`: {msg}"));
            }
        }
        harness::check_sizes(&[
            ("episodes", self.episodes, 1, 10_000_000),
            ("batch_size", self.batch_size as u64, 1, 1024),
            ("trace_len", self.trace_len as u64, 1, 1024),
            ("replay_episodes", self.replay_episodes as u64, 1, 100_000),
            (
                "updates_per_episode",
                self.updates_per_episode as u64,
                0,
                10_000,
            ),
            ("validation_maps", self.validation_maps as u64, 0, 100_000),
        ])?;
        let joint = (self.goals() as u64)
            .checked_pow(self.scenario.num_robots as u32)
            .unwrap_or(u64::MAX);
        if self.method == PaperMethod::MadeNet && joint > harness::MAX_JOINT_ACTIONS {
            return Err(format!(
                "field `scenario.num_robots`: the CEP's joint actions |G|^|I| = {}^{} exceed {}; train fewer robots, or made-net-dt",
                self.goals(),
                self.scenario.num_robots,
                harness::MAX_JOINT_ACTIONS
            ));
        }
        if self.validate_every > 0 && self.validation_maps == 0 {
            return Err(
                "field `validation_maps`: must be at least 1 when validate_every > 0".into(),
            );
        }
        Ok(())
    }

    /// The allocation that grows with the sizes at once: a minibatch of sequences, for the
    /// DEP and for the CEP, each `batch_size` windows of `trace_len` + 1 decisions of a
    /// 4-channel map image as f32, built on the host and copied into a tensor. (The replay
    /// grows with the episodes' decisions, which the config does not fix; not counted.)
    pub fn memory_needs(&self) -> Vec<(String, u64)> {
        let (h, w) = (self.map_height as u64, self.map_width as u64);
        let per_map = crate::MAP_CHANNELS as u64 * h * w * 4;
        let windows = self.batch_size as u64 * (self.trace_len as u64 + 1);
        vec![(
            format!(
                "a minibatch (`batch_size` {} × (`trace_len` {} + 1) × {h} × {w} map images, for DEP and CEP, host and tensor)",
                self.batch_size, self.trace_len
            ),
            2 * 2 * windows * per_map,
        )]
    }

    /// |G| on the training maps.
    pub fn goals(&self) -> usize {
        self.scenario
            .goal_count_for(self.map_height * self.map_width)
    }

    fn team(&self) -> usize {
        self.scenario.num_robots
    }

    /// The CEP's network config.
    pub fn cep_config(&self) -> NetConfig {
        NetConfig::cep(self.map_height, self.map_width, self.team(), self.goals())
            .with_concat_fc(self.concat_fc)
    }

    /// A DEP's network config.
    pub fn dep_config(&self) -> NetConfig {
        NetConfig::dep(self.map_height, self.map_width, self.team(), self.goals())
            .with_concat_fc(self.concat_fc)
    }

    /// ε after `episode` episodes.
    pub fn epsilon(&self, episode: u64) -> f32 {
        let f = (episode as f32 / self.epsilon_decay_episodes.max(1) as f32).min(1.0);
        self.epsilon_start + (self.epsilon_end - self.epsilon_start) * f
    }

    fn update_params(&self) -> UpdateParams {
        UpdateParams {
            gamma: self.gamma,
            learning_rate: self.learning_rate,
            reward_scale: self.reward_scale,
            map_height: self.map_height,
            map_width: self.map_width,
            team: self.team(),
            goals: self.goals(),
        }
    }

    /// Robot groups sharing a DEP.
    fn dep_groups(&self) -> Vec<Vec<usize>> {
        if self.shared_dep {
            vec![(0..self.team()).collect()]
        } else {
            (0..self.team()).map(|i| vec![i]).collect()
        }
    }
}

impl TrainConfig {
    /// How this run draws its training and validation scenarios.
    pub fn scenario_draw(&self) -> ScenarioDraw {
        ScenarioDraw::new(
            self.map_height,
            self.map_width,
            (self.density_min, self.density_max),
            self.team(),
            self.scenario.movement,
        )
    }

    /// The run's fixed validation maps ([`ScenarioDraw::validation_maps`]).
    pub fn validation_maps(&self) -> Result<Vec<TrialSpec>, TrainError> {
        self.scenario_draw()
            .validation_maps(self.seed, self.validation_maps, &self.scenario)
    }
}

/// Counters saved with a checkpoint.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct State {
    episode: u64,
    updates: u64,
    best_validation: Option<f64>,
    wall_s: f64,
}

/// Replay of one environment: the last `capacity` episodes.
#[derive(Default, Serialize, Deserialize)]
struct Replay {
    episodes: VecDeque<Episode>,
}

impl Replay {
    fn push(&mut self, e: Episode, capacity: usize) {
        if self.episodes.len() == capacity {
            self.episodes.pop_front();
        }
        self.episodes.push_back(e);
    }
    /// `n` windows of `trace_len + 1` joint decisions (the CEP's): episodes drawn uniformly
    /// with replacement; each window's start uniform in `−trace_len..len` and clipped at 0, so
    /// that every decision, the first ones included, is in the same number of windows.
    fn sample(
        &self,
        n: usize,
        trace_len: usize,
        rng: &mut madenet_world::rng::Rng,
    ) -> Vec<Window<'_>> {
        (0..n)
            .map(|_| {
                let e = &self.episodes[rng.random_range(0..self.episodes.len())];
                Window::new(
                    e,
                    window_start(e.decisions.len(), trace_len, rng),
                    trace_len,
                )
            })
            .collect()
    }

    /// `n` windows of `trace_len + 1` decisions of one robot of `robots` (drawn uniformly), for
    /// a DEP; starts drawn like [`Replay::sample`]'s in the robot's own decisions.
    fn sample_robots(
        &self,
        n: usize,
        trace_len: usize,
        robots: &[usize],
        rng: &mut madenet_world::rng::Rng,
    ) -> Vec<RobotWindow<'_>> {
        (0..n)
            .map(|_| {
                let e = &self.episodes[rng.random_range(0..self.episodes.len())];
                let robot = robots[rng.random_range(0..robots.len())];
                RobotWindow::new(
                    e,
                    robot,
                    window_start(e.dep[robot].len(), trace_len, rng),
                    trace_len,
                )
            })
            .collect()
    }
}

fn window_start(len: usize, trace_len: usize, rng: &mut madenet_world::rng::Rng) -> usize {
    let s = rng.random_range(0..(len + trace_len).max(1)) as i64 - trace_len as i64;
    s.max(0) as usize
}

/// The learner's nets and optimizers.
struct Nets {
    cep: Option<(QNet, QNet, ModuleOptimizer)>,
    deps: Vec<(QNet, QNet, ModuleOptimizer)>,
}

impl Nets {
    fn init(cfg: &TrainConfig) -> Result<Self, TrainError> {
        let device = cpu_autodiff();
        device.seed(cfg.seed);
        let optim = || {
            AdamConfig::new()
                .with_grad_clipping(Some(GradientClippingConfig::Norm(cfg.grad_clip_norm)))
                .init()
        };
        let cep = match cfg.method {
            PaperMethod::MadeNet => {
                let net = cfg.cep_config().init(&device)?;
                let target = target_of(&net);
                Some((net, target, optim()))
            }
            PaperMethod::MadeNetDt => None,
        };
        let mut deps = Vec::new();
        for _ in cfg.dep_groups() {
            let net = cfg.dep_config().init(&device)?;
            let target = target_of(&net);
            deps.push((net, target, optim()));
        }
        Ok(Nets { cep, deps })
    }

    fn actor_nets(&self) -> ActorNets {
        ActorNets {
            cep: self.cep.as_ref().map(|(o, _, _)| target_of(o)),
            deps: self.deps.iter().map(|(o, _, _)| target_of(o)).collect(),
        }
    }

    fn sync_targets(&mut self) {
        if let Some((o, t, _)) = self.cep.as_mut() {
            *t = target_of(o);
        }
        for (o, t, _) in &mut self.deps {
            *t = target_of(o);
        }
    }

    /// All nets and optimizers by file stem.
    fn save(&self, dir: &Path) -> Result<(), TrainError> {
        let save_net = |net: &QNet, stem: &str| -> Result<(), TrainError> {
            let path = dir.join(format!("{stem}.bpk"));
            net.clone()
                .into_record()
                .save(&path)
                .map_err(|e| TrainError::Io {
                    path: path.display().to_string(),
                    message: e.to_string(),
                })
        };
        let save_opt = |op: &ModuleOptimizer, stem: &str| -> Result<(), TrainError> {
            let path = dir.join(format!("{stem}.bpk"));
            op.save(&path).map_err(|e| TrainError::Io {
                path: path.display().to_string(),
                message: e.to_string(),
            })
        };
        if let Some((o, t, op)) = &self.cep {
            save_net(o, "cep")?;
            save_net(t, "cep_target")?;
            save_opt(op, "cep_optim")?;
        }
        for (k, (o, t, op)) in self.deps.iter().enumerate() {
            save_net(o, &format!("dep{k}"))?;
            save_net(t, &format!("dep{k}_target"))?;
            save_opt(op, &format!("dep{k}_optim"))?;
        }
        Ok(())
    }

    fn load(mut self, dir: &Path) -> Result<Self, TrainError> {
        let path = |stem: &str| dir.join(format!("{stem}.bpk"));
        let opt = |op: ModuleOptimizer, stem: &str| -> Result<ModuleOptimizer, TrainError> {
            let path = dir.join(format!("{stem}.bpk"));
            op.load(&path).map_err(|e| TrainError::Io {
                path: path.display().to_string(),
                message: e.to_string(),
            })
        };
        if let Some((o, t, op)) = self.cep.take() {
            self.cep = Some((
                harness::load_weights(o, &path("cep"))?,
                harness::load_weights(t, &path("cep_target"))?,
                opt(op, "cep_optim")?,
            ));
        }
        let deps = std::mem::take(&mut self.deps);
        for (k, (o, t, op)) in deps.into_iter().enumerate() {
            self.deps.push((
                harness::load_weights(o, &path(&format!("dep{k}")))?,
                harness::load_weights(t, &path(&format!("dep{k}_target")))?,
                opt(op, &format!("dep{k}_optim"))?,
            ));
        }
        Ok(self)
    }
}

/// MADE-Net and MADE-Net-DT as a [`Learner`] (`made-net`, `made-net-dt`).
pub struct MadeNetLearner;

impl Learner for MadeNetLearner {
    type Config = TrainConfig;
    const METHODS: &'static [&'static str] = &[
        PaperMethod::MadeNet.method().name(),
        PaperMethod::MadeNetDt.method().name(),
    ];

    crate::learner_config!(model = Model);

    fn set_method(cfg: &mut TrainConfig, method: &str) -> Result<(), String> {
        cfg.method = PaperMethod::ALL
            .into_iter()
            .find(|m| m.method().name() == method)
            .ok_or_else(|| format!("`{method}` is not trained by MADE-Net's learner"))?;
        Ok(())
    }

    /// The loop: episodes, updates, validation, checkpoints ([`EpisodeRun`]).
    fn train_loop(run: TrainRun<'_, TrainConfig>) -> Result<(), TrainError> {
        let (run_dir, cfg, progress) = (run.dir, run.cfg, run.progress);
        let ckpt_dir = run_dir.join("checkpoint");
        let mut nets = Nets::init(cfg)?;
        let (mut state, mut cen, mut dec) = if run.resuming {
            let state: State = harness::read_json(&ckpt_dir.join("state.json"))?;
            nets = nets.load(&ckpt_dir)?;
            let (cen, dec): (Replay, Replay) =
                harness::read_postcard(&ckpt_dir.join("replay.bin"))?;
            (state, cen, dec)
        } else {
            (State::default(), Replay::default(), Replay::default())
        };
        let per_iter = match cfg.method {
            PaperMethod::MadeNet => 2,
            PaperMethod::MadeNetDt => 1,
        };
        // Logs keep what the checkpoint has seen; a resumed run appends from there.
        let seen = state.episode * per_iter;
        let mut run = EpisodeRun::<UpdateRow>::open(
            run_dir,
            Seen {
                episodes: seen,
                updates: state.updates,
                first_loss_step: 1, // `loss/*` steps count updates from 1
            },
            state.wall_s,
            state.best_validation,
            crate::cadence!(cfg),
        )?;
        let params = cfg.update_params();
        let groups = cfg.dep_groups();
        let draw = cfg.scenario_draw();
        // Drawn at the first validation (a run that never validates draws none), then kept.
        let mut validation_maps: Option<Vec<TrialSpec>> = None;
        while state.episode < cfg.episodes {
            let e = state.episode;
            let epsilon = cfg.epsilon(e);
            let actor_nets = nets.actor_nets();
            let (mut reward_sum, mut steps_sum) = (0.0, 0.0);
            let envs: &[EnvKind] = match cfg.method {
                PaperMethod::MadeNet => &[EnvKind::Centralized, EnvKind::Decentralized],
                PaperMethod::MadeNetDt => &[EnvKind::Decentralized],
            };
            for (k, &kind) in envs.iter().enumerate() {
                let seed = derive_seed(cfg.seed, kind.short(), e);
                let (map, starts) = draw.draw(seed)?;
                let csp = match kind {
                    EnvKind::Centralized => 1.0,
                    EnvKind::Decentralized => stream(seed, "csp", 0).random::<f64>(),
                };
                let spec = TrialSpec {
                    map,
                    map_name: format!("train_{}_{e}", kind.short()),
                    starts,
                    config: ScenarioConfig {
                        comm_success_prob: csp,
                        ..cfg.scenario.clone()
                    },
                    policy: String::new(),
                    seed,
                };
                let actor = Actor::new(
                    kind,
                    actor_nets.clone(),
                    epsilon,
                    cfg.cen_explore,
                    cfg.goals(),
                    cfg.team(),
                    stream(seed, "actor", 0),
                );
                let ep = run_episode(spec, actor)?;
                let id = e * per_iter + k as u64;
                run.logs.episodes.append(&EpisodeRow {
                    episode: id,
                    env: kind.into(),
                    csp,
                    steps: ep.len() as u32,
                    team_reward: ep.team_return,
                    complete: ep.complete,
                    epsilon: f64::from(epsilon),
                    updates: state.updates,
                    wall_s: run.clock.wall(),
                })?;
                let tag = |what: &str| format!("episode/{}_{what}", kind.short());
                run.logs
                    .scalar(&tag("team_reward"), ep.team_return as f32, id)?;
                run.logs.scalar(&tag("steps"), ep.len() as f32, id)?;
                reward_sum += ep.team_return;
                steps_sum += ep.len() as f64;
                match kind {
                    EnvKind::Centralized => cen.push(ep, cfg.replay_episodes),
                    EnvKind::Decentralized => dec.push(ep, cfg.replay_episodes),
                }
            }
            state.episode += 1;
            if state.episode >= cfg.warmup_episodes {
                for _ in 0..cfg.updates_per_episode {
                    let mut rng = stream(cfg.seed, "sample", state.updates);
                    let mut cep_loss = f32::NAN;
                    if let Some((online, target, mut optim)) = nets.cep.take() {
                        let batch = cen.sample(cfg.batch_size, cfg.trace_len, &mut rng);
                        let (online, loss) =
                            cep_update(online, &target, &mut optim, &batch, &params);
                        cep_loss = loss;
                        nets.cep = Some((online, target, optim));
                    }
                    // DEP batches: `batch_size` robot sequences — for a shared DEP of any robot,
                    // for a per-robot DEP of its own.
                    let cep_plain = nets.cep.as_ref().map(|(o, _, _)| target_of(o));
                    let mut dep_loss = 0.0;
                    let deps = std::mem::take(&mut nets.deps);
                    for ((online, target, mut optim), robots) in deps.into_iter().zip(&groups) {
                        let batch =
                            dec.sample_robots(cfg.batch_size, cfg.trace_len, robots, &mut rng);
                        let (online, loss) = dep_update(
                            online,
                            &target,
                            &mut optim,
                            cep_plain.as_ref(),
                            &batch,
                            &params,
                        );
                        dep_loss += loss / groups.len() as f32;
                        nets.deps.push((online, target, optim));
                    }
                    state.updates += 1;
                    if state.updates % cfg.target_update_every == 0 {
                        nets.sync_targets();
                    }
                    run.logs.updates.append(&UpdateRow {
                        update: state.updates - 1,
                        cep_loss: cep_loss.into(),
                        dep_loss: dep_loss.into(),
                    })?;
                    if cep_loss.is_finite() {
                        run.logs.scalar("loss/cep", cep_loss, state.updates)?;
                    }
                    run.logs.scalar("loss/dep", dep_loss, state.updates)?;
                }
            }
            if run.validates(state.episode) {
                let model = Model::with_grid(
                    model_info(cfg, &state, None),
                    nets.deps
                        .iter()
                        .map(|(o, _, _)| Arc::new(target_of(o)))
                        .collect(),
                )
                .expect("one DEP per group");
                let mut registry = PolicyRegistry::default();
                model.register(&mut registry, "candidate", "the DEPs being trained");
                if validation_maps.is_none() {
                    validation_maps = Some(cfg.validation_maps()?);
                }
                let v = validate(
                    validation_maps.as_deref().expect("drawn above"),
                    &cfg.validation_csp,
                    &registry,
                    "candidate",
                )?;
                let id = state.episode * per_iter;
                run.log_validation(id, state.updates, &v)?;
                let steps = v.mean_steps;
                run.logs
                    .scalar("validation/mean_team_reward", v.mean_team_return as f32, id)?;
                if harness::new_best(&mut state.best_validation, steps) {
                    let info = model_info(cfg, &state, Some(steps));
                    save_model(&run_dir.join("best"), &nets, &info)?;
                }
            }
            let stopping = run.end_episode(state.episode, |wall_s| {
                state.wall_s = wall_s;
                checkpoint(&ckpt_dir, &nets, &state, &cen, &dec)?;
                save_model(&run_dir.join("last"), &nets, &model_info(cfg, &state, None))
            })?;
            progress(&run.progress(
                state.episode,
                state.updates,
                vec![
                    ("ε", epsilon as f64, 2),
                    ("reward", reward_sum / envs.len() as f64, 0),
                    ("steps", steps_sum / envs.len() as f64, 0),
                ],
            ));
            if stopping {
                break;
            }
        }
        Ok(())
    }
}

/// Trains MADE-Net or MADE-Net-DT into `run_dir` ([`harness::train`]), calling `progress`
/// after each iteration.
pub fn train(
    run_dir: &Path,
    cfg: Option<TrainConfig>,
    progress: &mut (dyn FnMut(&Progress) + Send),
) -> Result<(), TrainError> {
    harness::train::<MadeNetLearner>(run_dir, cfg, progress)
}

fn model_info(cfg: &TrainConfig, state: &State, validation_steps: Option<f64>) -> ModelInfo {
    let d = cfg.dep_config();
    ModelInfo {
        method: cfg.method.method(),
        agnostic: None,
        dep: Some(NetConfigToml {
            map_height: d.map_height,
            map_width: d.map_width,
            team_size: d.team_size,
            goal_count: d.goal_count,
            concat_fc: d.concat_fc,
        }),
        deps: (0..cfg.dep_groups().len())
            .map(|k| format!("dep{k}.bpk"))
            .collect(),
        digests: Vec::new(), // filled in by `write_model_toml`
        episode: state.episode,
        updates: state.updates,
        validation_steps,
        observation: Observation::Paper,
        recurrent: true,
        spread_margin: None,
    }
}

/// Writes the DEPs (and the CEP, for reference) and `model.toml` into `dir`, atomically.
fn save_model(dir: &Path, nets: &Nets, info: &ModelInfo) -> Result<(), TrainError> {
    replace_dir(dir, |tmp| {
        let save = |name: String, online| {
            let p = tmp.join(name);
            target_of(online)
                .into_record()
                .save(&p)
                .map_err(|e| TrainError::Io {
                    path: p.display().to_string(),
                    message: e.to_string(),
                })
        };
        for (k, (o, _, _)) in nets.deps.iter().enumerate() {
            save(format!("dep{k}.bpk"), o)?;
        }
        if let Some((o, _, _)) = &nets.cep {
            save("cep.bpk".into(), o)?;
        }
        harness::write_model_toml(tmp, info)
    })
}

fn checkpoint(
    dir: &Path,
    nets: &Nets,
    state: &State,
    cen: &Replay,
    dec: &Replay,
) -> Result<(), TrainError> {
    replace_dir(dir, |tmp| {
        nets.save(tmp)?;
        harness::write_postcard(&tmp.join("replay.bin"), &(cen, dec))?;
        harness::write_json(&tmp.join("state.json"), state)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epsilon_decays_linearly_then_stays() {
        let cfg = TrainConfig {
            epsilon_start: 1.0,
            epsilon_end: 0.1,
            epsilon_decay_episodes: 10,
            ..TrainConfig::default()
        };
        assert_eq!(cfg.epsilon(0), 1.0);
        assert!((cfg.epsilon(5) - 0.55).abs() < 1e-6);
        assert!((cfg.epsilon(10) - 0.1).abs() < 1e-6 && (cfg.epsilon(1000) - 0.1).abs() < 1e-6);
    }
}
