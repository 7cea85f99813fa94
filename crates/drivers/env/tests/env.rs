//! The environment against the simulator it drives: the same decisions give the trajectory
//! `madenet run` gives, observations never change the trajectory, masks match the candidates,
//! rewards add up, and bad calls are errors.

use madenet_env::{ActionMode, EnvError, ExplorationEnv};
use madenet_map::paper::{paper_map, paper_map_name, Corner};
use madenet_sim::{Trial, TrialResult, TrialSpec};
use madenet_world::ScenarioConfig;
use rand::RngExt;

/// Paper map 6, the team starting in its bottom-right corner, messages arriving with
/// probability `csp`: the scenario of every test here.
fn scene(csp: f64) -> TrialSpec {
    let map = paper_map(6).unwrap();
    let starts = Corner::BottomRight
        .start_cells(map.height(), map.width())
        .to_vec();
    TrialSpec {
        map,
        map_name: paper_map_name(6),
        starts,
        config: ScenarioConfig {
            comm_success_prob: csp,
            ..Default::default()
        },
        policy: String::new(),
        seed: 0,
    }
}

fn env(mode: ActionMode, csp: f64) -> ExplorationEnv {
    let s = scene(csp);
    ExplorationEnv::new(s.map, &s.map_name, s.starts, s.config, mode)
        .unwrap()
        .recording(true)
}

/// The trial `policy` runs on its own in [`scene`]`(csp)` with `seed`, its trajectory recorded.
fn own_trial(csp: f64, policy: &str, seed: u64) -> TrialResult {
    let spec = TrialSpec {
        policy: policy.into(),
        seed,
        ..scene(csp)
    };
    Trial::new(spec).unwrap().record_trajectory(true).run()
}

#[test]
fn random_candidates_through_the_env_reproduce_the_random_policy_trial() {
    for csp in [1.0, 0.4] {
        let seed = 9;
        let mut e = env(ActionMode::Macro, csp);
        let (n, g) = (e.num_robots(), e.action_count());
        let mut buffers = (
            vec![0.0; e.map_len()],
            vec![0.0; e.vector_len()],
            vec![0u8; g],
        );
        // The `random` policy's draws: a stream per robot, one draw per decision over its valid candidates.
        let mut rngs: Vec<_> = (0..n)
            .map(|i| madenet_world::rng::stream(seed, "policy/random", i as u64))
            .collect();
        e.reset(seed).unwrap();
        let (mut steps, mut team) = (0, 0.0);
        while !e.is_done() {
            let needs = e.needs_action();
            let mut actions = vec![0; n];
            for i in 0..n {
                e.observe_into(i, &mut buffers.0, &mut buffers.1, &mut buffers.2)
                    .unwrap();
                // The vector ends with the candidates' validity; the mask is the same but for a
                // robot with no candidate, whose mask offers slot 0 alone ("stay").
                let validity = &buffers.1[buffers.1.len() - g..];
                let valid = validity.iter().filter(|&&v| v == 1.0).count();
                assert!(
                    validity[..valid].iter().all(|&v| v == 1.0),
                    "valid candidates come first"
                );
                let expected: Vec<u8> = (0..g)
                    .map(|k| (k < valid || (valid == 0 && k == 0)) as u8)
                    .collect();
                assert_eq!(buffers.2, expected);
                if needs[i] && valid > 0 {
                    actions[i] = rngs[i].random_range(0..valid);
                } else if needs[i] {
                    actions[i] = g - 1; // invalid: the robot stays, as the policy's Idle
                }
            }
            let r = e.step(&actions).unwrap();
            steps += r.steps;
            team += r.team_reward;
            assert!(r.steps >= 1);
        }
        let ext = e.finish().unwrap();
        let own = own_trial(csp, "random", seed);
        assert_eq!(own.trajectory, ext.trajectory, "CSP {csp}");
        assert_eq!(own.metrics, ext.metrics);
        assert_eq!(steps, own.metrics.tns);
        let own_team: f64 = own.trajectory.iter().map(|s| s.rewards.team).sum();
        assert!((own_team - team).abs() < 1e-9);
    }
}

