//! The environment against the simulator it drives: the same decisions give the trajectory
//! `madenet run` gives, observations never change the trajectory, masks match the candidates,
//! rewards add up, and bad calls are errors.

use madenet_env::{ActionMode, EnvError, ExplorationEnv};
use madenet_map::paper::{paper_map, paper_map_name, Corner};
use madenet_sim::{Trial, TrialSpec};
use madenet_world::ScenarioConfig;
use rand::RngExt;

fn env(mode: ActionMode, csp: f64) -> ExplorationEnv {
    let map = paper_map(6).unwrap();
    let starts = Corner::BottomRight.start_cells(map.height(), map.width()).to_vec();
    let scenario = ScenarioConfig { comm_success_prob: csp, ..Default::default() };
    ExplorationEnv::new(map, &paper_map_name(6), starts, scenario, mode).unwrap().recording(true)
}

#[test]
fn random_candidates_through_the_env_reproduce_the_random_policy_trial() {
    for csp in [1.0, 0.4] {
        let seed = 9;
        let mut e = env(ActionMode::Macro, csp);
        let (n, g) = (e.num_robots(), e.action_count());
        let mut buffers = (vec![0.0; e.map_len()], vec![0.0; e.vector_len()], vec![0u8; g]);
        // The `random` policy's draws: a stream per robot, one draw per decision over its valid candidates.
        let mut rngs: Vec<_> = (0..n).map(|i| madenet_world::rng::stream(seed, "policy/random", i as u64)).collect();
        e.reset(seed).unwrap();
        let (mut steps, mut team) = (0, 0.0);
        while !e.is_done() {
            let needs = e.needs_action();
            let mut actions = vec![0; n];
            for i in 0..n {
                e.observe_into(i, &mut buffers.0, &mut buffers.1, &mut buffers.2).unwrap();
                let valid = buffers.2.iter().filter(|&&m| m == 1).count();
                assert!(buffers.2[..valid].iter().all(|&m| m == 1), "valid candidates come first");
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
        let map = paper_map(6).unwrap();
        let starts = Corner::BottomRight.start_cells(map.height(), map.width()).to_vec();
        let spec = TrialSpec {
            map,
            map_name: paper_map_name(6),
            starts,
            config: ScenarioConfig { comm_success_prob: csp, ..Default::default() },
            policy: "random".into(),
            seed,
        };
        let own = Trial::new(spec).unwrap().record_trajectory(true).run();
        assert_eq!(own.trajectory, ext.trajectory, "CSP {csp}");
        assert_eq!(own.metrics, ext.metrics);
        assert_eq!(steps, own.metrics.tns as usize);
        let own_team: f64 = own.trajectory.iter().map(|s| s.rewards.team).sum();
        assert!((own_team - team).abs() < 1e-9);
    }
}

#[test]
fn primitive_moves_and_bad_calls() {
    let mut e = env(ActionMode::Primitive, 1.0);
    assert_eq!(e.action_count(), 9);
    assert!(matches!(e.step(&[0, 0, 0]), Err(EnvError::Usage(_))), "step before reset");
    e.reset(3).unwrap();
    assert_eq!(e.needs_action(), vec![true; 3]);
    assert!(e.step(&[0, 0]).is_err());
    assert!(e.step(&[0, 0, 9]).is_err());
    let (mut map, mut vector, mut mask) = (vec![0.0; e.map_len()], vec![0.0; e.vector_len()], vec![0u8; 9]);
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
    assert!(traj.iter().any(|s| s.moves[0] != madenet_world::Move::Stay), "robot 0 moved");
    assert!(traj.iter().all(|s| s.moves[1] == madenet_world::Move::Stay && s.moves[2] == madenet_world::Move::Stay));
    // Bad construction: starts that do not match the team.
    let map = paper_map(1).unwrap();
    let err = ExplorationEnv::new(map, "m", vec![madenet_map::Pos::new(0, 0)], ScenarioConfig::default(), ActionMode::Macro).err().unwrap();
    assert!(err.to_string().contains("num_robots"), "{err}");
}
