//! The size- and team-agnostic DEP: one network scores decisions of any map size, team size and
//! |G|; its scores follow the candidates (not their slot numbers); padding a decision to a wider
//! batch does not change its scores; and a tiny curriculum run trains, saves and loads a model
//! that plays maps and teams it was not trained on.
//!
//! burn's `flex` device draws initial weights from one process-wide RNG, so the run that checks
//! same-seed determinism lives in one test with everything else that initialises networks.

use madenet_learn::agnostic::{
    inputs_for, AgnosticConfig, AgnosticInput, Batch, CANDIDATE_INPUTS, CONTEXT_FEATURES,
    PLAN_INPUTS, TERRITORY_INPUTS, WIDE_INPUTS,
};
use madenet_learn::dagger::{
    refit, stored_labels, train, Futures, Network, RolloutTrainConfig, Teacher,
};
use madenet_learn::Model;
use madenet_map::generate::{generate_with_movement, random_starts, GeneratorConfig};
use madenet_map::Pos;
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_testkit::Scratch;
use madenet_world::ScenarioConfig;

/// A decision's inputs taken from the first decision of a spread trial on a generated map.
fn decision_from(side: usize, team: usize, seed: u64) -> AgnosticInput {
    decision_for(side, team, seed, &AgnosticConfig::new())
}

/// [`decision_from`] for a network of `sizes`.
fn decision_for(side: usize, team: usize, seed: u64, sizes: &AgnosticConfig) -> AgnosticInput {
    let gen = GeneratorConfig {
        keep_free: vec![],
        ..GeneratorConfig::for_size(side, side)
    };
    let cfg = ScenarioConfig {
        num_robots: team,
        ..ScenarioConfig::default()
    };
    let map = generate_with_movement(&gen, seed, cfg.movement).unwrap();
    let starts = random_starts(&map, team, cfg.movement, seed).unwrap();
    let spec = TrialSpec {
        map,
        map_name: "g".into(),
        starts,
        config: cfg,
        policy: "spread".into(),
        seed,
    };
    let mut trial = Trial::new(spec).unwrap();
    assert!(trial.begin_step());
    let mut view = trial.agent_mut(0).view(true);
    inputs_for(&mut view, sizes)
}

/// `wide_inputs` appends WIDE_INPUTS shares to each candidate's usual inputs (those unchanged):
/// each in [0, 1], the unknown cells left to this robot within 4 d_s at most those within 4 d_s,
/// some unknown space around some candidate at the start; a wide network's decision scorer gives
/// burn's scores.
fn wide_inputs_extend_each_candidate_and_score_alike() {
    let wide = AgnosticConfig::new().with_wide_inputs(Some(true));
    assert_eq!(wide.candidate_inputs(), CANDIDATE_INPUTS + WIDE_INPUTS);
    for (side, team, seed) in [(20, 3, 4), (37, 5, 8)] {
        let (x, plain) = (
            decision_for(side, team, seed, &wide),
            decision_from(side, team, seed),
        );
        let slots = x.mask.len();
        assert_eq!(x.features.len(), slots * wide.candidate_inputs());
        assert_eq!(
            (&x.context, &x.crops, &x.mask),
            (&plain.context, &plain.crops, &plain.mask)
        );
        let mut unknown_near = 0.0f32;
        for k in 0..slots {
            let f = &x.features[k * wide.candidate_inputs()..(k + 1) * wide.candidate_inputs()];
            assert_eq!(
                &f[..CANDIDATE_INPUTS],
                &plain.features[k * CANDIDATE_INPUTS..(k + 1) * CANDIDATE_INPUTS]
            );
            let w = &f[CANDIDATE_INPUTS..];
            assert!(w.iter().all(|v| (0.0..=1.0).contains(v)), "{w:?}");
            assert!(w[2] <= w[1], "{w:?}");
            unknown_near += w[1];
        }
        assert!(unknown_near > 0.0, "{x:?}");
        let net = wide.init(&madenet_learn::cpu()).unwrap();
        let scorer = madenet_learn::agnostic::AgnosticScorer::new(&net);
        let (want, got) = (net.scores(&x), scorer.scores(&x));
        for k in (0..slots).filter(|&k| x.mask[k]) {
            assert!(
                (want[k] - got[k]).abs() < 1e-4 * want[k].abs().max(1.0),
                "{want:?} {got:?}"
            );
        }
    }
}