#[test]
fn primitive_moves_and_bad_calls() {
    let mut e = env(ActionMode::Primitive, 1.0);
    assert_eq!(e.action_count(), 9);
    assert!(
        matches!(e.step(&[0, 0, 0]), Err(EnvError::Usage(_))),
        "step before reset"
    );
    e.reset(3).unwrap();
    assert_eq!(e.needs_action(), vec![true; 3]);
    assert!(e.step(&[0, 0]).is_err());
    assert!(e.step(&[0, 0, 9]).is_err());
    let (mut map, mut vector, mut mask) = (
        vec![0.0; e.map_len()],
        vec![0.0; e.vector_len()],
        vec![0u8; 9],
    );
    // Robot 0 moves along valid moves; every step advances one timestep for everyone.
    for t in 0..40 {
        e.observe_into(0, &mut map, &mut vector, &mut mask).unwrap();
        assert_eq!(mask[0], 1, "stay is always valid");
        if t == 0 {
            // From the bottom-right corner, north and west hold teammates: masked.
            assert_eq!((mask[1], mask[7]), (0, 0), "{mask:?}");
        }
        let a = (1..9).find(|&k| mask[k] == 1).unwrap_or(0);
        let r = e.step(&[a, 0, 0]).unwrap();
        assert_eq!(r.steps, 1);
        assert_eq!(e.t(), t + 1);
        if e.is_done() {
            break;
        }
    }
    let traj = e.finish().unwrap().trajectory;
    assert!(
        traj.iter().any(|s| s.moves[0] != madenet_world::Move::Stay),
        "robot 0 moved"
    );
    assert!(traj.iter().all(
        |s| s.moves[1] == madenet_world::Move::Stay && s.moves[2] == madenet_world::Move::Stay
    ));
    // Bad construction: starts that do not match the team.
    let map = paper_map(1).unwrap();
    let err = ExplorationEnv::new(
        map,
        "m",
        vec![madenet_map::Pos::new(0, 0)],
        ScenarioConfig::default(),
        ActionMode::Macro,
    )
    .err()
    .unwrap();
    assert!(err.to_string().contains("num_robots"), "{err}");
}

#[test]
fn a_policys_decisions_through_the_env_reproduce_its_own_trial_and_modes_are_checked() {
    let registry = madenet_sim::PolicyRegistry::builtin();
    for (name, mode) in [("nf", ActionMode::Primitive), ("random", ActionMode::Macro)] {
        let mut e = env(mode, 0.5);
        e.reset(4).unwrap();
        while !e.is_done() {
            let d = e.policy_decisions(name, &registry).unwrap();
            e.step_decisions(&d).unwrap();
        }
        let ext = e.finish().unwrap();
        let own = own_trial(0.5, name, 4);
        assert_eq!(own.trajectory, ext.trajectory, "{name}");
        assert_eq!(own.metrics, ext.metrics, "{name}");
    }
    let mut e = env(ActionMode::Macro, 1.0);
    e.reset(1).unwrap();
    let err = e.policy_decisions("nf", &registry).unwrap_err().to_string();
    assert!(err.contains("primitive"), "{err}");
    assert!(e.policy_decisions("no-such", &registry).is_err());
}

