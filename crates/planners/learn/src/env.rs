//! The training environments (paper Sec. III.C.4, *Parallel Environments*): a team driven by
//! the CEP with full communication (centralized) and a team driven by the DEPs whose CSP is
//! drawn from U(0, 1) each episode (decentralized). Both run the real simulator pipeline
//! ([`madenet_sim::Trial`], through the one episode runner [`crate::episode::run`]) with an
//! [`Actor`] — a [`JointPolicy`] that acts ε-greedily and records, at every joint decision,
//! what the networks saw and chose. An [`Episode`] is one such run: its primitive steps (for
//! [`crate::replay`]) and its decisions' observations.

use crate::episode::{self, Recorder};
use crate::obs::{joint_obs, robot_obs, running_action, JointObs, RobotObs};
use crate::replay::{squeeze_robot, squeeze_team, MacroTransition, PrimitiveStep, ReplayError};
use crate::{
    conditional_argmax, joint_actions, masked_argmax_slice, LstmState, QNet, Tensor, TensorData,
};
use burn::tensor::Device;
use madenet_agent::{AgentView, Decision, JointPolicy};
use madenet_map::Occupancy;
use madenet_sim::{SimError, Trial, TrialSpec};
use madenet_world::rng::Rng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// Which of the two training environments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EnvKind {
    /// Driven by the CEP, full communication.
    Centralized,
    /// Driven by the DEPs, CSP ~ U(0, 1).
    Decentralized,
}

impl EnvKind {
    /// `cen` / `dec` (the training log's `env` column).
    pub fn short(self) -> &'static str {
        madenet_trainlog::Env::from(self).as_str()
    }
}

impl From<EnvKind> for madenet_trainlog::Env {
    fn from(k: EnvKind) -> Self {
        match k {
            EnvKind::Centralized => madenet_trainlog::Env::Cen,
            EnvKind::Decentralized => madenet_trainlog::Env::Dec,
        }
    }
}

/// What was recorded at one joint decision (a step where some robot's macro action ended).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JointStep {
    /// The timestep.
    pub t: usize,
    /// Which robots chose a new macro action here.
    pub decided: Vec<bool>,
    /// Each robot's macro action in force from here: the new choice, or for a running robot
    /// its action re-indexed into the current candidates ([`running_action`]).
    pub actions: Vec<usize>,
    /// The CEP's input (absent when no CEP is trained, as in MADE-Net-DT).
    pub joint: Option<JointObs>,
    /// Each deciding robot's DEP input.
    pub robots: Vec<Option<RobotObs>>,
}

/// The networks an actor uses, on the plain (non-autodiff) CPU device.
#[derive(Clone, Debug)]
pub struct ActorNets {
    /// The CEP: drives the centralized env; in the decentralized env it is stepped alongside
    /// for `cen_explore`. `None` for MADE-Net-DT.
    pub cep: Option<QNet>,
    /// The DEPs: one shared by all robots, or one per robot.
    pub deps: Vec<QNet>,
}

impl ActorNets {
    fn dep(&self, robot: usize) -> &QNet {
        &self.deps[if self.deps.len() == 1 { 0 } else { robot }]
    }
}

/// The ε-greedy actor of one training episode (a [`JointPolicy`]).
pub struct Actor {
    kind: EnvKind,
    nets: ActorNets,
    epsilon: f32,
    cen_explore: bool,
    goals: usize,
    rng: Rng,
    device: Device,
    cep_state: Option<LstmState>,
    dep_states: Vec<Option<LstmState>>,
    decisions: Vec<JointStep>,
}

impl Actor {
    /// The actor of one `kind` episode: ε = `epsilon`, |G| = `goals` candidates per robot, a
    /// team of `team` robots, zero LSTM states; `cen_explore` makes the decentralized env
    /// explore by the CEP's joint choice (if there is a CEP) rather than a random valid
    /// candidate.
    /// The ε draws and random candidates come from `rng`.
    pub fn new(
        kind: EnvKind,
        nets: ActorNets,
        epsilon: f32,
        cen_explore: bool,
        goals: usize,
        team: usize,
        rng: Rng,
    ) -> Self {
        Actor {
            kind,
            nets,
            epsilon,
            cen_explore,
            goals,
            rng,
            device: crate::cpu(),
            cep_state: None,
            dep_states: vec![None; team],
            decisions: Vec::new(),
        }
    }

