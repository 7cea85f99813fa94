//! [`NetConfig`]: the sizes of one MADE-Net Q-network (CEP or DEP), with the paper's values as
//! defaults, and the arithmetic that follows from them (convolution output sizes, observation
//! length, joint action count).

use burn::config::Config;

/// One convolution of the MFE: square kernel, stride, output channels. No padding (see
/// [`NetConfig::mfe_dims`]).
#[derive(Config, Debug, Copy, PartialEq, Eq)]
pub struct ConvSpec {
    /// Side of the square kernel.
    pub kernel: usize,
    /// Stride along both axes.
    pub stride: usize,
    /// Output channels.
    pub channels: usize,
}

impl ConvSpec {
    /// Output length of this convolution along one axis of length `input`, without padding:
    /// `⌊(input − kernel) / stride⌋ + 1`, or `None` if the kernel does not fit.
    pub fn output_len(&self, input: usize) -> Option<usize> {
        (input >= self.kernel && self.stride > 0).then(|| (input - self.kernel) / self.stride + 1)
    }
}

/// Why a [`NetConfig`] cannot be built into a network.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// The map is too small for the MFE's convolutions (at the paper's specs, both sides must be
    /// at least [`MIN_MAP_SIDE`]).
    #[error("map {height}×{width} is too small for convolution {layer} (input {input_h}×{input_w}, kernel {kernel}); each side must be ≥ {min_side} at the paper's conv specs")]
    MapTooSmall {
        /// Map height.
        height: usize,
        /// Map width.
        width: usize,
        /// The layer whose kernel does not fit (`"C1"`, `"C2"` or `"C3"`).
        layer: &'static str,
        /// Height entering that layer.
        input_h: usize,
        /// Width entering that layer.
        input_w: usize,
        /// That layer's kernel side.
        kernel: usize,
        /// Smallest side the conv stack accepts ([`NetConfig::min_map_side`]).
        min_side: usize,
    },
    /// A size that must be positive is zero.
    #[error("{0} must be positive")]
    Zero(&'static str),
}

/// The map sides every learner accepts ([`madenet_harness`]'s): [`MIN_MAP_SIDE`] is the
/// smallest the paper's MFE accepts ([`NetConfig::min_map_side`] at the paper's conv specs).
pub use madenet_harness::{MAX_TRAIN_MAP_SIDE, MIN_MAP_SIDE};

/// Number of binary channels of the map image (paper Sec. III.C.1): explored space, obstacles,
/// observed robot positions, goal candidates.
pub const MAP_CHANNELS: usize = 4;

/// Length of one robot's non-map macro-observation vector `z_i \ {m_i}` for a team of `team`
/// robots and `goals` = |G| goal candidates. The layout (the order the caller must fill):
///
/// | part | length |
/// | --- | --- |
/// | own position `x_i` (row, col, normalised) | 2 |
/// | teammate-detected flag `ϱ_i` | 1 |
/// | for each of the `team − 1` teammates `j` (β_i): previous goal `g_j^{t−1}` (2), position `x_j` (2), current goal `g_j^t` (2), explored count `\|E_j\|` (1, normalised), known flag (1: seen at least once, so its entries mean something) | 8 each |
/// | goal candidates `G_i` (row, col each, normalised) | 2·goals |
/// | candidate validity mask | goals |
///
/// i.e. `3 + 8·(team − 1) + 3·goals`; 31 for the paper's 3 robots and 4 candidates.
///
/// The robot's own explored count `|E_i|` is *not* in this layout (it follows the brief of the
/// learner issue); a caller that wants it adds 1 to [`NetConfig::obs_dim`].
pub fn obs_dim_for(team: usize, goals: usize) -> usize {
    // One formula: the agent's, which writes the vector.
    madenet_agent::AgentView::macro_observation_len(team, goals)
}

/// Length of the CEP's joint non-map observation: every robot's [`obs_dim_for`] vector,
/// concatenated in robot order (`team · obs_dim_for(team, goals)`; 93 at the defaults).
pub fn joint_obs_dim_for(team: usize, goals: usize) -> usize {
    team * obs_dim_for(team, goals)
}

/// Number of joint macro actions `|G|^|I|` (64 for 4 candidates and 3 robots).
///
/// # Panics
/// If it overflows `usize`.
pub fn joint_action_count(team: usize, goals: usize) -> usize {
    goals
        .checked_pow(u32::try_from(team).expect("team size fits u32"))
        .expect("|G|^|I| overflows usize")
}

