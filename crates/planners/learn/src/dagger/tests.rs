//! Unit tests of the learner.

use super::{collector::*, config::*, student::*, teacher::*};

use crate::agnostic::CONTEXT_FEATURES;
use burn::optim::{AdamConfig, ModuleOptimizer};
use burn::tensor::{Tensor, TensorData};
use madenet_agent::{AgentView, Decision};
use madenet_world::rng::stream;
use rand::RngExt;

/// `spread_label_corr` reads `spread`'s score (and negates it: lower is better there): spread
/// scores 0.1, 0.2, 0.3 against advantages 1, 0, −1 correlate exactly 1, while `spread`'s
/// choice flag (1, 0, 0 here) would correlate only 0.87; the empty slot 3 is not counted.
#[test]
fn spread_label_corr_reads_the_spread_score_negated() {
    let cfg = RolloutTrainConfig {
        network: Network::Agnostic,
        ..RolloutTrainConfig::default()
    };
    let net = Student::init(&cfg, &crate::cpu_autodiff()).unwrap();
    let (slots, s) = (4, cfg.agnostic().crop_side());
    let mut vec = vec![0.0f32; CONTEXT_FEATURES + slots * crate::agnostic::CANDIDATE_INPUTS];
    for (k, score) in [0.1f32, 0.2, 0.3].into_iter().enumerate() {
        let f = &mut vec[CONTEXT_FEATURES + k * crate::agnostic::CANDIDATE_INPUTS..];
        f[AgentView::SPREAD_SCORE_FEATURE] = score;
        f[AgentView::SPREAD_CHOICE_FEATURE] = (k == 0) as u8 as f32;
    }
    let l = Labelled {
        map: vec![0; (slots * crate::agnostic::CROP_CHANNELS * s * s).div_ceil(64)],
        vec,
        train_mask: vec![true, true, true, false],
        target: vec![1.0, 0.0, -1.0, 0.0],
    };
    let fit = net.imitation(std::iter::once(&l), &[0.5]);
    assert!(
        (fit.spread_label_corr.unwrap() - 1.0).abs() < 1e-9,
        "{fit:?}"
    );
    assert!(fit.label_corr.is_some_and(|c| (-1.0..=1.0).contains(&c)));
    // `spread` chose the best candidate here: nothing to gain, whatever the student does.
    assert_eq!(fit.teacher_label_gain, Some(0.0));
    assert_eq!(fit.student_gains.len(), 2);
    assert!(fit.student_gains.iter().all(|g| g.1 <= 0.0), "{fit:?}");
}

/// `label_norm = "side"` scales an episode's advantages by `map_height` / its side and
/// changes nothing else: the same decisions, valid slots and (scaled) values.
#[test]
fn side_label_norm_scales_a_larger_maps_labels_by_its_side() {
    let plain = RolloutTrainConfig {
        network: Network::Agnostic,
        map_side_max: 30,
        label_prob: 0.3,
        ..RolloutTrainConfig::default()
    };
    let side = |e: u64| episode_spec(&plain, "train", e, 30).unwrap().map.height();
    let e = (0..50).find(|&e| side(e) >= 26).unwrap();
    let req = CollectRequest {
        version: env!("CARGO_PKG_VERSION").into(),
        episodes: vec![e],
        side_max: 30,
        student: None,
        base: None,
    };
    let normed = RolloutTrainConfig {
        label_norm: LabelNorm::Side,
        ..plain.clone()
    };
    let run = |cfg: &RolloutTrainConfig| collect(cfg, &req, &|| false).unwrap().unwrap();
    let (a, b) = (run(&plain), run(&normed));
    let factor = 20.0 / side(e) as f32;
    let (mut nonzero, mut decisions) = (0, 0);
    for (ra, rb) in a[0].robots.iter().zip(&b[0].robots) {
        assert_eq!(ra.len(), rb.len());
        for (la, lb) in ra.iter().zip(rb) {
            assert_eq!((&la.vec, &la.train_mask), (&lb.vec, &lb.train_mask));
            for (ta, tb) in la.target.iter().zip(&lb.target) {
                // One rounding apart: `label_scale` and the factor are multiplied first.
                assert!((*tb - *ta * factor).abs() <= 1e-6 * ta.abs(), "{ta} {tb}");
                nonzero += (*ta != 0.0) as usize;
            }
            decisions += 1;
        }
    }
    assert!(decisions > 0 && nonzero > 0, "{decisions} {nonzero}");
}

