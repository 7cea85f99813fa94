//! `madenet train --method dme-drl`: MADDPG on episodes of the real simulator, read top to
//! bottom in [`train`].
//!
//! Each episode is a generated map (never the paper's) with the team started together and the
//! CSP drawn from U(0, 1), so the actors meet every communication condition of the study. Every
//! robot runs [`DmePolicy`] sampling from its actor; every timestep is stored (frames, poses,
//! masks, actions in force, who decided, per-robot rewards), and a robot's transitions run from
//! one of its decisions to its next. Every `update_every` timesteps one MADDPG update
//! ([`crate::maddpg`]) runs on a minibatch per robot from the replay of the last
//! `replay_steps` timesteps, and the acting actors get the new weights. Validation runs the
//! greedy actors on the same generated validation maps as `madenet train`'s MADE-Net runs; the
//! best weights go to `best/`, the latest to `last/`, and a checkpoint (networks, Adam states,
//! replay, counters) lets a killed run resume exactly where it stopped.
//!
//! Rewards (design brief §2, scaled to the grid): `r_i = new_cell_reward · (cells robot i
//! observed that it had not known) − move_cost · (cells it moved)`, individual, with no
//! interaction term — as the MADE-Net paper describes DME-DRL. An episode ends when the map is
//! explored or at the step cap; both end the bootstrap (the nets have no time input).

use crate::maddpg::{Batch, Maddpg, UpdateParams};
use crate::model::{Model, ModelInfo};
use crate::nets::DmeConfig;
use crate::obs::{history_step, FRAME_CHANNELS};
use crate::policy::{DecisionSlots, DmePolicy, SharedActor};
use crate::SECTORS;
use burn::module::Module;
use burn::store::ModuleRecord;
use burn::tensor::Device;
use madenet_harness::bits::{pack_bits, unpack_bits};
use madenet_harness::episode;
use madenet_harness::harness::{
    self, replace_dir, EpisodeRun, Learner, Logs, Progress, Seen, TrainRun,
};
use madenet_harness::scenario::{self, ScenarioDraw, Validation};
use madenet_harness::TrainError;
use madenet_sim::rewards::RewardConfig;
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_trainlog::{EpisodeRow, MaddpgUpdateRow};
use madenet_world::rng::{derive_seed, stream};
use madenet_world::ScenarioConfig;
use rand::RngExt;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::path::Path;
use std::sync::{Arc, Mutex, RwLock};

/// The registry name of the method.
pub const METHOD: &str = "dme-drl";

/// Every knob of a DME-DRL training run (`configs/train-dme.toml` holds the defaults).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DmeTrainConfig {
    /// Always `dme-drl` (tells `madenet train --resume` which learner a run directory needs).
    pub method: String,
    /// Master seed of every stream.
    pub seed: u64,
    /// Episodes to play (the original: 200 000).
    pub episodes: u64,
    /// Stop (with a checkpoint) after this many minutes of wall time; 0 = no limit.
    pub max_minutes: f64,
    /// The simulated world; its `comm_success_prob` is unused (drawn per episode from U(0, 1)).
    pub scenario: ScenarioConfig,
    /// Training map height in cells (as MADE-Net's: 20).
    pub map_height: usize,
    /// Training map width in cells (as MADE-Net's: 20).
    pub map_width: usize,
    /// Lowest obstacle density of the training maps, a fraction (as MADE-Net's: 0.4).
    pub density_min: f64,
    /// Highest obstacle density of the training maps, a fraction (as MADE-Net's: 0.6).
    pub density_max: f64,
    /// Frames of map history in an actor's input (the original: 6 frames of 100 × 100).
    pub history: usize,
    /// Newest frames per robot in the critics' input ([`DmeConfig::critic_history`]).
    pub critic_history: usize,
    /// Hidden units of the actors' and critics' fully connected layer.
    pub hidden: usize,
    /// Reward per newly observed cell (the original: 2e-5 per pixel ≈ 2e-3 per cell).
    pub new_cell_reward: f64,
    /// Cost per cell moved (the original: 1e-3 per pixel ≈ 1e-2 per cell).
    pub move_cost: f64,
    /// γ per timestep (the original: 0.95).
    pub gamma: f32,
    /// Soft target update rate (the original: 0.01).
    pub tau: f32,
    /// The actors' Adam step size (the original: 1e-3).
    pub actor_lr: f64,
    /// The critics' Adam step size (the original: 1e-3).
    pub critic_lr: f64,
    /// Gumbel-softmax temperature (the original: 1).
    pub temperature: f32,
    /// λ of the actors' logit penalty (MADDPG's reference code: 1e-3).
    pub logit_penalty: f32,
    /// Transitions per minibatch (the original: 100).
    pub batch_size: usize,
    /// Timesteps kept in the replay (the original: 5 000 transitions of whole-path steps).
    pub replay_steps: usize,
    /// Timesteps in the replay before the first update.
    pub warmup_steps: usize,
    /// One update every this many timesteps (the original: 10 environment steps).
    pub update_every: u64,
    /// Validate every this many episodes; 0 = never.
    pub validate_every: u64,
    /// Generated validation maps (fixed by `seed`, never the paper's).
    pub validation_maps: usize,
    /// CSPs each validation map is run at.
    pub validation_csp: Vec<f64>,
    /// Checkpoint every this many episodes.
    pub checkpoint_every: u64,
    /// Also checkpoint when this many minutes passed since the last checkpoint; 0 = by
    /// episodes only.
    pub checkpoint_minutes: f64,
    /// Learner threads (burn's CPU kernels run on this rayon pool).
    pub threads: usize,
}

