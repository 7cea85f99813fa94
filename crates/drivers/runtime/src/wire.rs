//! The wire format: every message between nodes is one [`Envelope`], serialized with postcard.
//!
//! An envelope carries the protocol version (a node refuses any other), the timestep it belongs
//! to, its sender and its addressee. The bodies are the data flow of a timestep: the world sends
//! each robot its observation and the radio the pairs in contact; the radio tells each robot in
//! contact with whom its link is up; robots send β to those teammates and plans to the
//! lower-priority ones — through the radio, which forwards only along links that are up; each
//! robot sends the world its move; the world ends the run with each robot's `Final` observation
//! (where the trial ended, not acted on) and `Stop`.

use madenet_agent::{Beta, PlanMessage};
use madenet_map::{Occupancy, Pos};
use madenet_world::{Move, Observation};
use serde::{Deserialize, Serialize};

/// Version of the wire format; bumped on any change to [`Envelope`] or [`Body`].
pub const PROTOCOL_VERSION: u16 = 8;

/// Who sends or receives: the world (ground truth, motion, sensing), the radio (the paper's
/// communication model) or a robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Node {
    /// The world node: ground truth, motion, sensing and the metrics.
    World,
    /// The radio node: the communication model (CSP, dropouts), carrier of every
    /// robot-to-robot message.
    Radio,
    /// Robot i's node.
    Robot(usize),
}

impl std::fmt::Display for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Node::World => f.write_str("world"),
            Node::Radio => f.write_str("radio"),
            Node::Robot(i) => write!(f, "robot {i}"),
        }
    }
}

/// One message.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Envelope {
    /// The sender's [`PROTOCOL_VERSION`]; a node refuses any other.
    pub version: u16,
    /// The timestep the message belongs to (the world's t when the observation was made).
    pub step: u64,
    /// The sender.
    pub from: Node,
    /// The addressee; a robot's message to a teammate travels through the radio.
    pub to: Node,
    /// What the message says.
    pub body: Body,
}

/// What a message says.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Body {
    /// World → robot: its observation o_i of this timestep (the teammates it detects; with whom
    /// it exchanges β is the radio's to say).
    Observation(Observation),
    /// World → radio: the pairs (i < j) in contact this timestep (within d_s, in line of sight).
    Contacts(Vec<(usize, usize)>),
    /// Radio → each robot, every timestep: the teammates it exchanges with now (ascending), so
    /// it knows whose β and plans to wait for, and those whose β will arrive late (a delaying
    /// radio; send them β, do not wait).
    Links {
        /// Teammates it exchanges with this timestep, ascending.
        now: Vec<usize>,
        /// Teammates whose β of this timestep will arrive late, ascending.
        late: Vec<usize>,
    },
    /// Robot → robot, along a successful exchange: β (paper Sec. III.C.1), its map sent as the
    /// changes since the last map sent to the same teammate.
    Beta(BetaMessage),
    /// Robot → lower-priority robot it exchanged with: its space-time plan.
    Plan(PlanMessage),
    /// Robot → world: the move it intends this timestep.
    Move(Move),
    /// World → robots and radio: the trial is over (complete or at the step cap).
    Stop,
    /// World → robots and radio, while it waits longer than [`crate::Timeouts::peer`] (for
    /// an absent robot's move, a slow ground): it is still there, wait on.
    Waiting,
    /// Robot → world when it starts: wait for my moves (again, after a restart). `scenario`:
    /// the digest of the map and scenario the robot was started with ([`scenario_digest`]), so
    /// that a world started with others refuses it by name; `None`: not checked.
    Hello {
        /// [`scenario_digest`] of the robot's map, starts and scenario config.
        scenario: Option<u64>,
    },
    /// Robot → world, answering `Stop`: its decisions and their total wall time, and its
    /// latency from observation to move (timesteps acted, total and longest, seconds).
    Done {
        /// Decisions its agent applied ([`madenet_agent::AgentStats::decisions`]).
        decisions: usize,
        /// Wall time of its own policy's decisions, seconds.
        decision_s: f64,
        /// Timesteps it sent a move.
        acted: usize,
        /// Total latency from observation to move, seconds.
        latency_s: f64,
        /// Longest latency from observation to move, seconds.
        latency_max_s: f64,
    },
    /// World → robot: after each move, also send what you show (`Shown`); world → radio: also
    /// send me each timestep's `Exchanges`. For pictures.
    Show,
    /// Radio → world, when asked by `Show`: the pairs (i < j) exchanging this timestep.
    Exchanges(Vec<(usize, usize)>),
    /// Robot → world after its move, when asked by `Show`: what a picture of the timestep
    /// draws of it besides its cell.
    Shown(Shown),
    /// World → each robot, just before `Stop`: what it observes where the trial ended (the
    /// last timestep's outcome), so that what it shows — its ROS 2 topics — ends there too. No
    /// move is asked for it.
    Final(Observation),
}

