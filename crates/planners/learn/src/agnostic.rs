//! The size- and team-agnostic DEP (`network = "agnostic"`, a departure from the paper, whose
//! networks are built for one map size, team size and |G|): every goal candidate is scored by
//! one shared network from what lies *around the candidate*, so the same weights play any map,
//! any team and any number of candidates.
//!
//! ```text
//!  per candidate k (any |G|)                                         per robot
//!  crop: 4 × S × S around k (S = 2·crop_radius + 1;                  context: CONTEXT_FEATURES
//!        explored, obstacles, robots, candidates;                    (explored share, ϱ_i, team
//!        outside the map = explored obstacle)                         size, teammates heard …)
//!   K1 conv k3 s1 ─ K2 conv k3 s2 ─ K3 conv k3 s2 ─ flatten ─ KF fc         │
//!             └──── ‖ features_k (CANDIDATE_INPUTS: path cost, information, │
//!                     teammates' goals/positions pooled by min and count, …)│
//!                          E  fc embed ─ leaky ReLU  → e_k                  │
//!            masked mean of e over the valid candidates ─── ‖ ──────────────┘
//!                          C  fc context ─ leaky ReLU  → c   (what the alternatives look like)
//!                    H  fc hidden on [e_k ‖ c] ─ leaky ReLU ─ O fc 1  → score_k
//! ```
//!
//! Teammates enter only through per-candidate features pooled over teammates (distance to the
//! nearest teammate goal and position, crowding count) and the context's shares, so any |I|
//! works. Training is the rollout teacher's ([`crate::dagger`]): its centralized critic
//! scores one robot's candidates one at a time by continuing the trial (never the |G|^|I| joint
//! actions), and the scores regress its advantages.

use crate::obs::{action_mask, pack_bits};
use crate::{masked_argmax_slice, ConvSpec, Tensor, TensorData};
use burn::config::Config;
use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{LeakyRelu, LeakyReluConfig, Linear, LinearConfig};
use burn::tensor::Device;
use madenet_agent::{AgentView, Decision, Policy, Spread};
use madenet_map::Pos;
use std::sync::Arc;

pub mod scorer;
pub use scorer::AgnosticScorer;

/// Values of the per-robot context vector (see [`inputs`]).
pub const CONTEXT_FEATURES: usize = 8;
/// Values per candidate: [`AgentView::CANDIDATE_FEATURES`] and 3 size-free ones (see [`inputs`]).
pub const CANDIDATE_INPUTS: usize = AgentView::CANDIDATE_FEATURES + 3;
/// Channels of a crop (the paper's map image channels).
pub const CROP_CHANNELS: usize = 4;
/// Values per candidate added by [`AgnosticConfig::wide_inputs`] (see [`inputs_for`]).
pub const WIDE_INPUTS: usize = 4;
/// Values per candidate added by [`AgnosticConfig::territory_inputs`] (see [`inputs_for`]).
pub const TERRITORY_INPUTS: usize = 3;
/// Values per candidate added by [`AgnosticConfig::plan_inputs`] (see [`inputs_for`]).
pub const PLAN_INPUTS: usize = 2;

/// Sizes of the agnostic DEP, with their defaults.
#[derive(Config, Debug, PartialEq)]
pub struct AgnosticConfig {
    /// Cells from the candidate to a crop's edge: crops are (2r + 1)² (6 → 13 × 13: d_s = 4
    /// plus a margin).
    #[config(default = 6)]
    pub crop_radius: usize,
    /// Channels of the crop convolutions K1, K2, K3.
    #[config(default = 16)]
    pub conv_channels: usize,
    /// Width of KF (the crop's feature).
    #[config(default = 32)]
    pub crop_width: usize,
    /// Width of E (a candidate's embedding).
    #[config(default = 64)]
    pub embed_width: usize,
    /// Width of C (the decision's context).
    #[config(default = 32)]
    pub context_width: usize,
    /// Width of H.
    #[config(default = 64)]
    pub hidden_width: usize,
    /// Negative slope of the leaky ReLUs.
    #[config(default = 0.01)]
    pub leaky_slope: f64,
    /// `Some(true)`: [`WIDE_INPUTS`] more values per candidate, about what lies beyond its crop
    /// ([`inputs_for`]). An option so that the `model.toml` of models made before them (no such
    /// field) still loads.
    pub wide_inputs: Option<bool>,
    /// `Some(true)`: [`TERRITORY_INPUTS`] more values per candidate (after the wide ones), about
    /// the robot's share of the whole map's unknown space, split among the team by geodesic
    /// distance ([`inputs_for`]). An option for the same reason as `wide_inputs`.
    pub territory_inputs: Option<bool>,
    /// `Some(true)`: [`PLAN_INPUTS`] more values per candidate (after the territory ones), from
    /// the team plan on the robot's own belief (the `belief-plan` policy's,
    /// [`madenet_baselines::reference::candidate_plan_moves`]; [`inputs_for`]). An option for the same
    /// reason as `wide_inputs`.
    pub plan_inputs: Option<bool>,
}

