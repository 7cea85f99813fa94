//! The multi-robot exploration world of MADE-Net (Tan et al., RA-L 2023, Sec. III and V.A).
//!
//! The world owns what no robot may see directly: the ground-truth grid, every robot's true
//! pose, the random streams, the communication dropouts and the team's merged knowledge (used
//! for termination, metrics and centralized training). One timestep is an explicit pipeline
//! of plain stages — see [`World::step`]:
//!
//! 1. **motion** — simultaneous 8-connected moves with slip (`motion_success_prob`), the
//!    corner-cutting rule and deterministic conflict resolution;
//! 2. **sensing** — a (2·d_s+1)² window of Bresenham rays with per-cell misses
//!    (`sensor_miss_prob`);
//! 3. **contact & communication** — robots within d_s and in line of sight detect each other and
//!    exchange β with probability `comm_success_prob` (CSP), a failure starting a dropout of
//!    `dropout_steps` for that pair (the [`Radio`], which a decentralized runtime runs as its
//!    own node).
//!
//! Robots see the world only through [`Observation`]s and act only through [`Move`]s; the
//! messages they exchange are delivered by the trial runner along [`World::exchanges`].
//! All parameters live in [`ScenarioConfig`], whose defaults are the paper's values.
//!
//! ```
//! use madenet_map::paper::{paper_map, Corner};
//! use madenet_world::{Move, ScenarioConfig, World};
//!
//! let map = paper_map(3).unwrap();
//! let starts = Corner::TopLeft.start_cells(map.height(), map.width());
//! let mut world = World::new(map, &starts, ScenarioConfig::default(), 7).unwrap();
//! let seen = world.explored_fraction(); // the start's first sensing (t = 0)
//! assert!(seen > 0.0);
//! // Each robot senses its window every timestep; staying put, it learns nothing new.
//! world.step(&[Move::Stay; 3]);
//! assert_eq!((world.t(), world.explored_fraction()), (1, seen));
//! assert_eq!(world.observation(0).pos, starts[0]);
//! ```

#![deny(missing_docs)]

pub mod config;
pub mod geometry;
pub mod radio;
pub mod rng;
pub mod world;

pub use config::{
    goal_count_eq3, CandidateRule, ConfigError, ScenarioConfig, MAX_GOALS, MAX_PLAN_HORIZON,
    MAX_ROBOTS, MAX_SENSING_RANGE, MAX_STEP_CAP,
};
pub use geometry::{
    bresenham, line_of_sight, ray_clear, squeezed, step_allowed, Move, ViewPattern,
};
pub use radio::Radio;
pub use world::{Observation, ScenarioError, Visibility, World};