impl Default for DmeTrainConfig {
    fn default() -> Self {
        DmeTrainConfig {
            method: METHOD.into(),
            seed: 1,
            episodes: 20_000,
            max_minutes: 55.0,
            scenario: ScenarioConfig::default(),
            map_height: madenet_harness::DEFAULT_MAP_SIDE,
            map_width: madenet_harness::DEFAULT_MAP_SIDE,
            density_min: 0.40,
            density_max: 0.60,
            history: 3,
            critic_history: 1,
            hidden: 128,
            new_cell_reward: 2e-3,
            move_cost: 1e-2,
            gamma: 0.95,
            tau: 0.01,
            actor_lr: 1e-3,
            critic_lr: 1e-3,
            temperature: 1.0,
            logit_penalty: 1e-3,
            batch_size: 100,
            replay_steps: 5_000,
            warmup_steps: 1_000,
            update_every: 10,
            validate_every: 100,
            validation_maps: 12,
            validation_csp: vec![1.0, 0.5, 0.0],
            checkpoint_every: 100,
            checkpoint_minutes: 10.0,
            threads: 2,
        }
    }
}

impl DmeTrainConfig {
    madenet_harness::toml_config_readers!();

    /// One message naming the first bad field.
    pub fn validate(&self) -> Result<(), String> {
        let bad = |field: &str, why: &str| Err(format!("field `{field}`: {why}"));
        if self.method != METHOD {
            return bad(
                "method",
                &format!(
                    "must be `{METHOD}` here (MADE-Net runs use `madenet train --method made-net`)"
                ),
            );
        }
        let side = madenet_harness::MAX_TRAIN_MAP_SIDE as u64;
        harness::check_sizes(&[
            ("episodes", self.episodes, 1, 10_000_000),
            ("map_height", self.map_height as u64, 1, side),
            ("map_width", self.map_width as u64, 1, side),
            ("history", self.history as u64, 1, 64),
            ("hidden", self.hidden as u64, 1, 4096),
            ("batch_size", self.batch_size as u64, 1, 4096),
            ("replay_steps", self.replay_steps as u64, 1, 1_000_000),
            ("validation_maps", self.validation_maps as u64, 0, 100_000),
        ])?;
        self.nets().check_size()?;
        if self.critic_history == 0 || self.critic_history > self.history {
            return bad("critic_history", "must lie in 1..=history");
        }
        if !(0.0..=1.0).contains(&self.gamma) {
            return bad("gamma", "must lie in [0, 1]");
        }
        if !(self.tau > 0.0 && self.tau <= 1.0) {
            return bad("tau", "must lie in (0, 1]");
        }
        if !(self.actor_lr > 0.0 && self.critic_lr > 0.0) {
            return bad(
                if self.actor_lr > 0.0 {
                    "critic_lr"
                } else {
                    "actor_lr"
                },
                "must be positive",
            );
        }
        if self.temperature <= 0.0 || !self.temperature.is_finite() {
            return bad("temperature", "must be positive");
        }
        if self.logit_penalty < 0.0 {
            return bad("logit_penalty", "must not be negative");
        }
        if self.batch_size == 0 {
            return bad("batch_size", "must be at least 1");
        }
        if self.replay_steps < self.batch_size {
            return bad("replay_steps", "must hold at least one batch");
        }
        if self.warmup_steps > self.replay_steps {
            return bad(
                "warmup_steps",
                "must not exceed replay_steps (the replay never holds more)",
            );
        }
        let finite = [
            ("new_cell_reward", self.new_cell_reward),
            ("move_cost", self.move_cost),
            ("actor_lr", self.actor_lr),
            ("critic_lr", self.critic_lr),
            ("logit_penalty", f64::from(self.logit_penalty)),
            ("gamma", f64::from(self.gamma)),
        ];
        if let Some((field, _)) = finite.iter().find(|(_, v)| !v.is_finite()) {
            return bad(field, "must be a finite number");
        }
        if self.validate_every > 0 && self.validation_csp.is_empty() {
            return bad(
                "validation_csp",
                "must name at least one CSP when validate_every > 0",
            );
        }
        if self.update_every == 0 {
            return bad("update_every", "must be at least 1");
        }
        if !(self.checkpoint_minutes.is_finite() && self.checkpoint_minutes >= 0.0) {
            return bad("checkpoint_minutes", "must be ≥ 0 (0 = by episodes only)");
        }
        if self.checkpoint_every == 0 {
            return bad("checkpoint_every", "must be at least 1");
        }
        if !(1..=256).contains(&self.threads) {
            return bad("threads", "must be in 1..=256");
        }
        if self.max_minutes.is_nan() || self.max_minutes < 0.0 {
            return bad("max_minutes", "must be 0 (no limit) or positive");
        }
        if self.validation_csp.iter().any(|c| !(0.0..=1.0).contains(c)) {
            return bad("validation_csp", "CSPs lie in [0, 1]");
        }
        // The scenario, maps and densities are checked as every learner's are.
        self.scenario
            .validate()
            .map_err(|e| format!("scenario: {e}"))?;
        self.scenario_draw().check()?;
        if self.validate_every > 0 && self.validation_maps == 0 {
            return bad(
                "validation_maps",
                "must be at least 1 when validate_every > 0",
            );
        }
        harness::check_memory(&self.memory_needs(), harness::physical_memory())
    }