/// The agnostic DEP's layers (see the module docs).
#[derive(Module, Debug)]
pub struct AgnosticNet {
    /// K1: conv kernel 3, stride 1.
    pub k1: Conv2d,
    /// K2: conv kernel 3, stride 2.
    pub k2: Conv2d,
    /// K3: conv kernel 3, stride 2.
    pub k3: Conv2d,
    /// KF: the crop's feature.
    pub kf: Linear,
    /// E: a candidate's embedding from [crop feature ‖ candidate inputs].
    pub embed: Linear,
    /// C: the decision's context from [mean embedding ‖ robot context].
    pub context: Linear,
    /// H: hidden layer on [embedding ‖ context].
    pub hidden: Linear,
    /// O: the score.
    pub out: Linear,
    /// The leaky ReLU after every layer but O.
    pub act: LeakyRelu,
    /// Crop side S expected.
    pub crop_side: usize,
}

const K1: ConvSpec = ConvSpec {
    kernel: 3,
    stride: 1,
    channels: 0,
};
const K2: ConvSpec = ConvSpec {
    kernel: 3,
    stride: 2,
    channels: 0,
};

impl AgnosticConfig {
    /// Crop side S = 2 · `crop_radius` + 1.
    pub fn crop_side(&self) -> usize {
        2 * self.crop_radius + 1
    }

    /// Whether candidates get the [`WIDE_INPUTS`] (`wide_inputs`).
    pub fn wide(&self) -> bool {
        self.wide_inputs == Some(true)
    }

    /// Whether the candidates carry the [`TERRITORY_INPUTS`] (`territory_inputs`).
    pub fn territory(&self) -> bool {
        self.territory_inputs == Some(true)
    }

    /// Whether the candidates carry the [`PLAN_INPUTS`] (`plan_inputs`).
    pub fn plan(&self) -> bool {
        self.plan_inputs == Some(true)
    }

    /// Values per candidate: [`CANDIDATE_INPUTS`], [`WIDE_INPUTS`] with `wide_inputs`,
    /// [`TERRITORY_INPUTS`] with `territory_inputs` and [`PLAN_INPUTS`] with `plan_inputs`.
    pub fn candidate_inputs(&self) -> usize {
        CANDIDATE_INPUTS
            + if self.wide() { WIDE_INPUTS } else { 0 }
            + if self.territory() {
                TERRITORY_INPUTS
            } else {
                0
            }
            + if self.plan() { PLAN_INPUTS } else { 0 }
    }

    /// Side of K3's output, or why the sizes don't work.
    fn conv_out(&self) -> Result<usize, String> {
        let s = self.crop_side();
        K1.output_len(s)
            .and_then(|x| K2.output_len(x))
            .and_then(|x| K2.output_len(x))
            .ok_or_else(|| {
                format!(
                    "field `crop_radius`: {} is too small for the crop convolutions (need ≥ 4)",
                    self.crop_radius
                )
            })
    }

