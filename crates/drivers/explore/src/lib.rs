//! `madenet explore`, one robot's exploration node for a team that nav2 drives (issue 58): a
//! drop-in for explore_lite (`m-explore-ros2`) that coordinates with its teammates.
//!
//! Its parts:
//! - [`params`]: explore_lite's parameter file read as ROS 2 reads a `--params-file` (node keys
//!   matched against the node's fully qualified name, as rclcpp matches them), with madenet's
//!   own settings beside explore_lite's;
//! - [`node`]: one robot's node, driving its nav2 through `navigate_to_pose`, with an expiring
//!   blacklist; its goals chosen by explore_lite's frontiers ([`lite`]) or any madenet policy on
//!   the paper's cells ([`choice`], [`cells`]);
//! - [`launch`]: a team of nodes as processes, beside the simulated nav2 team;
//! - [`team`]: what teammates share over ROS 2 topics (maps as deltas, positions, goals).
//!
//! ```
//! use madenet_explore::params::ExploreParams;
//! let yaml = "/**:\n  ros__parameters:\n    costmap_topic: map\n    planner_frequency: 0.15\n";
//! let p = ExploreParams::from_yaml(yaml, "/robot0/explore_node").unwrap();
//! assert_eq!(p.costmap_topic, "map");
//! assert_eq!(p.planner_frequency, 0.15);
//! assert_eq!(p.costmap_updates_topic, "costmap_updates"); // explore_lite's default
//! ```

pub mod cells;
pub mod choice;
pub mod cli;
pub mod launch;
pub mod lite;
pub mod node;
pub mod params;
pub mod team;