#[test]
fn joint_actions_decode_to_the_robots_parts() {
    let mut e = env(ActionMode::Macro, 1.0);
    let (n, g) = (e.num_robots(), e.goal_count());
    let count = e.joint_action_count().unwrap();
    assert_eq!(count, g.pow(n as u32));
    e.reset(2).unwrap();
    let (mut map, mut vector, mut mask) = (
        vec![0.0; e.map_len()],
        vec![0.0; e.joint_vector_len()],
        vec![0u8; count],
    );
    e.observe_joint_into(&mut map, &mut vector, &mut mask)
        .unwrap();
    // Every robot decides first; the joint mask is the product of the robots' masks.
    let mut own = Vec::new();
    for i in 0..n {
        let (mut m, mut v, mut k) = (
            vec![0.0; e.map_len()],
            vec![0.0; e.vector_len()],
            vec![0u8; g],
        );
        e.observe_into(i, &mut m, &mut v, &mut k).unwrap();
        assert_eq!(
            &vector[i * e.vector_len()..(i + 1) * e.vector_len()],
            &v[..]
        );
        own.push(k);
    }
    for (a, &m) in mask.iter().enumerate() {
        let expected = (0..n).all(|i| own[i][(a / g.pow(i as u32)) % g] == 1);
        assert_eq!(m == 1, expected, "joint action {a}");
    }
    // The merged map's explored channel is the team map; robots appear in channel 2.
    assert!(
        map[2 * e.height() * e.width()..3 * e.height() * e.width()]
            .iter()
            .filter(|&&v| v == 1.0)
            .count()
            >= 1
    );
    // A valid joint action whose parts differ (so the digit order matters) steps like them.
    let decode = |a: usize| -> Vec<usize> { (0..n).map(|i| (a / g.pow(i as u32)) % g).collect() };
    let a = (0..count)
        .find(|&a| mask[a] == 1 && decode(a)[0] != decode(a)[n - 1])
        .expect("robots with more than one candidate");
    let parts = decode(a);
    let mut twin = env(ActionMode::Macro, 1.0);
    twin.reset(2).unwrap();
    let mut reversed = env(ActionMode::Macro, 1.0);
    reversed.reset(2).unwrap();
    let (ours, twins) = (e.step_joint(a).unwrap(), twin.step(&parts).unwrap());
    assert_eq!(ours, twins);
    let rev: Vec<usize> = parts.iter().rev().copied().collect();
    reversed.step(&rev).unwrap();
    assert!(e.step_joint(count).is_err());
    let ours = e.finish().unwrap().trajectory;
    assert_eq!(ours, twin.finish().unwrap().trajectory);
    assert_ne!(
        ours[0].goals,
        reversed.finish().unwrap().trajectory[0].goals,
        "the digit order matters"
    );
    let err = env(ActionMode::Primitive, 1.0)
        .observe_joint_into(&mut map, &mut vector, &mut mask)
        .unwrap_err();
    assert!(err.to_string().contains("macro"), "{err}");
}

#[test]
fn a_restarted_episode_is_the_same_as_a_fresh_one() {
    for mode in [ActionMode::Primitive, ActionMode::Macro] {
        let run = |e: &mut ExplorationEnv, seed: u64, steps: usize| {
            e.reset(seed).unwrap();
            let mut rng = madenet_world::rng::stream(seed, "test/actions", 0);
            let mut rewards = Vec::new();
            for _ in 0..steps {
                if e.is_done() {
                    break;
                }
                let a: Vec<usize> = (0..e.num_robots())
                    .map(|_| rng.random_range(0..e.action_count().min(3)))
                    .collect();
                rewards.push(e.step(&a).unwrap());
            }
            rewards
        };
        let mut reused = env(mode, 0.6);
        run(&mut reused, 1, 120); // an earlier episode: moves robots, casts rays, drops links
        let again = run(&mut reused, 5, 400);
        let mut fresh = env(mode, 0.6);
        let first = run(&mut fresh, 5, 400);
        assert_eq!(again, first, "{mode:?}");
        // Sensing with another environment's cast rays changes nothing either.
        let mut sharing = env(mode, 0.6);
        sharing.share_visibility(env(mode, 0.6).visibility().unwrap());
        assert_eq!(run(&mut sharing, 5, 400), first, "{mode:?}");
        let want = fresh.finish().unwrap().trajectory;
        assert_eq!(reused.finish().unwrap().trajectory, want, "{mode:?}");
        assert_eq!(sharing.finish().unwrap().trajectory, want, "{mode:?}");
    }
}

