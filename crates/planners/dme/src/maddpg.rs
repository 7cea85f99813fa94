//! MADDPG (Lowe et al. 2017) for DME-DRL's sector actions, read top to bottom.
//!
//! Every robot i has an actor μ_i (its own frame history and pose vector → sector logits) and a
//! centralized critic Q_i (every robot's newest frames, actions in force and poses → value),
//! each with a target copy. A robot's action lasts until its goal is reached or void, so robots
//! decide at different timesteps; a transition of robot i runs from one of its decisions to
//! its next (reward `R = Σ γ^k r_i`, discount `γ^τ` after τ timesteps, 0 at the episode's end).
//! One update draws, for each robot i, a minibatch of its own transitions (as the original) and:
//!
//! 1. **Critic**: `y = R + γ^τ · Q'_i(s', a')`, where a robot j deciding at the next
//!    decision time contributes the Gumbel-softmax sample of target actor μ'_j (masked to its
//!    valid sectors) and a robot still busy its action in force; one Adam step on the mean of
//!    `(Q_i(s, a) − y)²` with the actions in force at the decision.
//! 2. **Actor**: robot i's action replaced by the Gumbel-softmax sample of μ_i, one Adam step
//!    descending `−Q_i(s, a_{−i}, μ_i(o_i)) + λ · mean(logits²)` (the logit penalty of the MADDPG
//!    authors' code keeps masked-out logits from drifting). The critic's map features enter as
//!    constants: only its head is differentiated, toward the action.
//! 3. **Targets**: θ' ← τ θ + (1 − τ) θ' for every actor and critic.
//!
//! The Gumbel noise comes from a named random stream, so an update is reproducible.

use crate::nets::{Actor, Critic, DmeConfig};
use crate::SECTORS;
use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use madenet_world::rng::Rng;
use rand::RngExt;

/// The hyperparameters of an update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateParams {
    /// Soft target update rate τ (the original: 0.01).
    pub tau: f32,
    /// The actors' Adam step size (the original: 1e-3).
    pub actor_lr: f64,
    /// The critics' Adam step size (the original: 1e-3).
    pub critic_lr: f64,
    /// Gumbel-softmax temperature (the original: 1).
    pub temperature: f32,
    /// λ of the actor's logit penalty.
    pub logit_penalty: f32,
}

/// A minibatch of one robot's transitions on the host, row-major.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Batch {
    /// B, the number of transitions (rows of every field below).
    pub size: usize,
    /// Every robot's stacked frames at the decision `[B][team · 4 · history][H][W]`, robot-major.
    pub maps: Vec<f32>,
    /// Every robot's pose vector `[B][team · 2 · team]`.
    pub poses: Vec<f32>,
    /// Every robot's action in force, one-hot `[B][team · 8]` (all zero for a robot without one).
    pub actions: Vec<f32>,
    /// Valid sectors `[B][team · 8]` (0/1).
    pub masks: Vec<f32>,
    /// The robot's discounted reward until its next decision `[B]`.
    pub rewards: Vec<f32>,
    /// γ^τ to the next decision, 0 if the episode ended first `[B]`.
    pub discounts: Vec<f32>,
    /// `maps` at the robot's next decision (this and the other `next_` fields are ignored
    /// where the discount is 0).
    pub next_maps: Vec<f32>,
    /// `poses` at the robot's next decision.
    pub next_poses: Vec<f32>,
    /// `masks` at the robot's next decision: the sectors the target actors may sample.
    pub next_masks: Vec<f32>,
    /// Actions in force at the next decision `[B][team · 8]`, kept by robots not deciding then.
    pub next_actions: Vec<f32>,
    /// Who decides at the next decision `[B][team]`: 1 samples its target actor μ'_j, 0 keeps
    /// its action in force.
    pub next_deciding: Vec<f32>,
}

/// What an update reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateStats {
    /// Mean over robots of the critics' TD loss before their step.
    pub critic_loss: f32,
    /// Mean over robots of −Q_i under the actor's own action.
    pub actor_loss: f32,
}

/// The learner's networks: per robot an actor and a critic (online on the autodiff device,
/// targets on the plain one) and their optimizers.
pub struct Maddpg {
    /// Sizes of every actor and critic.
    pub cfg: DmeConfig,
    /// Online actors μ_i, one per robot (autodiff device).
    pub actors: Vec<Actor>,
    /// Online centralized critics Q_i, one per robot (autodiff device).
    pub critics: Vec<Critic>,
    /// Target actors μ'_i (plain device), soft-updated toward `actors` at rate τ.
    pub target_actors: Vec<Actor>,
    /// Target critics Q'_i (plain device), soft-updated toward `critics` at rate τ.
    pub target_critics: Vec<Critic>,
    /// Adam state of each actor, in robot order.
    pub actor_optims: Vec<ModuleOptimizer>,
    /// Adam state of each critic, in robot order.
    pub critic_optims: Vec<ModuleOptimizer>,
}

