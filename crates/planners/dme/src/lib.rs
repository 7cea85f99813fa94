//! The DME-DRL baseline (He et al., decentralized multi-robot exploration with multi-agent deep
//! RL): MADDPG with decentralized actors and centralized critics, as the MADE-Net paper
//! compares against it (Sec. IV.B: no interaction penalty; the sector actions are walked to
//! their goal as in the original code — see `models/README.md` for why not re-decided every step).
//!
//! * [`sectors`]: the action space — one of 8 angular sectors around the robot; its goal is
//!   the nearest (by path through the robot's known free cells) frontier cell in that sector;
//!   sectors without one are masked.
//! * [`obs`]: what an actor sees — its own map as a short frame history, and a pose vector
//!   (own and teammates' last known positions).
//! * [`nets`]: actor and centralized critic on burn.
//! * [`policy`]: execution — a robot picks a sector and heads for its goal until the goal is
//!   reached or void, then picks again.
//! * [`maddpg`]: the update (critic TD step, Gumbel-softmax actor step, soft targets).
//! * [`train`]: `madenet train --method dme-drl` — episodes on generated maps, replay,
//!   validation, checkpoints and resume, the logs and Fig. 2 of `madenet-trainlog`.
//!
//! `docs/design/dme-drl-brief.md` records what the original code does and where this
//! implementation departs from it.

#![deny(missing_docs)]

pub mod maddpg;
pub mod model;
pub mod nets;
pub mod obs;
pub mod policy;
pub mod sectors;
pub mod shipped;
pub mod train;

pub use policy::DmePolicy;
pub use sectors::{sector_goals, sector_of, view_sector_goals, SectorGoals, SECTORS};