/// The label gains by hand: `spread` chose slot 0, the labels prefer slot 1, the scores
/// slot 2; the student's choice follows its margin.
#[test]
fn label_gains_follow_the_margin_by_hand() {
    let slots = 4;
    let width = crate::agnostic::CANDIDATE_INPUTS;
    let mut vec = vec![0.0f32; CONTEXT_FEATURES + slots * width];
    vec[CONTEXT_FEATURES + AgentView::SPREAD_CHOICE_FEATURE] = 1.0;
    let l = Labelled {
        map: Vec::new(),
        vec,
        train_mask: vec![true, true, true, false],
        target: vec![0.0, 1.0, -0.5, 0.0],
    };
    // Slot 3 scores highest but is not a candidate.
    let q = [0.0, 0.3, 1.0, 9.0];
    let (teacher, students) = label_gains(&l, &q, &[None, Some(0.5), Some(2.0)]).unwrap();
    assert_eq!(teacher, 1.0);
    // Greedy and margin 0.5 take slot 2 (−0.5 against spread's 0); margin 2 keeps spread's.
    assert_eq!(students, vec![-0.5, -0.5, 0.0]);
    // Without `spread`'s choice among the candidates there is nothing to compare with.
    let mut alone = l.clone();
    alone.train_mask[0] = false;
    assert!(label_gains(&alone, &q, &[None]).is_none());
}

/// Decisions whose advantages are a learnable function of one candidate input (its spread
/// score, centred), drawn from `seed`.
fn learnable(cfg: &RolloutTrainConfig, n: usize, seed: u64) -> Vec<Vec<Labelled>> {
    let mut rng = stream(seed, "test-labels", 0);
    let (slots, side) = (3, cfg.agnostic().crop_side());
    let width = crate::agnostic::CANDIDATE_INPUTS;
    (0..n)
        .map(|_| {
            let mut vec = vec![0.0f32; CONTEXT_FEATURES + slots * width];
            let x: Vec<f32> = (0..slots).map(|_| rng.random::<f32>()).collect();
            for (k, &v) in x.iter().enumerate() {
                vec[CONTEXT_FEATURES + k * width + AgentView::SPREAD_SCORE_FEATURE] = v;
            }
            let mean = x.iter().sum::<f32>() / slots as f32;
            vec![Labelled {
                map: vec![0; (slots * crate::agnostic::CROP_CHANNELS * side * side).div_ceil(64)],
                vec,
                train_mask: vec![true; slots],
                target: x.iter().map(|v| mean - v).collect(),
            }]
        })
        .collect()
}

/// The stopping rule keeps the student it scored best on the held-out labels (its score is
/// the one reported), makes whole rounds (or every update), and without held-out labels
/// fits exactly as many updates as configured.
#[test]
fn the_fit_stopping_rule_keeps_the_best_held_out_student() {
    let cfg = RolloutTrainConfig {
        network: Network::Agnostic,
        updates_per_iteration: 40,
        fit_check_every: 4,
        fit_patience: 1,
        batch_size: 8,
        ..RolloutTrainConfig::default()
    };
    let (train, held_out) = (learnable(&cfg, 60, 1), learnable(&cfg, 30, 2));
    let (start, _) = fresh_student(&cfg, None).unwrap();
    let fresh = || start.clone();
    let adam = || -> ModuleOptimizer { AdamConfig::new().init() };
    let done = fit_checked(fresh(), &mut adam(), &cfg, (&train, &held_out), 0, &|| {
        false
    })
    .unwrap();
    assert!(
        done.updates <= 40 && done.updates.is_multiple_of(4),
        "{}",
        done.updates
    );
    let kept = done
        .net
        .imitation(held_out.iter().flatten(), &[])
        .label_corr;
    assert_eq!(kept, done.holdout_corr);
    // Learnable labels: the kept student ranks held-out candidates as the labels do.
    assert!(kept.unwrap() > 0.0, "{kept:?}");
    // The rule's rounds replayed: the kept score is the best of the rounds made, and the
    // fit ended `fit_patience` rounds after it (or at the end).
    let (mut net, mut optim, mut scores) = (fresh(), adam(), Vec::new());
    for r in 0..done.updates / 4 {
        net = fit(net, &mut optim, &cfg, &train, r * 4..r * 4 + 4, &|| false)
            .unwrap()
            .0;
        scores.push(
            net.imitation(held_out.iter().flatten(), &[])
                .label_corr
                .unwrap(),
        );
    }
    let best = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(Some(best), done.holdout_corr);
    let at = scores.iter().position(|&s| s == best).unwrap();
    assert!(
        at + 1 == scores.len() - 1 || done.updates == 40,
        "{scores:?}"
    );
    let plain = fit_checked(fresh(), &mut adam(), &cfg, (&train, &[]), 0, &|| false).unwrap();
    assert_eq!((plain.updates, plain.holdout_corr), (40, None));
}

