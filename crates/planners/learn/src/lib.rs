//! MADE-Net's learner (Tan et al., RA-L 2023, Sec. III.C.2–4 and IV), following MacDec-DDRQN with
//! a centralized Q-net (Xiao et al., ICRA 2020). The data flow, one module each:
//!
//! * [`QNet`] / [`NetConfig`] — the Q-network shared by the centralized exploration policy (CEP)
//!   and the decentralized exploration policies (DEP), built from map size, team size and |G|;
//!   masked and conditional action selection ([`masked_argmax`], [`conditional_argmax`]);
//! * [`obs`] — the networks' inputs from the simulator (a robot's macro observation, the joint
//!   observation with the merged map);
//! * [`env`](mod@env) — the two training environments (CEP-driven with full communication, DEP-driven
//!   with CSP ~ U(0, 1)) as an ε-greedy [`madenet_agent::JointPolicy`] recording [`env::Episode`]s;
//! * [`replay`] — episodes of primitive steps squeezed into the CEP's and DEPs' macro transitions;
//! * [`learner`] — the updates of Eq. (5) and (6) (and MADE-Net-DT's double DRQN) on sampled
//!   windows;
//! * [`train`](mod@train) — the paper's training loop ([`MadeNetLearner`]) and its [`TrainConfig`];
//!   [`dagger`] the rollout teacher's;
//! * what every learner does around its algorithm lives in [`madenet_harness`], shared with
//!   `madenet-dme`, and is re-exported here at its old paths: [`harness`] (the [`Learner`]
//!   contract, run directories and resume, [`Progress`], logs, checkpoints; here also
//!   [`harness::write_model_toml`] for MADE-Net's model folder), [`episode`] (the one episode
//!   runner), [`scenario`] (the generated training and validation scenarios and the one
//!   validator), [`integrity`] (the weight files' digests and checks), [`error`]
//!   ([`TrainError`]; here also how MADE-Net's errors become one), the model-folder helpers of
//!   [`model`], the bit packing of [`obs`] and the map sides [`MIN_MAP_SIDE`] ..=
//!   [`MAX_TRAIN_MAP_SIDE`];
//! * [`model`] / [`policy`] / [`shipped`] — a trained model as shipped and loaded, the DEP acting
//!   alone at execution, and the models shipped in `models/`, registered as the policies
//!   `made-net`, `made-net-paper`, `made-net-dt` and `made-net-any` (loaded on first use).
//!
//! Built on burn 0.22, whose tensors are not generic over a backend: a [`Tensor<D>`] lives on a
//! runtime [`Device`]. [`cpu`] is burn's `flex` CPU backend; [`cpu_autodiff`] the same with
//! automatic differentiation (for training with [`burn::optim::AdamConfig`]).
//!
//! # Architecture
//!
//! ```text
//!  map image m (4 × H × W: explored, obstacles, robots, goal candidates)      observation z \ m
//!          │                                                                 (obs_dim, see obs_dim_for)
//!   C1  conv k4 s2,  8 ch ─ leaky ReLU        ┐                                      │
//!   C2  conv k3 s2, 16 ch ─ leaky ReLU        │ MFE                        F3  fc width ─ leaky ReLU
//!   C3  conv k2 s2, 16 ch ─ leaky ReLU        │ (map feature                         │
//!   flatten (16 · h3 · w3; 64 on 20 × 20)     │  extractor)                          │
//!   F1  fc 32 ─ leaky ReLU                    │                                      │
//!   F2  fc 10 ─ leaky ReLU                    ┘                                      │
//!          └──────────────────────── CONCAT [F3 ‖ F2] ───────────────────────────────┘
//!                                  (bare: width + 10; or, with concat_fc, fc width ─ leaky ReLU)
//!                                           │
//!                                   F4  fc width ─ leaky ReLU
//!                                   LSTM hidden 64 (over macro steps)
//!                                   F5  fc width ─ leaky ReLU
//!                                   F6  fc outputs (Q values, no activation)
//!
//!   CEP: width 128, obs = joint observation (3 · 31 = 93), outputs |G|^|I| = 64
//!   DEP: width  64, obs = own observation (31),           outputs |G|     = 4
//! ```
//!
//! # Conventions
//!
//! * **Shapes.** Sequences are batch-first: maps `[batch, time, 4, H, W]` (row = `H` axis),
//!   observations `[batch, time, obs_dim]`, Q `[batch, time, outputs]`
//!   ([`QNet::forward`]); a single decision drops the time axis ([`QNet::act`]). The LSTM state
//!   ([`LstmState`]) is `[batch, 64]` cell and hidden; `None` means zeros (episode start).
//! * **Convolutions** use no padding; sizes follow from the map (20×20 → 9 → 4 → 2; 30×30 → 14
//!   → 6 → 3; 40×60 → 19×29 → 9×14 → 4×7). A map side below [`MIN_MAP_SIDE`] (12) is a
//!   [`ConfigError::MapTooSmall`].
//! * **Observation vector** layout: [`obs_dim_for`] (per robot) and [`joint_obs_dim_for`] (CEP:
//!   the robots' vectors concatenated in robot order). The networks only see its length.
//! * **Joint actions** (CEP): base-|G| index with robot 0 the least significant digit
//!   ([`joint_index`], [`joint_actions`]).
//! * **Masks**: `true` = the action may be chosen. Invalid candidates are never returned by
//!   [`masked_argmax`] / [`conditional_argmax`] and are excluded from [`masked_max`]. In the
//!   conditional argmax a robot whose macro action is still running keeps it (its mask is not
//!   consulted).
//! * **Parameters** (burn's layers): conv = k·k·in·out + out, linear = in·out + out, and burn's
//!   LSTM keeps *separate* input and hidden biases per gate: 4·(in·h + h + h·h + h). At the
//!   defaults the CEP has 101 202 parameters and a DEP 49 686 (hand arithmetic in the tests).

