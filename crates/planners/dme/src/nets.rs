//! DME-DRL's networks (MADDPG: one decentralized actor per robot, one centralized critic per
//! robot), sized for madenet's grid world. The original (design brief §1) feeds 100 × 100 map
//! frames through two convolutions and an LSTM over a 6-frame history; here the history is
//! stacked as channels (`history` frames × 4 channels of the map image), the convolutions are
//! scaled to 20 × 20 maps, and a hidden layer of `hidden` units follows (the original goes
//! straight to the output).
//!
//! * Actor: map history `[b, 4·history, H, W]` → C1 (k4 s2, 16) → C2 (k3 s2, 32) → flatten,
//!   ‖ pose vector `[b, 2·team]` (own and teammates' last known positions, normalised, −1
//!   unknown) → FC hidden → FC 8 sector logits.
//! * Critic (robot i's): every robot's newest `critic_history` frames stacked
//!   `[b, team·4·critic_history, H, W]` → the
//!   same convolutions → flatten, ‖ every robot's action (`team · 8`, one-hot or soft) ‖ every
//!   robot's pose vector (`team · 2·team`) → FC hidden → FC 1.

use crate::SECTORS;
use burn::config::Config;
use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{Linear, LinearConfig, Relu};
use burn::tensor::{Device, Tensor};

/// Sizes of the DME-DRL networks.
#[derive(Config, Debug, PartialEq)]
pub struct DmeConfig {
    /// Map height H in cells (default: the paper's training maps').
    #[config(default = "madenet_harness::DEFAULT_MAP_SIDE")]
    pub map_height: usize,
    /// Map width W in cells (default: the paper's training maps').
    #[config(default = "madenet_harness::DEFAULT_MAP_SIDE")]
    pub map_width: usize,
    /// Robots |I|.
    #[config(default = 3)]
    pub team_size: usize,
    /// Map frames stacked as input (the original: 6; ours 3 on a 20 × 20 world).
    #[config(default = 3)]
    pub history: usize,
    /// The newest frames of each robot the critics see (ours: 1 — the critic is centralized
    /// and sees every robot's map; the history serves the actors' partial view, and
    /// three frames would triple the critics' convolution cost).
    #[config(default = 1)]
    pub critic_history: usize,
    /// Units of the hidden fully connected layer.
    #[config(default = 128)]
    pub hidden: usize,
}

/// Valid-convolution output side.
fn out_side(input: usize, kernel: usize, stride: usize) -> usize {
    (input.saturating_sub(kernel)) / stride + 1
}

impl DmeConfig {
    /// Channels of one robot's input: 4 map channels per frame.
    pub fn robot_channels(&self) -> usize {
        4 * self.history
    }
    /// Channels of one robot's frames in a critic's input.
    pub fn critic_robot_channels(&self) -> usize {
        4 * self.critic_history.clamp(1, self.history)
    }
    /// Length of a pose vector: every robot's (row, col).
    pub fn pose_len(&self) -> usize {
        2 * self.team_size
    }
    /// Flattened length after the two convolutions (32 channels × their output sides; the
    /// same for any number of input channels).
    fn flat(&self) -> usize {
        let (h, w) = (
            out_side(out_side(self.map_height, 4, 2), 3, 2),
            out_side(out_side(self.map_width, 4, 2), 3, 2),
        );
        32 * h * w
    }
    /// Refuses sizes whose hidden layer would be too large to build: the flattened map ×
    /// `hidden` weights of an actor's (and a critic's) first fully connected layer, at most
    /// [`Self::MAX_FC_WEIGHTS`] (64 MB of f32; the default 20 × 20, 128 units is 0.1 M).
    pub fn check_size(&self) -> Result<(), String> {
        let weights = (self.flat() as u64).saturating_mul(self.hidden as u64);
        if weights > Self::MAX_FC_WEIGHTS {
            return Err(format!(
                "field `hidden`: {} units on {} × {} maps make {weights} weights in one layer, more than {}; fewer units or smaller maps",
                self.hidden,
                self.map_height,
                self.map_width,
                Self::MAX_FC_WEIGHTS
            ));
        }
        Ok(())
    }

    /// The largest first fully connected layer [`Self::check_size`] lets through.
    pub const MAX_FC_WEIGHTS: u64 = 1 << 24;

