//! End-to-end training plumbing on a tiny run: logs, checkpoints, best weights, a resumed run
//! equal to an uninterrupted one, same seed ⇒ same updates, bad configs. Not convergence.
//!
//! burn's `flex` device draws initial weights from one process-wide RNG, so everything that
//! initialises networks lives in this one test (tests of a binary run on parallel threads).

use madenet_learn::scenario;
use madenet_learn::{train, Model, Tensor, TrainConfig, TrainError};
use madenet_sim::PolicyRegistry;
use madenet_testkit::{read, Scratch};
use std::path::Path;

fn tiny(episodes: u64) -> TrainConfig {
    let mut cfg = TrainConfig {
        episodes,
        max_minutes: 0.0,
        warmup_episodes: 2,
        batch_size: 4,
        trace_len: 6,
        replay_episodes: 8,
        target_update_every: 2,
        validate_every: 3,
        validation_maps: 1,
        validation_csp: vec![1.0],
        checkpoint_every: 2,
        threads: 1,
        epsilon_decay_episodes: 4,
        ..TrainConfig::default()
    };
    cfg.scenario.step_cap = 40;
    cfg
}

/// episodes.csv without the wall-time column.
fn episodes_without_time(dir: &Path) -> Vec<String> {
    read(dir.join("episodes.csv"))
        .lines()
        .map(|l| l.rsplit_once(',').expect("columns").0.to_string())
        .collect()
}

#[test]
fn tiny_training_logs_checkpoints_resumes_and_repeats() {
    let root = Scratch::new("train-test");
    let (straight, again, resumed) = (
        root.join("straight"),
        root.join("again"),
        root.join("resumed"),
    );

    train(&straight, Some(tiny(6)), &mut |_| {}).unwrap();
    // Files of a run directory.
    for f in [
        "config.toml",
        "episodes.csv",
        "updates.csv",
        "validation.csv",
        "checkpoint/state.json",
        "checkpoint/replay.bin",
        "best/model.toml",
        "last/dep0.bpk",
        "last/cep.bpk",
    ] {
        assert!(straight.join(f).exists(), "{f} missing");
    }
    assert!(std::fs::read_dir(&straight).unwrap().any(|e| e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .starts_with("events.out.tfevents.")));
    let eps = episodes_without_time(&straight);
    assert_eq!(eps.len(), 1 + 12, "header + 6 iterations × 2 environments");
    let cols = |l: &str| l.split(',').map(String::from).collect::<Vec<_>>();
    let (first, second) = (cols(&eps[1]), cols(&eps[2]));
    assert_eq!(
        (
            first[0].as_str(),
            first[1].as_str(),
            first[2].parse::<f64>().unwrap()
        ),
        ("0", "cen", 1.0)
    );
    assert_eq!((second[0].as_str(), second[1].as_str()), ("1", "dec"));
    let updates = read(straight.join("updates.csv"));
    assert_eq!(
        updates.lines().count(),
        1 + 5,
        "updates from iteration 2 to 6"
    );
    assert!(updates.lines().skip(1).all(|l| l
        .split(',')
        .skip(1)
        .all(|v| v.parse::<f32>().is_ok_and(f32::is_finite))));
    assert_eq!(read(straight.join("validation.csv")).lines().count(), 1 + 2);

    // Same seed ⇒ the same episodes and the same updates.
    train(&again, Some(tiny(6)), &mut |_| {}).unwrap();
    assert_eq!(episodes_without_time(&again), eps);
    assert_eq!(read(again.join("updates.csv")), updates);

    // Stopped after 3 iterations (checkpoint at 2, one more iteration logged and lost), then
    // resumed to 6: the same as the uninterrupted run.
    train(&resumed, Some(tiny(3)), &mut |_| {}).unwrap();
    std::fs::remove_dir_all(resumed.join("checkpoint")).unwrap();
    std::fs::rename(resumed.join("last"), resumed.join("unused")).unwrap();
    // Put back the checkpoint of iteration 2 by re-running to 2 in a scratch dir.
    let scratch = root.join("scratch");
    train(&scratch, Some(tiny(2)), &mut |_| {}).unwrap();
    copy_dir(&scratch.join("checkpoint"), &resumed.join("checkpoint"));
    train(&resumed, Some(tiny(6)), &mut |_| {}).unwrap();
    assert_eq!(
        episodes_without_time(&resumed),
        eps,
        "resumed run differs in its episodes"
    );
    assert_eq!(
        read(resumed.join("updates.csv")),
        updates,
        "resumed run differs in its updates"
    );
    assert!(
        q_of(&resumed.join("last")) == q_of(&straight.join("last")),
        "resumed run ends with other weights"
    );
    // TensorBoard holds each scalar once: the resumed run dropped what it wrote after the
    // checkpoint before writing it again.
    let scalars = madenet_testkit::tb_scalars;
    let want = scalars(&straight);
    assert!(
        want.iter().any(|s| s.0.starts_with("loss/"))
            && want.iter().any(|s| s.0.starts_with("validation/"))
    );
    assert_eq!(scalars(&resumed), want, "resumed run's TensorBoard scalars");

    // The saved model loads and plays.
    let model = Model::load(&straight.join("best")).unwrap();
    let mut registry = PolicyRegistry::default();
    model.register(&mut registry, "m", "test model");
    let cfg = tiny(1);
    let maps = cfg.validation_maps().unwrap();
    let v = scenario::validate(&maps, &cfg.validation_csp, &registry, "m").unwrap();
    assert_eq!(v.trials, 1);
    assert!(v.mean_steps > 0.0 && v.mean_steps <= 40.0);

    // A changed config on resume is refused; extending `episodes` is not.
    let other = TrainConfig {
        learning_rate: 0.5,
        ..tiny(6)
    };
    let err = train(&straight, Some(other), &mut |_| {}).unwrap_err();
    assert!(
        matches!(&err, TrainError::Config { path, .. } if path.ends_with("config.toml")),
        "{err}"
    );
    train(&straight, Some(tiny(7)), &mut |_| {}).unwrap();
    assert_eq!(episodes_without_time(&straight).len(), 1 + 14);
}

/// The final DEP's Q values on a fixed input.
fn q_of(model_dir: &Path) -> Vec<f32> {
    let model = Model::load(model_dir).unwrap();
    let device = madenet_learn::cpu();
    let net = &model.deps[0];
    let maps = Tensor::<4>::ones([1, 4, 20, 20], &device);
    let obs = Tensor::<2>::ones([1, net.obs_dim], &device);
    net.act(maps, obs, None)
        .0
        .into_data()
        .try_into_vec_as::<f32>()
        .unwrap()
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

#[test]
fn bad_train_configs_name_file_and_field() {
    let dir = Scratch::new("train-cfg");
    for (text, needle) in [
        ("batch_size = 0\n", "batch_size"),
        ("gamma = 1.5\n", "gamma"),
        ("learning_rat = 0.1\n", "learning_rat"),
        ("method = \"dqn\"\n", "dqn"),
        ("[scenario]\nsensing_range = 0\n", "sensing_range"),
    ] {
        let p = dir.write("bad.toml", text);
        let e = TrainConfig::from_toml_file(&p).unwrap_err().to_string();
        assert!(
            e.contains("bad.toml") && e.contains(needle),
            "{text:?} gave {e}"
        );
    }
}

#[test]
fn shipped_train_config_is_the_default() {
    for name in ["train.toml", "train-paper.toml"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../configs")
            .join(name);
        assert_eq!(
            TrainConfig::from_toml_file(&path).unwrap(),
            TrainConfig::default(),
            "{name}"
        );
    }
}