    /// The two allocations that grow with the sizes: the replay once it holds `replay_steps`
    /// timesteps (plus one episode beyond, before the oldest is dropped), every robot's
    /// bit-packed frame per timestep; and a minibatch's maps (this and the next decision's
    /// `history` frames per robot, as f32).
    pub fn memory_needs(&self) -> Vec<(String, u64)> {
        let (h, w) = (self.map_height as u64, self.map_width as u64);
        let team = self.scenario.num_robots as u64;
        let frame_bits = FRAME_CHANNELS as u64 * h * w;
        let steps = self.replay_steps as u64 + self.scenario.step_cap as u64;
        let replay = steps * team * frame_bits.div_ceil(64) * 8;
        let batch = 2 * self.batch_size as u64 * team * self.history as u64 * frame_bits * 4;
        vec![
            (
                format!(
                    "the replay at capacity (`replay_steps` {} × {team} robots × {h} × {w} frames)",
                    self.replay_steps
                ),
                replay,
            ),
            (
                format!(
                    "a minibatch (`batch_size` {} × {team} robots × `history` {} × {h} × {w} frames, twice)",
                    self.batch_size, self.history
                ),
                batch,
            ),
        ]
    }

    /// The networks' sizes.
    pub fn nets(&self) -> DmeConfig {
        DmeConfig::new()
            .with_map_height(self.map_height)
            .with_map_width(self.map_width)
            .with_team_size(self.scenario.num_robots)
            .with_history(self.history)
            .with_critic_history(self.critic_history)
            .with_hidden(self.hidden)
    }