/// What a robot shows in a picture of a timestep: its macro action's goal, its planned path,
/// its goal candidates G_i and the teammates it exchanged β with.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Shown {
    /// g_i, the goal of its macro action (None: it has none).
    pub goal: Option<Pos>,
    /// Its planned path, first = next cell.
    pub path: Vec<Pos>,
    /// Its goal candidates 𝒢_i.
    pub candidates: Vec<Pos>,
    /// The teammates it exchanged β with this timestep.
    pub exchanged_with: Vec<usize>,
    /// The values its policy weighed at its last decision, per candidate slot (a learned
    /// policy's; empty for a rule).
    pub scores: Vec<f32>,
    /// Its decisions so far (one more: a new decision, its candidates and scores to show).
    pub decisions: u64,
}

impl Shown {
    /// What the robot shows, as outputs read it ([`madenet_sim::stepping::RobotShown`]; its
    /// chosen slot is its goal's among its candidates).
    pub fn view(&self) -> madenet_sim::stepping::RobotShown<'_> {
        madenet_sim::stepping::RobotShown {
            goal: self.goal,
            path: &self.path,
            candidates: &self.candidates,
            chosen: self
                .goal
                .and_then(|g| self.candidates.iter().position(|&c| c == g)),
            scores: (!self.scores.is_empty()).then_some(&self.scores[..]),
            decisions: self.decisions,
        }
    }
}

/// A message that could not be read.
#[derive(Debug, thiserror::Error)]
pub enum WireError {
    /// The bytes do not decode as an envelope.
    #[error("malformed message: {0}")]
    Malformed(#[from] postcard::Error),
    /// The message is of another protocol version.
    #[error("message of protocol version {got}, this node speaks {PROTOCOL_VERSION}")]
    Version {
        /// The version it carries.
        got: u16,
    },
    /// A β whose whole map, or a changed cell's index, does not fit this map's size.
    #[error("a β whose map does not fit this map's size")]
    MapSize,
}

impl Envelope {
    /// A message of this node's [`PROTOCOL_VERSION`].
    pub fn new(step: u64, from: Node, to: Node, body: Body) -> Self {
        Envelope {
            version: PROTOCOL_VERSION,
            step,
            from,
            to,
            body,
        }
    }

    /// The envelope serialized with postcard, as a [`Transport`](crate::transport::Transport)
    /// carries it.
    pub fn encode(&self) -> Vec<u8> {
        postcard::to_stdvec(self).expect("every envelope serializes")
    }

    /// Reads a message, refusing other protocol versions.
    pub fn decode(bytes: &[u8]) -> Result<Envelope, WireError> {
        // The version comes first, so a message of another version is named as such rather
        // than failing on a body layout this node does not know.
        let (version, _) = postcard::take_from_bytes::<u16>(bytes)?;
        if version != PROTOCOL_VERSION {
            return Err(WireError::Version { got: version });
        }
        Ok(postcard::from_bytes(bytes)?)
    }
}

/// β on the wire: the paper's β with its local map m_j as a [`MapUpdate`] for this addressee.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BetaMessage {
    /// The sender's robot index j.
    pub from: usize,
    /// Timestep at which it was sent.
    pub t: usize,
    /// g_j^{t-1}
    pub prev_goal: Option<madenet_map::Pos>,
    /// x_j^t
    pub pos: madenet_map::Pos,
    /// g_j^t
    pub goal: Option<madenet_map::Pos>,
    /// |E_j|: cells robot j knows.
    pub explored: usize,
    /// m_j^t, whole or as the changes since the map last sent to this addressee.
    pub map: MapUpdate,
    /// The last changes this sender received from the addressee did not fit (a message was
    /// lost, or the sender restarted): send the whole map next time.
    pub want_full: bool,
}

