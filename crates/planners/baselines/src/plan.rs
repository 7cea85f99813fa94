//! **belief-plan**: the known-map reference's team plan run on what one robot knows
//! ([`crate::reference::candidate_plan_moves`]) — a decentralized, multi-step planner
//! that is not learned, the yardstick a learned planner must beat besides `spread`.

use madenet_agent::{AgentView, Decision, Policy, Spread};
use madenet_map::OccGrid;

/// At each macro termination the robot plans the whole team's routes on its own belief m_i —
/// itself and every teammate it has heard of or seen, at the goal it last announced or else its
/// last known cell — with the reference's set-cover viewpoints and min–max routes, and
/// takes the goal candidate with the fewest moves to its own first viewpoint; ties, and a plan
/// that leaves it nothing, go to `spread`'s order. The belief's unknown cells are redrawn by the
/// map generator over `futures` maps ([`BeliefPlan::new`]; the moves averaged, as the plan-redrawn
/// teacher's), or taken as free with none.
#[derive(Clone, Debug)]
pub struct BeliefPlan {
    spread: Spread,
    futures: usize,
    seed: u64,
    robot: usize,
    decisions: u64,
}

impl BeliefPlan {
    /// The planner redrawing over `futures` maps (0: unknown cells free), its draws from the
    /// stream `belief-plan/redraw` of the trial's `seed` and the robot's index `robot` (d_s: the
    /// view's).
    pub fn new(futures: usize, seed: u64, robot: usize) -> Self {
        BeliefPlan {
            spread: Spread,
            futures,
            seed,
            robot,
            decisions: 0,
        }
    }

    /// Maps redrawn for the decision at hand (none with `futures` = 0; none either if the
    /// generator fails, which leaves the decision to `spread`'s order).
    fn fills(&mut self, view: &AgentView<'_>) -> Vec<OccGrid> {
        self.decisions += 1;
        let base = ((self.robot as u64) << 40) | (self.decisions << 8);
        crate::rollout::generated_maps(
            view.belief.height(),
            view.belief.width(),
            view.belief.movement(),
            self.seed,
            "belief-plan/redraw",
            (0..self.futures as u64).map(|k| base | k),
        )
        .unwrap_or_default()
    }
}

impl Policy for BeliefPlan {
    fn name(&self) -> &str {
        "belief-plan"
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let spread = self.spread.scores(view);
        let fills = self.fills(view);
        let moves = crate::reference::candidate_plan_moves(view, &fills);
        let best = spread
            .iter()
            .enumerate()
            .filter_map(|(k, s)| s.map(|s| (k, s)))
            .min_by(|a, b| {
                let m = |k: usize| moves.as_ref().map_or(0.0, |m| m[k]);
                m(a.0)
                    .total_cmp(&m(b.0))
                    .then(a.1.total_cmp(&b.1))
                    .then(a.0.cmp(&b.0))
            });
        match best {
            Some((k, _)) => Decision::Candidate(k),
            None => Decision::Idle,
        }
    }
}
