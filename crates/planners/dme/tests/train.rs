//! DME-DRL end to end on a tiny run: the files of a run directory, a killed-and-resumed run
//! equal to an uninterrupted one, the trained actors loading and playing, every decision's goal
//! being the nearest frontier of the chosen sector (masked sectors never chosen), and bad
//! configs naming their field. Not convergence.
//!
//! burn's `flex` device draws initial weights from one process-wide RNG, so everything that
//! initialises networks lives in this one test.

use madenet_dme::model::Model;
use madenet_dme::policy::{DecisionSlots, DmePolicy};
use madenet_dme::train::{train, DmeTrainConfig};
use madenet_dme::{sector_goals, SECTORS};
use madenet_nav::Dijkstra;
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_testkit::{read, Scratch};
use std::path::Path;
use std::sync::{Arc, Mutex};

fn tiny(episodes: u64) -> DmeTrainConfig {
    let mut cfg = DmeTrainConfig {
        episodes,
        max_minutes: 0.0,
        batch_size: 8,
        replay_steps: 200,
        warmup_steps: 16,
        update_every: 4,
        validate_every: 2,
        validation_maps: 1,
        validation_csp: vec![1.0],
        checkpoint_every: 1,
        threads: 1,
        hidden: 32,
        ..DmeTrainConfig::default()
    };
    cfg.scenario.step_cap = 30;
    cfg
}

/// A log without its wall-time column (the last one in episodes.csv).
fn without_time(dir: &Path) -> Vec<String> {
    read(dir.join("episodes.csv"))
        .lines()
        .map(|l| l.rsplit_once(',').expect("columns").0.to_string())
        .collect()
}

