//! The oracles ([`madenet_baselines::rollout`]) and the known-map reference on whole trials:
//! rollouts from a fork are the trial itself, redrawn futures agree with what the team knows,
//! and the plan oracles complete, repeat and depart from their base.

use madenet_map::paper::Corner;
use madenet_sim::{Trial, TrialSpec};
use madenet_world::ScenarioConfig;

fn spec(map: usize, corner: Corner, policy: &str, csp: f64, seed: u64) -> TrialSpec {
    TrialSpec::paper(map, corner, policy, csp, seed).unwrap()
}

/// Walks `trial` to the `n`th step at which robot 0 decides with a choice (its candidates
/// extracted, the step begun, no decision taken); how many such steps it saw (`n` unless the
/// trial ended first).
fn walk_to_choice(trial: &mut Trial, n: usize) -> usize {
    let mut seen = 0;
    while trial.begin_step() {
        if trial.deciding()[0] {
            trial.agent_mut(0).view(true); // extracts the candidates
            if trial.agents()[0].candidates().cells.len() >= 2 {
                seen += 1;
                if seen == n {
                    break;
                }
            }
        }
        trial.decide_with(&[]);
        trial.finish_step();
    }
    seen
}

/// A continuation cut by the trial's step cap before its horizon: valued by mean discovery, the
/// cells still unknown count every step up to the horizon (they stay unknown there).
#[test]
fn mean_discovery_counts_cells_left_at_the_step_cap_to_the_horizon() {
    use madenet_agent::Decision;
    use madenet_baselines::rollout::{candidate_values_by, Lookahead, Value};
    use madenet_sim::{Future, PolicyRegistry};
    let registry = PolicyRegistry::builtin();
    let mut s = spec(3, Corner::TopLeft, "spread", 1.0, 2);
    s.config.step_cap = 12;
    let mut trial = Trial::new(s).unwrap();
    // To the first timestep after t = 5 at which robot 0 decides with a choice.
    loop {
        assert!(trial.begin_step(), "robot 0 chose before the cap");
        if trial.world().t() > 5 && trial.deciding()[0] {
            trial.agent_mut(0).view(true);
            if trial.agents()[0].candidates().cells.len() >= 2 {
                break;
            }
        }
        trial.decide_with(&[]);
        trial.finish_step();
    }
    let horizon = 40;
    let look = Lookahead {
        horizon: Some(horizon),
        value: Value::MeanDiscovery,
    };
    let got = candidate_values_by(&trial, 0, &[], "spread", &registry, &[Future::Own], look)
        .unwrap()[0]
        .unwrap();
    let unknown = |f: &Trial| (f.world().explorable_count() - f.world().known_count()) as f64;
    let mut area = unknown(&trial);
    let mut fork = trial.fork("spread", &registry, Future::Own).unwrap();
    let mut fixed = vec![None; 3];
    fixed[0] = Some(Decision::Candidate(0));
    fork.decide_with(&fixed);
    fork.finish_step();
    let mut steps = 1;
    loop {
        let before = unknown(&fork);
        if !fork.step() {
            break;
        }
        area += before;
        steps += 1;
    }
    assert!(
        steps < horizon && unknown(&fork) > 0.0,
        "the cap ends it first"
    );
    area += unknown(&fork) * (horizon - steps) as f64;
    let want = area / fork.world().explorable_count() as f64;
    assert!((got - want).abs() < 1e-9, "{got} vs {want}");
}