    /// How this run draws its training and validation scenarios: as MADE-Net's runs do, so the
    /// two methods train and validate on the same generated maps.
    pub fn scenario_draw(&self) -> ScenarioDraw {
        ScenarioDraw::new(
            self.map_height,
            self.map_width,
            (self.density_min, self.density_max),
            self.scenario.num_robots,
            self.scenario.movement,
        )
    }

    /// The run's fixed validation maps ([`ScenarioDraw::validation_maps`]).
    pub fn validation_maps(&self) -> Result<Vec<TrialSpec>, TrainError> {
        self.scenario_draw()
            .validation_maps(self.seed, self.validation_maps, &self.scenario)
    }

    fn update_params(&self) -> UpdateParams {
        UpdateParams {
            tau: self.tau,
            actor_lr: self.actor_lr,
            critic_lr: self.critic_lr,
            temperature: self.temperature,
            logit_penalty: self.logit_penalty,
        }
    }
}

/// One played episode, as the replay keeps it: per timestep and robot the frame (bit-packed),
/// pose vector, valid sectors, action in force, whether it decided, and its reward.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Episode {
    team: usize,
    /// u64 words per packed frame.
    words: usize,
    frames: Vec<u64>,
    poses: Vec<f32>,
    /// Bit k set: sector k valid.
    masks: Vec<u8>,
    /// Sector in force, or [`NO_ACTION`].
    actions: Vec<u8>,
    decided: Vec<bool>,
    rewards: Vec<f32>,
    /// Per robot, the timesteps at which it chose a sector: its transitions start there.
    decisions: Vec<Vec<u32>>,
    steps: usize,
    /// The team explored the whole map before the step cap.
    pub complete: bool,
}

/// The stored action of a robot that had no valid sector (it stayed).
pub const NO_ACTION: u8 = u8::MAX;

impl Episode {
    fn new(team: usize) -> Self {
        Episode {
            team,
            decisions: vec![Vec::new(); team],
            ..Episode::default()
        }
    }
    /// Timesteps played.
    pub fn len(&self) -> usize {
        self.steps
    }
    /// True if no timestep was played.
    pub fn is_empty(&self) -> bool {
        self.steps == 0
    }
    fn push(&mut self, records: &[crate::policy::StepRecord], rewards: &[f32]) {
        for (i, r) in records.iter().enumerate() {
            let words = pack_bits(&r.frame);
            self.words = words.len();
            self.frames.extend(words);
            self.poses.extend(&r.pose);
            self.masks.push(
                r.mask
                    .iter()
                    .enumerate()
                    .fold(0u8, |m, (k, &v)| m | ((v as u8) << k)),
            );
            self.actions.push(r.action.unwrap_or(NO_ACTION));
            self.decided.push(r.decided);
            if r.decided && r.action.is_some() {
                self.decisions[i].push(self.steps as u32);
            }
        }
        self.rewards.extend(rewards);
        self.steps += 1;
    }
    /// Sum of all robots' rewards.
    pub fn team_return(&self) -> f64 {
        self.rewards.iter().map(|&r| f64::from(r)).sum()
    }
}

/// DME-DRL's episode recorder: the robots' own (sampling, recording) policies decide; after
/// each timestep their decisions and rewards go into the episode, and every `update_every`
/// timesteps, once the replay is warm, one MADDPG update runs and the acting actors take the
/// new weights.
struct Stepping<'a> {
    cfg: &'a DmeTrainConfig,
    net_cfg: &'a DmeConfig,
    params: &'a UpdateParams,
    slots: DecisionSlots,
    acting: &'a [SharedActor],
    episode: Episode,
    nets: &'a mut Maddpg,
    replay: &'a Replay,
    state: &'a mut State,
    logs: &'a mut Logs<MaddpgUpdateRow>,
}