    /// Checks the sizes; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        self.conv_out()?;
        if self.crop_radius > 32 {
            return Err("field `crop_radius`: must be at most 32".into());
        }
        let widths = [
            self.conv_channels,
            self.crop_width,
            self.embed_width,
            self.context_width,
            self.hidden_width,
        ];
        if widths.iter().any(|&w| w == 0 || w > 4096) {
            return Err("field `conv_channels`/`*_width`: widths must be in 1..=4096".into());
        }
        if !(0.0..1.0).contains(&self.leaky_slope) {
            return Err("field `leaky_slope`: must be in [0, 1)".into());
        }
        Ok(())
    }

    /// Builds the network on `device`.
    pub fn init(&self, device: &Device) -> Result<AgnosticNet, String> {
        let side = self.conv_out()?;
        self.validate()?;
        let ch = self.conv_channels;
        let conv = |cin: usize, spec: ConvSpec| {
            Conv2dConfig::new([cin, ch], [spec.kernel, spec.kernel])
                .with_stride([spec.stride, spec.stride])
                .init(device)
        };
        let linear = |i: usize, o: usize| LinearConfig::new(i, o).init(device);
        Ok(AgnosticNet {
            k1: conv(CROP_CHANNELS, K1),
            k2: conv(ch, K2),
            k3: conv(ch, K2),
            kf: linear(ch * side * side, self.crop_width),
            embed: linear(self.crop_width + self.candidate_inputs(), self.embed_width),
            context: linear(self.embed_width + CONTEXT_FEATURES, self.context_width),
            hidden: linear(self.embed_width + self.context_width, self.hidden_width),
            out: linear(self.hidden_width, 1),
            act: LeakyReluConfig::new()
                .with_negative_slope(self.leaky_slope)
                .init(),
            crop_side: self.crop_side(),
        })
    }
}

impl AgnosticNet {
    /// Scores of `b` decisions with `g` candidate slots each:
    /// * `crops` `[b·g, 4, S, S]`, `features` `[b·g, candidate_inputs()]` (slot-major per
    ///   decision);
    /// * `context` `[b, CONTEXT_FEATURES]`;
    /// * `mask` `[b, g]`: 1 for a valid candidate (pooled into the context), else 0.
    ///
    /// Returns `[b, g]` (scores of masked-out slots are meaningless).
    pub fn forward(
        &self,
        crops: Tensor<4>,
        features: Tensor<2>,
        context: Tensor<2>,
        mask: Tensor<2>,
    ) -> Tensor<2> {
        let [b, g] = mask.dims();
        let n = b * g;
        let x = self.act.forward(self.k1.forward(crops));
        let x = self.act.forward(self.k2.forward(x));
        let x = self.act.forward(self.k3.forward(x));
        let x: Tensor<2> = x.flatten(1, 3);
        let x = self.act.forward(self.kf.forward(x));
        let e = self
            .act
            .forward(self.embed.forward(Tensor::cat(vec![x, features], 1)));
        let width = e.dims()[1];
        let e3 = e.clone().reshape([b, g, width]);
        let m3 = mask.reshape([b, g, 1]);
        let count = m3.clone().sum_dim(1).clamp_min(1.0);
        let pooled = e3.mul(m3).sum_dim(1).div(count).reshape([b, width]);
        let c = self
            .act
            .forward(self.context.forward(Tensor::cat(vec![pooled, context], 1)));
        let cw = c.dims()[1];
        let c = c.reshape([b, 1, cw]).repeat_dim(1, g).reshape([n, cw]);
        let h = self
            .act
            .forward(self.hidden.forward(Tensor::cat(vec![e, c], 1)));
        self.out.forward(h).reshape([b, g])
    }

    /// Scores of one decision's inputs (plain CPU device).
    pub fn scores(&self, input: &AgnosticInput) -> Vec<f32> {
        let batch = Batch::of(&[input], self.crop_side, &crate::cpu());
        self.forward(batch.crops, batch.features, batch.context, batch.mask)
            .into_data()
            .try_into_vec_as::<f32>()
            .expect("scores readable as f32")
    }
}

/// One robot's inputs at a decision, for any map, team and |G|.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AgnosticInput {
    /// [`CONTEXT_FEATURES`] values.
    pub context: Vec<f32>,
    /// [`AgnosticConfig::candidate_inputs`] values per slot (zeros for an empty slot).
    pub features: Vec<f32>,
    /// Crops of every slot (4 × S × S each, zeros for an empty slot), bit-packed.
    pub crops: Vec<u64>,
    /// Which slots may be chosen ([`action_mask`]).
    pub mask: Vec<bool>,
}