    fn convs(&self, channels: usize, device: &Device) -> (Conv2d, Conv2d) {
        (
            Conv2dConfig::new([channels, 16], [4, 4])
                .with_stride([2, 2])
                .init(device),
            Conv2dConfig::new([16, 32], [3, 3])
                .with_stride([2, 2])
                .init(device),
        )
    }

    /// Robot i's actor.
    pub fn actor(&self, device: &Device) -> Actor {
        let (c1, c2) = self.convs(self.robot_channels(), device);
        Actor {
            c1,
            c2,
            f1: LinearConfig::new(self.flat() + self.pose_len(), self.hidden).init(device),
            f2: LinearConfig::new(self.hidden, SECTORS).init(device),
            act: Relu::new(),
        }
    }

    /// Robot i's centralized critic.
    pub fn critic(&self, device: &Device) -> Critic {
        let (c1, c2) = self.convs(self.team_size * self.critic_robot_channels(), device);
        let extra = self.team_size * SECTORS + self.team_size * self.pose_len();
        Critic {
            c1,
            c2,
            f1: LinearConfig::new(self.flat() + extra, self.hidden).init(device),
            f2: LinearConfig::new(self.hidden, 1).init(device),
            act: Relu::new(),
        }
    }
}

/// A decentralized actor: sector logits from the robot's own map history and pose vector.
#[derive(Module, Debug)]
pub struct Actor {
    /// C1: convolution k4 s2, 4·history → 16 channels.
    pub c1: Conv2d,
    /// C2: convolution k3 s2, 16 → 32 channels.
    pub c2: Conv2d,
    /// Hidden layer: flattened map features ‖ pose vector (2·team) → `hidden` units.
    pub f1: Linear,
    /// Output layer: `hidden` units → 8 sector logits.
    pub f2: Linear,
    /// ReLU after C1, C2 and the hidden layer.
    pub act: Relu,
}

impl Actor {
    /// `maps` `[b, 4·history, H, W]`, `pose` `[b, 2·team]` → logits `[b, 8]`.
    pub fn forward(&self, maps: Tensor<4>, pose: Tensor<2>) -> Tensor<2> {
        let x = self
            .act
            .forward(self.c2.forward(self.act.forward(self.c1.forward(maps))));
        let x: Tensor<2> = x.flatten(1, 3);
        let x = self
            .act
            .forward(self.f1.forward(Tensor::cat(vec![x, pose], 1)));
        self.f2.forward(x)
    }
}

/// A centralized critic: Q_i from every robot's map history, action and pose vector.
#[derive(Module, Debug)]
pub struct Critic {
    /// C1: convolution k4 s2, team·4·min(critic_history, history) → 16 channels.
    pub c1: Conv2d,
    /// C2: convolution k3 s2, 16 → 32 channels.
    pub c2: Conv2d,
    /// Hidden layer: flattened map features ‖ every robot's action (team·8) ‖ every robot's
    /// pose vector (team·2·team) → `hidden` units.
    pub f1: Linear,
    /// Output layer: `hidden` units → Q_i.
    pub f2: Linear,
    /// ReLU after C1, C2 and the hidden layer.
    pub act: Relu,
}

impl Critic {
    /// `maps` `[b, team·4·critic_history, H, W]`, `actions` `[b, team·8]`, `poses`
    /// `[b, team·2·team]` → Q `[b, 1]`.
    pub fn forward(&self, maps: Tensor<4>, actions: Tensor<2>, poses: Tensor<2>) -> Tensor<2> {
        self.head(self.features(maps), actions, poses)
    }

    /// The convolutional trunk alone: flattened map features `[b, flat]` (the actors' update
    /// reuses them, since only the action input changes).
    pub fn features(&self, maps: Tensor<4>) -> Tensor<2> {
        let x = self
            .act
            .forward(self.c2.forward(self.act.forward(self.c1.forward(maps))));
        x.flatten(1, 3)
    }

    /// Q from trunk features, actions and poses.
    pub fn head(&self, features: Tensor<2>, actions: Tensor<2>, poses: Tensor<2>) -> Tensor<2> {
        let x = self.act.forward(
            self.f1
                .forward(Tensor::cat(vec![features, actions, poses], 1)),
        );
        self.f2.forward(x)
    }
}
