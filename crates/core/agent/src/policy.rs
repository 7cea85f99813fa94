//! The policy interface, and the policies that ship with the simulator core.

use crate::view::AgentView;
use madenet_map::{Occupancy, Pos};
use rand::RngExt;

/// When a policy is asked for a goal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecisionMode {
    /// Every timestep: the paper's primitive-level baselines (NF, UB, PB).
    EveryStep,
    /// Only when the robot's macro action terminated (reached, teammate newly detected, goal
    /// no longer a reachable frontier): macro-action policies such as MADE-Net.
    OnTermination,
}

/// What a policy returns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    /// Macro action k: go to goal candidate k (must be valid).
    Candidate(usize),
    /// Go to any cell (classical policies pick any frontier cell).
    Goal(Pos),
    /// Nothing left to do: stay in place.
    Idle,
}

/// A decentralized policy: one instance per robot, seeing only that robot's view.
pub trait Policy: Send {
    /// Registry name (e.g. `"nf"`).
    fn name(&self) -> &str;
    /// When this policy is asked for a decision. The default is macro actions, decided when
    /// the current one terminates, as the paper's planners do.
    fn mode(&self) -> DecisionMode {
        DecisionMode::OnTermination
    }
    /// Whether the view must carry goal candidates (their extraction costs a full Dijkstra).
    fn needs_candidates(&self) -> bool {
        true
    }
    /// The robot's decision from its own view z_i: at each macro termination, or every
    /// timestep under [`DecisionMode::EveryStep`].
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision;
    /// The values the last decision weighed, one per goal-candidate slot (a learned policy's
    /// scores or Q-values, higher preferred; −∞ for a slot it could not take), if this policy
    /// has any and its last decision used them. Reading them changes nothing.
    fn last_scores(&self) -> Option<&[f32]> {
        None
    }
}

/// A centralized policy choosing for the whole team from the joint observation (the CEP of
/// centralized training). `needs[i]` tells which robots' macro actions terminated; the
/// decisions of the others are ignored.
pub trait JointPolicy: Send {
    /// Registry name.
    fn name(&self) -> &str;
    /// One decision per robot from every robot's view and the team's merged map 𝓜
    /// (`team_map`, row-major); only those of robots with `needs[i]` are applied.
    fn decide(
        &mut self,
        views: &mut [AgentView<'_>],
        needs: &[bool],
        team_map: &[Occupancy],
    ) -> Vec<Decision>;
}

/// The stand-in policy of a robot whose decisions come from outside, from a [`JointPolicy`]:
/// it decides at macro terminations, and asked itself it idles.
#[derive(Clone, Debug, Default)]
pub struct External;

impl Policy for External {
    fn name(&self) -> &str {
        "external"
    }
    fn decide(&mut self, _view: &mut AgentView<'_>) -> Decision {
        Decision::Idle
    }
}

/// Nearest frontier (NF; Yamauchi, "A frontier-based approach for autonomous exploration",
/// 1997): the frontier cell with the shortest path from the robot through its known free
/// cells, re-decided every timestep as in the authors' code. Ties go to the lower row-major
/// index. The robot's own cell is never its goal. Coordination happens only through the maps
/// teammates share.
#[derive(Clone, Debug, Default)]
pub struct NearestFrontier;

impl Policy for NearestFrontier {
    fn name(&self) -> &str {
        "nf"
    }
    fn mode(&self) -> DecisionMode {
        DecisionMode::EveryStep
    }
    fn needs_candidates(&self) -> bool {
        false
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        match view.nearest_frontier() {
            Some(p) => Decision::Goal(p),
            None => Decision::Idle,
        }
    }
}

/// A uniformly random valid goal candidate at each macro termination: the floor any learned
/// macro policy must beat, and a driver for testing macro actions.
#[derive(Clone, Debug)]
pub struct RandomCandidate {
    rng: madenet_world::rng::Rng,
}

impl RandomCandidate {
    /// The policy of robot `robot`, its random stream derived from the trial `seed`.
    pub fn new(seed: u64, robot: usize) -> Self {
        RandomCandidate {
            rng: madenet_world::rng::stream(seed, "policy/random", robot as u64),
        }
    }
}

impl Policy for RandomCandidate {
    fn name(&self) -> &str {
        "random"
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let n = view.candidates().cells.len();
        if n == 0 {
            Decision::Idle
        } else {
            Decision::Candidate(self.rng.random_range(0..n))
        }
    }
}

/// "spread": the ten-line rule a learned macro policy must beat. At each macro termination it
/// takes the goal candidate of least path cost plus a penalty of 2·d_s for every teammate whose
/// announced goal (heard within [`Spread::GOAL_MEMORY`] steps) or last known position (within
/// [`Spread::POSITION_MEMORY`] steps) lies within d_s (Chebyshev) of the candidate: go to the
/// nearest frontier nobody else is heading for or standing at. Ties go to the lower slot. The
/// constants were chosen once, not tuned.
#[derive(Clone, Copy, Debug, Default)]
pub struct Spread;

impl Spread {
    /// Announced goals older than this many steps are ignored.
    pub const GOAL_MEMORY: usize = 30;
    /// Positions older than this many steps are ignored.
    pub const POSITION_MEMORY: usize = 10;

    /// The spread score of every candidate (lower is better; path cost in cells plus the
    /// crowding penalty), `None` for a candidate the robot cannot reach.
    pub fn scores(&self, view: &mut AgentView<'_>) -> Vec<Option<f64>> {
        let cells = view.candidates().cells.clone();
        let costs: Vec<Option<f64>> = cells.iter().map(|&c| view.path_cost(c)).collect();
        let view = &*view;
        let ds = view.sensing_range;
        let recent = |at: Option<usize>, memory: usize| {
            at.is_some_and(|a| view.t.saturating_sub(a) <= memory)
        };
        let near = |a: Pos, b: Pos| a.chebyshev(b) <= ds;
        cells
            .iter()
            .zip(costs)
            .map(|(&c, cost)| {
                let cost = cost?;
                let crowded = view
                    .teammates
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != view.id)
                    .filter(|(_, r)| {
                        let goal = r.goal.filter(|_| recent(r.heard_at, Self::GOAL_MEMORY));
                        let seen_at = match (r.seen_at, r.heard_at) {
                            (Some(s), Some(h)) => Some(s.max(h)),
                            (s, h) => s.or(h),
                        };
                        let pos = r
                            .last_pos()
                            .filter(|_| recent(seen_at, Self::POSITION_MEMORY));
                        goal.is_some_and(|g| near(g, c)) || pos.is_some_and(|p| near(p, c))
                    })
                    .count();
                Some(cost + 2.0 * ds as f64 * crowded as f64)
            })
            .collect()
    }
}

impl Policy for Spread {
    fn name(&self) -> &str {
        "spread"
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let best = self
            .scores(view)
            .into_iter()
            .enumerate()
            .filter_map(|(k, s)| s.map(|s| (k, s)))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        match best {
            Some((k, _)) => Decision::Candidate(k),
            None => Decision::Idle,
        }
    }
}