/// The inputs of `view` (d_s = `sensing_range`, crops of `crop_radius`):
///
/// * **context**: 0. known cells / all cells; 1. ϱ_i; 2. (|I| − 1) / 8; 3. share of teammates
///   whose goal was heard within [`Spread::GOAL_MEMORY`] steps; 4. share whose position is known
///   from the last [`Spread::POSITION_MEMORY`] steps; 5. ln(cells) / 10; 6. valid candidates /
///   |G|; 7. teammates' mean last heard |E_j| / cells;
/// * **per candidate**: [`AgentView::write_candidate_features`] (9), then 9. path cost / (4 d_s),
///   10. the `spread` score / (4 d_s) (both capped at 4 and divided by 4: free of the map size,
///   unlike features 0 and 7), 11. Chebyshev distance from the robot / (4 d_s), capped at 1;
/// * **crop** of each candidate: the robot's 4-channel map image (explored, obstacles, robots,
///   candidates) in a (2r + 1)² window centred on it; cells outside the map are explored
///   obstacles.
pub fn inputs(view: &mut AgentView<'_>, crop_radius: usize) -> AgnosticInput {
    let slots = view.candidates().slots;
    let mut base = vec![0.0; AgentView::candidate_features_len(slots)];
    view.write_candidate_features(&mut base);
    let sensing_range = view.sensing_range;
    let b = view.belief;
    let (h, w) = (b.height(), b.width());
    let cells = (h * w).max(1) as f32;
    let scale = (h + w) as f32;
    let reach = (4 * sensing_range.max(1)) as f32;
    let mut features = vec![0.0; CANDIDATE_INPUTS * slots];
    let valid = view.candidates().cells.len();
    for k in 0..slots {
        let f = &mut features[k * CANDIDATE_INPUTS..(k + 1) * CANDIDATE_INPUTS];
        let src = &base[k * AgentView::CANDIDATE_FEATURES..(k + 1) * AgentView::CANDIDATE_FEATURES];
        f[..AgentView::CANDIDATE_FEATURES].copy_from_slice(src);
        if let Some(c) = view.candidates().get(k) {
            let capped = |x: f32| (x / reach).min(4.0) / 4.0;
            f[9] = capped(src[0] * scale);
            f[10] = capped(src[AgentView::SPREAD_SCORE_FEATURE] * scale);
            f[11] = (view.pos.chebyshev(c) as f32 / reach).min(1.0);
        }
    }
    let t = view.t;
    let recent =
        |at: Option<usize>, memory: usize| at.is_some_and(|a| t.saturating_sub(a) <= memory);
    let mates: Vec<_> = view
        .teammates
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != view.id)
        .map(|(_, r)| r)
        .collect();
    let share = |n: usize| n as f32 / mates.len().max(1) as f32;
    let heard = mates
        .iter()
        .filter(|r| r.goal.is_some() && recent(r.heard_at, Spread::GOAL_MEMORY))
        .count();
    let placed = mates
        .iter()
        .filter(|r| {
            r.last_pos().is_some()
                && (recent(r.seen_at, Spread::POSITION_MEMORY)
                    || recent(r.heard_at, Spread::POSITION_MEMORY))
        })
        .count();
    let known_mates: Vec<f32> = mates
        .iter()
        .filter(|r| r.heard_at.is_some() || r.seen_at.is_some())
        .map(|r| r.explored as f32 / cells)
        .collect();
    let context = vec![
        b.known_count() as f32 / cells,
        view.teammate_detected as u8 as f32,
        mates.len() as f32 / 8.0,
        share(heard),
        share(placed),
        cells.ln() / 10.0,
        valid as f32 / slots.max(1) as f32,
        known_mates.iter().sum::<f32>() / known_mates.len().max(1) as f32,
    ];
    let img = view.map_image();
    let side = 2 * crop_radius + 1;
    let r = crop_radius as i32;
    let mut crops = vec![0u8; slots * CROP_CHANNELS * side * side];
    for k in 0..valid {
        let c = view.candidates().cells[k];
        let crop =
            &mut crops[k * CROP_CHANNELS * side * side..(k + 1) * CROP_CHANNELS * side * side];
        for dr in -r..=r {
            for dc in -r..=r {
                let q = Pos::new(c.row + dr, c.col + dc);
                let at = ((dr + r) as usize) * side + (dc + r) as usize;
                if b.in_bounds(q) {
                    let i = b.index(q);
                    for ch in 0..CROP_CHANNELS {
                        crop[ch * side * side + at] = img[ch * h * w + i];
                    }
                } else {
                    crop[at] = 1;
                    crop[side * side + at] = 1;
                }
            }
        }
    }
    AgnosticInput {
        context,
        features,
        crops: pack_bits(&crops),
        mask: action_mask(view),
    }
}

