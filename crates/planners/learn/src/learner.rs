//! The updates of the CEP (Eq. 5) and the DEPs (Eq. 6), read top to bottom.
//!
//! A batch is a set of [`Window`]s: `trace_len + 1` consecutive joint decisions of an episode
//! (fewer at its end), unrolled from zero LSTM state at the window's start and padded at the
//! end — MacDec-DDRQN's `trace_len` sampling; whole episodes of 100+ joint decisions would cost
//! ~8× more per update. A step enters the loss when its successor lies inside the window (the
//! last one only bootstraps) or when it is terminal; padded steps never do. Targets
//! are computed on the host from the networks' Q values:
//!
//! * **CEP** (Eq. 5): `y = r + γ · Q'_φ(δ', a*)`, `a* = argmax Q_φ(δ', ·)` over the joint actions
//!   that keep every robot whose macro action is still running at the next joint decision fixed
//!   to it (the conditional argmax) and the others on valid candidates. `r` is the team reward
//!   summed over the macro step.
//! * **DEP** (Eq. 6): `y_i = r_i + γ · Q'_θi(δ'_i, a*_i)` where `a*_i` is robot i's part of the
//!   CEP's conditional argmax on the joint history at robot i's next decision.
//! * **MADE-Net-DT**: a plain double DRQN per robot, `a*_i = argmax Q_θi(δ'_i, ·)` over i's valid
//!   candidates.
//!
//! Terminal macro steps (the episode ended inside them) have no bootstrap term. The loss is the
//! mean squared TD error over the real (unpadded) steps.

use crate::env::Episode;

use crate::obs::unpack_bits;
use crate::{
    conditional_argmax, conditional_joint_mask, gather_q, joint_actions, joint_index,
    masked_argmax_slice, QNet,
};
use burn::module::Module;
use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};

/// The hyperparameters an update needs (a view of [`crate::TrainConfig`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateParams {
    /// γ, applied once per macro step.
    pub gamma: f32,
    /// Adam step size.
    pub learning_rate: f64,
    /// Rewards are multiplied by this before entering the targets.
    pub reward_scale: f32,
    /// Map height H in cells (rows of the map images).
    pub map_height: usize,
    /// Map width W in cells (columns of the map images).
    pub map_width: usize,
    /// Team size |I|.
    pub team: usize,
    /// Goal candidates per robot |G| (macro actions per robot).
    pub goals: usize,
}

/// Sequences laid out for the networks: `[batch, time, …]` host buffers plus per-step targets'
/// ingredients.
struct Sequences {
    batch: usize,
    time: usize,
    maps: Vec<f32>,
    obs: Vec<f32>,
    obs_dim: usize,
    actions: Vec<usize>,
    rewards: Vec<f32>,
    /// 1 where the macro step has a successor (bootstrap), 0 at terminal and padded steps.
    not_done: Vec<f32>,
    /// 1 on real steps, 0 on padding.
    real: Vec<f32>,
}

impl Sequences {
    fn new(batch: usize, time: usize, map_len: usize, obs_dim: usize) -> Self {
        let n = batch * time;
        Sequences {
            batch,
            time,
            maps: vec![0.0; n * map_len],
            obs: vec![0.0; n * obs_dim],
            obs_dim,
            actions: vec![0; n],
            rewards: vec![0.0; n],
            not_done: vec![0.0; n],
            real: vec![0.0; n],
        }
    }

    fn tensors(&self, p: &UpdateParams, device: &Device) -> (Tensor<5>, Tensor<3>) {
        let (b, t) = (self.batch, self.time);
        let maps = Tensor::from_data(
            TensorData::new(self.maps.clone(), [b, t, 4, p.map_height, p.map_width]),
            device,
        );
        let obs = Tensor::from_data(
            TensorData::new(self.obs.clone(), [b, t, self.obs_dim]),
            device,
        );
        (maps, obs)
    }
}

/// The online net's Q over a batch (kept for the gradient) with its host copy, and the target
/// net's Q on the host.
struct Forward {
    q: Tensor<3>,
    outputs: usize,
    qv: Vec<f32>,
    qt: Vec<f32>,
}