impl Maddpg {
    /// Fresh networks on `device` (an autodiff device), targets equal to them.
    pub fn new(cfg: &DmeConfig, device: &Device) -> Self {
        let n = cfg.team_size;
        let actors: Vec<Actor> = (0..n).map(|_| cfg.actor(device)).collect();
        let critics: Vec<Critic> = (0..n).map(|_| cfg.critic(device)).collect();
        Maddpg {
            cfg: cfg.clone(),
            target_actors: actors.iter().map(|a| a.valid()).collect(),
            target_critics: critics.iter().map(|c| c.valid()).collect(),
            actors,
            critics,
            actor_optims: (0..n).map(|_| AdamConfig::new().init()).collect(),
            critic_optims: (0..n).map(|_| AdamConfig::new().init()).collect(),
        }
    }

    /// One MADDPG update, `batches[i]` holding robot i's transitions (steps 1–3 of the module
    /// docs).
    pub fn update(&mut self, batches: &[Batch], noise: &mut Rng, p: &UpdateParams) -> UpdateStats {
        let cfg = self.cfg.clone();
        let n = cfg.team_size;
        let (h, w, c) = (cfg.map_height, cfg.map_width, cfg.robot_channels());
        let pose_len = cfg.pose_len();
        let ad = self.actors[0].devices()[0].clone();
        let plain = Device::flex();
        let (mut critic_loss, mut actor_loss) = (0.0, 0.0);
        for (i, batch) in batches.iter().enumerate().take(n) {
            let b = batch.size;
            let t2 = |v: &[f32], cols: usize, d: &Device| {
                Tensor::<2>::from_data(TensorData::new(v.to_vec(), [b, cols]), d)
            };
            let t4 = |v: &[f32], d: &Device| {
                Tensor::<4>::from_data(TensorData::new(v.to_vec(), [b, n * c, h, w]), d)
            };

            // 1a. The target, without gradients: deciding robots sample their target actor,
            // busy ones keep their action.
            let next_maps = t4(&batch.next_maps, &plain);
            let next_poses = t2(&batch.next_poses, n * pose_len, &plain);
            let next_masks = t2(&batch.next_masks, n * SECTORS, &plain);
            let in_force = t2(&batch.next_actions, n * SECTORS, &plain);
            let deciding = t2(&batch.next_deciding, n, &plain);
            let next_actions: Vec<Tensor<2>> = (0..n)
                .map(|j| {
                    let logits = self.target_actors[j].forward(
                        next_maps.clone().narrow(1, j * c, c),
                        next_poses.clone().narrow(1, j * pose_len, pose_len),
                    );
                    let sampled = gumbel_softmax(
                        logits,
                        next_masks.clone().narrow(1, j * SECTORS, SECTORS),
                        gumbel(b, noise, &plain),
                        p.temperature,
                    );
                    let d = deciding.clone().narrow(1, j, 1);
                    sampled * d.clone()
                        + in_force.clone().narrow(1, j * SECTORS, SECTORS) * d.neg().add_scalar(1.0)
                })
                .collect();
            let q = self.target_critics[i].forward(
                critic_maps(&cfg, next_maps),
                Tensor::cat(next_actions, 1),
                next_poses,
            );
            let q = q
                .into_data()
                .try_into_vec_as::<f32>()
                .expect("Q readable as f32");
            let y: Vec<f32> = (0..b)
                .map(|k| batch.rewards[k] + batch.discounts[k] * q[k])
                .collect();

            // 1b. Critic i: one step on the squared TD error.
            let maps = t4(&batch.maps, &ad);
            let state = critic_maps(&cfg, maps.clone());
            let poses = t2(&batch.poses, n * pose_len, &ad);
            let actions = t2(&batch.actions, n * SECTORS, &ad);
            let critic = self.critics[i].clone();
            let q = critic.forward(state, actions.clone(), poses.clone());
            let y = Tensor::<2>::from_data(TensorData::new(y, [b, 1]), &ad);
            let loss = (q - y).powf_scalar(2.0).mean();
            critic_loss += scalar(loss.clone()) / n as f32;
            let grads = GradientsParams::from_grads(loss.backward(), &critic);
            self.critics[i] = self.critic_optims[i].step(p.critic_lr, critic, grads);

            // 2. Actor i: its own action replaced by its Gumbel-softmax sample. The updated
            // critic's trunk features carry no gradient (only the action input changes), so
            // they are computed once without the autodiff graph.
            let actor = self.actors[i].clone();
            let logits = actor.forward(
                maps.narrow(1, i * c, c),
                poses.clone().narrow(1, i * pose_len, pose_len),
            );
            let mask = t2(&batch.masks, n * SECTORS, &ad).narrow(1, i * SECTORS, SECTORS);
            let own = gumbel_softmax(logits.clone(), mask, gumbel(b, noise, &ad), p.temperature);
            let joint: Vec<Tensor<2>> = (0..n)
                .map(|j| {
                    if j == i {
                        own.clone()
                    } else {
                        actions.clone().narrow(1, j * SECTORS, SECTORS)
                    }
                })
                .collect();
            let features = self.critics[i]
                .valid()
                .features(critic_maps(&cfg, t4(&batch.maps, &plain)));
            let features = Tensor::<2>::from_data(features.into_data(), &ad);
            let q = self.critics[i].head(features, Tensor::cat(joint, 1), poses);
            let pg = q.mean().neg();
            actor_loss += scalar(pg.clone()) / n as f32;
            let loss = pg + logits.powf_scalar(2.0).mean().mul_scalar(p.logit_penalty);
            let grads = GradientsParams::from_grads(loss.backward(), &actor);
            self.actors[i] = self.actor_optims[i].step(p.actor_lr, actor, grads);
        }

        // 3. Soft target updates.
        for i in 0..n {
            self.target_actors[i] =
                soft_update(self.target_actors[i].clone(), &self.actors[i], p.tau);
            self.target_critics[i] =
                soft_update(self.target_critics[i].clone(), &self.critics[i], p.tau);
        }
        UpdateStats {
            critic_loss,
            actor_loss,
        }
    }