/// The inputs of `view` for a network of `sizes`: [`inputs`], then after each candidate's
/// [`CANDIDATE_INPUTS`] the [`WIDE_INPUTS`] (with `wide_inputs`), the [`TERRITORY_INPUTS`]
/// (with `territory_inputs`) and the [`PLAN_INPUTS`] (with `plan_inputs`), in that order.
///
/// **Wide inputs**, about what lies beyond the candidate's crop (d_s = `sensing_range`; cells
/// outside the map count as known):
///
/// 0. unknown cells within 2 d_s (Chebyshev) of the candidate / (4 d_s + 1)²;
/// 1. the same within 4 d_s / (8 d_s + 1)²;
/// 2. unknown cells within 4 d_s of the candidate nearer (Chebyshev) to it than to every
///    teammate's announced goal and last known position (as [`AgentView::write_candidate_features`]
///    keeps them) / (8 d_s + 1)²: what is left there for this robot;
/// 3. unknown cells of the whole map on the candidate's side of the robot (Σ over cells whose
///    offset from the robot has a positive dot product with the candidate's) / all cells.
///
/// **Territory inputs**, about the whole map's unknown space as the team would split it: the
/// robot's *territory* T is the unknown cells it reaches in fewer moves than every teammate's
/// announced goal and last known position (geodesic: 8-neighbour moves over cells not known to be
/// obstacles — what a team plan on the belief would hand it);
///
/// 0. the share of T nearer (geodesic) to the candidate than to the robot: how much of its own
///    part of the map the candidate heads into;
/// 1. the mean over T of (moves from the robot − moves from the candidate) / moves from the robot
///    to the candidate, in [−1, 1]: how directly it heads there;
/// 2. unknown cells of the whole map nearer to the candidate than to every teammate / unknown
///    cells: what is left for the robot around it, map-wide (wide input 2 looks within 4 d_s).
///
/// All three are 0 for an empty slot, and 0 when T (or the unknown space) is empty.
///
/// **Plan inputs**, from the team plan on the robot's own belief (unknown cells free, the
/// teammates it knows of at their last announced goal or last known cell: `belief-plan-free`'s,
/// [`madenet_baselines::reference::candidate_plan_moves`]):
///
/// 0. the candidate's moves to the robot's first viewpoint / (4 d_s), capped at 4 and divided by
///    4 (size-free, as inputs 9–10);
/// 1. 1 for the candidates with the fewest such moves (the plan's choice, ties included), else 0.
///
/// Both are 0 for an empty slot and for every slot when the plan gives the robot no viewpoint.
pub fn inputs_for(view: &mut AgentView<'_>, sizes: &AgnosticConfig) -> AgnosticInput {
    let mut x = inputs(view, sizes.crop_radius);
    if !sizes.wide() && !sizes.territory() && !sizes.plan() {
        return x;
    }
    let slots = x.mask.len();
    let wide = sizes.wide().then(|| wide_inputs(view, slots));
    let territory = sizes.territory().then(|| territory_inputs(view, slots));
    let plan = sizes.plan().then(|| plan_inputs(view, slots));
    let mut features = Vec::with_capacity(slots * sizes.candidate_inputs());
    for k in 0..slots {
        features.extend_from_slice(&x.features[k * CANDIDATE_INPUTS..(k + 1) * CANDIDATE_INPUTS]);
        if let Some(w) = &wide {
            features.extend_from_slice(&w[k]);
        }
        if let Some(t) = &territory {
            features.extend_from_slice(&t[k]);
        }
        if let Some(p) = &plan {
            features.extend_from_slice(&p[k]);
        }
    }
    x.features = features;
    x
}