/// A fork living the trial's own future is the trial: the value the rollout machinery gives a
/// candidate (`Future::Own`) is exactly the steps left when the trial itself takes it and
/// everyone follows the base rule; another future differs somewhere; the noiseless future
/// never slips.
#[test]
fn rollouts_from_a_fork_are_the_trial_itself() {
    use madenet_agent::Decision;
    use madenet_baselines::rollout::{
        candidate_values, candidate_values_by, run_oracle, Lookahead, OracleKind, Value,
    };
    use madenet_sim::{Future, PolicyRegistry};
    let registry = PolicyRegistry::builtin();
    let mut checked = 0;
    let mut salted_differs = false;
    for (map, corner, csp) in [
        (3, Corner::TopLeft, 1.0),
        (7, Corner::BottomRight, 0.5),
        (5, Corner::TopRight, 0.0),
    ] {
        let s = spec(map, corner, "spread", csp, 4);
        let mut trial = Trial::new(s.clone()).unwrap();
        let seen = walk_to_choice(&mut trial, 3);
        assert_eq!(
            seen, 3,
            "test_{map}: robot 0 decided with a choice three times"
        );
        let values = candidate_values(&trial, 0, &[], "spread", &registry, &[Future::Own]).unwrap();
        let now = trial.world().t();
        // Cut continuations: a horizon past the end changes nothing; a short one estimates the
        // rest at the trial's exploration rate so far — by hand from a fork cut at 5 steps.
        let by = |horizon, value| {
            let look = Lookahead { horizon, value };
            candidate_values_by(&trial, 0, &[], "spread", &registry, &[Future::Own], look).unwrap()
        };
        assert_eq!(by(Some(100_000), Value::StepsLeft), values);
        let cut = by(Some(5), Value::StepsLeft);
        {
            let mut fork = trial.fork("spread", &registry, Future::Own).unwrap();
            let mut fixed = vec![None; 3];
            fixed[0] = Some(Decision::Candidate(0));
            let rate = (trial.world().known_count() as f64 / now.max(1) as f64).max(1.0);
            fork.decide_with(&fixed);
            fork.finish_step();
            for _ in 1..5 {
                assert!(fork.step());
            }
            let w = fork.world();
            assert!(!w.is_done(), "test_{map}: five steps do not finish the map");
            let left = (w.explorable_count() - w.known_count()) as f64;
            assert_eq!(cut[0], Some(5.0 + left / rate), "test_{map}");
        }
        // Valued by mean discovery time: each cell counts the steps until it is known (capped
        // at the horizon), so a value lies below the steps left (full) and the horizon (cut),
        // and the horizon cuts exactly the mean of the capped discovery times.
        let discovery = by(None, Value::MeanDiscovery);
        for (d, v) in discovery.iter().zip(&values) {
            assert_eq!(d.is_some(), v.is_some());
            if let (Some(d), Some(v)) = (d, v) {
                assert!(*d > 0.0 && d <= v, "test_{map}: {d} vs steps left {v}");
            }
        }
        let cut = by(Some(4), Value::MeanDiscovery);
        {
            let mut fork = trial.fork("spread", &registry, Future::Own).unwrap();
            let mut fixed = vec![None; 3];
            fixed[0] = Some(Decision::Candidate(0));
            fork.decide_with(&fixed);
            fork.finish_step();
            let unknown =
                |f: &Trial| (f.world().explorable_count() - f.world().known_count()) as f64;
            // Cells unknown before each of the 4 steps (the present's, then after steps 1–3).
            let mut area = unknown(&trial);
            for _ in 1..4 {
                area += unknown(&fork);
                assert!(fork.step());
            }
            let want = area / fork.world().explorable_count() as f64;
            assert!((cut[0].unwrap() - want).abs() < 1e-9, "test_{map}");
            assert!(
                cut[0].unwrap() <= 4.0,
                "no cell counts more than the horizon"
            );
        }
        let salted =
            candidate_values(&trial, 0, &[], "spread", &registry, &[Future::Salted(7)]).unwrap();
        salted_differs |= salted != values;
        for (k, v) in values.iter().enumerate() {
            let Some(v) = v else { continue };
            // The same present, taken for real: a fresh trial replayed to here by its own policy.
            let mut real = Trial::new(s.clone()).unwrap();
            for _ in 0..now {
                real.step();
            }
            assert!(real.begin_step());
            real.agent_mut(0).view(true); // extracts the candidates
            let mut fixed = vec![None; 3];
            fixed[0] = Some(Decision::Candidate(k));
            real.decide_with(&fixed);
            real.finish_step();
            while real.step() {}
            assert_eq!(
                *v,
                (real.finish().metrics.tns - now) as f64,
                "test_{map} candidate {k}"
            );
            checked += 1;
        }
        // The noiseless future never slips: every executed move is the planned one.
        let mut quiet = trial.fork("spread", &registry, Future::Noiseless).unwrap();
        quiet.decide_with(&[]);
        quiet.finish_step();
        assert!(
            quiet.world().config().motion_success_prob == 1.0
                && quiet.world().config().sensor_miss_prob == 0.0
        );
        // Oracles complete and are deterministic.
        let a = run_oracle(s.clone(), &registry, OracleKind::Noiseless, 1).unwrap();
        assert_eq!(
            a.metrics,
            run_oracle(s.clone(), &registry, OracleKind::Noiseless, 1)
                .unwrap()
                .metrics
        );
        assert!(a.metrics.completed);
    }
    assert!(checked >= 6, "{checked} candidates checked");
    assert!(salted_differs, "another future changes some value");
}