fn forward_both(online: &QNet, target: &QNet, seq: &Sequences, p: &UpdateParams) -> Forward {
    let (maps, obs) = seq.tensors(p, &online.devices()[0]);
    let (q, _) = online.forward(maps, obs, None);
    let outputs = q.dims()[2];
    let qv = host(q.clone());
    let (maps_t, obs_t) = seq.tensors(p, &crate::cpu());
    let qt = host(target.forward(maps_t, obs_t, None).0);
    Forward { q, outputs, qv, qt }
}

fn host(q: Tensor<3>) -> Vec<f32> {
    q.into_data()
        .try_into_vec_as::<f32>()
        .expect("Q values readable as f32")
}

/// Mean squared TD error over real steps, one Adam step; returns the loss.
fn td_step(
    net: QNet,
    optim: &mut ModuleOptimizer,
    seq: &Sequences,
    q_online: Tensor<3>,
    targets: Vec<f32>,
    lr: f64,
) -> (QNet, f32) {
    let device = q_online.device();
    let n = seq.batch * seq.time;
    let outputs = q_online.dims()[2];
    let q = gather_q(q_online.reshape([n, outputs]), &seq.actions);
    let y = Tensor::<1>::from_data(TensorData::new(targets, [n]), &device);
    let real = Tensor::<1>::from_data(TensorData::new(seq.real.clone(), [n]), &device);
    let count = seq.real.iter().sum::<f32>().max(1.0);
    let loss = (q - y).powf_scalar(2.0).mul(real).sum().div_scalar(count);
    adam_step(net, optim, lr, loss)
}

/// Backpropagates `loss` through `net` and takes one optimizer step with learning rate `lr`:
/// the updated net and the loss's value. Every learner's update ends here.
pub(crate) fn adam_step<M: Module>(
    net: M,
    optim: &mut ModuleOptimizer,
    lr: f64,
    loss: Tensor<1>,
) -> (M, f32) {
    let value = loss
        .clone()
        .into_data()
        .try_into_vec_as::<f32>()
        .expect("loss readable")[0];
    let grads = GradientsParams::from_grads(loss.backward(), &net);
    (optim.step(lr, net, grads), value)
}

/// A slice of an episode: joint decisions `start..end`.
#[derive(Clone, Copy, Debug)]
pub struct Window<'a> {
    /// The episode the decisions belong to.
    pub episode: &'a Episode,
    /// First joint decision (index into `episode.decisions`).
    pub start: usize,
    /// One past the last joint decision.
    pub end: usize,
}

impl<'a> Window<'a> {
    /// The window of `trace_len + 1` joint decisions from `start` (clipped to the episode).
    pub fn new(episode: &'a Episode, start: usize, trace_len: usize) -> Self {
        let end = (start + trace_len + 1).min(episode.decisions.len());
        Window {
            episode,
            start: start.min(end),
            end,
        }
    }
    /// The whole episode.
    pub fn whole(episode: &'a Episode) -> Self {
        Window {
            episode,
            start: 0,
            end: episode.decisions.len(),
        }
    }
    fn len(&self) -> usize {
        self.end - self.start
    }
}

