//! The rollout-teacher learner end to end on a tiny run: logs, best/last models that load and
//! play, same seed ⇒ same run, a run stopped at an iteration boundary and resumed equal to an
//! uninterrupted one, bad configs. Not convergence.
//!
//! burn's `flex` device draws initial weights from one process-wide RNG, so everything that
//! initialises networks lives in one test.

use madenet_learn::dagger::{train, Futures, RolloutTrainConfig};
use madenet_learn::Model;
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_testkit::{read, Scratch};
use std::path::Path;

fn tiny() -> RolloutTrainConfig {
    let mut cfg = RolloutTrainConfig {
        episodes: 4,
        iterations: 2,
        max_minutes: 0.0,
        updates_per_iteration: 3,
        batch_size: 4,
        validation_maps: 2,
        validation_csp: vec![1.0, 0.0],
        spread_margins: vec![0.1],
        threads: 1,
        ..RolloutTrainConfig::default()
    };
    cfg.scenario.step_cap = 60;
    cfg
}

/// The Q values of a saved model's DEP on a fixed input (weight files also hold random
/// parameter ids, so the files themselves differ between identical runs).
fn q_of(dir: &Path) -> Vec<f32> {
    use madenet_learn::{Tensor, TensorData};
    let model = Model::load(dir).unwrap();
    let net = &model.deps[0];
    let device = madenet_learn::cpu();
    let maps: Vec<f32> = (0..4 * 400)
        .map(|i| ((i * 7) % 3 == 0) as u8 as f32)
        .collect();
    let maps = Tensor::<4>::from_data(TensorData::new(maps, [1, 4, 20, 20]), &device);
    let obs: Vec<f32> = (0..net.obs_dim).map(|i| (i as f32 * 0.37).sin()).collect();
    let obs = Tensor::<2>::from_data(TensorData::new(obs, [1, net.obs_dim]), &device);
    net.act(maps, obs, None)
        .0
        .into_data()
        .try_into_vec_as::<f32>()
        .unwrap()
}

/// iterations.csv without the wall-time column (the last).
fn log_without_time(dir: &Path) -> Vec<String> {
    read(dir.join("iterations.csv"))
        .lines()
        .map(|l| l.rsplit_once(',').map_or(l, |(a, _)| a).to_string())
        .collect()
}

