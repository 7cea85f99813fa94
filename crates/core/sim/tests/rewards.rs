//! Eq. (7) and (8) on hand-made scenarios, through the real trial pipeline.

use madenet_agent::{AgentView, Decision, DecisionMode, Policy};
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_world::ScenarioConfig;

/// Goes east every step (goal: the cell to its east), or stays.
struct East(bool);
impl Policy for East {
    fn name(&self) -> &str {
        "east"
    }
    fn mode(&self) -> DecisionMode {
        DecisionMode::EveryStep
    }
    fn needs_candidates(&self) -> bool {
        false
    }
    fn decide(&mut self, v: &mut AgentView<'_>) -> Decision {
        if self.0 {
            Decision::Goal(Pos::new(v.pos.row, v.pos.col + 1))
        } else {
            Decision::Idle
        }
    }
}

fn trial(robots: usize, starts: Vec<Pos>, moving: bool) -> Trial {
    let mut reg = PolicyRegistry::default();
    reg.register("east", "", move |_| Box::new(East(moving)));
    let config = ScenarioConfig {
        num_robots: robots,
        sensor_miss_prob: 0.0,
        motion_success_prob: 1.0,
        ..Default::default()
    };
    let spec = TrialSpec {
        map: OccGrid::new(12, 14, Occupancy::Free),
        map_name: "open".into(),
        starts,
        config,
        policy: "east".into(),
        seed: 1,
    };
    Trial::with_registry(spec, &reg).unwrap()
}

#[test]
fn one_robot_moving_east() {
    // At (5, 5) the 9×9 window (rows 1..=9, cols 1..=9) is all seen at t = 0. One step east
    // reveals column 10 (9 new cells) and sees the other 72 again.
    let mut t = trial(1, vec![Pos::new(5, 5)], true);
    assert!(t.step());
    assert_eq!(t.world().positions()[0], Pos::new(5, 6));
    assert_eq!(t.rewards().robots, vec![9.0 - 72.0]);
    assert_eq!(t.rewards().team, 9.0 - 72.0 - 1.0);
}

#[test]
fn interaction_penalty_grows_with_consecutive_contact() {
    // Two robots side by side that stay: everything is re-observed (81 + the neighbour's
    // extra column 9 cells, all known), and ρ counts 1, 2, 3, …
    let mut t = trial(2, vec![Pos::new(5, 5), Pos::new(5, 6)], false);
    let mut rewards = Vec::new();
    for _ in 0..9 {
        t.step();
        rewards.push(t.rewards().robots[0]);
    }
    let seen = 81.0; // robot 0 re-observes its whole window every step
    assert_eq!(rewards[0], -seen); // ρ = 1: no penalty
    for (k, r) in rewards.iter().enumerate().skip(1) {
        let rho = k as f64 + 1.0;
        let expect = if rho <= 7.0 {
            -seen - (rho.exp() / 5.0).sqrt()
        } else {
            -seen - 15.0
        };
        assert!((r - expect).abs() < 1e-9, "step {k}: {r} vs {expect}");
    }
    // The team re-observes the union of both windows (9 × 10 = 90 cells), pays −1 per step.
    assert_eq!(t.rewards().team, -90.0 - 1.0);
}

#[test]
fn completion_bonus_once() {
    // A 5×5 open map is fully seen at t = 0 by a robot in the middle; the trial is then
    // complete, so no step runs. A 5×14 corridor needs moves; the last step gets +100.
    let mut reg = PolicyRegistry::default();
    reg.register("east", "", |_| Box::new(East(true)));
    let spec = TrialSpec {
        map: OccGrid::new(5, 14, Occupancy::Free),
        map_name: "corridor".into(),
        starts: vec![Pos::new(2, 2)],
        config: ScenarioConfig {
            num_robots: 1,
            sensor_miss_prob: 0.0,
            motion_success_prob: 1.0,
            ..Default::default()
        },
        policy: "east".into(),
        seed: 1,
    };
    let mut t = Trial::with_registry(spec, &reg)
        .unwrap()
        .record_trajectory(true);
    while t.step() {}
    let r = t.finish();
    assert!(r.metrics.completed);
    let bonuses = r
        .trajectory
        .iter()
        .filter(|s| s.rewards.team > 50.0)
        .count();
    assert_eq!(bonuses, 1);
    let last = r.trajectory.last().unwrap();
    // Columns 2 + 4 + k: each step east reveals one new column of 5 cells and re-sees 40.
    assert_eq!(last.rewards.team, 5.0 - 40.0 - 1.0 + 100.0);
}