/// The sizes of one MADE-Net Q-network (paper Sec. IV). Build the CEP's with [`NetConfig::cep`]
/// and a DEP's with [`NetConfig::dep`]; everything else has the paper's value as default.
#[derive(Config, Debug, PartialEq)]
pub struct NetConfig {
    /// Map height `H` in cells (rows of the map image).
    #[config(default = 20)]
    pub map_height: usize,
    /// Map width `W` in cells (columns of the map image).
    #[config(default = 20)]
    pub map_width: usize,
    /// Team size |I|.
    #[config(default = 3)]
    pub team_size: usize,
    /// Goal candidates per robot |G| (= macro actions per robot).
    #[config(default = 4)]
    pub goal_count: usize,
    /// Channels of the map image ([`MAP_CHANNELS`]).
    #[config(default = 4)]
    pub map_channels: usize,
    /// MFE convolution C1: (kernel 4, stride 2, 8 channels).
    #[config(default = "ConvSpec::new(4, 2, 8)")]
    pub c1: ConvSpec,
    /// MFE convolution C2: (3, 2, 16).
    #[config(default = "ConvSpec::new(3, 2, 16)")]
    pub c2: ConvSpec,
    /// MFE convolution C3: (2, 2, 16).
    #[config(default = "ConvSpec::new(2, 2, 16)")]
    pub c3: ConvSpec,
    /// MFE fully connected F1 units (32).
    #[config(default = 32)]
    pub f1: usize,
    /// MFE fully connected F2 units (10): the map feature that enters CONCAT.
    #[config(default = 10)]
    pub f2: usize,
    /// LSTM hidden size (64 in both policies).
    #[config(default = 64)]
    pub lstm_hidden: usize,
    /// Slope of the leaky ReLU for negative inputs (the paper does not say; 0.01 is PyTorch's and
    /// burn's default).
    #[config(default = 0.01)]
    pub leaky_slope: f64,
    /// Whether CONCAT is a learned layer: `false` (default) — CONCAT is the bare concatenation of
    /// F3's and F2's outputs (`width + f2` features) feeding F4; `true` — a fully connected layer
    /// of `width` units (with leaky ReLU) on that concatenation, the literal reading of the
    /// paper's "128 neurons in F3, CONCAT, F4-5".
    #[config(default = false)]
    pub concat_fc: bool,
    /// Length of the non-map observation vector ([`obs_dim_for`] for a DEP,
    /// [`joint_obs_dim_for`] for the CEP).
    pub obs_dim: usize,
    /// Units of F3, CONCAT (when learned), F4 and F5: 128 for the CEP, 64 for a DEP.
    pub width: usize,
    /// Outputs of F6 (Q values): `|G|^|I|` for the CEP, `|G|` for a DEP.
    pub outputs: usize,
}

/// The spatial sizes through the MFE, computed from the map size by [`NetConfig::mfe_dims`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MfeDims {
    /// `(height, width)` after C1.
    pub c1: (usize, usize),
    /// After C2.
    pub c2: (usize, usize),
    /// After C3.
    pub c3: (usize, usize),
    /// Length of the flattened C3 output entering F1 (`c3.channels · h3 · w3`).
    pub flat: usize,
}

impl NetConfig {
    /// The centralized exploration policy (CEP) of a `height × width` map, `team` robots and
    /// `goals` candidates per robot: joint observation ([`joint_obs_dim_for`]), width 128,
    /// `goals^team` outputs.
    pub fn cep(height: usize, width: usize, team: usize, goals: usize) -> Self {
        Self::new(
            joint_obs_dim_for(team, goals),
            128,
            joint_action_count(team, goals),
        )
        .with_map_height(height)
        .with_map_width(width)
        .with_team_size(team)
        .with_goal_count(goals)
    }

    /// A decentralized exploration policy (DEP): own observation ([`obs_dim_for`]), width 64,
    /// `goals` outputs.
    pub fn dep(height: usize, width: usize, team: usize, goals: usize) -> Self {
        Self::new(obs_dim_for(team, goals), 64, goals)
            .with_map_height(height)
            .with_map_width(width)
            .with_team_size(team)
            .with_goal_count(goals)
    }

    /// Spatial sizes after C1, C2, C3 (valid convolutions, no padding) and the flattened length,
    /// or [`ConfigError::MapTooSmall`] if a kernel does not fit.
    pub fn mfe_dims(&self) -> Result<MfeDims, ConfigError> {
        let convs = [("C1", self.c1), ("C2", self.c2), ("C3", self.c3)];
        let mut dims = [(0, 0); 3];
        let (mut h, mut w) = (self.map_height, self.map_width);
        for (k, (name, spec)) in convs.iter().enumerate() {
            match (spec.output_len(h), spec.output_len(w)) {
                (Some(oh), Some(ow)) => {
                    dims[k] = (oh, ow);
                    (h, w) = (oh, ow);
                }
                _ => {
                    return Err(ConfigError::MapTooSmall {
                        height: self.map_height,
                        width: self.map_width,
                        layer: name,
                        input_h: h,
                        input_w: w,
                        kernel: spec.kernel,
                        min_side: self.min_map_side(),
                    })
                }
            }
        }
        Ok(MfeDims {
            c1: dims[0],
            c2: dims[1],
            c3: dims[2],
            flat: self.c3.channels * h * w,
        })
    }

    /// Smallest map side the conv stack accepts ([`MIN_MAP_SIDE`] = 12 at the paper's specs),
    /// found by trying sides upward.
    pub fn min_map_side(&self) -> usize {
        let fits = |mut n: usize| {
            [self.c1, self.c2, self.c3]
                .iter()
                .all(|s| match s.output_len(n) {
                    Some(o) => {
                        n = o;
                        true
                    }
                    None => false,
                })
        };
        (1..).find(|&n| fits(n)).expect("some side fits")
    }

    /// Checks every size; `Ok` carries the MFE sizes.
    pub fn validate(&self) -> Result<MfeDims, ConfigError> {
        for (name, v) in [
            ("map_channels", self.map_channels),
            ("f1", self.f1),
            ("f2", self.f2),
            ("lstm_hidden", self.lstm_hidden),
            ("obs_dim", self.obs_dim),
            ("width", self.width),
            ("outputs", self.outputs),
            ("c1.channels", self.c1.channels),
            ("c2.channels", self.c2.channels),
            ("c3.channels", self.c3.channels),
            ("c1.stride", self.c1.stride),
            ("c2.stride", self.c2.stride),
            ("c3.stride", self.c3.stride),
        ] {
            if v == 0 {
                return Err(ConfigError::Zero(name));
            }
        }
        self.mfe_dims()
    }

    /// Features entering F4: `width + f2` (bare concatenation) or `width` (learned CONCAT).
    pub fn f4_input(&self) -> usize {
        if self.concat_fc {
            self.width
        } else {
            self.width + self.f2
        }
    }
}