/// The CEP's sequences of a batch of windows (their joint decisions).
fn cep_sequences(eps: &[Window<'_>], p: &UpdateParams) -> (Sequences, Vec<Vec<bool>>) {
    let map_len = 4 * p.map_height * p.map_width;
    let obs_dim = crate::joint_obs_dim_for(p.team, p.goals);
    let time = eps.iter().map(|w| w.len()).max().unwrap_or(1).max(1);
    let mut seq = Sequences::new(eps.len(), time, map_len, obs_dim);
    let joint = crate::joint_action_count(p.team, p.goals);
    // The conditional joint mask of the *next* decision, per (b, k).
    let mut next_mask = vec![Vec::new(); eps.len() * time];
    for (b, w) in eps.iter().enumerate() {
        let e = w.episode;
        for (k, d) in e.decisions[w.start..w.end].iter().enumerate() {
            let (k, kw) = (w.start + k, k);
            let j = d
                .joint
                .as_ref()
                .expect("CEP training needs joint observations");
            let idx = b * time + kw;
            unpack_bits(&j.map, &mut seq.maps[idx * map_len..(idx + 1) * map_len]);
            seq.obs[idx * obs_dim..(idx + 1) * obs_dim].copy_from_slice(&j.vec);
            seq.actions[idx] = joint_index(&d.actions, p.goals);
            seq.rewards[idx] = e.cep[k].reward * p.reward_scale;
            let terminal = e.cep[k].to.is_none();
            seq.real[idx] = (terminal || k + 1 < w.end) as u8 as f32;
            if !terminal && k + 1 < w.end {
                let nd = &e.decisions[k + 1];
                let fixed: Vec<Option<usize>> = (0..p.team)
                    .map(|i| (!nd.decided[i]).then_some(nd.actions[i]))
                    .collect();
                let masks = &nd.joint.as_ref().expect("joint observation").masks;
                next_mask[idx] = conditional_joint_mask(masks, &fixed);
                seq.not_done[idx] = 1.0;
            } else {
                next_mask[idx] = vec![false; joint];
            }
        }
    }
    (seq, next_mask)
}

/// One CEP update (Eq. 5) on `eps`; returns the new online net and the loss.
pub fn cep_update(
    online: QNet,
    target: &QNet,
    optim: &mut ModuleOptimizer,
    eps: &[Window<'_>],
    p: &UpdateParams,
) -> (QNet, f32) {
    let (seq, next_mask) = cep_sequences(eps, p);
    let Forward { q, outputs, qv, qt } = forward_both(&online, target, &seq, p);
    let targets: Vec<f32> = (0..seq.batch * seq.time)
        .map(|idx| {
            let mut y = seq.rewards[idx];
            if seq.not_done[idx] > 0.0 {
                let next = idx + 1;
                let row = next * outputs..(next + 1) * outputs;
                let a = masked_argmax_slice(&qv[row.clone()], &next_mask[idx])
                    .expect("admissible joint action");
                y += p.gamma * qt[row][a];
            }
            y
        })
        .collect();
    td_step(online, optim, &seq, q, targets, p.learning_rate)
}

/// A slice of one robot's decisions in an episode: its DEP transitions `start..end` (indices
/// into `dep[robot]` / `dep_at[robot]`). Cut in the robot's own decisions, so a macro action
/// that spans many joint decisions (teammates deciding often) is trained like any other.
#[derive(Clone, Copy, Debug)]
pub struct RobotWindow<'a> {
    /// The episode the decisions belong to.
    pub episode: &'a Episode,
    /// The robot whose DEP transitions these are.
    pub robot: usize,
    /// First transition (index into `episode.dep[robot]`).
    pub start: usize,
    /// One past the last transition.
    pub end: usize,
}

impl<'a> RobotWindow<'a> {
    /// `trace_len + 1` decisions of `robot` from `start` (clipped to the episode).
    pub fn new(episode: &'a Episode, robot: usize, start: usize, trace_len: usize) -> Self {
        let n = episode.dep[robot].len();
        let end = (start + trace_len + 1).min(n);
        RobotWindow {
            episode,
            robot,
            start: start.min(end),
            end,
        }
    }
    /// The joint decisions this window's decisions span (for the CEP's target actions).
    fn joint_span(&self) -> Window<'a> {
        let at = &self.episode.dep_at[self.robot];
        match (
            at.get(self.start),
            self.end.checked_sub(1).and_then(|l| at.get(l)),
        ) {
            (Some(&a), Some(&b)) if self.end > self.start => Window {
                episode: self.episode,
                start: a,
                end: b + 1,
            },
            _ => Window {
                episode: self.episode,
                start: 0,
                end: 0,
            },
        }
    }
}