/// A local map on the wire.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum MapUpdate {
    /// The whole map, row-major (the first exchange with a teammate, or after a resync).
    Full(Vec<Occupancy>),
    /// The cells (row-major index, value) that differ from the map the sender sent to this
    /// addressee at timestep `base`. A belief's merge copies only cells unknown to the
    /// receiver, and a receiver that merged the base already knows every other cell, so
    /// merging the changes leaves it exactly where merging the whole map would.
    Changes {
        /// Timestep of the map the changes build on.
        base: usize,
        /// (row-major index, new value) of every cell that changed.
        cells: Vec<(u32, Occupancy)>,
    },
}

impl BetaMessage {
    /// `beta` for an addressee that last got `base` (timestep, map) from this robot.
    pub fn new(beta: &Beta, base: Option<(usize, &[Occupancy])>, want_full: bool) -> Self {
        let map = match base {
            Some((t, old)) if old.len() == beta.map.len() => MapUpdate::Changes {
                base: t,
                cells: beta
                    .map
                    .iter()
                    .zip(old)
                    .enumerate()
                    .filter(|(_, (new, old))| new != old)
                    .map(|(k, (&new, _))| (k as u32, new))
                    .collect(),
            },
            _ => MapUpdate::Full(beta.map.clone()),
        };
        BetaMessage {
            from: beta.from,
            t: beta.t,
            prev_goal: beta.prev_goal,
            pos: beta.pos,
            goal: beta.goal,
            explored: beta.explored,
            map,
            want_full,
        }
    }

    /// The β to merge, for a receiver whose last map from this sender was of timestep
    /// `heard`, with `cells` cells: the whole map, or the changes on an unknown background.
    /// Also says whether the changes fitted (false: this receiver missed the base).
    pub fn to_beta(&self, heard: Option<usize>, cells: usize) -> Result<(Beta, bool), WireError> {
        let (map, fitted) = match &self.map {
            MapUpdate::Full(m) if m.len() == cells => (m.clone(), true),
            MapUpdate::Changes {
                base,
                cells: changes,
            } => {
                let mut m = vec![Occupancy::Unknown; cells];
                for &(k, v) in changes {
                    *m.get_mut(k as usize).ok_or(WireError::MapSize)? = v;
                }
                (m, heard == Some(*base))
            }
            MapUpdate::Full(_) => return Err(WireError::MapSize),
        };
        let beta = Beta {
            from: self.from,
            t: self.t,
            prev_goal: self.prev_goal,
            pos: self.pos,
            goal: self.goal,
            map,
            explored: self.explored,
        };
        Ok((beta, fitted))
    }
}

/// The digest a node's hello carries of what every node of a run must share: the map's cells,
/// the starts and the scenario config (as TOML). XXH3-64; equal inputs, equal digests, on any
/// machine.
pub fn scenario_digest(
    map: &madenet_map::OccGrid,
    starts: &[madenet_map::Pos],
    config: &madenet_world::ScenarioConfig,
) -> u64 {
    let mut bytes = format!("{}x{};", map.height(), map.width()).into_bytes();
    for r in 0..map.height() {
        for c in 0..map.width() {
            bytes.push(map.get(madenet_map::Pos::new(r as i32, c as i32)) as u8);
        }
    }
    for p in starts {
        bytes.extend_from_slice(format!(";{},{}", p.row, p.col).as_bytes());
    }
    bytes.extend_from_slice(toml::to_string(config).unwrap_or_default().as_bytes());
    xxhash_rust::xxh3::xxh3_64(&bytes)
}
