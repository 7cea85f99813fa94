//! The continuous world as a step-wise environment: the robots' own policies through the
//! environment give the trial `madenet run --world continuous` runs; outside actions are
//! obeyed; observing never changes the trajectory; misuse is an error.

use madenet_continuous::scene::generate_cluttered;
use madenet_continuous::ContinuousConfig;
use madenet_env::{ContinuousEnv, EnvError};
use madenet_map::Pos;
use madenet_sim::continuous::{ContinuousSpec, ContinuousTrial};
use madenet_sim::PolicyRegistry;
use madenet_world::ScenarioConfig;
use std::sync::Arc;

fn spec(policy: &str) -> ContinuousSpec {
    ContinuousSpec {
        scene: Arc::new(generate_cluttered(12.0, 0.1, 4)),
        starts: vec![Pos::new(10, 1), Pos::new(10, 2), Pos::new(9, 1)],
        config: ScenarioConfig::default(),
        continuous: ContinuousConfig::default(),
        policy: policy.into(),
        seed: 0,
    }
}

/// Runs an episode, each deciding robot taking `choose(robot, mask)`; observes every robot
/// (deciding or not) `looks` times per step. Returns the result and the steps' rewards and
/// seconds.
fn episode(
    env: &mut ContinuousEnv,
    seed: u64,
    looks: usize,
    choose: impl Fn(usize, &[u8]) -> Option<usize>,
) -> (madenet_sim::continuous::ContinuousResult, f64, f64, usize) {
    env.reset(seed).unwrap();
    let n = env.num_robots();
    let (mut map, mut vector, mut mask) = (
        vec![0.0; env.map_len()],
        vec![0.0; env.vector_len()],
        vec![0u8; env.action_count()],
    );
    let (mut reward, mut seconds, mut steps) = (0.0, 0.0, 0);
    loop {
        let needs = env.needs_action();
        let mut actions = vec![None; n];
        for i in 0..n {
            for _ in 0..looks {
                env.observe_into(i, &mut map, &mut vector, &mut mask)
                    .unwrap();
            }
            if needs[i] {
                env.observe_into(i, &mut map, &mut vector, &mut mask)
                    .unwrap();
                actions[i] = choose(i, &mask);
            }
        }
        let s = env.step(&actions).unwrap();
        reward += s.team_reward;
        seconds += s.seconds;
        steps += 1;
        if s.terminated || s.truncated {
            break;
        }
    }
    (env.finish().unwrap(), reward, seconds, steps)
}

#[test]
fn the_robots_own_policies_through_the_environment_give_the_trial() {
    let registry = PolicyRegistry::builtin();
    for policy in ["nf", "spread"] {
        let trial = ContinuousTrial::new(
            ContinuousSpec {
                seed: 5,
                ..spec(policy)
            },
            &registry,
        )
        .unwrap()
        .run();
        let mut env = ContinuousEnv::new(spec(policy), &registry).unwrap();
        let (mut got, reward, seconds, steps) = episode(&mut env, 5, 0, |_, _| None);
        got.wall_s = trial.wall_s;
        assert_eq!(got, trial, "{policy}");
        assert!(steps > 10, "{policy}: {steps} steps");
        // The rewards count the explorable cells the team came to know; the seconds add up to
        // the trial's simulated time.
        let known = trial.explored.last().unwrap() * trial.explorable_cells as f64;
        let first = trial.explored[0] * trial.explorable_cells as f64;
        assert!(
            (reward - (known - first)).abs() <= steps as f64,
            "{reward} vs {known} - {first}"
        );
        assert!(
            (seconds - trial.exploration_time_s).abs() < 1.0,
            "{seconds}"
        );
    }
}

#[test]
fn outside_actions_are_obeyed_and_observing_changes_nothing() {
    let registry = PolicyRegistry::builtin();
    let mut env = ContinuousEnv::new(spec("nf"), &registry).unwrap();
    // The last valid candidate, not what nf would choose.
    let last = |_: usize, mask: &[u8]| mask.iter().rposition(|&m| m == 1);
    let (a, ra, sa, na) = episode(&mut env, 2, 0, last);
    let (b, rb, sb, nb) = episode(&mut env, 2, 3, last);
    let mut b = b;
    b.wall_s = a.wall_s;
    assert_eq!(
        (a.clone(), ra, sa, na),
        (b, rb, sb, nb),
        "observing changed the episode"
    );
    let own = ContinuousTrial::new(
        ContinuousSpec {
            seed: 2,
            ..spec("nf")
        },
        &registry,
    )
    .unwrap()
    .run();
    assert_ne!(
        a.distance, own.distance,
        "the outside actions were not taken"
    );
    assert_eq!(a.obstacle_collisions + a.robot_collisions, 0);
}

#[test]
fn misuse_is_an_error() {
    let registry = PolicyRegistry::builtin();
    let mut env = ContinuousEnv::new(spec("nf"), &registry).unwrap();
    let usage = |r: Result<madenet_env::ContinuousStep, EnvError>| match r {
        Err(EnvError::Usage(m)) => m,
        other => panic!("{other:?}"),
    };
    assert!(usage(env.step(&[None, None, None])).contains("reset"));
    env.reset(1).unwrap();
    assert!(usage(env.step(&[None])).contains("3 robots"));
    let k = env.action_count();
    assert!(usage(env.step(&[Some(k), None, None])).contains("actions"));
    let bad = ContinuousSpec {
        starts: vec![Pos::new(0, 0)],
        ..spec("nf")
    };
    assert!(ContinuousEnv::new(bad, &registry).is_err());
}
