//! One robot of MADE-Net, self-contained (paper Sec. III.C): its belief (local map m_i with
//! an incrementally maintained frontier), its teammate records (the β it last heard), goal
//! extraction (𝒢_i), its policy and its navigation controller.
//!
//! An [`Agent`] sees the world only through a [`madenet_world::Observation`], hears teammates
//! only through [`Beta`] and [`PlanMessage`], and acts only through a [`madenet_world::Move`],
//! so the same code can later run as its own process over a real transport. Per timestep the
//! runner calls, in order: [`Agent::observe`], [`Agent::receive_beta`] for each exchange,
//! [`Agent::needs_decision`] / [`Agent::decide`], [`Agent::receive_plan`] from higher-priority
//! teammates, [`Agent::plan`], [`Agent::next_move`].
//!
//! Policies implement [`Policy`] (one per robot) or [`JointPolicy`] (centralized). The
//! nearest-frontier baseline [`NearestFrontier`] ships here.
//!
//! ```
//! use madenet_agent::{Agent, AgentConfig, NearestFrontier};
//! use madenet_map::paper::{paper_map, Corner};
//! use madenet_world::{ScenarioConfig, World};
//!
//! let cfg = ScenarioConfig { num_robots: 1, ..ScenarioConfig::default() };
//! let map = paper_map(3).unwrap();
//! let starts = Corner::TopLeft.start_cells(map.height(), map.width());
//! let (h, w) = (map.height(), map.width());
//! let mut world = World::new(map, &starts, cfg.clone(), 7).unwrap();
//! let seen = world.explored_fraction();
//! // One robot: each timestep it sees, decides when its macro action ends, plans and moves.
//! let mut agent = Agent::new(AgentConfig::from_scenario(&cfg, 0, h, w), starts[0], Box::new(NearestFrontier));
//! for _ in 0..10 {
//!     agent.observe(world.observation(0));
//!     if agent.needs_decision() {
//!         agent.decide();
//!     }
//!     agent.plan();
//!     world.step(&[agent.next_move()]);
//! }
//! assert!(world.explored_fraction() > seen, "it explored");
//! assert_ne!(world.positions()[0], starts[0]);
//! ```

#![deny(missing_docs)]

pub mod agent;
pub mod belief;
pub mod goals;
pub mod joint;
pub mod messages;
pub mod policy;
pub mod view;

pub use agent::{
    Agent, AgentConfig, AgentStats, Termination, ViewScratch, BLOCKED_STEPS, OSCILLATION_CELLS,
    OSCILLATION_STEPS, YIELD_STEPS,
};
pub use belief::Belief;
pub use goals::{extract_goals, extract_goals_with, GoalCandidates};
pub use joint::{joint_decode, joint_digit, joint_encode};
pub use messages::{Beta, PlanMessage, TeammateRecord};
pub use policy::{
    Decision, DecisionMode, External, JointPolicy, NearestFrontier, Policy, RandomCandidate, Spread,
};
pub use view::{action_mask, write_joint_map_image, AgentView};