    fn input(&self, map: &[u64], vec: &[f32], h: usize, w: usize) -> (Tensor<4>, Tensor<2>) {
        let mut m = vec![0.0f32; 4 * h * w];
        crate::obs::unpack_bits(map, &mut m);
        let maps = Tensor::<4>::from_data(TensorData::new(m, [1, 4, h, w]), &self.device);
        let obs =
            Tensor::<2>::from_data(TensorData::new(vec.to_vec(), [1, vec.len()]), &self.device);
        (maps, obs)
    }

    fn random_valid(&mut self, mask: &[bool]) -> usize {
        let valid: Vec<usize> = (0..mask.len()).filter(|&k| mask[k]).collect();
        valid[self.rng.random_range(0..valid.len())]
    }
}

fn q_host(q: Tensor<2>) -> Vec<f32> {
    q.into_data()
        .try_into_vec_as::<f32>()
        .expect("Q values readable as f32")
}

impl JointPolicy for Actor {
    fn name(&self) -> &str {
        match self.kind {
            EnvKind::Centralized => "made-net-cep",
            EnvKind::Decentralized => "made-net-dep",
        }
    }

    fn decide(
        &mut self,
        views: &mut [AgentView<'_>],
        needs: &[bool],
        team_map: &[Occupancy],
    ) -> Vec<Decision> {
        let n = views.len();
        let (h, w) = (views[0].belief.height(), views[0].belief.width());
        let joint = self.nets.cep.is_some().then(|| joint_obs(views, team_map));
        let mut actions: Vec<usize> = views.iter().map(running_action).collect();
        let fixed: Vec<Option<usize>> = (0..n).map(|i| (!needs[i]).then_some(actions[i])).collect();
        // The CEP's greedy conditional joint choice (running robots fixed), stepping its state.
        let cep_choice = match (&self.nets.cep, &joint) {
            (Some(cep), Some(j)) => {
                let (maps, obs) = self.input(&j.map, &j.vec, h, w);
                let (q, state) = cep.act(maps, obs, self.cep_state.take());
                self.cep_state = Some(state);
                let q = q_host(q);
                let a = conditional_argmax(&q, &j.masks, &fixed)
                    .expect("every robot has an admissible action");
                Some(joint_actions(a, n, self.goals))
            }
            _ => None,
        };
        let mut robots: Vec<Option<RobotObs>> = vec![None; n];
        for i in (0..n).filter(|&i| needs[i]) {
            let o = robot_obs(&views[i]);
            let explore = self.rng.random::<f32>() < self.epsilon;
            actions[i] = match self.kind {
                EnvKind::Centralized => {
                    if explore {
                        self.random_valid(&o.mask)
                    } else {
                        cep_choice.as_ref().expect("the centralized env has a CEP")[i]
                    }
                }
                EnvKind::Decentralized => {
                    let (maps, obs) = self.input(&o.map, &o.vec, h, w);
                    let (q, state) = self.nets.dep(i).act(maps, obs, self.dep_states[i].take());
                    self.dep_states[i] = Some(state);
                    let greedy =
                        masked_argmax_slice(&q_host(q), &o.mask).expect("mask has a valid action");
                    match (explore, &cep_choice) {
                        (false, _) => greedy,
                        (true, Some(c)) if self.cen_explore => c[i],
                        (true, _) => self.random_valid(&o.mask),
                    }
                }
            };
            robots[i] = Some(o);
        }
        let decisions = (0..n).map(|i| Decision::Candidate(actions[i])).collect();
        self.decisions.push(JointStep {
            t: views[0].t,
            decided: needs.to_vec(),
            actions,
            joint,
            robots,
        });
        decisions
    }
}

/// One recorded training episode.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Episode {
    /// The environment that played it.
    pub kind: EnvKind,
    /// The episode's CSP (1 in the centralized env, drawn from U(0, 1) in the decentralized).
    pub comm_success_prob: f64,
    /// Primitive steps (decided flags, actions in force, Eq. 7/8 rewards).
    pub steps: Vec<PrimitiveStep>,
    /// The joint decisions, in time order; `steps[decisions[k].t]` is joint-valid.
    pub decisions: Vec<JointStep>,
    /// The CEP's macro transitions: `cep[k]` starts at `decisions[k]`.
    pub cep: Vec<MacroTransition>,
    /// Each robot's DEP transitions, from its own decisions.
    pub dep: Vec<Vec<MacroTransition>>,
    /// `dep_at[i][k]`: the index into `decisions` where robot i's `k`-th DEP transition was
    /// chosen.
    pub dep_at: Vec<Vec<usize>>,
    /// The team explored everything (else the step cap ended it).
    pub complete: bool,
    /// Σ r (Eq. 8) over the episode, unscaled.
    pub team_return: f64,
}