impl episode::Recorder for Stepping<'_> {
    type Error = TrainError;

    fn stepped(&mut self, trial: &Trial) -> Result<(), TrainError> {
        let (cfg, team) = (self.cfg, self.cfg.scenario.num_robots);
        let records: Vec<_> = self
            .slots
            .lock()
            .expect("recorder lock")
            .iter_mut()
            .map(|r| r.take())
            .collect();
        let records: Vec<_> = records
            .into_iter()
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| TrainError::Other("a robot skipped its decision".into()))?;
        let moved = trial.world().executed_moves();
        let r: Vec<f32> = (0..team)
            .map(|i| (trial.rewards().robots[i] - cfg.move_cost * moved[i].length()) as f32)
            .collect();
        self.episode.push(&records, &r);
        let (state, replay) = (&mut *self.state, self.replay);
        state.steps += 1;
        let ready =
            replay.steps >= cfg.warmup_steps && (0..team).all(|i| replay.transitions(i) > 0);
        if ready && state.steps % cfg.update_every == 0 {
            let mut rng = stream(cfg.seed, "dme/batch", state.updates);
            let batches: Vec<Batch> = (0..team)
                .map(|i| replay.sample(i, cfg.batch_size, self.net_cfg, cfg.gamma, &mut rng))
                .collect();
            let stats = self.nets.update(
                &batches,
                &mut stream(cfg.seed, "dme/gumbel", state.updates),
                self.params,
            );
            for (i, a) in self.acting.iter().enumerate() {
                *a.write().expect("actor lock") = self.nets.acting_actor(i);
            }
            self.logs.updates.append(&MaddpgUpdateRow {
                update: state.updates,
                critic_loss: stats.critic_loss.into(),
                actor_loss: stats.actor_loss.into(),
            })?;
            self.logs
                .scalar("loss/critic", stats.critic_loss, state.updates)?;
            self.logs
                .scalar("loss/actor", stats.actor_loss, state.updates)?;
            state.updates += 1;
        }
        Ok(())
    }
}

/// The replay: whole episodes, the oldest dropped once more than `capacity` timesteps.
#[derive(Default, Serialize, Deserialize)]
struct Replay {
    episodes: VecDeque<Episode>,
    steps: usize,
}

impl Replay {
    fn push(&mut self, e: Episode, capacity: usize) {
        self.steps += e.len();
        self.episodes.push_back(e);
        while self.steps > capacity && self.episodes.len() > 1 {
            let old = self.episodes.pop_front().expect("non-empty");
            self.steps -= old.len();
        }
    }

    /// Robot i's transitions in the replay.
    fn transitions(&self, robot: usize) -> usize {
        self.episodes.iter().map(|e| e.decisions[robot].len()).sum()
    }

    /// `n` of robot `robot`'s transitions drawn uniformly (with replacement), as a [`Batch`].
    fn sample(
        &self,
        robot: usize,
        n: usize,
        cfg: &DmeConfig,
        gamma: f32,
        rng: &mut madenet_world::rng::Rng,
    ) -> Batch {
        let team = cfg.team_size;
        let frame_len = FRAME_CHANNELS * cfg.map_height * cfg.map_width;
        let robot_len = cfg.history * frame_len;
        let pose_len = cfg.pose_len();
        let mut b = Batch {
            size: n,
            maps: vec![0.0; n * team * robot_len],
            next_maps: vec![0.0; n * team * robot_len],
            poses: Vec::with_capacity(n * team * pose_len),
            next_poses: Vec::with_capacity(n * team * pose_len),
            actions: vec![0.0; n * team * SECTORS],
            next_actions: vec![0.0; n * team * SECTORS],
            masks: vec![0.0; n * team * SECTORS],
            next_masks: vec![0.0; n * team * SECTORS],
            next_deciding: vec![0.0; n * team],
            rewards: Vec::with_capacity(n),
            discounts: Vec::with_capacity(n),
        };
        let total = self.transitions(robot);
        for k in 0..n {
            let mut g = rng.random_range(0..total);
            let e = self
                .episodes
                .iter()
                .find(|e| {
                    g < e.decisions[robot].len() || {
                        g -= e.decisions[robot].len();
                        false
                    }
                })
                .expect("index within the replay");
            let t = e.decisions[robot][g] as usize;
            let next = e.decisions[robot].get(g + 1).map(|&s| s as usize);
            let end = next.unwrap_or(e.len());
            let (mut ret, mut disc) = (0.0f32, 1.0f32);
            for s in t..end {
                ret += disc * e.rewards[s * team + robot];
                disc *= gamma;
            }
            b.rewards.push(ret);
            b.discounts.push(if next.is_some() { disc } else { 0.0 });
            let at_next = next.unwrap_or(t);
            for (step, maps, poses, masks, actions) in [
                (t, &mut b.maps, &mut b.poses, &mut b.masks, &mut b.actions),
                (
                    at_next,
                    &mut b.next_maps,
                    &mut b.next_poses,
                    &mut b.next_masks,
                    &mut b.next_actions,
                ),
            ] {
                for i in 0..team {
                    for slot in 0..cfg.history {
                        let s = history_step(step, cfg.history, slot);
                        let at = ((k * team + i) * cfg.history + slot) * frame_len;
                        let words = &e.frames[(s * team + i) * e.words..][..e.words];
                        unpack_bits(words, &mut maps[at..at + frame_len]);
                    }
                    let m = e.masks[step * team + i];
                    for a in 0..SECTORS {
                        masks[(k * team + i) * SECTORS + a] = ((m >> a) & 1) as f32;
                    }
                    let a = e.actions[step * team + i];
                    if a != NO_ACTION {
                        actions[(k * team + i) * SECTORS + a as usize] = 1.0;
                    }
                }
                poses.extend(&e.poses[step * team * pose_len..(step + 1) * team * pose_len]);
            }
            for i in 0..team {
                b.next_deciding[k * team + i] = e.decided[at_next * team + i] as u8 as f32;
            }
        }
        b
    }
}

