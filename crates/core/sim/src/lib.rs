//! Runs MADE-Net trials (paper Sec. V.A): wires a [`madenet_world::World`] to one
//! [`madenet_agent::Agent`] per robot, carries their messages along the world's successful
//! exchanges, and records the trajectory and [`madenet_metrics::TrialMetrics`].
//!
//! One timestep of [`Trial::step`] is the paper's data flow as explicit stages:
//!
//! 1. **observe** — each agent takes its [`madenet_world::Observation`];
//! 2. **exchange** — for every pair whose exchange succeeded, each side's β (sent as it was
//!    before this step's exchanges, so nothing is relayed within a step) is delivered;
//! 3. **decide** — agents whose macro action terminated (or every agent, for primitive-level
//!    policies) ask their policy for a goal;
//! 4. **plan** — in priority order (robot index), each agent plans and sends its plan to the
//!    lower-priority teammates it exchanged with, who plan around it (space-time A*);
//! 5. **act** — the agents' moves go to [`madenet_world::World::step`] (motion, sensing,
//!    contact & communication).
//!
//! The same seed gives byte-identical trajectories and metrics.
//!
//! ```
//! use madenet_map::paper::{paper_map, Corner};
//! use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
//! use madenet_world::ScenarioConfig;
//!
//! let map = paper_map(3).unwrap();
//! let spec = TrialSpec {
//!     starts: Corner::TopLeft.start_cells(map.height(), map.width()).to_vec(),
//!     map,
//!     map_name: "paper_3".into(),
//!     config: ScenarioConfig { comm_success_prob: 0.5, ..ScenarioConfig::default() },
//!     policy: "spread".into(),
//!     seed: 7,
//! };
//! let registry = PolicyRegistry::builtin();
//! let result = Trial::with_registry(spec.clone(), &registry).unwrap().run();
//! assert!(result.metrics.completed);
//! // Same seed, same trial.
//! let again = Trial::with_registry(spec, &registry).unwrap().run();
//! assert_eq!(again.metrics.tns, result.metrics.tns);
//! ```

#![deny(missing_docs)]

pub mod continuous;
mod registry;
pub mod rewards;
pub mod scenario;
pub mod stepping;
mod summary;
mod trial;

pub use registry::{PolicyContext, PolicyRegistry};
pub use rewards::{RewardConfig, StepRewards};
pub use scenario::{check_trial_set_size, MapSource, StartSpec, MAX_PLANNED_CELLS, MAX_TRIALS};
pub use stepping::{Present, Sink, Stepping};
pub use trial::{
    build, build_agent, record_step, Future, StepRecord, Trial, TrialResult, TrialSpec,
};

/// Errors setting up a trial; messages name the field at fault.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A continuous world that cannot start (bad start, bad field).
    #[error("{0}")]
    Continuous(String),
    /// No policy of that name is in the [`PolicyRegistry`].
    #[error("unknown policy `{name}` (field `policy`); known policies: {known}")]
    UnknownPolicy {
        /// The name asked for (field `policy`).
        name: String,
        /// The registered names, comma-separated.
        known: String,
    },
    /// The policy exists but its check refuses this scenario
    /// ([`PolicyRegistry::register_checked`]).
    #[error("policy `{name}` cannot run this scenario: {reason}")]
    PolicyUnavailable {
        /// The policy's registered name.
        name: String,
        /// Why not, as the policy's check says (e.g. the model's map or team size).
        reason: String,
    },
    /// The world cannot start: a bad config or bad start cells.
    #[error(transparent)]
    Scenario(#[from] madenet_world::ScenarioError),
    /// A bad config on its own (the world's own validation arrives as [`SimError::Scenario`]).
    #[error(transparent)]
    Config(#[from] madenet_world::ConfigError),
    /// The map generator cannot draw a map of the trial's size (the redrawn oracle, `madenet_baselines::rollout`).
    #[error("the redrawn oracle cannot draw a map of the trial's size: {0}")]
    Redraw(madenet_map::MapError),
}