/// The [`WIDE_INPUTS`] of each of `slots` candidates (see [`inputs_for`]).
fn wide_inputs(view: &AgentView<'_>, slots: usize) -> Vec<[f32; WIDE_INPUTS]> {
    let b = view.belief;
    let (h, w) = (b.height() as i32, b.width() as i32);
    // Summed-area table of unknown cells: O(1) per window (hand-written: two loops).
    let mut sat = vec![0u32; ((h + 1) * (w + 1)) as usize];
    let cell = |r: i32, c: i32| (r * (w + 1) + c) as usize;
    let me = view.pos;
    // Every unknown cell's offset from the robot, for the "ahead" share (one pass over the map).
    let mut unknown_offsets = Vec::new();
    for r in 0..h {
        for c in 0..w {
            let unknown = b.get(Pos::new(r, c)) == madenet_map::Occupancy::Unknown;
            if unknown {
                unknown_offsets.push((r - me.row, c - me.col));
            }
            sat[cell(r + 1, c + 1)] =
                unknown as u32 + sat[cell(r, c + 1)] + sat[cell(r + 1, c)] - sat[cell(r, c)];
        }
    }
    let window = |p: Pos, rad: i32| {
        let (r0, r1) = ((p.row - rad).max(0), (p.row + rad + 1).min(h));
        let (c0, c1) = ((p.col - rad).max(0), (p.col + rad + 1).min(w));
        if r0 >= r1 || c0 >= c1 {
            return 0;
        }
        sat[cell(r1, c1)] + sat[cell(r0, c0)] - sat[cell(r0, c1)] - sat[cell(r1, c0)]
    };
    let ds = view.sensing_range.max(1);
    let area = |rad: i32| ((2 * rad + 1) * (2 * rad + 1)) as f32;
    let others: Vec<Pos> = view
        .recent_teammates()
        .into_iter()
        .flat_map(|(goal, at)| goal.into_iter().chain(at))
        .collect();
    let cells = (h * w).max(1) as f32;
    let mut out = vec![[0.0; WIDE_INPUTS]; slots];
    for (k, o) in out.iter_mut().enumerate() {
        let Some(c) = view.candidates().get(k) else {
            continue;
        };
        let far = 4 * ds;
        let mut left = 0u32;
        for r in (c.row - far).max(0)..(c.row + far + 1).min(h) {
            for col in (c.col - far).max(0)..(c.col + far + 1).min(w) {
                let q = Pos::new(r, col);
                if b.get(q) == madenet_map::Occupancy::Unknown {
                    let d = q.chebyshev(c);
                    left += others.iter().all(|m| m.chebyshev(q) > d) as u32;
                }
            }
        }
        let (dr, dc) = (c.row - me.row, c.col - me.col);
        let ahead = unknown_offsets
            .iter()
            .filter(|&&(r, col)| r * dr + col * dc > 0)
            .count();
        *o = [
            window(c, 2 * ds) as f32 / area(2 * ds),
            window(c, far) as f32 / area(far),
            left as f32 / area(far),
            ahead as f32 / cells,
        ];
    }
    out
}

/// The [`PLAN_INPUTS`] of each of `slots` candidates (see [`inputs_for`]).
fn plan_inputs(view: &AgentView<'_>, slots: usize) -> Vec<[f32; PLAN_INPUTS]> {
    let mut out = vec![[0.0; PLAN_INPUTS]; slots];
    let Some(moves) = madenet_baselines::reference::candidate_plan_moves(view, &[]) else {
        return out;
    };
    let reach = f64::from(4 * view.sensing_range.max(1));
    let fewest = moves.iter().copied().min_by(f64::total_cmp);
    for (o, &m) in out.iter_mut().zip(&moves) {
        *o = [
            ((m / reach).min(4.0) / 4.0) as f32,
            f32::from(Some(m) == fewest),
        ];
    }
    out
}

/// The [`TERRITORY_INPUTS`] of each of `slots` candidates (see [`inputs_for`]).
fn territory_inputs(view: &AgentView<'_>, slots: usize) -> Vec<[f32; TERRITORY_INPUTS]> {
    let teammates: Vec<Pos> = view
        .recent_teammates()
        .into_iter()
        .flat_map(|(goal, at)| goal.into_iter().chain(at))
        .collect();
    let candidates: Vec<Option<Pos>> = (0..slots).map(|k| view.candidates().get(k)).collect();
    territory(view.belief, view.pos, &teammates, &candidates)
}