/// The redrawn (belief-consistent) future: a fork whose unseen cells come from another map
/// agrees with the team's knowledge and keeps the robots where they stand; redrawn with the
/// true map it is the noiseless future exactly; with generator draws it values candidates
/// otherwise; its oracle completes and repeats itself.
#[test]
fn a_redrawn_future_agrees_with_what_the_team_knows() {
    use madenet_baselines::rollout::{candidate_values, redrawn_futures, run_oracle, OracleKind};
    use madenet_map::Occupancy;
    use madenet_sim::{Future, PolicyRegistry};
    use std::sync::Arc;
    let registry = PolicyRegistry::builtin();
    let mut values_differ = false;
    for (map, corner) in [(2, Corner::TopLeft), (6, Corner::BottomRight)] {
        let s = spec(map, corner, "spread", 1.0, 3);
        let mut trial = Trial::new(s.clone()).unwrap();
        let seen = walk_to_choice(&mut trial, 2);
        assert_eq!(seen, 2, "test_{map}");
        let w = trial.world();
        let truth = Arc::new(w.truth().clone());
        let value = |f: Future| candidate_values(&trial, 0, &[], "spread", &registry, &[f]);
        assert_eq!(
            value(Future::Redrawn(truth)).unwrap(),
            value(Future::Noiseless).unwrap(),
            "test_{map}: redrawn with the true map is the noiseless future"
        );
        let draws = redrawn_futures(&trial, s.seed, 1, 2).unwrap();
        for f in &draws {
            let Future::Redrawn(other) = f else {
                panic!("a redrawn future")
            };
            let fork = trial.fork("spread", &registry, f.clone()).unwrap();
            let (fw, unseen) = (fork.world(), |i: usize| {
                w.team_map()[i] == Occupancy::Unknown
            });
            let cells = w.truth().len();
            for i in 0..cells {
                let want = if unseen(i) {
                    match other.cells()[i] {
                        Occupancy::Unknown => Occupancy::Obstacle,
                        c => c,
                    }
                } else {
                    w.truth().cells()[i]
                };
                assert_eq!(fw.truth().cells()[i], want, "test_{map} cell {i}");
                assert!(
                    unseen(i) || fw.explorable()[i],
                    "a seen cell stays explorable"
                );
            }
            assert!(
                (0..cells).any(|i| unseen(i) && fw.truth().cells()[i] != w.truth().cells()[i]),
                "test_{map}: the draw changes some unseen cell"
            );
            assert_eq!(fw.positions(), w.positions());
            assert_eq!(fw.known_count(), w.known_count());
            assert!(!fw.is_done());
        }
        values_differ |= value(draws[0].clone()).unwrap() != value(Future::Noiseless).unwrap();
        let a = run_oracle(s.clone(), &registry, OracleKind::Redrawn, 2).unwrap();
        assert!(a.metrics.completed, "test_{map}");
        let b = run_oracle(s, &registry, OracleKind::Redrawn, 2).unwrap();
        assert_eq!(a.metrics, b.metrics, "test_{map}: same seed, same trial");
    }
    assert!(values_differ, "another map values some candidate otherwise");
    // The draws take the trial's size: a 12 × 15 map redraws as one.
    let map = madenet_map::generate::generate(
        &madenet_map::generate::GeneratorConfig::for_size(12, 15),
        5,
    )
    .unwrap();
    let starts = Corner::BottomLeft.start_cells(12, 15).to_vec();
    let small = TrialSpec {
        map,
        map_name: "small".into(),
        starts,
        config: ScenarioConfig::default(),
        policy: "spread".into(),
        seed: 2,
    };
    let r = run_oracle(small, &registry, OracleKind::Redrawn, 1).unwrap();
    assert!(r.metrics.completed);
}

/// The plan oracles (the known-map reference's team plan on redrawn maps: the team's cells and
/// true positions, the deciding robot's own map, or the team's cells with the teammates where
/// the robot last knew them) complete, repeat themselves for a seed, choose otherwise than
/// their base rule somewhere, and the restricted ones otherwise than the full one somewhere.
#[test]
fn the_plan_oracles_complete_repeat_and_depart_from_their_base() {
    use madenet_baselines::rollout::{run_oracle, OracleKind};
    use madenet_sim::PolicyRegistry;
    let registry = PolicyRegistry::builtin();
    let mut departs = [false; 3];
    let mut differ = [false; 2];
    for (map, corner, csp) in [
        (2, Corner::TopLeft, 1.0),
        (6, Corner::BottomRight, 1.0),
        (9, Corner::TopRight, 0.0),
    ] {
        let s = spec(map, corner, "spread", csp, 3);
        let base = Trial::new(s.clone()).unwrap().run();
        let mut runs = Vec::new();
        for (k, kind) in [
            OracleKind::PlanRedrawn,
            OracleKind::PlanOwnMap,
            OracleKind::PlanTeamMap,
        ]
        .into_iter()
        .enumerate()
        {
            let a = run_oracle(s.clone(), &registry, kind, 2).unwrap();
            assert!(a.metrics.completed, "test_{map}, {kind:?}");
            let b = run_oracle(s.clone(), &registry, kind, 2).unwrap();
            assert_eq!(
                a.metrics, b.metrics,
                "test_{map}, {kind:?}: same seed, same trial"
            );
            departs[k] |= a.metrics.tns != base.metrics.tns || a.metrics.ttd != base.metrics.ttd;
            runs.push(a.metrics);
        }
        differ[0] |= runs[0] != runs[1];
        differ[1] |= runs[0] != runs[2];
    }
    assert_eq!(
        departs, [true; 3],
        "each plan chooses otherwise than spread somewhere"
    );
    assert_eq!(
        differ, [true; 2],
        "each restricted plan departs from the full one somewhere"
    );
}
