//! A continuous 2-D world for madenet's agents (issue 26): the paper's second experiment
//! (Sec. V.B: differential-drive robots, maps from SLAM discretized into 1 m cells, a local
//! planner, time in seconds) without Gazebo.
//!
//! The same agents that explore the grid world drive here. Each robot sees the world only
//! through its own lidar: its scans build its own occupancy-probability grid ([`mapping`]), and
//! the agent reads that grid through the paper's discretization rule into its 1 m cells. The
//! agent's moves name the next cell; the [`local`] planner drives the robot into it on the
//! robot's own fine map, around what it has seen and its teammates (constant-velocity
//! prediction). Geometry, bodies, contacts and ray casts are rapier2d's.
//!
//! - [`config`]: every parameter, its default and its source, in [`ContinuousConfig`].
//! - [`scene`]: the true geometry (shapes and a fine raster), from a map file at its native
//!   resolution ([`Scene::from_grid`]) or the seeded generator of cluttered worlds
//!   ([`scene::generate_cluttered`]).
//! - [`world`]: [`ContinuousWorld`], one control period at a time: motion → contacts →
//!   sensing; radio contacts on demand.
//! - [`mapping`]: [`RobotMap`], log-odds per pixel and the coarse cells read from it.
//! - [`local`]: the local planner, [`LocalPlanner`].
//! - [`navigate`]: navigation to a point (nav2's `NavigateToPose`), [`Navigator`].
//!
//! ```
//! use madenet_continuous::{scene::generate_cluttered, ContinuousConfig, ContinuousWorld};
//! use madenet_map::Pos;
//! use std::sync::Arc;
//!
//! let scene = Arc::new(generate_cluttered(20.0, 0.1, 7));
//! let starts = [Pos::new(17, 2), Pos::new(17, 3), Pos::new(18, 2)];
//! let cfg = ContinuousConfig::default();
//! let mut world =
//!     ContinuousWorld::new(scene, &starts, Default::default(), cfg, 7).unwrap();
//! world.step(&[(0.3, 0.0), (0.0, 0.5), (0.0, 0.0)]);
//! assert!((world.time() - cfg.control_period).abs() < 1e-9);
//! assert!(world.explored_fraction() > 0.0);
//! ```

#![deny(missing_docs)]

pub mod config;
pub mod local;
pub mod mapping;
pub mod navigate;
pub mod scene;
pub mod world;

pub use config::{ConfigError, ContinuousConfig, MAX_TIME_CAP};
pub use local::{Command, LocalPlanner, Neighbour};
pub use mapping::RobotMap;
pub use navigate::{NavError, NavParams, NavStatus, Navigator};
pub use scene::Scene;
pub use world::{
    check_map_memory, normalize_angle, Collisions, ContinuousError, ContinuousWorld, Pose,
};