impl Episode {
    /// Robots in the team.
    pub fn team(&self) -> usize {
        self.dep.len()
    }
    /// Primitive steps taken.
    pub fn len(&self) -> usize {
        self.steps.len()
    }
    /// True if no primitive step was taken.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }
}

/// Why an episode could not be recorded.
#[derive(Debug, thiserror::Error)]
pub enum EpisodeError {
    /// The simulator could not build the trial from the spec.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The recorded steps could not be squeezed into macro transitions.
    #[error(transparent)]
    Replay(#[from] ReplayError),
}

/// The recorder of a MADE-Net episode: the actor decides for the deciding robots; each
/// timestep becomes a [`PrimitiveStep`] with the actions in force and its rewards.
struct Recording {
    actor: Actor,
    steps: Vec<PrimitiveStep>,
    actions: Vec<usize>,
    decided: Vec<bool>,
    team_return: f64,
}

impl Recorder for Recording {
    type Error = std::convert::Infallible;

    fn decide(&mut self, trial: &mut Trial) -> Result<(), Self::Error> {
        let before = self.actor.decisions.len();
        trial.decide_jointly(&mut self.actor);
        match self.actor.decisions.last() {
            Some(js) if self.actor.decisions.len() > before => {
                self.actions.clone_from(&js.actions);
                self.decided.clone_from(&js.decided);
            }
            _ => self.decided.fill(false),
        }
        Ok(())
    }

    fn stepped(&mut self, trial: &Trial) -> Result<(), Self::Error> {
        let r = trial.rewards();
        self.team_return += r.team;
        self.steps.push(PrimitiveStep {
            decided: self.decided.clone(),
            actions: self.actions.clone(),
            robot_rewards: r.robots.iter().map(|&x| x as f32).collect(),
            team_reward: r.team as f32,
        });
        Ok(())
    }
}

/// Runs one episode of `spec` (its config's CSP and step cap apply) with `actor`.
pub fn run_episode(spec: TrialSpec, actor: Actor) -> Result<Episode, EpisodeError> {
    let kind = actor.kind;
    let csp = spec.config.comm_success_prob;
    let name = actor.name().to_string();
    let mut trial = Trial::driven_from_outside(spec, &name)?;
    let n = trial.agents().len();
    let mut rec = Recording {
        actor,
        steps: Vec::new(),
        actions: vec![0; n],
        decided: vec![false; n],
        team_return: 0.0,
    };
    let Ok(end) = episode::run(&mut trial, &mut rec);
    let Recording {
        actor,
        steps,
        team_return,
        ..
    } = rec;
    let decisions = actor.decisions;
    let cep = squeeze_team(&steps)?;
    let mut dep = Vec::with_capacity(n);
    let mut dep_at = Vec::with_capacity(n);
    for i in 0..n {
        dep.push(squeeze_robot(&steps, i)?);
        dep_at.push(
            decisions
                .iter()
                .enumerate()
                .filter(|(_, d)| d.decided[i])
                .map(|(k, _)| k)
                .collect::<Vec<_>>(),
        );
    }
    debug_assert_eq!(cep.len(), decisions.len());
    Ok(Episode {
        kind,
        comm_success_prob: csp,
        steps,
        decisions,
        cep,
        dep,
        dep_at,
        complete: end.complete,
        team_return,
    })
}
