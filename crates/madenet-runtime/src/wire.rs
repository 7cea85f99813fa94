//! The wire format: every message between nodes is one [`Envelope`], serialized with postcard.
//!
//! An envelope carries the protocol version (a node refuses any other), the timestep it belongs
//! to, and its sender. The bodies are the data flow of a timestep: the world sends each robot its
//! observation; robots send β to the teammates they exchanged with and plans to lower-priority
//! ones; each robot sends the world its move; the world ends the run with `Stop`.

use madenet_agent::{Beta, PlanMessage};
use madenet_world::{Move, Observation};
use serde::{Deserialize, Serialize};

/// Version of the wire format; bumped on any change to [`Envelope`] or [`Body`].
pub const PROTOCOL_VERSION: u16 = 1;

/// Who sends or receives: the world (ground truth, motion, sensing, the radio model) or a robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Node {
    World,
    Robot(usize),
}

/// One message.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Envelope {
    pub version: u16,
    /// The timestep the message belongs to (the world's t when the observation was made).
    pub step: u64,
    pub from: Node,
    pub body: Body,
}

/// What a message says.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Body {
    /// World → robot: its observation o_i of this timestep (with whom it exchanged β).
    Observation(Observation),
    /// Robot → robot, along a successful exchange: β (paper Sec. III.C.1).
    Beta(Beta),
    /// Robot → lower-priority robot it exchanged with: its space-time plan.
    Plan(PlanMessage),
    /// Robot → world: the move it intends this timestep.
    Move(Move),
    /// World → robot: the trial is over (complete or at the step cap).
    Stop,
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
    pub fn new(step: u64, from: Node, body: Body) -> Self {
        Envelope {
            version: PROTOCOL_VERSION,
            step,
            from,
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
