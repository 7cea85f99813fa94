//! The `belief-plan` policy: a whole trial on generated maps, at full and no communication.

use madenet_sim::Trial;

mod common;
use common::spec;

/// It completes, repeats itself for a seed (trajectories and metrics), and decides otherwise
/// than `spread` on some trial: it is its own rule, not `spread` under another name.
#[test]
fn belief_plan_completes_repeats_and_departs_from_spread() {
    let registry = madenet_baselines::registry();
    let mut departs = false;
    for (seed, side, robots, csp) in [(3, 20, 3, 1.0), (4, 24, 3, 1.0), (5, 24, 3, 0.0)] {
        let run = |policy: &str| {
            Trial::with_registry(spec(seed, side, robots, csp, policy), &registry)
                .unwrap()
                .record_trajectory(true)
                .run()
        };
        let a = run("belief-plan");
        assert!(a.metrics.completed, "generate:{seed}: {:?}", a.metrics);
        let b = run("belief-plan");
        assert_eq!(
            a.metrics, b.metrics,
            "generate:{seed}: same seed, same metrics"
        );
        assert!(!a.trajectory.is_empty());
        assert_eq!(
            a.trajectory, b.trajectory,
            "generate:{seed}: same trajectory"
        );
        let s = run("spread");
        departs |= a.trajectory != s.trajectory;
    }
    assert!(
        departs,
        "belief-plan chooses otherwise than spread somewhere"
    );
}
