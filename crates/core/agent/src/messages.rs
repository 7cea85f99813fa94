//! What robots say to each other. Everything a robot learns from a teammate arrives as one of
//! these plain messages, so an agent can run as its own process over a real transport.

use madenet_map::{Occupancy, Pos};
use serde::{Deserialize, Serialize};

/// β_j: what robot `from` shares when an exchange succeeds (paper Sec. III.C.1): previous goal,
/// current position, current goal and local map, plus |E_j| for the networks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Beta {
    /// The sender's robot index j.
    pub from: usize,
    /// Timestep at which it was sent.
    pub t: usize,
    /// g_j^{t-1}
    pub prev_goal: Option<Pos>,
    /// x_j^t
    pub pos: Pos,
    /// g_j^t
    pub goal: Option<Pos>,
    /// m_j^t, row-major.
    pub map: Vec<Occupancy>,
    /// |E_j|: cells robot j knows.
    pub explored: usize,
}

/// A robot's navigation plan, sent to lower-priority teammates it currently communicates
/// with for prioritized space-time planning: `path[k]` is the cell it will hold at t + k + 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanMessage {
    /// The sender's robot index.
    pub from: usize,
    /// Timestep at which the plan was made.
    pub t: usize,
    /// The sender's position at `t`, where the path starts.
    pub start: Pos,
    /// The planned cells, first = next cell: `path[k]` is held at t + k + 1.
    pub path: Vec<Pos>,
}

/// What robot i remembers of teammate j: the last β it heard (the map is merged on receipt
/// and not kept) and the last position it detected directly.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TeammateRecord {
    /// Timestep of the last β heard, if any.
    pub heard_at: Option<usize>,
    /// g_j^{t-1} from the last β (None: never heard, or j had no previous goal).
    pub prev_goal: Option<Pos>,
    /// g_j^t from the last β (None: never heard, or j had no goal).
    pub goal: Option<Pos>,
    /// Position from the last β.
    pub beta_pos: Option<Pos>,
    /// |E_j| from the last β (0 until one is heard).
    pub explored: usize,
    /// Last directly detected position and its timestep (teammate detection works during
    /// dropouts too).
    pub seen_pos: Option<Pos>,
    /// Timestep of `seen_pos` (None: never detected).
    pub seen_at: Option<usize>,
    /// Detected in the current timestep.
    pub detected: bool,
}

impl TeammateRecord {
    /// The most recent position known: detection or β, whichever is newer.
    pub fn last_pos(&self) -> Option<Pos> {
        match (self.seen_at, self.heard_at) {
            (Some(s), Some(h)) if h > s => self.beta_pos,
            (Some(_), _) => self.seen_pos,
            (None, _) => self.beta_pos,
        }
    }
}