#[test]
fn tiny_run_logs_plays_is_deterministic_and_resumes_exactly() {
    let root = Scratch::new("rollout");
    let (a, b, c) = (root.join("a"), root.join("b"), root.join("c"));
    let mut calls = 0;
    train(&a, Some(tiny()), &mut |_| calls += 1).unwrap();
    assert_eq!(calls, 2, "one progress report per iteration");
    let log = log_without_time(&a);
    assert_eq!(log.len(), 3, "header + one row per iteration: {log:?}");
    assert!(log[0].starts_with("iteration,episodes,decisions,rollouts"));
    for f in [
        "config.toml",
        "best/model.toml",
        "best/dep0.bpk",
        "last/model.toml",
        "last/dep0.bpk",
        "checkpoint/state.json",
        "checkpoint/data.bin",
    ] {
        assert!(a.join(f).exists(), "{f}");
    }
    // Labelled decisions and teacher rollouts were made.
    let row: Vec<&str> = log[1].split(',').collect();
    assert!(
        row[2].parse::<usize>().unwrap() > 0 && row[3].parse::<usize>().unwrap() > 0,
        "{row:?}"
    );

    // The model loads, says what it reads, and plays a whole trial as a registered policy.
    let model = Model::load(&a.join("best")).unwrap();
    assert_eq!(
        model.info.observation,
        madenet_learn::obs::Observation::CandidateFeatures
    );
    assert!(!model.info.recurrent);
    let mut registry = PolicyRegistry::builtin();
    model.register(&mut registry, "student", "the tiny run's model");
    let grid = madenet_map::paper::paper_map(3).unwrap();
    let starts = madenet_map::paper::Corner::TopLeft
        .start_cells(20, 20)
        .to_vec();
    let spec = TrialSpec {
        map: grid,
        map_name: "test_3".into(),
        starts,
        config: Default::default(),
        policy: "student".into(),
        seed: 1,
    };
    let r = Trial::with_registry(spec, &registry).unwrap().run();
    assert!(r.metrics.tns > 0 && r.timing.decisions > 0);

    // Same seed, same run: logs and weights.
    train(&b, Some(tiny()), &mut |_| {}).unwrap();
    assert_eq!(log_without_time(&b), log);
    assert!(
        q_of(&b.join("last")) == q_of(&a.join("last")),
        "same seed, same weights"
    );

    // A time limit that is always exceeded stops inside the first iteration: its work is
    // dropped, nothing is checkpointed, and the call says nothing was trained.
    let e = train(
        &c,
        Some(RolloutTrainConfig {
            max_minutes: 1e-9,
            ..tiny()
        }),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("ran out inside iteration 1"), "{e}");
    assert!(!c.join("iterations.csv").exists() && !c.join("checkpoint").exists());
    // Killed right after the first iteration's checkpoint (the progress report follows it),
    // then resumed: the uninterrupted run's logs and weights.
    let killed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        train(&c, Some(tiny()), &mut |p| {
            assert!(p.done < 1, "killed after iteration 1");
        })
    }));
    assert!(killed.is_err());
    assert_eq!(log_without_time(&c).len(), 2, "stopped after one iteration");
    train(&c, Some(tiny()), &mut |_| {}).unwrap();
    assert_eq!(log_without_time(&c), log);
    // TensorBoard: one point per iteration and figure, each once after the resume.
    let scalars = madenet_testkit::tb_scalars;
    let want = scalars(&a);
    assert_eq!(want.len(), 2 * 8, "2 iterations × 8 figures: {want:?}");
    assert!(want
        .iter()
        .any(|s| s.0 == "iteration/validation_steps" && s.1 == 1));
    assert_eq!(scalars(&c), want, "resumed run's TensorBoard scalars");
    assert!(
        q_of(&c.join("last")) == q_of(&a.join("last")),
        "resumed, the uninterrupted run's weights"
    );

    // A resumed run may change only its time limit.
    let e = train(
        &c,
        Some(RolloutTrainConfig { seed: 2, ..tiny() }),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("different config"), "{e}");

    // The team teacher: the first iteration's episodes are the same (the base rule behaves,
    // the same decisions are labelled), but robots choosing together are valued by coordinate
    // descent — more continuations, other labels.
    let f = root.join("f");
    train(
        &f,
        Some(RolloutTrainConfig {
            team_rounds: 2,
            iterations: 1,
            episodes: 2,
            ..tiny()
        }),
        &mut |_| {},
    )
    .unwrap();
    let (solo, team) = (&table(&a)[0], &table(&f)[0]);
    assert_eq!(solo["decisions"], team["decisions"]);
    assert_eq!(solo["behaviour_steps"], team["behaviour_steps"]);
    let count =
        |r: &std::collections::HashMap<String, String>| -> usize { r["rollouts"].parse().unwrap() };
    assert!(count(team) > count(solo), "{solo:?} vs {team:?}");
    assert_ne!(solo["loss"], team["loss"]);

    // The redrawn teacher: the same episodes and labelled decisions, each candidate valued over
    // `rollouts` futures on redrawn unseen cells — twice the noiseless teacher's continuations
    // at 2, and other labels.
    let r = root.join("r");
    train(
        &r,
        Some(RolloutTrainConfig {
            futures: Futures::Redrawn,
            rollouts: 2,
            iterations: 1,
            episodes: 2,
            ..tiny()
        }),
        &mut |_| {},
    )
    .unwrap();
    let redrawn = &table(&r)[0];
    assert_eq!(solo["decisions"], redrawn["decisions"]);
    assert_eq!(solo["behaviour_steps"], redrawn["behaviour_steps"]);
    assert_eq!(count(redrawn), 2 * count(solo), "{solo:?} vs {redrawn:?}");
    assert_ne!(solo["loss"], redrawn["loss"]);

    // The labels' noise, measured (`teacher_check`): every labelled decision valued again over
    // futures of its own changes nothing learned or counted; the noiseless teacher agrees with
    // itself exactly, the redrawn one does not.
    assert_eq!(redrawn["teacher_self_agreement"], "");
    assert_eq!(redrawn["label_reliability"], "");
    let checked = |futures, dir: &Path| {
        train(
            dir,
            Some(RolloutTrainConfig {
                futures,
                rollouts: 2,
                teacher_check: 1.0,
                iterations: 1,
                episodes: 2,
                ..tiny()
            }),
            &mut |_| {},
        )
        .unwrap();
        table(dir).remove(0)
    };
    let (rc, nc) = (
        checked(Futures::Redrawn, &root.join("rc")),
        checked(Futures::Noiseless, &root.join("nc")),
    );
    for (with, without) in [(&rc, redrawn), (&nc, solo)] {
        for k in [
            "decisions",
            "rollouts",
            "loss",
            "teacher_gain",
            "base_agreement",
        ] {
            assert_eq!(with[k], without[k], "{k}");
        }
    }
    let share =
        |r: &std::collections::HashMap<String, String>, k: &str| -> f64 { r[k].parse().unwrap() };
    assert_eq!(share(&nc, "teacher_self_agreement"), 1.0);
    assert!(
        (share(&nc, "label_reliability") - 1.0).abs() < 1e-9,
        "{nc:?}"
    );
    let (agree, rel) = (
        share(&rc, "teacher_self_agreement"),
        share(&rc, "label_reliability"),
    );
    assert!(0.0 < agree && agree < 1.0, "{rc:?}");
    assert!(-1.0 < rel && rel < 1.0 - 1e-6, "{rc:?}");

    // Expert iteration over a weak base rule (random candidates): the teacher gains over its
    // base, a student that beats the base becomes the next iteration's base (kept in the
    // checkpoint: a killed and resumed run equals an uninterrupted one), and the run stops by
    // the patience rule, not by hand.
    // (Continuations cut after 30 steps: under random, most would hit the step cap and tie.)
    let expert = || RolloutTrainConfig {
        base_policy: "random".into(),
        expert_iteration: true,
        patience: 1,
        iterations: 4,
        episodes: 8,
        horizon: 30,
        ..tiny()
    };
    let (d, e) = (root.join("d"), root.join("e"));
    train(&d, Some(expert()), &mut |_| {}).unwrap();
    let rows = table(&d);
    let col = |r: &std::collections::HashMap<String, String>, k: &str| r[k].clone();
    let num =
        |r: &std::collections::HashMap<String, String>, k: &str| -> f64 { r[k].parse().unwrap() };
    assert_eq!(col(&rows[0], "teacher_base"), "random");
    // The grid network logs no student agreement; the base's agreement with the teacher is a
    // share, and over the same maps with the same teacher lookahead `spread` agrees with the
    // teacher more often than the random rule does.
    assert_eq!(col(&rows[0], "student_agreement"), "");
    let g = root.join("g");
    let spread_first = RolloutTrainConfig {
        base_policy: "spread".into(),
        iterations: 1,
        episodes: 2,
        ..expert()
    };
    train(&g, Some(spread_first), &mut |_| {}).unwrap();
    let spread_agrees = num(&table(&g)[0], "base_agreement");
    let random_agrees = num(&rows[0], "base_agreement");
    assert!(
        0.0 < random_agrees && random_agrees < spread_agrees && spread_agrees <= 1.0,
        "random {random_agrees}, spread {spread_agrees}"
    );
    assert!(
        num(&rows[0], "teacher_gain") > 0.0,
        "one step over random gains"
    );
    let (mut best, mut stale, mut base) = (f64::INFINITY, 0, "random".to_string());
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(col(r, "teacher_base"), base, "iteration {k}");
        let v = num(r, "validation_steps");
        let gain = 100.0 * (num(r, "base_steps") - v) / num(r, "base_steps");
        assert!((num(r, "student_gain_pct") - gain).abs() < 1e-6);
        if v < best {
            (best, stale) = (v, 0);
            if v < num(r, "base_steps") {
                base = format!("student@{k}");
            }
        } else {
            stale += 1;
        }
        let last = k + 1 == rows.len();
        // Patience 1: an iteration without a new best is the last; a run ends early only so.
        assert!(
            stale == 0 || last,
            "ran on after iteration {k} without a new best"
        );
        assert!(
            !last || k + 1 == 4 || stale >= 1,
            "stopped early at {k} with a new best"
        );
    }
    assert!(
        rows.iter()
            .any(|r| col(r, "teacher_base").starts_with("student@")),
        "a student beat random and became the base: {rows:?}"
    );
    // The kill below lands after iteration 2 while a student is the base and the run goes on:
    // the resumed run must restore that base from the checkpoint.
    assert!(
        rows.len() > 2 && col(&rows[2], "teacher_base").starts_with("student@"),
        "{rows:?}"
    );
    let killed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        train(&e, Some(expert()), &mut |p| {
            assert!(p.done < 2, "killed after iteration 2");
        })
    }));
    assert!(killed.is_err());
    train(&e, Some(expert()), &mut |_| {}).unwrap();
    assert_eq!(log_without_time(&e), log_without_time(&d));
}