/// `territory_inputs` appends TERRITORY_INPUTS values after the wide ones (both unchanged by
/// it), and splits a corridor's unknown cells as worked out by hand.
fn territory_inputs_follow_the_wide_ones_and_split_a_corridor_by_hand() {
    let both = AgnosticConfig::new()
        .with_wide_inputs(Some(true))
        .with_territory_inputs(Some(true));
    let wide = AgnosticConfig::new().with_wide_inputs(Some(true));
    assert_eq!(
        both.candidate_inputs(),
        CANDIDATE_INPUTS + WIDE_INPUTS + TERRITORY_INPUTS
    );
    let (x, w) = (decision_for(30, 4, 3, &both), decision_for(30, 4, 3, &wide));
    let slots = x.mask.len();
    for k in 0..slots {
        let f = &x.features[k * both.candidate_inputs()..(k + 1) * both.candidate_inputs()];
        let g = &w.features[k * wide.candidate_inputs()..(k + 1) * wide.candidate_inputs()];
        assert_eq!(&f[..wide.candidate_inputs()], g);
        let t = &f[wide.candidate_inputs()..];
        assert!(
            (0.0..=1.0).contains(&t[0]) && (-1.0..=1.0).contains(&t[1]),
            "{t:?}"
        );
        assert!((0.0..=1.0).contains(&t[2]), "{t:?}");
        if !x.mask[k] {
            assert_eq!(t, &[0.0; TERRITORY_INPUTS]);
        }
    }
    // A 1 × 40 corridor, the robot at column 15 knowing 13..=17 (its candidates: 13 and 17).
    let corridor = |right_end: &str| {
        let row = format!("{}{}{}", "?".repeat(13), ".".repeat(5), right_end);
        madenet_agent::Belief::from_rows(&[row.as_str()], Default::default())
    };
    let (robot, candidates) = (
        Pos::new(0, 15),
        [Some(Pos::new(0, 13)), Some(Pos::new(0, 17)), None],
    );
    let close = |got: [f32; 3], want: [f32; 3]| {
        assert!(
            got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-6),
            "{got:?} != {want:?}"
        );
    };
    // No teammate known: T is all 35 unknown cells (0..=12, 18..=39). The left candidate is
    // nearer than the robot to 0..=12 (13 cells), the right one to 18..=39 (22); each is 2 moves
    // away and gains 2 moves on its side's cells, loses 2 on the other's: progress (13 − 22) / 35
    // and (22 − 13) / 35; with no teammate, every unknown cell is left to it.
    let t = madenet_learn::agnostic::territory(&corridor(&"?".repeat(22)), robot, &[], &candidates);
    close(t[0], [13.0 / 35.0, -9.0 / 35.0, 1.0]);
    close(t[1], [22.0 / 35.0, 9.0 / 35.0, 1.0]);
    assert_eq!(t[2], [0.0; TERRITORY_INPUTS]);
    // A teammate at column 39 (known free): 34 unknown cells (0..=12, 18..=38). T: those the robot
    // reaches first, |c − 15| < 39 − c: 0..=12 and 18..=26 (22). The left candidate is nearer to
    // 13 of them, the right one to 9: progress ±(13 − 9) / 22. Map-wide, nearer to 13 than to 39
    // are 0..=12 and 18..=25 (21 of 34); nearer to 17, 0..=12 and 18..=27 (23).
    let b = corridor(&format!("{}.", "?".repeat(21)));
    let t = madenet_learn::agnostic::territory(&b, robot, &[Pos::new(0, 39)], &candidates);
    close(t[0], [13.0 / 22.0, 4.0 / 22.0, 21.0 / 34.0]);
    close(t[1], [9.0 / 22.0, -4.0 / 22.0, 23.0 / 34.0]);
    // An obstacle at column 20 cuts the right side off: T is 0..=12 and 18..=19 (15), the right
    // candidate nearer to 2 of them and progressing on them by 2 / 2, losing 2 / 2 on the 13;
    // map-wide, 15 of the 33 unknown cells are nearer to it than to the teammate (who alone
    // reaches 21..=38).
    let b = madenet_agent::Belief::from_rows(
        &[format!("{}.....??#{}.", "?".repeat(13), "?".repeat(18)).as_str()],
        Default::default(),
    );
    let t = madenet_learn::agnostic::territory(&b, robot, &[Pos::new(0, 39)], &candidates);
    close(t[1], [2.0 / 15.0, -11.0 / 15.0, 15.0 / 33.0]);
}