#![deny(missing_docs)]

mod actions;
pub mod agnostic;
mod config;
pub mod dagger;
pub mod env;
pub mod error;
pub mod harness;
pub mod learner;
pub mod model;
mod net;
pub mod obs;
pub mod policy;
pub mod replay;
pub mod shipped;
pub mod train;

pub use actions::{
    conditional_argmax, conditional_argmax_batch, conditional_joint_mask, gather_q, joint_actions,
    joint_index, joint_valid_mask, mask_tensor, masked_argmax, masked_argmax_slice, masked_max,
    try_masked_argmax, INVALID_Q,
};
pub use burn::tensor::{Bool, Device, Int, Tensor, TensorData};
pub use config::{
    joint_action_count, joint_obs_dim_for, obs_dim_for, ConfigError, ConvSpec, MfeDims, NetConfig,
    MAP_CHANNELS, MAX_TRAIN_MAP_SIDE, MIN_MAP_SIDE,
};
pub use error::TrainError;
pub use harness::{Learner, Progress};
pub use madenet_harness::{cadence, learner_config, toml_config_readers};
pub use madenet_harness::{episode, integrity, scenario};
pub use model::{Method, Model, ModelInfo};
pub use net::{LayerShape, LstmState, QNet};
pub use policy::DepPolicy;
pub use train::{train, MadeNetLearner, PaperMethod, TrainConfig};

/// burn's `flex` CPU device, without autodiff (acting, evaluation, target networks).
///
/// burn 0.22 has no backend type parameter, so this stands where a `type Cpu = …` alias would
/// in earlier versions.
pub fn cpu() -> Device {
    Device::flex()
}

/// The `flex` CPU device with automatic differentiation (training). Move a trained module to
/// [`cpu`] with `module.valid()` or `.to_device(&cpu())`.
pub fn cpu_autodiff() -> Device {
    Device::flex().autodiff()
}