/// The [`TERRITORY_INPUTS`] of each of `candidates` (`None`: an empty slot, zeros) for a robot at
/// `robot` whose teammates are last known at (or bound for) `teammates` (see [`inputs_for`]).
///
/// ```
/// use madenet_agent::Belief;
/// use madenet_map::Pos;
/// // A corridor known around the robot (column 3), unknown on both sides, no teammate known:
/// // the candidate at column 4 heads into the 3 unknown cells on the right (of 5 in all).
/// let b = Belief::from_rows(&["??...???"], Default::default());
/// let t = madenet_learn::agnostic::territory(&b, Pos::new(0, 3), &[], &[Some(Pos::new(0, 4))]);
/// assert_eq!(t[0][0], 3.0 / 5.0);
/// ```
pub fn territory(
    b: &madenet_agent::Belief,
    robot: Pos,
    teammates: &[Pos],
    candidates: &[Option<Pos>],
) -> Vec<[f32; TERRITORY_INPUTS]> {
    let mut from_mates = Vec::new();
    let mut from_me = Vec::new();
    let mut from_candidate = Vec::new();
    moves_from(b, teammates, &mut from_mates);
    moves_from(b, &[robot], &mut from_me);
    let (h, w) = (b.height() as i32, b.width() as i32);
    let unknown: Vec<usize> = (0..h)
        .flat_map(|r| (0..w).map(move |c| Pos::new(r, c)))
        .filter(|&p| b.get(p) == madenet_map::Occupancy::Unknown)
        .map(|p| b.index(p))
        .collect();
    let territory: Vec<usize> = unknown
        .iter()
        .copied()
        .filter(|&i| from_me[i] < from_mates[i])
        .collect();
    let mut out = vec![[0.0; TERRITORY_INPUTS]; candidates.len()];
    for (o, c) in out.iter_mut().zip(candidates) {
        // A candidate the robot cannot reach (none should be) keeps zeros.
        let Some(c) = c.filter(|&c| b.in_bounds(c) && from_me[b.index(c)] != u32::MAX) else {
            continue;
        };
        moves_from(b, &[c], &mut from_candidate);
        // Every cell of T is reachable from the robot, so from the candidate too.
        let towards = from_me[b.index(c)].max(1) as f32;
        let (mut nearer, mut progress) = (0usize, 0.0f32);
        for &i in &territory {
            nearer += (from_candidate[i] < from_me[i]) as usize;
            let gain = from_me[i] as f32 - from_candidate[i] as f32;
            progress += (gain / towards).clamp(-1.0, 1.0);
        }
        let left = unknown
            .iter()
            .filter(|&&i| from_candidate[i] < from_mates[i])
            .count();
        let share = |n: usize, of: usize| if of == 0 { 0.0 } else { n as f32 / of as f32 };
        *o = [
            share(nearer, territory.len()),
            if territory.is_empty() {
                0.0
            } else {
                progress / territory.len() as f32
            },
            share(left, unknown.len()),
        ];
    }
    out
}

/// Fewest 8-neighbour moves from the nearest of `seeds` to each cell over cells not known to be
/// obstacles (`u32::MAX`: unreachable). Hand-written: a multi-source BFS into a flat field, which
/// the pathfinding crate's searches (one path, or a `HashMap` of all) do not give.
fn moves_from(b: &madenet_agent::Belief, seeds: &[Pos], out: &mut Vec<u32>) {
    let (h, w) = (b.height() as i32, b.width() as i32);
    out.clear();
    out.resize((h * w) as usize, u32::MAX);
    let mut queue = std::collections::VecDeque::new();
    for &p in seeds.iter().filter(|&&p| b.in_bounds(p)) {
        let i = b.index(p);
        if out[i] != 0 {
            out[i] = 0;
            queue.push_back(p);
        }
    }
    while let Some(p) = queue.pop_front() {
        let d = out[b.index(p)] + 1;
        for dr in -1..=1 {
            for dc in -1..=1 {
                let q = Pos::new(p.row + dr, p.col + dc);
                if (dr, dc) == (0, 0) || !b.in_bounds(q) {
                    continue;
                }
                let i = b.index(q);
                if out[i] == u32::MAX && b.get(q) != madenet_map::Occupancy::Obstacle {
                    out[i] = d;
                    queue.push_back(q);
                }
            }
        }
    }
}

/// The slot of `spread`'s choice among candidates whose inputs, `width` values each, are
/// `features` ([`AgentView::SPREAD_CHOICE_FEATURE`]), if it is one of the `valid` slots.
pub(crate) fn spread_slot(features: &[f32], width: usize, valid: &[bool]) -> Option<usize> {
    (0..valid.len())
        .find(|&k| valid[k] && features[k * width + AgentView::SPREAD_CHOICE_FEATURE] == 1.0)
}