/// `plan_inputs` appends PLAN_INPUTS values after the base ones (unchanged by it): each valid
/// candidate's moves to the robot's first viewpoint in its belief plan, scaled into [0, 1], and a
/// flag on the candidates with the fewest — at least one, and only those; zeros in empty slots.
fn plan_inputs_follow_the_base_ones_and_flag_the_plans_choice() {
    let plan = AgnosticConfig::new().with_plan_inputs(Some(true));
    assert_eq!(plan.candidate_inputs(), CANDIDATE_INPUTS + PLAN_INPUTS);
    let mut flagged_somewhere = false;
    for (side, team, seed) in [(30, 4, 3), (20, 3, 7), (40, 2, 11)] {
        let (x, base) = (
            decision_for(side, team, seed, &plan),
            decision_for(side, team, seed, &AgnosticConfig::new()),
        );
        let width = plan.candidate_inputs();
        let p: Vec<&[f32]> = (0..x.mask.len())
            .map(|k| &x.features[k * width + CANDIDATE_INPUTS..(k + 1) * width])
            .collect();
        for (k, (pk, &valid)) in p.iter().zip(&x.mask).enumerate() {
            assert_eq!(
                &x.features[k * width..k * width + CANDIDATE_INPUTS],
                &base.features[k * CANDIDATE_INPUTS..(k + 1) * CANDIDATE_INPUTS]
            );
            if !valid {
                assert_eq!(*pk, &[0.0; PLAN_INPUTS]);
            }
            assert!((0.0..=1.0).contains(&pk[0]) && [0.0, 1.0].contains(&pk[1]));
        }
        let valid: Vec<usize> = (0..x.mask.len()).filter(|&k| x.mask[k]).collect();
        let fewest = valid.iter().map(|&k| p[k][0]).fold(f32::INFINITY, f32::min);
        let flags: Vec<bool> = valid.iter().map(|&k| p[k][1] == 1.0).collect();
        if flags.iter().any(|&f| f) {
            flagged_somewhere = true;
            for (&k, &f) in valid.iter().zip(&flags) {
                assert_eq!(f, p[k][0] == fewest, "side {side}: {p:?}");
            }
        }
    }
    assert!(flagged_somewhere, "some first decision has a plan");
}

fn permuted(x: &AgnosticInput, order: &[usize]) -> AgnosticInput {
    let crop_bits = 4 * 13 * 13;
    let mut crops = vec![0u8; x.mask.len() * crop_bits];
    let mut bits = vec![0.0f32; x.mask.len() * crop_bits];
    madenet_learn::obs::unpack_bits(&x.crops, &mut bits);
    let mut features = vec![0.0; x.features.len()];
    let mut mask = vec![false; x.mask.len()];
    for (to, &from) in order.iter().enumerate() {
        for b in 0..crop_bits {
            crops[to * crop_bits + b] = bits[from * crop_bits + b] as u8;
        }
        features[to * CANDIDATE_INPUTS..(to + 1) * CANDIDATE_INPUTS]
            .copy_from_slice(&x.features[from * CANDIDATE_INPUTS..(from + 1) * CANDIDATE_INPUTS]);
        mask[to] = x.mask[from];
    }
    AgnosticInput {
        context: x.context.clone(),
        features,
        crops: madenet_learn::obs::pack_bits(&crops),
        mask,
    }
}

#[test]
fn agnostic_network_and_its_training() {
    one_network_scores_any_map_team_and_candidate_count_by_candidate_not_slot();
    the_decision_scorer_scores_as_the_network();
    wide_inputs_extend_each_candidate_and_score_alike();
    territory_inputs_follow_the_wide_ones_and_split_a_corridor_by_hand();
    plan_inputs_follow_the_base_ones_and_flag_the_plans_choice();
    tiny_curriculum_run_trains_a_model_that_plays_unseen_sizes_and_teams_deterministically();
}

