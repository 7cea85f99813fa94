//! The text summaries of a trial's result, as `madenet run` and `launch` print them without
//! `--json`: one line per metric, named as the paper names them (TNS, TTD, NOLI, OFV, CT; the
//! continuous world's ET).

use crate::continuous::ContinuousResult;
use crate::TrialResult;

impl TrialResult {
    /// The summary of a grid trial started at `start` (its name: `top-left`, `random`, …).
    pub fn summary(&self, start: &str) -> Vec<String> {
        let m = &self.metrics;
        let t = &self.timing;
        vec![
            format!(
                "map {}  start {start}  policy {}  csp {}  seed {}",
                self.map, self.policy, self.comm_success_prob, self.seed
            ),
            format!("completed  {}", m.completed),
            format!("TNS        {} steps", m.tns),
            format!("TTD        {:.2} m", m.ttd),
            format!("NOLI       {}", m.noli),
            format!("OFV        {:.3}", m.ofv),
            format!("explored   {:.1} %", 100.0 * m.explored),
            format!(
                "CT         {:.3} ms per trial, {:.1} µs per decision ({} decisions)",
                1e3 * t.trial_s,
                1e6 * t.per_decision_s,
                t.decisions
            ),
        ]
    }
}

impl ContinuousResult {
    /// The summary of a continuous trial started at `start`.
    pub fn summary(&self, start: &str) -> Vec<String> {
        let completed = match (self.complete, self.no_frontier_at) {
            (true, _) => "completed  true".to_string(),
            (false, Some(t)) => format!(
                "completed  false: no robot had a reachable frontier from {t:.1} s on, the team \
                 stopped at {:.1} % explored (`no_frontier_time`)",
                100.0 * self.explored.last().copied().unwrap_or(0.0)
            ),
            (false, None) => "completed  false: time cap reached (`time_cap`)".to_string(),
        };
        vec![
            format!(
                "map {}  start {start}  policy {}  csp {}  seed {}  (continuous world)",
                self.map, self.policy, self.comm_success_prob, self.seed
            ),
            completed,
            format!("ET         {:.1} s", self.exploration_time_s),
            format!("TTD        {:.1} m", self.team_distance_m),
            format!(
                "collisions {} with obstacles, {} between robots",
                self.obstacle_collisions, self.robot_collisions
            ),
            format!("local interactions {}", self.local_interactions),
            format!(
                "impassable cells {}  written off {}  held up {}  stuck {}",
                self.impassable_cells, self.written_off_cells, self.held_up, self.stuck
            ),
            format!(
                "wall clock {:.2} s ({:.0}x real time)",
                self.wall_s,
                self.real_time_factor()
            ),
        ]
    }
}