/// A map seen whole from the start cells: the episode is over at reset. The first step reports
/// the end (terminated, nothing advanced, zero rewards), a second is an error, and a `VecEnv`
/// of such environments keeps stepping (each step ends and restarts them) instead of failing.
#[test]
fn an_episode_over_at_its_start_ends_at_the_first_step() {
    use madenet_env::VecEnv;
    use madenet_map::{OccGrid, Occupancy, Pos};
    let map = OccGrid::new(4, 4, Occupancy::Free);
    let starts = vec![Pos::new(0, 0), Pos::new(0, 1), Pos::new(1, 0)];
    let scenario = ScenarioConfig {
        sensor_miss_prob: 0.0,
        ..Default::default()
    };
    for mode in [ActionMode::Primitive, ActionMode::Macro] {
        let mut e = ExplorationEnv::new(
            map.clone(),
            "open_4x4",
            starts.clone(),
            scenario.clone(),
            mode,
        )
        .unwrap();
        e.reset(1).unwrap();
        assert!(e.is_done(), "{mode:?}: seen whole at t = 0");
        let r = e.step(&[0, 0, 0]).unwrap();
        assert!(r.terminated && !r.truncated, "{mode:?}: {r:?}");
        assert_eq!(
            (r.steps, r.rewards.clone(), r.team_reward),
            (0, vec![0.0; 3], 0.0),
            "{mode:?}"
        );
        assert!(
            matches!(e.step(&[0, 0, 0]), Err(EnvError::Usage(_))),
            "{mode:?}: a step after the reported end"
        );
        e.reset(2).unwrap();
        assert!(
            e.step(&[0, 0, 0]).unwrap().terminated,
            "{mode:?}: again after a reset"
        );
        // A shipped policy has nothing to decide then (names and modes are still checked).
        let registry = madenet_sim::PolicyRegistry::builtin();
        let own = if mode == ActionMode::Primitive {
            "nf"
        } else {
            "random"
        };
        e.reset(4).unwrap();
        assert!(e.policy_decisions("no-such-policy", &registry).is_err());
        assert!(
            e.policy_decisions(if own == "nf" { "random" } else { "nf" }, &registry)
                .is_err(),
            "{mode:?}: wrong mode"
        );
        assert_eq!(
            e.policy_decisions(own, &registry).unwrap(),
            vec![madenet_env::Decision::Idle; 3]
        );
        assert!(
            e.step_decisions(&[madenet_env::Decision::Idle; 3])
                .unwrap()
                .terminated
        );
        assert!(
            e.policy_decisions(own, &registry).is_err(),
            "{mode:?}: asked after the reported end"
        );

        let n = 2;
        let mut v = VecEnv::new(e.clone_config().unwrap(), n, 3).unwrap();
        let mut out = v.outputs();
        out.buffers().rewards.fill(1.0);
        v.reset(out.buffers()).unwrap();
        let seeds = v.episode_seeds();
        for step in 0..3 {
            v.step(&[0; 6], out.buffers()).unwrap();
            let b = out.buffers();
            assert_eq!(b.terminated, vec![true; n], "{mode:?} step {step}");
            assert!(b.rewards.iter().all(|&r| r == 0.0));
        }
        assert_ne!(
            v.episode_seeds(),
            seeds,
            "{mode:?}: the environments restarted with their next seeds"
        );
    }
}

/// Observing before a step (whose candidates the step then hands to the deciding robots) or not
/// (the step extracts them itself) gives the same episode.
#[test]
fn stepping_with_or_without_observing_first_is_the_same() {
    for csp in [1.0, 0.3] {
        let run = |observe: bool| {
            let mut e = env(ActionMode::Macro, csp);
            e.reset(21).unwrap();
            let (n, g) = (e.num_robots(), e.action_count());
            let mut buffers = (
                vec![0.0; e.map_len()],
                vec![0.0; e.vector_len()],
                vec![0u8; g],
            );
            let mut rng = madenet_world::rng::stream(3, "test/actions", 0);
            let mut results = Vec::new();
            while !e.is_done() {
                if observe {
                    for i in 0..n {
                        e.observe_into(i, &mut buffers.0, &mut buffers.1, &mut buffers.2)
                            .unwrap();
                    }
                }
                let a: Vec<usize> = (0..n).map(|_| rng.random_range(0..g.min(3))).collect();
                results.push(e.step(&a).unwrap());
            }
            (results, e.finish().unwrap().trajectory)
        };
        let (observed, plain) = (run(true), run(false));
        assert!(observed.0.len() > 5);
        assert_eq!(observed, plain, "CSP {csp}");
    }
}