fn one_network_scores_any_map_team_and_candidate_count_by_candidate_not_slot() {
    let net = AgnosticConfig::new().init(&madenet_learn::cpu()).unwrap();
    let small = decision_from(20, 3, 4);
    let large = decision_from(45, 6, 5);
    assert_eq!(small.context.len(), CONTEXT_FEATURES);
    assert_eq!(small.mask.len(), 4, "|G| on 20 × 20 with 3 robots (Eq. 3)");
    assert_eq!(
        large.mask.len(),
        6 + 2,
        "|G| on 45 × 45 with 6 robots (Eq. 3)"
    );
    for x in [&small, &large] {
        let q = net.scores(x);
        assert_eq!(q.len(), x.mask.len());
        assert!(q.iter().all(|v| v.is_finite()), "{q:?}");
        assert!(x.mask.iter().filter(|&&m| m).count() >= 2, "a real choice");
    }
    // Scores follow the candidates: reversing the slots reverses the scores.
    let q = net.scores(&large);
    let order: Vec<usize> = (0..large.mask.len()).rev().collect();
    let qr = net.scores(&permuted(&large, &order));
    for (k, &from) in order.iter().enumerate() {
        if large.mask[from] {
            assert!(
                (qr[k] - q[from]).abs() < 1e-4,
                "slot {k}: {} vs {}",
                qr[k],
                q[from]
            );
        }
    }
    // Batched with a wider decision (padded slots), a decision keeps its scores.
    let batch = Batch::of(&[&small, &large], 13, &madenet_learn::cpu());
    assert_eq!(batch.slots, 8);
    let both = net
        .forward(batch.crops, batch.features, batch.context, batch.mask)
        .into_data()
        .try_into_vec_as::<f32>()
        .unwrap();
    let alone = net.scores(&small);
    for k in 0..4 {
        if small.mask[k] {
            assert!(
                (both[k] - alone[k]).abs() < 1e-4,
                "slot {k}: {} vs {}",
                both[k],
                alone[k]
            );
        }
    }
}

/// `AgnosticScorer` (the decision-time forward pass) gives burn's scores to 1e-4 for every
/// valid slot, and −∞ for the others, with fresh weights and with the shipped model's.
fn the_decision_scorer_scores_as_the_network() {
    let fresh = AgnosticConfig::new().init(&madenet_learn::cpu()).unwrap();
    let shipped = madenet_learn::shipped::model("made-net-any").unwrap();
    let shipped = shipped.agnostic().map(|a| &**a).unwrap();
    let mut decisions = vec![decision_from(20, 3, 4), decision_from(45, 6, 5)];
    for seed in 6..12 {
        decisions.push(decision_from(
            20 + 4 * seed as usize,
            2 + seed as usize % 5,
            seed,
        ));
    }
    // A decision with a slot masked out.
    let mut masked = decision_from(30, 4, 3);
    let k = masked.mask.iter().position(|&m| m).unwrap();
    masked.mask[k] = false;
    decisions.push(masked);
    for net in [&fresh, shipped] {
        let scorer = madenet_learn::agnostic::AgnosticScorer::new(net);
        for (i, x) in decisions.iter().enumerate() {
            let (want, got) = (net.scores(x), scorer.scores(x));
            assert_eq!(want.len(), got.len());
            for k in 0..x.mask.len() {
                if x.mask[k] {
                    let tol = 1e-4 * want[k].abs().max(1.0);
                    assert!(
                        (want[k] - got[k]).abs() < tol,
                        "decision {i} slot {k}: {want:?} vs {got:?}"
                    );
                } else {
                    assert_eq!(got[k], f32::NEG_INFINITY, "decision {i} slot {k}");
                }
            }
        }
    }
}

