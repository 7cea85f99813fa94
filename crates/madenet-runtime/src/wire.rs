//! The wire format: every message between nodes is one [`Envelope`], serialized with postcard.
//!
//! An envelope carries the protocol version (a node refuses any other), the timestep it belongs
//! to, its sender and its addressee. The bodies are the data flow of a timestep: the world sends
//! each robot its observation and the radio the pairs in contact; the radio tells each robot in
//! contact with whom its link is up; robots send β to those teammates and plans to the
//! lower-priority ones — through the radio, which forwards only along links that are up; each
//! robot sends the world its move; the world ends the run with `Stop`.

use madenet_agent::{Beta, PlanMessage};
use madenet_world::{Move, Observation};
use serde::{Deserialize, Serialize};

/// Version of the wire format; bumped on any change to [`Envelope`] or [`Body`].
pub const PROTOCOL_VERSION: u16 = 2;

/// Who sends or receives: the world (ground truth, motion, sensing), the radio (the paper's
/// communication model) or a robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Node {
    World,
    Radio,
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
    pub version: u16,
    /// The timestep the message belongs to (the world's t when the observation was made).
    pub step: u64,
    pub from: Node,
    /// The addressee; a robot's message to a teammate travels through the radio.
    pub to: Node,
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
    Links { now: Vec<usize>, late: Vec<usize> },
    /// Robot → robot, along a successful exchange: β (paper Sec. III.C.1).
    Beta(Beta),
    /// Robot → lower-priority robot it exchanged with: its space-time plan.
    Plan(PlanMessage),
    /// Robot → world: the move it intends this timestep.
    Move(Move),
    /// World → robots and radio: the trial is over (complete or at the step cap).
    Stop,
    /// Robot → world when it starts: wait for my moves (again, after a restart).
    Hello,
    /// Robot → world, answering `Stop`: its decisions and their total wall time, and its
    /// latency from observation to move (timesteps acted, total and longest, seconds).
    Done {
        decisions: usize,
        decision_s: f64,
        acted: usize,
        latency_s: f64,
        latency_max_s: f64,
    },
}

/// A message that could not be read.
#[derive(Debug, thiserror::Error)]
pub enum WireError {
    #[error("malformed message: {0}")]
    Malformed(#[from] postcard::Error),
    #[error("message of protocol version {got}, this node speaks {PROTOCOL_VERSION}")]
    Version { got: u16 },
}

impl Envelope {
    pub fn new(step: u64, from: Node, to: Node, body: Body) -> Self {
        Envelope {
            version: PROTOCOL_VERSION,
            step,
            from,
            to,
            body,
        }
    }

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