/// The labels' check by hand: advantages (1, 0, −1) and (1, −1, 0) correlate 0.5; the
/// first valuation's best (slot 0) is the second's best too; a decision without a valued
/// candidate is not counted.
#[test]
fn label_check_agreement_and_reliability_by_hand() {
    let mut c = LabelCheck::default();
    c.add(
        &[Some(1.0), Some(2.0), Some(3.0), None],
        &[Some(1.0), Some(3.0), Some(2.0), None],
    );
    assert_eq!((c.decisions, c.agree), (1, 1));
    assert!((c.reliability().unwrap() - 0.5).abs() < 1e-12, "{c:?}");
    // A second decision whose best moves: agreement 1 of 2.
    let mut d = LabelCheck::default();
    d.add(&[Some(1.0), Some(2.0)], &[Some(2.0), Some(1.0)]);
    d.add(&[None, None], &[None, None]);
    assert_eq!((d.decisions, d.agree), (1, 0));
    c.merge(&d);
    assert_eq!(c.self_agreement(), Some(0.5));
    assert_eq!(LabelCheck::default().reliability(), None);
}

/// The team teacher's step: the lowest value wins; a tie keeps the robot's current choice,
/// else goes to the lower slot; no valid candidate, no choice.
#[test]
fn best_candidate_keeps_the_current_choice_on_ties() {
    let c = Decision::Candidate;
    let v = [Some(3.0), None, Some(2.0), Some(2.0)];
    assert_eq!(best_candidate(&v, Some(c(0))), Some(c(2)));
    assert_eq!(best_candidate(&v, Some(c(3))), Some(c(3)));
    assert_eq!(best_candidate(&v, None), Some(c(2)));
    assert_eq!(best_candidate(&[None, None], Some(c(1))), None);
}

fn rows(v: &[f32], rows: usize) -> Tensor<2> {
    let cols = v.len() / rows;
    Tensor::<2>::from_data(TensorData::new(v.to_vec(), [rows, cols]), &crate::cpu())
}

fn value(t: Tensor<1>) -> f32 {
    t.into_data().try_to_vec::<f32>().unwrap()[0]
}

/// The listwise loss is lowest where the scores are the labels (up to a shift per row),
/// ignores untrained slots and rows without any, and equals the cross-entropy by hand.
#[test]
fn listwise_loss_ranks_over_trained_slots_only() {
    let tau = 0.5;
    let y = [
        1.0, 0.0, -1.0, 0.0, /* row 2: */ 0.0, 0.5, 0.0, 0.0, /* row 3: */ 0.0, 0.0, 0.0,
        0.0,
    ];
    let m = [1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let loss = |q: &[f32]| value(listwise_loss(rows(q, 3), rows(&y, 3), rows(&m, 3), tau));
    let exact = loss(&[1.0, 0.0, -1.0, 7.0, 3.0, 2.5, 2.0, -9.0, 5.0, 1.0, 2.0, 3.0]);
    // Row 1: softmax of (2, 0, −2); row 2: of (1, 0) over its two trained slots.
    let ce = |z: &[f32]| {
        let s: f32 = z.iter().map(|x| x.exp()).sum();
        -z.iter().map(|x| (x.exp() / s) * (x - s.ln())).sum::<f32>()
    };
    let by_hand = (ce(&[2.0, 0.0, -2.0]) + ce(&[1.0, 0.0])) / 2.0;
    assert!((exact - by_hand).abs() < 1e-4, "{exact} vs {by_hand}");
    let wrong = loss(&[-1.0, 0.0, 1.0, 7.0, 3.0, 2.0, 2.5, -9.0, 5.0, 1.0, 2.0, 3.0]);
    assert!(wrong > exact + 0.5, "{wrong} vs {exact}");
    let flat = loss(&[0.0; 12]);
    assert!(flat > exact, "{flat} vs {exact}");
}