fn tiny_curriculum_run_trains_a_model_that_plays_unseen_sizes_and_teams_deterministically() {
    let tiny = || {
        let mut cfg = RolloutTrainConfig {
            network: Network::Agnostic,
            map_side_max: 24,
            team_max: 4,
            horizon: 10,
            label_prob: 0.5,
            episodes: 4,
            iterations: 2,
            max_minutes: 0.0,
            updates_per_iteration: 3,
            batch_size: 8,
            validation_maps: 2,
            validation_csp: vec![1.0],
            spread_margins: vec![0.1],
            threads: 1,
            ..RolloutTrainConfig::default()
        };
        cfg.scenario.num_robots = 2;
        cfg.scenario.step_cap = 120;
        cfg
    };
    let root = Scratch::new("agnostic");
    let (a, b) = (root.join("a"), root.join("b"));
    train(&a, Some(tiny()), &mut |_| {}).unwrap();
    // Imitation is measured on each iteration's fresh labels: the base's and the student's
    // agreement with the teacher's best candidates, shares in [0, 1].
    let mut log = csv::Reader::from_path(a.join("iterations.csv")).unwrap();
    let head = log.headers().unwrap().clone();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (base_col, student_col) = (col("base_agreement"), col("student_agreement"));
    for row in log.records() {
        let row = row.unwrap();
        for c in [base_col, student_col] {
            let share: f64 = row[c].parse().unwrap();
            assert!((0.0..=1.0).contains(&share), "{row:?}");
        }
        // The student's scores against the fresh labels: a correlation.
        let corr: f64 = row[col("student_label_corr")].parse().unwrap();
        assert!((-1.0..=1.0).contains(&corr), "{row:?}");
        // `spread`'s score ranks candidates as the teacher's labels do, more than by chance
        // (its choice is the teacher's best more often than a random candidate's).
        let spread: f64 = row[col("spread_label_corr")].parse().unwrap();
        assert!(0.0 < spread && spread <= 1.0, "{row:?}");
        // The label gains over `spread`'s choice: the teacher's is the ceiling (its choice is
        // the best label, `spread`'s one of the candidates), the student's at most that, at a
        // margin of the run's (0: greedy).
        let teacher: f64 = row[col("teacher_label_gain")].parse().unwrap();
        let student: f64 = row[col("student_label_gain")].parse().unwrap();
        let margin: f32 = row[col("student_gain_margin")].parse().unwrap();
        assert!(teacher >= 0.0 && student <= teacher, "{row:?}");
        assert!(margin == 0.0 || margin == 0.1, "{row:?}");
    }
    // The supervised half alone: a fresh student fitted to the stored labels of iteration 0
    // (as the run fitted it) scores iteration 1's labels exactly as the run's log says.
    let stored = stored_labels(&a).unwrap();
    assert_eq!(stored.len(), 2);
    let cfg = tiny();
    let test: Vec<_> = stored[1].iter().flatten().cloned().collect();
    let curve = refit(&cfg, &cfg.agnostic(), &stored[0], &test, 3, 2).unwrap();
    assert_eq!(
        curve.iter().map(|r| r.0).collect::<Vec<_>>(),
        vec![2, 3],
        "rows after 2 updates and at the end"
    );
    let mut log = csv::Reader::from_path(a.join("iterations.csv")).unwrap();
    let logged: f64 = log.records().nth(1).unwrap().unwrap()[col("student_label_corr")]
        .parse()
        .unwrap();
    let refitted = curve[1].2.label_corr.unwrap();
    assert!(
        (refitted - logged).abs() < 1e-12,
        "refit {refitted} vs the run's {logged}"
    );
    let mut log = csv::Reader::from_path(a.join("iterations.csv")).unwrap();
    let row = log.records().nth(1).unwrap().unwrap();
    let logged: f64 = row[col("student_label_gain")].parse().unwrap();
    let refitted = curve[1].2.best_gain().unwrap().1;
    assert!(
        (refitted - logged).abs() < 1e-12,
        "refit's label gain {refitted} vs the run's {logged}"
    );
    // Policy iteration: iteration 1's continuations follow the greedy student of iteration 0
    // (other labels, so another teacher gain); with expert iteration too, a named error.
    let pi = root.join("pi");
    let iterating = RolloutTrainConfig {
        policy_iteration: true,
        ..tiny()
    };
    train(&pi, Some(iterating.clone()), &mut |_| {}).unwrap();
    let mut log = csv::Reader::from_path(pi.join("iterations.csv")).unwrap();
    let rows: Vec<_> = log.records().map(Result::unwrap).collect();
    assert_eq!(&rows[0][col("teacher_base")], "spread");
    assert_eq!(&rows[1][col("teacher_base")], "greedy student@0");
    let mut plain = csv::Reader::from_path(a.join("iterations.csv")).unwrap();
    let plain: Vec<_> = plain.records().map(Result::unwrap).collect();
    assert_eq!(rows[0][col("teacher_gain")], plain[0][col("teacher_gain")]);
    assert_ne!(rows[1][col("teacher_gain")], plain[1][col("teacher_gain")]);
    // Killed after iteration 0's checkpoint and resumed: the uninterrupted run's log (the fit
    // of iteration 1 starts at the checkpoint's labels, as it did without the kill).
    let without_time = |dir: &std::path::Path| -> Vec<String> {
        std::fs::read_to_string(dir.join("iterations.csv"))
            .unwrap()
            .lines()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string())
            .collect()
    };
    let killed_dir = root.join("pi-killed");
    let killed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        train(&killed_dir, Some(iterating.clone()), &mut |p| {
            assert!(p.done < 1, "killed after iteration 0");
        })
    }));
    assert!(killed.is_err());
    assert_eq!(without_time(&killed_dir).len(), 2, "header and iteration 0");
    train(&killed_dir, Some(iterating.clone()), &mut |_| {}).unwrap();
    assert_eq!(without_time(&killed_dir), without_time(&pi));
    let both = RolloutTrainConfig {
        expert_iteration: true,
        ..iterating
    };
    let err = train(&root.join("both"), Some(both), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("policy_iteration/expert_iteration"), "{err}");
    // The team-plan teacher: one plan per redrawn future and labelled decision (the check's
    // second valuation, of half the decisions, not counted), other labels than the rollout
    // teacher's, and the check's agreement and reliability logged; without redrawn futures, or
    // with a team teacher, a named error.
    let plan = RolloutTrainConfig {
        teacher: Teacher::Plan,
        futures: Futures::Redrawn,
        rollouts: 2,
        iterations: 1,
        teacher_check: 0.5,
        ..tiny()
    };
    train(&root.join("plan"), Some(plan.clone()), &mut |_| {}).unwrap();
    let mut log = csv::Reader::from_path(root.join("plan").join("iterations.csv")).unwrap();
    let row = log.records().next().unwrap().unwrap();
    let decisions: usize = row[col("decisions")].parse().unwrap();
    let plans: usize = row[col("rollouts")].parse().unwrap();
    assert!(decisions > 0 && plans == 2 * decisions, "{row:?}");
    assert_ne!(row[col("teacher_gain")], plain[0][col("teacher_gain")]);
    let agreement: f64 = row[col("teacher_self_agreement")].parse().unwrap();
    let reliability: f64 = row[col("label_reliability")].parse().unwrap();
    assert!((0.0..=1.0).contains(&agreement), "{row:?}");
    assert!((-1.0..=1.0).contains(&reliability), "{row:?}");
    let err = train(
        &root.join("plan-team"),
        Some(RolloutTrainConfig {
            team_rounds: 2,
            ..plan.clone()
        }),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("teacher") && err.contains("team_rounds"),
        "{err}"
    );
    let err = train(
        &root.join("plan-noiseless"),
        Some(RolloutTrainConfig {
            futures: Futures::Noiseless,
            ..plan
        }),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("teacher") && err.contains("redrawn"), "{err}");
    // A warm start: with a learning rate too small to move a weight, a run started from the
    // shipped made-net scores a decision as made-net does, and a fresh run does not; a missing
    // folder or a grid model is a named error.
    let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../models");
    let still = RolloutTrainConfig {
        learning_rate: 1e-12,
        iterations: 1,
        ..tiny()
    };
    let warm = RolloutTrainConfig {
        init_model: models.join("made-net").display().to_string(),
        ..still.clone()
    };
    train(&root.join("warm"), Some(warm.clone()), &mut |_| {}).unwrap();
    train(&root.join("still"), Some(still), &mut |_| {}).unwrap();
    let x = decision_from(20, 3, 4);
    let scores = |dir: &str| {
        let m = Model::load(&root.join(dir).join("last")).unwrap();
        m.agnostic().unwrap().scores(&x)
    };
    let shipped = madenet_learn::shipped::model("made-net").unwrap();
    let want = shipped.agnostic().unwrap().scores(&x);
    let (warm_q, fresh_q) = (scores("warm"), scores("still"));
    let valid: Vec<usize> = (0..x.mask.len()).filter(|&k| x.mask[k]).collect();
    for &k in &valid {
        assert!((warm_q[k] - want[k]).abs() < 1e-4, "{warm_q:?} {want:?}");
    }
    assert!(
        valid.iter().any(|&k| (fresh_q[k] - want[k]).abs() > 1e-3),
        "{fresh_q:?} {want:?}"
    );
    for (dir, needle) in [
        ("nowhere", "init_model"),
        ("made-net-paper", "agnostic model"),
    ] {
        let err = train(
            &root.join(format!("warm-{dir}")),
            Some(RolloutTrainConfig {
                init_model: models.join(dir).display().to_string(),
                ..warm.clone()
            }),
            &mut |_| {},
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("init_model") && err.contains(needle), "{err}");
    }
    // The fit's stopping rule: half of each iteration's new sequences held out, a check after
    // every update; each iteration logs the updates it made and the kept student's held-out
    // score, and the model counts exactly those updates.
    let es = root.join("es");
    let mut stopped = tiny();
    (
        stopped.fit_holdout,
        stopped.fit_check_every,
        stopped.fit_patience,
    ) = (0.5, 1, 1);
    stopped.updates_per_iteration = 6;
    train(&es, Some(stopped), &mut |_| {}).unwrap();
    let mut log = csv::Reader::from_path(es.join("iterations.csv")).unwrap();
    let head = log.headers().unwrap().clone();
    let at = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (mut total, mut rows) = (0u64, 0);
    for row in log.records() {
        let row = row.unwrap();
        let made: u64 = row[at("fit_updates")].parse().unwrap();
        assert!((1..=6).contains(&made), "{row:?}");
        let corr: f64 = row[at("holdout_label_corr")].parse().unwrap();
        assert!((-1.0..=1.0).contains(&corr), "{row:?}");
        total += made;
        rows += 1;
        let logged: u64 = row[at("updates")].parse().unwrap();
        assert_eq!(logged, total, "{row:?}");
    }
    assert_eq!(rows, 2);
    let info = Model::load(&es.join("last")).unwrap().info;
    assert_eq!(info.updates, total);
    // A wider student is another student.
    let wide = cfg.agnostic().with_hidden_width(96);
    let other = refit(&cfg, &wide, &stored[0], &test, 3, 3).unwrap();
    assert_ne!(other[0].2.label_corr, curve[1].2.label_corr);
    let toml = std::fs::read_to_string(a.join("last/model.toml")).unwrap();
    assert!(
        toml.contains("[agnostic]") && !toml.contains("[dep]"),
        "{toml}"
    );
    let model = Model::load(&a.join("last")).unwrap();
    assert!(model.agnostic().is_some() && model.deps.is_empty());
    let mut registry = PolicyRegistry::builtin();
    model.register(&mut registry, "any", "the tiny run's model");
    // A map side and team outside the curriculum, through the registry's check.
    let x = decision_from(33, 5, 9);
    assert_eq!(x.mask.len(), 5 + 2);
    let gen = GeneratorConfig {
        keep_free: vec![],
        ..GeneratorConfig::for_size(33, 27)
    };
    let map = generate_with_movement(&gen, 9, Default::default()).unwrap();
    let starts = random_starts(&map, 5, Default::default(), 9).unwrap();
    let spec = TrialSpec {
        map,
        map_name: "g".into(),
        starts,
        config: ScenarioConfig {
            num_robots: 5,
            ..ScenarioConfig::default()
        },
        policy: "any".into(),
        seed: 3,
    };
    let r = Trial::with_registry(spec, &registry).unwrap().run();
    assert!(
        r.timing.decisions > 0 && r.metrics.explored > 0.5,
        "{:?}",
        r.metrics.explored
    );
    // Same seed, same scores.
    train(&b, Some(tiny()), &mut |_| {}).unwrap();
    let again = Model::load(&b.join("last")).unwrap();
    let (m1, m2) = (model.agnostic().unwrap(), again.agnostic().unwrap());
    assert_eq!(m1.scores(&x), m2.scores(&x));
}