/// Counters saved with a checkpoint.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct State {
    episode: u64,
    /// Timesteps played.
    steps: u64,
    updates: u64,
    best_validation: Option<f64>,
    wall_s: f64,
}

fn model_info(cfg: &DmeTrainConfig, state: &State, validation_steps: Option<f64>) -> ModelInfo {
    ModelInfo {
        method: METHOD.into(),
        map_height: cfg.map_height,
        map_width: cfg.map_width,
        team_size: cfg.scenario.num_robots,
        history: cfg.history,
        hidden: cfg.hidden,
        actors: (0..cfg.scenario.num_robots)
            .map(|i| format!("actor{i}.bpk"))
            .collect(),
        digests: Vec::new(), // filled in by `save_model`
        episode: state.episode,
        updates: state.updates,
        validation_steps,
    }
}

fn save_err<E: std::fmt::Display>(p: &Path) -> impl FnOnce(E) -> TrainError + '_ {
    move |e| TrainError::Io {
        path: p.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes the actors and `model.toml` into `dir`, atomically.
fn save_model(dir: &Path, nets: &Maddpg, info: &ModelInfo) -> Result<(), TrainError> {
    replace_dir(dir, |tmp| {
        for (i, name) in info.actors.iter().enumerate() {
            let p = tmp.join(name);
            nets.acting_actor(i)
                .into_record()
                .save(&p)
                .map_err(save_err(&p))?;
        }
        let info = ModelInfo {
            digests: harness::file_digests(tmp, &info.actors)?,
            ..info.clone()
        };
        harness::write_toml(&tmp.join("model.toml"), &info)
    })
}

/// Everything a resumed run needs: networks, targets, Adam states, replay, counters.
fn checkpoint(dir: &Path, nets: &Maddpg, state: &State, replay: &Replay) -> Result<(), TrainError> {
    replace_dir(dir, |tmp| {
        for i in 0..nets.actors.len() {
            let files: [(String, ModuleRecord); 4] = [
                (format!("actor{i}"), nets.actors[i].clone().into_record()),
                (format!("critic{i}"), nets.critics[i].clone().into_record()),
                (
                    format!("actor{i}_target"),
                    nets.target_actors[i].clone().into_record(),
                ),
                (
                    format!("critic{i}_target"),
                    nets.target_critics[i].clone().into_record(),
                ),
            ];
            for (stem, rec) in files {
                let p = tmp.join(format!("{stem}.bpk"));
                rec.save(&p).map_err(save_err(&p))?;
            }
            for (stem, op) in [
                (format!("actor{i}_optim"), &nets.actor_optims[i]),
                (format!("critic{i}_optim"), &nets.critic_optims[i]),
            ] {
                let p = tmp.join(format!("{stem}.bpk"));
                op.save(&p).map_err(save_err(&p))?;
            }
        }
        harness::write_postcard(&tmp.join("replay.bin"), replay)?;
        harness::write_json(&tmp.join("state.json"), state)
    })
}

fn restore(dir: &Path, mut nets: Maddpg) -> Result<(Maddpg, State, Replay), TrainError> {
    let p = |stem: String| dir.join(format!("{stem}.bpk"));
    for i in 0..nets.actors.len() {
        nets.actors[i] = harness::load_weights(nets.actors[i].clone(), &p(format!("actor{i}")))?;
        nets.critics[i] = harness::load_weights(nets.critics[i].clone(), &p(format!("critic{i}")))?;
        nets.target_actors[i] = harness::load_weights(
            nets.target_actors[i].clone(),
            &p(format!("actor{i}_target")),
        )?;
        nets.target_critics[i] = harness::load_weights(
            nets.target_critics[i].clone(),
            &p(format!("critic{i}_target")),
        )?;
        for (stem, op) in [
            (format!("actor{i}_optim"), &mut nets.actor_optims[i]),
            (format!("critic{i}_optim"), &mut nets.critic_optims[i]),
        ] {
            let p = dir.join(format!("{stem}.bpk"));
            let loaded = std::mem::replace(op, burn::optim::AdamConfig::new().init())
                .load(&p)
                .map_err(save_err(&p))?;
            *op = loaded;
        }
    }
    let state: State = harness::read_json(&dir.join("state.json"))?;
    let replay: Replay = harness::read_postcard(&dir.join("replay.bin"))?;
    Ok((nets, state, replay))
}

/// Validation: the greedy actors on the generated validation maps (its mean team return is
/// Eq. 8's, for comparison with MADE-Net's runs).
pub fn validate(cfg: &DmeTrainConfig, nets: &Maddpg) -> Result<Validation, TrainError> {
    let model = Model {
        info: model_info(cfg, &State::default(), None),
        actors: (0..nets.actors.len())
            .map(|i| Arc::new(RwLock::new(nets.acting_actor(i))))
            .collect(),
    };
    let mut registry = PolicyRegistry::default();
    model.register(&mut registry, "candidate", "the actors being trained");
    scenario::validate(
        &cfg.validation_maps()?,
        &cfg.validation_csp,
        &registry,
        "candidate",
    )
}

/// DME-DRL as a [`Learner`] (`dme-drl`).
pub struct DmeLearner;

impl Learner for DmeLearner {
    type Config = DmeTrainConfig;
    const METHODS: &'static [&'static str] = &[METHOD];

    madenet_harness::learner_config!(model = Model);

    /// The loop: episodes, updates, validation, checkpoints ([`EpisodeRun`]).
    fn train_loop(run: TrainRun<'_, DmeTrainConfig>) -> Result<(), TrainError> {
        let (run_dir, cfg, progress) = (run.dir, run.cfg, run.progress);
        let ckpt_dir = run_dir.join("checkpoint");
        let device = Device::flex().autodiff();
        device.seed(cfg.seed);
        let net_cfg = cfg.nets();
        let nets = Maddpg::new(&net_cfg, &device);
        let (mut nets, mut state, mut replay) = if run.resuming {
            restore(&ckpt_dir, nets)?
        } else {
            (nets, State::default(), Replay::default())
        };
        let mut run = EpisodeRun::<MaddpgUpdateRow>::open(
            run_dir,
            Seen {
                episodes: state.episode,
                updates: state.updates,
                first_loss_step: 0, // `loss/*` steps count updates from 0
            },
            state.wall_s,
            state.best_validation,
            madenet_harness::cadence!(cfg),
        )?;
        let params = cfg.update_params();
        let team = cfg.scenario.num_robots;
        let draw = cfg.scenario_draw();
        // The acting actors: the policies read them, the trainer replaces them after each update.
        let acting: Vec<SharedActor> = (0..team)
            .map(|i| Arc::new(RwLock::new(nets.acting_actor(i))))
            .collect();
        let rewards = RewardConfig {
            new_cell: cfg.new_cell_reward,
            reobserved_cell: 0.0,
            interaction_from: u32::MAX,
            ..RewardConfig::default()
        };
        while state.episode < cfg.episodes {
            let e = state.episode;
            let seed = derive_seed(cfg.seed, "dme", e);
            let (map, starts) = draw.draw(seed)?;
            let csp = stream(seed, "csp", 0).random::<f64>();
            let recorder: DecisionSlots = Arc::new(Mutex::new(vec![None; team]));
            let mut registry = PolicyRegistry::default();
            {
                let (acting, recorder, history) = (acting.clone(), recorder.clone(), cfg.history);
                registry.register("dme-train", "DME-DRL actors sampling", move |ctx| {
                    Box::new(
                        DmePolicy::new(
                            "dme-train",
                            ctx.robot,
                            Arc::clone(&acting[ctx.robot]),
                            history,
                        )
                        .sampling(stream(ctx.seed, "dme/sample", ctx.robot as u64))
                        .recording(recorder.clone()),
                    )
                });
            }
            let spec = TrialSpec {
                map,
                map_name: format!("train_dme_{e}"),
                starts,
                config: ScenarioConfig {
                    comm_success_prob: csp,
                    ..cfg.scenario.clone()
                },
                policy: "dme-train".into(),
                seed,
            };
            let mut trial = Trial::with_registry(spec, &registry)
                .map_err(|err| TrainError::Other(err.to_string()))?
                .reward_config(rewards.clone());
            let mut stepping = Stepping {
                cfg,
                net_cfg: &net_cfg,
                params: &params,
                slots: recorder,
                acting: &acting,
                episode: Episode::new(team),
                nets: &mut nets,
                replay: &replay,
                state: &mut state,
                logs: &mut run.logs,
            };
            let end = episode::run(&mut trial, &mut stepping)?;
            let mut episode = stepping.episode;
            episode.complete = end.complete;
            let (steps, reward) = (episode.len(), episode.team_return());
            run.logs.episodes.append(&EpisodeRow {
                episode: e,
                env: madenet_trainlog::Env::Dec,
                csp,
                steps: steps as u32,
                team_reward: reward,
                complete: episode.complete,
                epsilon: 0.0,
                updates: state.updates,
                wall_s: run.clock.wall(),
            })?;
            run.logs.scalar("episode/reward", reward as f32, e)?;
            run.logs.scalar("episode/steps", steps as f32, e)?;
            replay.push(episode, cfg.replay_steps);
            state.episode += 1;
            if run.validates(state.episode) {
                let v = validate(cfg, &nets)?;
                run.log_validation(state.episode, state.updates, &v)?;
                let steps = v.mean_steps;
                if harness::new_best(&mut state.best_validation, steps) {
                    save_model(
                        &run_dir.join("best"),
                        &nets,
                        &model_info(cfg, &state, Some(steps)),
                    )?;
                }
            }
            let stopping = run.end_episode(state.episode, |wall_s| {
                state.wall_s = wall_s;
                checkpoint(&ckpt_dir, &nets, &state, &replay)?;
                save_model(&run_dir.join("last"), &nets, &model_info(cfg, &state, None))
            })?;
            progress(&run.progress(
                state.episode,
                state.updates,
                vec![("reward", reward, 2), ("steps", steps as f64, 0)],
            ));
            if stopping {
                break;
            }
        }
        Ok(())
    }
}

