//! Network inputs built from the simulator: one robot's macro observation for its DEP and the
//! joint observation (merged map, every robot's vector) for the CEP (paper Sec. III.C.1–2).

use madenet_agent::AgentView;
use madenet_map::Occupancy;
use serde::{Deserialize, Serialize};

/// One robot's DEP input at a decision: the 4-channel map image (`[4][H][W]`, 0/1), the
/// non-map vector of [`crate::obs_dim_for`] values and the candidate mask used for acting.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotObs {
    /// The map image, bit-packed ([`pack_bits`]).
    pub map: Vec<u64>,
    /// The non-map macro observation `z_i \ {m_i}` ([`crate::obs_dim_for`] values).
    pub vec: Vec<f32>,
    /// Which macro actions may be chosen ([`action_mask`]).
    pub mask: Vec<bool>,
}

/// The CEP's input at a joint decision: the merged map image (explored and obstacles of the
/// team's merged map, every robot's true position, every robot's goal candidates), the robots'
/// vectors concatenated in robot order ([`crate::joint_obs_dim_for`]) and each robot's mask.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointObs {
    /// The merged map image, bit-packed ([`pack_bits`]).
    pub map: Vec<u64>,
    /// Every robot's non-map vector, concatenated in robot order.
    pub vec: Vec<f32>,
    /// Each robot's candidate mask ([`action_mask`]), in robot order.
    pub masks: Vec<Vec<bool>>,
}

pub use madenet_agent::action_mask;
pub use madenet_harness::bits::{pack_bits, unpack_bits};

/// Robot `view.id`'s DEP input.
pub fn robot_obs(view: &AgentView<'_>) -> RobotObs {
    RobotObs {
        map: pack_bits(&view.map_image()),
        vec: view.macro_observation(),
        mask: action_mask(view),
    }
}

/// The CEP's joint input from every robot's view and the team's merged map (row-major, the
/// world's `team_map`).
pub fn joint_obs(views: &[AgentView<'_>], team_map: &[Occupancy]) -> JointObs {
    let mut map = vec![0u8; 4 * team_map.len()];
    madenet_agent::write_joint_map_image(views, team_map, &mut map);
    let mut vec = Vec::new();
    let mut masks = Vec::with_capacity(views.len());
    for v in views {
        vec.extend(v.macro_observation());
        masks.push(action_mask(v));
    }
    JointObs {
        map: pack_bits(&map),
        vec,
        masks,
    }
}

/// Which non-map observation vector a DEP reads: the one definition of its layout, used by
/// training, acting and `model.toml`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Observation {
    /// The paper's z_i \ m_i ([`AgentView::macro_observation`], [`crate::obs_dim_for`]).
    #[default]
    Paper,
    /// The paper's vector followed by [`AgentView::CANDIDATE_FEATURES`] features per goal
    /// candidate ([`AgentView::write_candidate_features`]: path cost, unknown and frontier cells
    /// around it, distance to teammates' goals and positions, crowding, cost rank, the `spread`
    /// rule's score and choice) — a departure from the paper (the "MADE-Net that wins" issue).
    CandidateFeatures,
}

impl Observation {
    /// Length of the vector for `team` robots and `goals` candidates.
    pub fn dim(self, team: usize, goals: usize) -> usize {
        crate::obs_dim_for(team, goals)
            + match self {
                Observation::Paper => 0,
                Observation::CandidateFeatures => AgentView::candidate_features_len(goals),
            }
    }

    /// The vector of `view`.
    pub fn vector(self, view: &mut AgentView<'_>) -> Vec<f32> {
        let mut z = view.macro_observation();
        if self == Observation::CandidateFeatures {
            let base = z.len();
            z.resize(
                base + AgentView::candidate_features_len(view.candidates().slots),
                0.0,
            );
            view.write_candidate_features(&mut z[base..]);
        }
        z
    }
}

/// The candidate index that stands for a robot's running macro action at a later joint
/// decision. Goal candidates are re-extracted at every joint decision, so the index chosen
/// earlier may now name another cell: the running action is the valid candidate equal to the
/// robot's goal, else the valid candidate nearest to it (Euclidean; ties to the lower index),
/// else slot 0.
pub fn running_action(view: &AgentView<'_>) -> usize {
    let cells = &view.candidates().cells;
    match view.goal {
        Some(g) => cells
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.euclid(g).total_cmp(&b.1.euclid(g)).then(a.0.cmp(&b.0)))
            .map_or(0, |(k, _)| k),
        None => 0,
    }
}