/// One DEP update (Eq. 6, or MADE-Net-DT's double DRQN when `cep` is `None`) on the robot
/// sequences `seqs`; returns the new online net and the loss.
pub fn dep_update(
    online: QNet,
    target: &QNet,
    optim: &mut ModuleOptimizer,
    cep: Option<&QNet>,
    seqs: &[RobotWindow<'_>],
    p: &UpdateParams,
) -> (QNet, f32) {
    let map_len = 4 * p.map_height * p.map_width;
    let obs_dim = crate::obs_dim_for(p.team, p.goals);
    let ks: Vec<std::ops::Range<usize>> = seqs.iter().map(|w| w.start..w.end).collect();
    let time = ks.iter().map(|r| r.len()).max().unwrap_or(1).max(1);
    let mut seq = Sequences::new(seqs.len(), time, map_len, obs_dim);
    for (s, w) in seqs.iter().enumerate() {
        let (e, i) = (w.episode, w.robot);
        for (kw, k) in ks[s].clone().enumerate() {
            let tr = &e.dep[i][k];
            let o = e.decisions[e.dep_at[i][k]].robots[i]
                .as_ref()
                .expect("a deciding robot's observation");
            let idx = s * time + kw;
            unpack_bits(&o.map, &mut seq.maps[idx * map_len..(idx + 1) * map_len]);
            seq.obs[idx * obs_dim..(idx + 1) * obs_dim].copy_from_slice(&o.vec);
            seq.actions[idx] = tr.actions[0];
            seq.rewards[idx] = tr.reward * p.reward_scale;
            let terminal = tr.to.is_none();
            let next_inside = k + 1 < ks[s].end;
            seq.real[idx] = (terminal || next_inside) as u8 as f32;
            seq.not_done[idx] = (!terminal && next_inside) as u8 as f32;
        }
    }
    let spans: Vec<Window<'_>> = seqs.iter().map(RobotWindow::joint_span).collect();
    // The CEP's Q values on every sampled episode's joint history (no gradient).
    let cep_q: Option<(Vec<f32>, usize, usize)> = cep.map(|cep| {
        let (cseq, _) = cep_sequences(&spans, p);
        let (maps, obs) = cseq.tensors(p, &crate::cpu());
        let q = cep.forward(maps, obs, None).0;
        let outputs = q.dims()[2];
        (host(q), cseq.time, outputs)
    });
    let Forward { q, outputs, qv, qt } = forward_both(&online, target, &seq, p);
    let targets: Vec<f32> = (0..seq.batch * seq.time)
        .map(|idx| {
            let mut y = seq.rewards[idx];
            if seq.not_done[idx] > 0.0 {
                let (s, kw) = (idx / time, idx % time);
                let (w, k) = (&seqs[s], ks[s].start + kw);
                let (e, i, span) = (w.episode, w.robot, &spans[s]);
                let a = match &cep_q {
                    Some((cq, ctime, couts)) => {
                        let j = e.dep_at[i][k + 1];
                        let d = &e.decisions[j];
                        let j = j - span.start;
                        let fixed: Vec<Option<usize>> = (0..p.team)
                            .map(|r| (!d.decided[r]).then_some(d.actions[r]))
                            .collect();
                        let masks = &d.joint.as_ref().expect("joint observation").masks;
                        let row = (s * ctime + j) * couts..(s * ctime + j + 1) * couts;
                        let ja = conditional_argmax(&cq[row], masks, &fixed)
                            .expect("admissible joint action");
                        joint_actions(ja, p.team, p.goals)[i]
                    }
                    None => {
                        let o = e.decisions[e.dep_at[i][k + 1]].robots[i]
                            .as_ref()
                            .expect("observation");
                        masked_argmax_slice(&qv[(idx + 1) * outputs..(idx + 2) * outputs], &o.mask)
                            .expect("valid action")
                    }
                };
                y += p.gamma * qt[(idx + 1) * outputs + a];
            }
            y
        })
        .collect();
    td_step(online, optim, &seq, q, targets, p.learning_rate)
}

/// The target network: a copy of `online` without autodiff.
pub fn target_of(online: &QNet) -> QNet {
    online.valid()
}