/// A batch of decisions as tensors, slots padded to the widest decision.
pub struct Batch {
    /// `[b·g, 4, S, S]`.
    pub crops: Tensor<4>,
    /// `[b·g, candidate_inputs()]`.
    pub features: Tensor<2>,
    /// `[b, CONTEXT_FEATURES]`.
    pub context: Tensor<2>,
    /// `[b, g]` (1 = valid slot).
    pub mask: Tensor<2>,
    /// g, the padded slot count.
    pub slots: usize,
}

impl Batch {
    /// Stacks `inputs` (crops of side `side`) on `device`.
    pub fn of(inputs: &[&AgnosticInput], side: usize, device: &Device) -> Batch {
        let b = inputs.len();
        let g = inputs
            .iter()
            .map(|x| x.mask.len())
            .max()
            .unwrap_or(1)
            .max(1);
        let crop_len = CROP_CHANNELS * side * side;
        // Values per candidate: CANDIDATE_INPUTS, or more with `wide_inputs`.
        let width = inputs
            .iter()
            .find(|x| !x.mask.is_empty())
            .map_or(CANDIDATE_INPUTS, |x| x.features.len() / x.mask.len());
        let mut crops = vec![0.0f32; b * g * crop_len];
        let mut features = vec![0.0f32; b * g * width];
        let mut context = vec![0.0f32; b * CONTEXT_FEATURES];
        let mut mask = vec![0.0f32; b * g];
        for (i, x) in inputs.iter().enumerate() {
            let slots = x.mask.len();
            crate::obs::unpack_bits(
                &x.crops,
                &mut crops[i * g * crop_len..(i * g + slots) * crop_len],
            );
            features[i * g * width..(i * g + slots) * width].copy_from_slice(&x.features);
            context[i * CONTEXT_FEATURES..(i + 1) * CONTEXT_FEATURES].copy_from_slice(&x.context);
            for (k, &m) in x.mask.iter().enumerate() {
                mask[i * g + k] = m as u8 as f32;
            }
        }
        Batch {
            crops: Tensor::from_data(
                TensorData::new(crops, [b * g, CROP_CHANNELS, side, side]),
                device,
            ),
            features: Tensor::from_data(TensorData::new(features, [b * g, width]), device),
            context: Tensor::from_data(TensorData::new(context, [b, CONTEXT_FEATURES]), device),
            mask: Tensor::from_data(TensorData::new(mask, [b, g]), device),
            slots: g,
        }
    }
}

/// One robot's agnostic DEP at execution: greedy over its valid candidates, or conservative
/// (the `spread` rule's candidate unless the DEP values another more by the margin).
pub struct AgnosticPolicy {
    name: String,
    net: Arc<AgnosticScorer>,
    sizes: AgnosticConfig,
    spread_margin: Option<f32>,
    /// The scores of the last decision (empty: it had no choice to weigh).
    last: Vec<f32>,
}

impl AgnosticPolicy {
    /// Policy `name` deciding with `net` of `sizes` (its crops and inputs; d_s: the view's).
    pub fn new(name: &str, net: Arc<AgnosticScorer>, sizes: &AgnosticConfig) -> Self {
        AgnosticPolicy {
            name: name.into(),
            net,
            sizes: sizes.clone(),
            spread_margin: None,
            last: Vec::new(),
        }
    }

    /// Conservative acting with `margin` (`None`: greedy).
    pub fn with_spread_margin(mut self, margin: Option<f32>) -> Self {
        self.spread_margin = margin;
        self
    }
}

impl Policy for AgnosticPolicy {
    fn name(&self) -> &str {
        &self.name
    }
    fn last_scores(&self) -> Option<&[f32]> {
        (!self.last.is_empty()).then_some(&self.last[..])
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        self.last.clear();
        if view.candidates().cells.is_empty() {
            return Decision::Idle;
        }
        if view.candidates().cells.len() == 1 {
            return Decision::Candidate(0);
        }
        let input = inputs_for(view, &self.sizes);
        let q = self.net.scores(&input);
        self.last.clone_from(&q);
        let greedy = masked_argmax_slice(&q, &input.mask).expect("a valid candidate");
        // `spread`'s choice is among the candidate inputs, already computed for the features.
        let anchor = spread_slot(&input.features, self.sizes.candidate_inputs(), &input.mask);
        Decision::Candidate(crate::policy::conservative(
            &q,
            greedy,
            self.spread_margin,
            anchor,
        ))
    }
}