#[test]
fn tiny_run_resumes_exactly_and_its_actors_play() {
    let root = Scratch::new("dme-train-test");
    let (straight, resumed) = (root.join("straight"), root.join("resumed"));

    train(&straight, Some(tiny(4)), &mut |_| {}).unwrap();
    for f in [
        "config.toml",
        "episodes.csv",
        "updates.csv",
        "validation.csv",
        "checkpoint/state.json",
        "checkpoint/replay.bin",
        "checkpoint/critic2_optim.bpk",
        "best/model.toml",
        "last/actor2.bpk",
    ] {
        assert!(straight.join(f).exists(), "{f} missing");
    }
    let eps = without_time(&straight);
    assert_eq!(eps.len(), 1 + 4, "header + 4 episodes");
    let updates = read(straight.join("updates.csv"));
    assert!(updates.lines().count() > 10, "updates ran:\n{updates}");
    assert_eq!(
        read(straight.join("validation.csv")).lines().count(),
        1 + 2,
        "validated at episodes 2 and 4"
    );

    // Killed after 3 episodes with its checkpoint of episode 2 (the third episode's logs lie
    // past it), then resumed to 4: the same episodes, updates, TensorBoard scalars and weights.
    train(&resumed, Some(tiny(3)), &mut |_| {}).unwrap();
    let scratch = root.join("scratch");
    train(&scratch, Some(tiny(2)), &mut |_| {}).unwrap();
    std::fs::remove_dir_all(resumed.join("checkpoint")).unwrap();
    std::fs::create_dir_all(resumed.join("checkpoint")).unwrap();
    for f in std::fs::read_dir(scratch.join("checkpoint")).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, resumed.join("checkpoint").join(f.file_name().unwrap())).unwrap();
    }
    train(&resumed, Some(tiny(4)), &mut |_| {}).unwrap();
    assert_eq!(without_time(&resumed), eps);
    assert_eq!(read(resumed.join("updates.csv")), updates);
    let scalars = madenet_testkit::tb_scalars;
    let want = scalars(&straight);
    assert!(
        want.iter().any(|s| s.0.starts_with("loss/"))
            && want.iter().any(|s| s.0.starts_with("episode/"))
    );
    assert_eq!(scalars(&resumed), want, "resumed run's TensorBoard scalars");
    // Same weights (the files also carry parameter ids, which differ): same logits.
    let (a, b) = (
        Model::load(&straight.join("last")).unwrap(),
        Model::load(&resumed.join("last")).unwrap(),
    );
    let device = burn::tensor::Device::flex();
    for i in 0..3 {
        let maps = burn::tensor::Tensor::<4>::ones([2, 12, 20, 20], &device);
        let pose = burn::tensor::Tensor::<2>::zeros([2, 6], &device).add_scalar(0.5);
        let logits = |m: &Model| {
            m.actors[i]
                .read()
                .unwrap()
                .forward(maps.clone(), pose.clone())
                .into_data()
                .try_to_vec::<f32>()
                .unwrap()
        };
        assert!(logits(&a) == logits(&b), "actor {i} differs after resume");
    }
    // Resuming with another config is refused, naming the file.
    let other = DmeTrainConfig {
        gamma: 0.5,
        ..tiny(4)
    };
    let err = train(&resumed, Some(other), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("config.toml") && err.contains("different config"),
        "{err}"
    );

    // The trained actors load, refuse other team sizes, and play a trial greedily.
    let model = Model::load(&straight.join("last")).unwrap();
    let cfg = tiny(4);
    let mut four = cfg.scenario.clone();
    four.num_robots = 4;
    assert!(model.check(20, 20, &four).unwrap_err().contains("3 robots"));
    let (map, starts) = cfg.scenario_draw().draw(77).unwrap();

    // Every decision: the goal is the chosen sector's nearest frontier cell on the robot's own
    // map at decision time, and masked sectors are never chosen; between decisions the goal
    // stays, an unreached frontier cell; no valid sector ⇒ no goal.
    let recorder: DecisionSlots = Arc::new(Mutex::new(vec![None; 3]));
    let mut registry = PolicyRegistry::default();
    let (actors, rec) = (model.actors.clone(), recorder.clone());
    registry.register("dme-test", "recording", move |ctx| {
        Box::new(
            DmePolicy::new("dme-test", ctx.robot, Arc::clone(&actors[ctx.robot]), 3)
                .recording(rec.clone()),
        )
    });
    let spec = TrialSpec {
        map,
        map_name: "generated".into(),
        starts,
        config: madenet_world::ScenarioConfig {
            comm_success_prob: 0.5,
            ..cfg.scenario.clone()
        },
        policy: "dme-test".into(),
        seed: 77,
    };
    let mut trial = Trial::with_registry(spec, &registry).unwrap();
    let mut dijkstra = Dijkstra::new(20, 20);
    let (mut decisions, mut kept, mut steps) = (0, 0, 0);
    let mut previous: Vec<Option<madenet_map::Pos>> = vec![None; 3];
    while trial.step() {
        steps += 1;
        for (i, agent) in trial.agents().iter().enumerate() {
            let r = recorder.lock().unwrap()[i]
                .take()
                .expect("the policy runs every step");
            let held: Vec<_> = agent
                .teammates()
                .iter()
                .filter(|t| t.detected)
                .filter_map(|t| t.seen_pos)
                .collect();
            let goals = sector_goals(agent.belief(), agent.pos(), &held, &mut dijkstra);
            assert_eq!(r.mask, goals.mask(), "robot {i} step {steps}");
            match (r.decided, r.action) {
                (true, Some(k)) => {
                    assert!(
                        (k as usize) < SECTORS && goals.mask()[k as usize],
                        "robot {i} step {steps}: masked sector {k}"
                    );
                    assert_eq!(
                        agent.goal(),
                        goals.goals[k as usize],
                        "robot {i} step {steps}"
                    );
                    decisions += 1;
                }
                (true, None) => assert!(!r.mask.contains(&true) && agent.goal().is_none()),
                (false, _) => {
                    let g = agent.goal().expect("a macro action in force has a goal");
                    assert_eq!(Some(g), previous[i]);
                    assert!(g != agent.pos() && agent.belief().is_frontier(g));
                    kept += 1;
                }
            }
            previous[i] = agent.goal();
        }
    }
    assert!(
        decisions > 0 && kept > 0 && steps > 0,
        "{decisions} decisions, {kept} steps keeping a goal"
    );

    // Bad configs: one message naming the field.
    type Edit = fn(&mut DmeTrainConfig);
    let cases: [(&str, Edit); 7] = [
        ("critic_history", |c| c.critic_history = 4),
        ("tau", |c| c.tau = 0.0),
        ("method", |c| c.method = "made-net".into()),
        ("replay_steps", |c| c.replay_steps = 4),
        ("warmup_steps", |c| c.warmup_steps = 500),
        ("move_cost", |c| c.move_cost = f64::NAN),
        ("validation_csp", |c| c.validation_csp = vec![]),
    ];
    for (field, set) in cases {
        let mut cfg = tiny(1);
        set(&mut cfg);
        let err = cfg.validate().unwrap_err();
        assert!(err.contains(field), "{field}: {err}");
    }
    assert!(DmeTrainConfig {
        validate_every: 0,
        validation_maps: 0,
        ..tiny(1)
    }
    .validate()
    .is_ok());
    // A model whose sizes do not fit its weights is an error naming the file, not a crash.
    let broken = root.join("broken");
    std::fs::create_dir_all(&broken).unwrap();
    for f in ["actor0.bpk", "actor1.bpk", "actor2.bpk"] {
        std::fs::copy(straight.join("last").join(f), broken.join(f)).unwrap();
    }
    let toml = read(straight.join("last/model.toml")).replace("hidden = 32", "hidden = 64");
    std::fs::write(broken.join("model.toml"), toml).unwrap();
    let err = Model::load(&broken)
        .err()
        .expect("sizes do not fit")
        .to_string();
    assert!(
        err.contains("model.toml") && err.contains("actor0.bpk"),
        "{err}"
    );
    let file = root.join("bad.toml");
    std::fs::write(&file, "gamma = \"high\"\n").unwrap();
    let err = DmeTrainConfig::from_toml_file(&file)
        .unwrap_err()
        .to_string();
    assert!(err.contains("bad.toml") && err.contains("gamma"), "{err}");
}

#[test]
fn shipped_config_is_the_defaults() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../configs/train-dme.toml");
    assert_eq!(
        DmeTrainConfig::from_toml_file(&path).unwrap(),
        DmeTrainConfig::default()
    );
}

/// DME-DRL's config is checked by its own fields and the shared scenario draw: a team whose
/// joint action space would be too large for MADE-Net's CEP is fine here (DME-DRL has no CEP;
/// it was refused while its checks borrowed MADE-Net's), and a map below the networks'
/// smallest side is refused naming the field.
#[test]
fn checks_are_dme_drl_own_and_the_shared_draw() {
    let nine = DmeTrainConfig {
        scenario: madenet_world::ScenarioConfig {
            num_robots: 9,
            ..Default::default()
        },
        ..DmeTrainConfig::default()
    };
    assert_eq!(nine.validate(), Ok(()));
    let small = DmeTrainConfig {
        map_height: 8,
        ..DmeTrainConfig::default()
    };
    let e = small.validate().unwrap_err();
    assert!(e.starts_with("field `map_height/map_width`"), "{e}");
}
