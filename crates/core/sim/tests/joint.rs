//! A centralized (joint) policy drives the team through the same runner.

use madenet_agent::{AgentView, Decision, JointPolicy};
use madenet_map::generate::{generate, GeneratorConfig};
use madenet_map::paper::Corner;
use madenet_map::Occupancy;
use madenet_sim::{Trial, TrialSpec};
use madenet_world::ScenarioConfig;
use std::sync::{Arc, Mutex};

/// Gives each deciding robot a different candidate (robot i takes slot i mod count) and logs
/// what it was asked.
/// What a joint decision was asked: each robot's deciding flag, and the timestep.
type Asked = (Vec<bool>, usize);

struct Spread {
    log: Arc<Mutex<Vec<Asked>>>,
}

impl JointPolicy for Spread {
    fn name(&self) -> &str {
        "spread"
    }
    fn decide(
        &mut self,
        views: &mut [AgentView<'_>],
        needs: &[bool],
        team_map: &[Occupancy],
    ) -> Vec<Decision> {
        self.log.lock().unwrap().push((
            needs.to_vec(),
            team_map.iter().filter(|o| o.is_known()).count(),
        ));
        views
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let n = v.candidates().cells.len();
                if n == 0 {
                    Decision::Idle
                } else {
                    Decision::Candidate(i % n)
                }
            })
            .collect()
    }
}

#[test]
fn joint_policy_decides_only_for_terminated_robots_and_explores() {
    let map = generate(&GeneratorConfig::default(), 42).unwrap();
    let spec = TrialSpec {
        starts: Corner::BottomRight.start_cells(20, 20).to_vec(),
        map,
        map_name: "generated_42".into(),
        config: ScenarioConfig::default(),
        policy: String::new(),
        seed: 3,
    };
    let log = Arc::new(Mutex::new(Vec::new()));
    let mut trial = Trial::with_joint_policy(spec, Box::new(Spread { log: log.clone() }))
        .unwrap()
        .record_trajectory(true);
    let mut steps = 0;
    while trial.step() {
        steps += 1;
        // A robot that decided this step now heads for one of its candidates (or idles).
        for a in trial.agents().iter().filter(|a| a.termination().is_some()) {
            match a.goal() {
                Some(g) => assert!(
                    a.candidates().cells.contains(&g),
                    "{g} not in {:?}",
                    a.candidates().cells
                ),
                None => assert!(a.candidates().cells.is_empty()),
            }
            // The recorded macro action is the index of that candidate.
            assert_eq!(a.action().map(|k| a.candidates().cells[k]), a.goal());
        }
    }
    let result = trial.finish();
    assert_eq!(result.policy, "spread");
    assert!(
        result.metrics.completed,
        "explored {}",
        result.metrics.explored
    );
    let log = log.lock().unwrap();
    // Called only on steps where some robot's macro action ended, and told which.
    assert!(
        !log.is_empty() && log.len() < steps,
        "{} calls over {steps} steps",
        log.len()
    );
    assert!(log.iter().all(|(needs, _)| needs.contains(&true)));
    let decided_steps = result
        .trajectory
        .iter()
        .filter(|s| s.decided.contains(&true))
        .count();
    assert_eq!(decided_steps, log.len());
    // The team map it sees grows.
    assert!(log.first().unwrap().1 < log.last().unwrap().1);
}