    /// Robot i's actor for acting (plain device).
    pub fn acting_actor(&self, i: usize) -> Actor {
        self.actors[i].valid()
    }
}

/// The critics' map input: each robot's newest `critic_history` frames out of its stacked
/// history `[b, team · 4 · history, H, W]`.
fn critic_maps(cfg: &DmeConfig, maps: Tensor<4>) -> Tensor<4> {
    let (c, cc) = (cfg.robot_channels(), cfg.critic_robot_channels());
    if c == cc {
        return maps;
    }
    Tensor::cat(
        (0..cfg.team_size)
            .map(|j| maps.clone().narrow(1, j * c + c - cc, cc))
            .collect(),
        1,
    )
}

fn scalar(t: Tensor<1>) -> f32 {
    t.into_data()
        .try_into_vec_as::<f32>()
        .expect("scalar readable as f32")[0]
}

/// `[b, 8]` standard Gumbel noise −ln(−ln u) from `rng`.
fn gumbel(b: usize, rng: &mut Rng, device: &Device) -> Tensor<2> {
    let g: Vec<f32> = (0..b * SECTORS)
        .map(|_| {
            let u = rng.random::<f64>().clamp(1e-12, 1.0 - 1e-12);
            -(-(u.ln())).ln() as f32
        })
        .collect();
    Tensor::from_data(TensorData::new(g, [b, SECTORS]), device)
}

/// softmax((logits + g) / τ) over the valid sectors; all zero where none is valid.
pub fn gumbel_softmax(
    logits: Tensor<2>,
    mask: Tensor<2>,
    g: Tensor<2>,
    temperature: f32,
) -> Tensor<2> {
    // Invalid sectors get −1e9 before the softmax, then the mask zeroes rows with none valid.
    let off = mask.clone().sub_scalar(1.0).mul_scalar(1e9);
    let y = burn::tensor::activation::softmax((logits + g).div_scalar(temperature) + off, 1);
    y * mask
}

/// θ' ← τ θ + (1 − τ) θ', parameter by parameter (both modules have the same structure).
pub fn soft_update<M: Module>(target: M, online: &M, tau: f32) -> M {
    struct Collect(Vec<TensorData>);
    impl ModuleVisitor for Collect {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            self.0.push(param.val().into_data());
        }
    }
    struct Blend {
        online: std::vec::IntoIter<TensorData>,
        tau: f32,
    }
    impl ModuleMapper for Blend {
        fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
            let data = self.online.next().expect("same module structure");
            let tau = self.tau;
            param.map(|t| {
                let o = Tensor::<D>::from_data(data, &t.device());
                t.mul_scalar(1.0 - tau) + o.mul_scalar(tau)
            })
        }
    }
    let mut collect = Collect(Vec::new());
    online.visit(&mut collect);
    target.map(&mut Blend {
        online: collect.0.into_iter(),
        tau,
    })
}
