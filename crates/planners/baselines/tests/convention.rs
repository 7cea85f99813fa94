//! The `convention` policy: the two robots of a meeting agree on the same split without
//! negotiating, a silent team plays `spread` exactly, and whole trials repeat for a seed.

use madenet_agent::{Policy, ViewScratch};
use madenet_baselines::Convention;
use madenet_map::Pos;
use madenet_sim::{Trial, TrialSpec};

mod common;
use common::spec;

/// Two robots that exchanged β this timestep, each with its own policy and its own view, compute
/// the same split of the map, and it gives each of them a part.
#[test]
fn both_sides_of_a_meeting_agree_on_the_split() {
    let registry = madenet_baselines::registry();
    let side = 24;
    let mut agreed = 0;
    for seed in [3, 4] {
        let mut trial =
            Trial::with_registry(spec(seed, side, 2, 1.0, "spread"), &registry).unwrap();
        let mut scratch = ViewScratch::new(side, side);
        while agreed < 3 && trial.begin_step() {
            let t = trial.agents()[0].peek_view(false, &mut scratch).t;
            let meeting = trial.deciding().iter().all(|&d| d)
                && (0..2).all(|i| {
                    let r = &trial.agents()[i].teammates()[1 - i];
                    r.detected && r.heard_at == Some(t)
                });
            if meeting {
                let parts: Vec<Vec<Option<usize>>> = (0..2)
                    .map(|i| {
                        let mut c = Convention::new(2, 4.0, seed, side, side);
                        let mut view = trial.agents()[i].peek_view(true, &mut scratch);
                        c.decide(&mut view);
                        (0..side * side)
                            .map(|k| c.part(Pos::new((k / side) as i32, (k % side) as i32)))
                            .collect()
                    })
                    .collect();
                assert_eq!(
                    parts[0], parts[1],
                    "generate:{seed}, t = {t}: the same split"
                );
                for robot in 0..2 {
                    assert!(
                        parts[0].contains(&Some(robot)),
                        "generate:{seed}, t = {t}: robot {robot} has a part"
                    );
                }
                agreed += 1;
            }
            trial.decide_with(&[None, None]);
            trial.finish_step();
        }
    }
    assert!(agreed >= 3, "meetings seen: {agreed}");
}

/// Without exchanges (CSP 0) no meeting is ever agreed on and the robots play `spread` move for
/// move; with them the policy completes, repeats itself for a seed, and departs from `spread`.
#[test]
fn convention_is_spread_when_silent_and_its_own_rule_when_robots_talk() {
    let registry = madenet_baselines::registry();
    let run = |s: TrialSpec| {
        Trial::with_registry(s, &registry)
            .unwrap()
            .record_trajectory(true)
            .run()
    };
    for seed in [3, 5] {
        let c = run(spec(seed, 24, 3, 0.0, "convention"));
        let s = run(spec(seed, 24, 3, 0.0, "spread"));
        assert!(!c.trajectory.is_empty());
        assert_eq!(c.trajectory, s.trajectory, "generate:{seed}, CSP 0");
    }
    let mut departs = false;
    for seed in [3, 4, 5] {
        let a = run(spec(seed, 24, 3, 1.0, "convention"));
        assert!(a.metrics.completed, "generate:{seed}: {:?}", a.metrics);
        let b = run(spec(seed, 24, 3, 1.0, "convention"));
        assert_eq!(
            a.metrics, b.metrics,
            "generate:{seed}: same seed, same metrics"
        );
        assert_eq!(
            a.trajectory, b.trajectory,
            "generate:{seed}: same trajectory"
        );
        departs |= a.trajectory != run(spec(seed, 24, 3, 1.0, "spread")).trajectory;
    }
    assert!(
        departs,
        "convention chooses otherwise than spread somewhere"
    );
}