/// iterations.csv as rows of column → value.
fn table(dir: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_path(dir.join("iterations.csv")).unwrap();
    let head: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    r.records()
        .map(|rec| {
            head.iter()
                .cloned()
                .zip(rec.unwrap().iter().map(String::from))
                .collect()
        })
        .collect()
}

#[test]
fn shipped_rollout_config_is_the_default_and_bad_fields_are_named() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../configs/train-rollout.toml");
    assert_eq!(
        RolloutTrainConfig::from_toml_file(&path).unwrap(),
        RolloutTrainConfig::default()
    );
    let dir = Scratch::new("rollout-bad");
    for (text, needle) in [
        ("method = \"made-net\"\n", "method"),
        ("rollouts = 0\n", "rollouts"),
        ("density_max = 0.95\n", "density"),
        ("base_policy = \"nope\"\n", "base_policy"),
        ("spread_margins = [-1.0]\n", "spread_margins"),
        ("iterations = 0\n", "iterations"),
        ("threads = 100000\n", "threads"),
        ("nonsense = 1\n", "nonsense"),
        ("wide_inputs = true\n", "wide_inputs"),
        ("territory_inputs = true\n", "territory_inputs"),
        ("plan_inputs = true\n", "plan_inputs"),
        ("init_model = \"models/made-net\"\n", "init_model"),
        ("label_norm = \"per-map\"\n", "label_norm"),
        ("fit_holdout = 0.2\n", "fit_holdout"),
        ("network = \"agnostic\"\nfit_holdout = 0.9\n", "fit_holdout"),
        (
            "network = \"agnostic\"\nfit_holdout = 0.2\nfit_check_every = 0\n",
            "fit_check_every",
        ),
    ] {
        let p = dir.write("bad.toml", text);
        let e = RolloutTrainConfig::from_toml_file(&p)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bad.toml") && e.contains(needle),
            "{text:?} gave {e}"
        );
    }
}

/// configs/train-plan.toml reproduces the shipped `made-net`: it reads as the config its run
/// wrote beside the model (models/made-net/training/config.toml).
#[test]
fn plan_config_is_the_shipped_made_nets() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../");
    let documented =
        RolloutTrainConfig::from_toml_file(&root.join("configs/train-plan.toml")).unwrap();
    let shipped =
        RolloutTrainConfig::from_toml_file(&root.join("models/made-net/training/config.toml"))
            .unwrap();
    assert_eq!(documented, shipped);
    assert_ne!(documented, RolloutTrainConfig::default());
}