/// Trains into `run_dir` ([`harness::train`]), calling `progress` after each episode.
pub fn train(
    run_dir: &Path,
    cfg: Option<DmeTrainConfig>,
    progress: &mut (dyn FnMut(&Progress) + Send),
) -> Result<(), TrainError> {
    harness::train::<DmeLearner>(run_dir, cfg, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_needs_are_the_replay_at_capacity_and_a_minibatch() {
        let gib = 1u64 << 30;
        let cfg = DmeTrainConfig::default();
        assert!(harness::check_memory(&cfg.memory_needs(), Some(gib)).is_ok());
        let big = DmeTrainConfig {
            map_height: 200,
            map_width: 200,
            replay_steps: 1_000_000,
            ..cfg.clone()
        };
        let needs = big.memory_needs();
        // (1 000 000 + step cap) timesteps × 3 robots × 4 × 200 × 200 bits, in u64 words.
        let steps = 1_000_000 + cfg.scenario.step_cap as u64;
        assert_eq!(needs[0].1, steps * 3 * 2_500 * 8);
        let err = harness::check_memory(&needs, Some(24 * gib)).unwrap_err();
        assert!(
            err.contains("24.0 GiB") && err.contains("`replay_steps` 1000000"),
            "{err}"
        );
        assert!(
            harness::check_memory(&needs, None).is_ok(),
            "unknown: not checked"
        );
    }
}
