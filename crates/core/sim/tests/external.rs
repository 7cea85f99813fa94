//! A trial driven from outside (`begin_step` → `apply_decisions` → `finish_step`), as a Python
//! environment will drive it, is the same trial as one whose robots ask their own policies: the
//! caller here asks a separate copy of each robot's policy on the robot's view.

use madenet_agent::{Decision, NearestFrontier, Policy, RandomCandidate};
use madenet_map::paper::{paper_map, paper_map_name, Corner};
use madenet_sim::{Trial, TrialSpec};
use madenet_world::ScenarioConfig;

fn spec(policy: &str, csp: f64) -> TrialSpec {
    let grid = paper_map(4).unwrap();
    let starts = Corner::TopLeft
        .start_cells(grid.height(), grid.width())
        .to_vec();
    TrialSpec {
        map: grid,
        map_name: paper_map_name(4),
        starts,
        config: ScenarioConfig {
            comm_success_prob: csp,
            ..Default::default()
        },
        policy: policy.to_string(),
        seed: 5,
    }
}

/// Runs `spec` with decisions from `policies` (one per robot) supplied through the external API.
fn external(spec: TrialSpec, mut policies: Vec<Box<dyn Policy>>) -> madenet_sim::TrialResult {
    let mut trial = Trial::new(spec).unwrap().record_trajectory(true);
    while trial.begin_step() {
        let deciding = trial.deciding().to_vec();
        let mut decisions = vec![Decision::Idle; deciding.len()];
        for (i, d) in deciding.iter().enumerate() {
            if *d {
                let policy = &mut policies[i];
                let needs = policy.needs_candidates();
                decisions[i] = policy.decide(&mut trial.agent_mut(i).view(needs));
            }
        }
        trial.apply_decisions(&decisions);
        trial.finish_step();
    }
    trial.finish()
}

#[test]
fn external_decisions_reproduce_the_policies_own_trial() {
    for (name, csp) in [("nf", 1.0), ("nf", 0.3), ("random", 0.5)] {
        let own = Trial::new(spec(name, csp))
            .unwrap()
            .record_trajectory(true)
            .run();
        let policies: Vec<Box<dyn Policy>> = (0..3)
            .map(|i| -> Box<dyn Policy> {
                match name {
                    "nf" => Box::new(NearestFrontier),
                    _ => Box::new(RandomCandidate::new(5, i)),
                }
            })
            .collect();
        let ext = external(spec(name, csp), policies);
        assert!(own.metrics.completed, "{name} at CSP {csp} completes");
        assert_eq!(own.trajectory, ext.trajectory, "{name} at CSP {csp}");
        assert_eq!(own.metrics, ext.metrics);
    }
}
