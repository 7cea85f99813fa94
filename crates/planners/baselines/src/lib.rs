//! The classical baselines of the MADE-Net comparison study (paper Sec. V.A.5), as
//! [`madenet_agent::Policy`] implementations that re-decide every timestep (they are the
//! paper's primitive-level methods):
//!
//! * [`UtilityBased`] (**UB**) — coordinated exploration after Burgard, Moors, Stachniss and
//!   Schneider, "Coordinated multi-robot exploration", IEEE T-RO 2005: frontier targets are
//!   scored by expected information gain minus β · path cost, and targets near the goals the
//!   teammates announced are discounted.
//! * [`DistributedValueFunctions`] (**PB**) — the planning-based Dec-MDP of Matignon,
//!   Jeanpierre and Mouaddib, "Coordinated multi-robot exploration under communication
//!   constraints using decentralized Markov decision processes", AAAI 2012: each robot solves
//!   its MDP over grid cells by value iteration, minus the expected value of the cells its
//!   teammates are likely to reach, their positions predicted from the last contact.
//!
//! * [`BeliefPlan`] (**belief-plan**, ours, not the paper's) — the known-map reference's team
//!   plan (set-cover viewpoints, min–max routes) run on the robot's own belief, its unknown
//!   cells redrawn by the map generator over four maps (`belief-plan-free`: taken as free), its
//!   teammates at their announced goal or else their last known cell; it takes the candidate
//!   nearest its own first viewpoint at each macro termination. A multi-step, team-wide
//!   planner that is not learned: the other yardstick, besides `spread`, that a learned
//!   planner must beat.
//! * [`ExploreLite`] (**explore-lite**) — explore_lite's frontier search and cost, what ROS 2
//!   users run today, for comparisons inside one tool.
//! * [`Convention`] (**convention**, ours) — the robots of a meeting each compute the same team
//!   plan on their merged map (redrawn maps seeded by the trial and the timestep only) and keep
//!   softly to their own part of it until the next meeting: `spread` with a teammate's part
//!   d_s cells dearer.
//!
//! Every constant of UB and PB is a documented field of [`BaselineParams`] (serde, with the
//! defaults named after their source). [`register`] adds `ub`, `pb`, `explore-lite`, `belief-plan`,
//! `belief-plan-free` and `convention` to a [`madenet_sim::PolicyRegistry`].

#![deny(missing_docs)]

mod convention;
mod dvf;
mod explore_lite;
mod plan;
pub mod reference;
pub mod rollout;
mod utility;

pub use convention::Convention;
pub use dvf::{DistributedValueFunctions, PbParams};
pub use explore_lite::{ExploreLite, ExploreLiteParams};
pub use plan::BeliefPlan;
pub use utility::{UbParams, UtilityBased};

use madenet_sim::PolicyRegistry;
use serde::{Deserialize, Serialize};

/// The parameters of both baselines.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaselineParams {
    /// The constants of UB, [`UtilityBased`].
    pub ub: UbParams,
    /// The constants of PB, [`DistributedValueFunctions`].
    pub pb: PbParams,
    /// explore_lite's parameters, [`ExploreLite`].
    pub explore_lite: ExploreLiteParams,
}

impl BaselineParams {
    /// Checks every parameter's range; the error names the field (`pb.discount`, …).
    pub fn validate(&self) -> Result<(), String> {
        fn at_least(name: &str, v: f64, min: f64) -> Result<(), String> {
            if v.is_finite() && v >= min {
                Ok(())
            } else {
                Err(format!("{name}: must be a finite number ≥ {min}, got {v}"))
            }
        }
        fn within(name: &str, v: usize, lo: usize, hi: usize) -> Result<(), String> {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(format!("{name}: must be in {lo}..={hi}, got {v}"))
            }
        }
        if let Some(b) = self.ub.beta {
            at_least("ub.beta", b, 0.0)?;
        }
        if let Some(r) = self.ub.coordination_radius {
            if !(r.is_finite() && r > 0.0) {
                return Err(format!(
                    "ub.coordination_radius: must be a positive number of cells, got {r}"
                ));
            }
        }
        let pb = &self.pb;
        // The MDP covers (2·horizon + 1)² cells around the robot.
        within("pb.horizon", pb.horizon, 1, 256)?;
        within("pb.iterations", pb.iterations, 1, 100_000)?;
        within("pb.reach_radius", pb.reach_radius, 0, 1024)?;
        at_least("pb.tolerance", pb.tolerance as f64, 0.0)?;
        if !(pb.discount > 0.0 && pb.discount <= 1.0) {
            return Err(format!(
                "pb.discount: the discount γ must be in (0, 1], got {}",
                pb.discount
            ));
        }
        at_least("pb.teammate_weight", pb.teammate_weight as f64, 0.0)?;
        at_least("pb.crowding_weight", pb.crowding_weight as f64, 0.0)?;
        at_least("pb.stuck_threshold", pb.stuck_threshold as f64, 0.0)?;
        self.explore_lite.validate()
    }
}

/// Registers `ub`, `pb` and `explore-lite` with these parameters, and `belief-plan`,
/// `belief-plan-free` and `convention` at their fixed settings.
pub fn register(registry: &mut PolicyRegistry, params: &BaselineParams) {
    let el = params.explore_lite.clone();
    registry.register(
        "explore-lite",
        "explore_lite's frontier search and cost (m-explore-ros2, what ROS 2 users run today), each robot on its own: the cheapest frontier off its blacklist, replanned at 0.15 Hz",
        move |ctx| Box::new(ExploreLite::new(el.clone(), ctx.config.cell_size)),
    );
    let ub = params.ub.clone();
    registry.register(
        "ub",
        "utility-based coordinated exploration (Burgard et al. 2005), re-decided every timestep",
        move |ctx| {
            Box::new(UtilityBased::new(
                ub.clone(),
                ctx.config,
                ctx.height,
                ctx.width,
            ))
        },
    );
    let pb = params.pb.clone();
    registry.register(
        "pb",
        "planning-based Dec-MDP with distributed value functions (Matignon et al. 2012), re-decided every timestep",
        move |ctx| Box::new(DistributedValueFunctions::new(pb.clone(), ctx.config, ctx.height, ctx.width)),
    );
    registry.register(
        "belief-plan",
        "the known-map reference's team plan on the robot's own belief (unknown cells redrawn by the map generator over 4 maps, teammates at their announced goal or last known cell); the candidate nearest its first viewpoint",
        |ctx| Box::new(BeliefPlan::new(4, ctx.seed, ctx.robot)),
    );
    registry.register(
        "belief-plan-free",
        "belief-plan with the belief's unknown cells taken as free (optimistic) instead of redrawn",
        |ctx| Box::new(BeliefPlan::new(0, ctx.seed, ctx.robot)),
    );
    registry.register(
        "convention",
        "spread with the teammates' parts of a team plan that every robot of a meeting computes alike (the known-map reference's planner on the merged map, 4 redrawn maps) d_s dearer, until the next meeting",
        |ctx| {
            Box::new(Convention::new(
                4,
                f64::from(ctx.config.sensing_range),
                ctx.seed,
                ctx.height,
                ctx.width,
            ))
        },
    );
}

/// The built-in policies plus the baselines at their defaults.
pub fn registry() -> PolicyRegistry {
    let mut r = PolicyRegistry::builtin();
    register(&mut r, &BaselineParams::default());
    r
}
