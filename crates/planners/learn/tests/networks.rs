//! The networks: layer shapes, parameter counts (by hand), output sizes, masked and conditional
//! action selection, joint indices, sequence forward = stepped `act`, and one Adam step.

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::Distribution;
use madenet_learn::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

fn conv(k: usize, cin: usize, cout: usize) -> usize {
    k * k * cin * cout + cout
}
fn linear(i: usize, o: usize) -> usize {
    i * o + o
}
/// burn's LSTM: per gate an input Linear (in·h + h) and a hidden Linear (h·h + h) — two biases.
fn lstm(i: usize, h: usize) -> usize {
    4 * (i * h + h + h * h + h)
}

fn rand_inputs(cfg: &NetConfig, b: usize, t: usize, device: &Device) -> (Tensor<5>, Tensor<3>) {
    let maps = Tensor::<5>::random(
        [b, t, cfg.map_channels, cfg.map_height, cfg.map_width],
        Distribution::Bernoulli(0.5),
        device,
    );
    let obs = Tensor::<3>::random([b, t, cfg.obs_dim], Distribution::Uniform(0.0, 1.0), device);
    (maps, obs)
}

fn host(t: Tensor<2>) -> Vec<f32> {
    t.into_data().try_into_vec_as::<f32>().unwrap()
}

fn shapes(net: &QNet, cfg: &NetConfig, b: usize, t: usize) -> Vec<(&'static str, Vec<usize>)> {
    let (maps, obs) = rand_inputs(cfg, b, t, &cpu());
    net.trace(maps, obs)
        .into_iter()
        .map(|s| (s.layer, s.dims))
        .collect()
}

#[test]
fn defaults_are_the_papers() {
    let cep = NetConfig::cep(20, 20, 3, 4);
    let dep = NetConfig::dep(20, 20, 3, 4);
    assert_eq!((cep.outputs, dep.outputs), (64, 4));
    assert_eq!((cep.width, dep.width), (128, 64));
    assert_eq!(
        obs_dim_for(3, 4),
        2 + 1 + 2 * (2 + 2 + 2 + 1 + 1) + 4 * 2 + 4
    );
    assert_eq!(obs_dim_for(3, 4), 31);
    assert_eq!((cep.obs_dim, dep.obs_dim), (93, 31));
    assert_eq!(cep.c1, ConvSpec::new(4, 2, 8));
    assert_eq!(cep.c2, ConvSpec::new(3, 2, 16));
    assert_eq!(cep.c3, ConvSpec::new(2, 2, 16));
    assert_eq!((cep.f1, cep.f2, cep.lstm_hidden), (32, 10, 64));
    // Built networks really have those output sizes.
    let (q, _) = cep.init(&cpu()).unwrap().act(
        Tensor::zeros([1, 4, 20, 20], &cpu()),
        Tensor::zeros([1, 93], &cpu()),
        None,
    );
    assert_eq!(q.dims(), [1, 64]);
    let (q, _) = dep.init(&cpu()).unwrap().act(
        Tensor::zeros([1, 4, 20, 20], &cpu()),
        Tensor::zeros([1, 31], &cpu()),
        None,
    );
    assert_eq!(q.dims(), [1, 4]);
}

#[test]
fn layer_shapes_cep_20x20() {
    let cfg = NetConfig::cep(20, 20, 3, 4);
    let net = cfg.init(&cpu()).unwrap();
    let n = 2 * 3;
    let expected: Vec<(&str, Vec<usize>)> = vec![
        ("C1", vec![n, 8, 9, 9]),
        ("C2", vec![n, 16, 4, 4]),
        ("C3", vec![n, 16, 2, 2]),
        ("F1", vec![n, 32]),
        ("F2", vec![n, 10]),
        ("F3", vec![n, 128]),
        ("CONCAT", vec![n, 138]),
        ("F4", vec![n, 128]),
        ("LSTM", vec![2, 3, 64]),
        ("F5", vec![2, 3, 128]),
        ("F6", vec![2, 3, 64]),
    ];
    assert_eq!(shapes(&net, &cfg, 2, 3), expected);
}

#[test]
fn layer_shapes_dep_20x20_and_30x30() {
    let cfg = NetConfig::dep(20, 20, 3, 4);
    let net = cfg.init(&cpu()).unwrap();
    let got = shapes(&net, &cfg, 2, 3);
    let n = 6;
    assert_eq!(got[2], ("C3", vec![n, 16, 2, 2]));
    assert_eq!(got[5], ("F3", vec![n, 64]));
    assert_eq!(got[6], ("CONCAT", vec![n, 74]));
    assert_eq!(got[10], ("F6", vec![2, 3, 4]));

    let cfg = NetConfig::dep(30, 30, 3, 4);
    let net = cfg.init(&cpu()).unwrap();
    let expected: Vec<(&str, Vec<usize>)> = vec![
        ("C1", vec![n, 8, 14, 14]),
        ("C2", vec![n, 16, 6, 6]),
        ("C3", vec![n, 16, 3, 3]),
        ("F1", vec![n, 32]),
        ("F2", vec![n, 10]),
        ("F3", vec![n, 64]),
        ("CONCAT", vec![n, 74]),
        ("F4", vec![n, 64]),
        ("LSTM", vec![2, 3, 64]),
        ("F5", vec![2, 3, 64]),
        ("F6", vec![2, 3, 4]),
    ];
    assert_eq!(shapes(&net, &cfg, 2, 3), expected);
}

#[test]
fn layer_shapes_cep_40x60_four_robots_five_goals() {
    let cfg = NetConfig::cep(40, 60, 4, 5);
    assert_eq!(cfg.outputs, 625);
    assert_eq!(cfg.obs_dim, 4 * (3 + 8 * 3 + 15));
    let net = cfg.init(&cpu()).unwrap();
    let got = shapes(&net, &cfg, 1, 2);
    assert_eq!(got[0], ("C1", vec![2, 8, 19, 29]));
    assert_eq!(got[1], ("C2", vec![2, 16, 9, 14]));
    assert_eq!(got[2], ("C3", vec![2, 16, 4, 7]));
    assert_eq!(got[10], ("F6", vec![1, 2, 625]));
    assert_eq!(cfg.mfe_dims().unwrap().flat, 16 * 4 * 7);
}

#[test]
fn param_counts_by_hand() {
    // MFE on 20×20: flatten 16·2·2 = 64.
    let mfe = conv(4, 4, 8) + conv(3, 8, 16) + conv(2, 16, 16) + linear(64, 32) + linear(32, 10);
    assert_eq!(mfe, 520 + 1168 + 1040 + 2080 + 330);

    let cep = NetConfig::cep(20, 20, 3, 4);
    let cep_hand = mfe
        + linear(93, 128) // F3
        + linear(128 + 10, 128) // F4 on the bare CONCAT
        + lstm(128, 64)
        + linear(64, 128) // F5
        + linear(128, 64); // F6
    assert_eq!(cep_hand, 101_202);
    assert_eq!(cep.init(&cpu()).unwrap().num_params(), cep_hand);

    let dep = NetConfig::dep(20, 20, 3, 4);
    let dep_hand =
        mfe + linear(31, 64) + linear(64 + 10, 64) + lstm(64, 64) + linear(64, 64) + linear(64, 4);
    assert_eq!(dep_hand, 49_686);
    assert_eq!(dep.init(&cpu()).unwrap().num_params(), dep_hand);

    // Learned CONCAT: one more width-unit layer, F4 then takes width inputs.
    let cep_fc = cep.clone().with_concat_fc(true);
    let hand = cep_hand - linear(138, 128) + linear(138, 128) + linear(128, 128);
    assert_eq!(cep_fc.init(&cpu()).unwrap().num_params(), hand);

    // Another map size changes only F1: 30×30 → flatten 16·3·3 = 144.
    let dep30 = NetConfig::dep(30, 30, 3, 4);
    assert_eq!(
        dep30.init(&cpu()).unwrap().num_params(),
        dep_hand - linear(64, 32) + linear(144, 32)
    );
}

#[test]
fn map_too_small_is_a_config_error() {
    assert_eq!(NetConfig::dep(20, 20, 3, 4).min_map_side(), MIN_MAP_SIDE);
    assert_eq!(MIN_MAP_SIDE, 12);
    assert!(NetConfig::dep(12, 12, 3, 4).init(&cpu()).is_ok());
    assert!(NetConfig::dep(12, 40, 3, 4).init(&cpu()).is_ok());
    for (h, w) in [(11, 11), (11, 20), (20, 11), (3, 3)] {
        match NetConfig::dep(h, w, 3, 4).init(&cpu()) {
            Err(ConfigError::MapTooSmall { .. }) => {}
            other => panic!("{h}×{w}: expected MapTooSmall, got {other:?}"),
        }
    }
    assert_eq!(
        NetConfig::new(0, 64, 4).init(&cpu()).unwrap_err(),
        ConfigError::Zero("obs_dim")
    );
}

#[test]
fn forward_over_sequence_equals_stepping_act() {
    for cfg in [NetConfig::cep(20, 20, 3, 4), NetConfig::dep(30, 30, 3, 4)] {
        let device = cpu();
        let net = cfg.init(&device).unwrap();
        let (b, t) = (2, 5);
        let (maps, obs) = rand_inputs(&cfg, b, t, &device);
        let (q_seq, final_seq) = net.forward(maps.clone(), obs.clone(), None);
        let mut state = None;
        let mut worst = 0.0f32;
        for step in 0..t {
            let m = maps.clone().narrow(1, step, 1).reshape([
                b,
                cfg.map_channels,
                cfg.map_height,
                cfg.map_width,
            ]);
            let o = obs.clone().narrow(1, step, 1).reshape([b, cfg.obs_dim]);
            let (q, s) = net.act(m, o, state);
            state = Some(s);
            let q_ref = q_seq.clone().narrow(1, step, 1).reshape([b, cfg.outputs]);
            for (x, y) in host(q).iter().zip(host(q_ref)) {
                worst = worst.max((x - y).abs());
            }
        }
        assert!(worst < 1e-5, "forward vs act differ by {worst}");
        let state = state.unwrap();
        for (x, y) in host(state.hidden)
            .iter()
            .zip(host(final_seq.hidden.clone()))
        {
            assert!((x - y).abs() < 1e-5);
        }
        // The state matters: a second sequence started from the carried state differs from one
        // started from zeros (so the test above is not vacuous).
        let (q_zero, _) = net.forward(maps.clone(), obs.clone(), None);
        let (q_carried, _) = net.forward(maps, obs, Some(final_seq));
        let diff = host(q_zero.reshape([b * t, cfg.outputs]))
            .iter()
            .zip(host(q_carried.reshape([b * t, cfg.outputs])))
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
        assert!(diff > 1e-6, "carried LSTM state had no effect");
    }
}

#[test]
fn masked_argmax_never_picks_invalid() {
    let device = cpu();
    let mut rng = Pcg64Mcg::seed_from_u64(7);
    for _ in 0..300 {
        let (b, n) = (rng.random_range(1..6), rng.random_range(1..70));
        // Coarse values so that ties happen; the best valid entries are often masked out.
        let q: Vec<f32> = (0..b * n).map(|_| rng.random_range(-3..4) as f32).collect();
        let mut valid: Vec<bool> = (0..b * n).map(|_| rng.random_range(0..3) == 0).collect();
        for r in 0..b {
            if !valid[r * n..(r + 1) * n].iter().any(|&v| v) {
                valid[r * n + rng.random_range(0..n)] = true;
            }
        }
        let qt = Tensor::<2>::from_data(TensorData::new(q.clone(), [b, n]), &device);
        let picks = masked_argmax(qt.clone(), mask_tensor(&valid, b, n, &device));
        let maxes = host(masked_max(qt, mask_tensor(&valid, b, n, &device)).reshape([b, 1]));
        for r in 0..b {
            let row = &q[r * n..(r + 1) * n];
            let ok = &valid[r * n..(r + 1) * n];
            let best = (0..n)
                .filter(|&k| ok[k])
                .map(|k| row[k])
                .fold(f32::NEG_INFINITY, f32::max);
            assert!(ok[picks[r]], "picked an invalid action");
            assert_eq!(row[picks[r]], best);
            assert_eq!(
                picks[r],
                (0..n).find(|&k| ok[k] && row[k] == best).unwrap(),
                "ties to lowest"
            );
            assert_eq!(maxes[r], best);
        }
    }
    // No valid action: try_ says so, masked_max gives INVALID_Q.
    let q = Tensor::<2>::from_data(TensorData::new(vec![1.0f32, 2.0], [1, 2]), &device);
    assert_eq!(
        try_masked_argmax(q.clone(), mask_tensor(&[false, false], 1, 2, &device)),
        vec![None]
    );
    assert_eq!(
        host(masked_max(q, mask_tensor(&[false, false], 1, 2, &device)).reshape([1, 1])),
        vec![INVALID_Q]
    );
}

#[test]
fn gather_q_picks_entries() {
    let device = cpu();
    let q = Tensor::<2>::from_data(
        TensorData::new(vec![1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0], [2, 3]),
        &device,
    );
    assert_eq!(host(gather_q(q, &[2, 0]).reshape([2, 1])), vec![3.0, 4.0]);
}

#[test]
fn joint_index_round_trip_and_order() {
    // Robot 0 is the least significant digit — the order of the environments and of Python's
    // CentralizedEnv (madenet_agent::joint_encode).
    assert_eq!(joint_index(&[1, 2, 3], 4), 1 + 2 * 4 + 3 * 16);
    assert_eq!(joint_actions(57, 3, 4), vec![1, 2, 3]);
    assert_eq!(
        joint_index(&[1, 2, 3], 4),
        madenet_agent::joint_encode(&[1, 2, 3], 4)
    );
    for (team, goals) in [(1, 4), (3, 4), (2, 7), (4, 5)] {
        let count = joint_action_count(team, goals);
        for index in 0..count {
            let a = joint_actions(index, team, goals);
            assert!(a.iter().all(|&x| x < goals));
            assert_eq!(joint_index(&a, goals), index);
        }
    }
}

#[test]
fn joint_valid_mask_is_product_of_robot_masks() {
    let masks = [
        vec![true, false, true, true],
        vec![false, true, true, true],
        vec![true, true, true, false],
    ];
    let joint = joint_valid_mask(&masks);
    assert_eq!(joint.len(), 64);
    for (index, &ok) in joint.iter().enumerate() {
        let a = joint_actions(index, 3, 4);
        assert_eq!(ok, (0..3).all(|i| masks[i][a[i]]), "index {index}");
    }
    assert_eq!(joint.iter().filter(|&&v| v).count(), 3 * 3 * 3);
}

#[test]
fn conditional_argmax_keeps_running_robots_fixed() {
    // q[k] = k, so the unconstrained best is (3, 3, 3) = 63; two decoys sit at inconsistent
    // indices.
    let mut q: Vec<f32> = (0..64).map(|k| k as f32).collect();
    q[63] = 1000.0; // a0 = 3: inconsistent with robot 0 fixed to 2
    q[joint_index(&[2, 3, 2], 4)] = 500.0; // a1 = 3: invalid for robot 1
    let masks = [
        vec![true, true, false, true], // robot 0's mask says 2 is invalid, but 2 is running
        vec![true, true, false, false],
        vec![true, false, true, false],
    ];
    // Robot 0 running action 2; robots 1, 2 choose: best is a1 = 1, a2 = 2 → 2 + 4 + 2·16.
    let fixed = [Some(2), None, None];
    assert_eq!(conditional_argmax(&q, &masks, &fixed), Some(38));
    // Nobody fixed: robot 0 can't take 2; decoy 63 is (3,3,3) with a1 = 3 invalid → (3, 1, 2).
    assert_eq!(
        conditional_argmax(&q, &masks, &[None, None, None]),
        Some(joint_index(&[3, 1, 2], 4))
    );
    // Everybody fixed: that joint action, whatever its Q.
    assert_eq!(
        conditional_argmax(&q, &masks, &[Some(0), Some(3), Some(3)]),
        Some(joint_index(&[0, 3, 3], 4))
    );
    // Robots 0 and 2 fixed: robot 1 picks its best valid.
    assert_eq!(
        conditional_argmax(&q, &masks, &[Some(1), None, Some(0)]),
        Some(joint_index(&[1, 1, 0], 4))
    );
    // A free robot with no valid candidate: none.
    let dead = [vec![true; 4], vec![false; 4], vec![true; 4]];
    assert_eq!(conditional_argmax(&q, &dead, &[None, None, None]), None);

    // Batched on a tensor agrees.
    let device = cpu();
    let mut q2 = q.clone();
    q2.extend((0..64).map(|k| -(k as f32)));
    let qt = Tensor::<2>::from_data(TensorData::new(q2, [2, 64]), &device);
    let picks = conditional_argmax_batch(
        qt,
        &[masks.to_vec(), masks.to_vec()],
        &[fixed.to_vec(), vec![None, None, Some(3)]],
    );
    // Row 1: q = −k → smallest index with a2 = 3: a0 = 0, a1 = 0 → 3·16 = 48.
    assert_eq!(picks, vec![38, joint_index(&[0, 0, 3], 4)]);
    assert_eq!(picks[1], 48);
}

#[test]
fn one_adam_step_lowers_mse_on_a_fixed_batch() {
    let device = cpu_autodiff();
    device.seed(11);
    for cfg in [NetConfig::cep(20, 20, 3, 4), NetConfig::dep(20, 20, 3, 4)] {
        let mut net = cfg.init(&device).unwrap();
        let (maps, obs) = rand_inputs(&cfg, 4, 6, &device);
        let target = Tensor::<3>::random(
            [4, 6, cfg.outputs],
            Distribution::Uniform(-1.0, 1.0),
            &device,
        );
        let loss_of = |net: &QNet| {
            let (q, _) = net.forward(maps.clone(), obs.clone(), None);
            (q - target.clone()).powi_scalar(2).mean()
        };
        let mut optim = AdamConfig::new().init();
        let loss = loss_of(&net);
        let before: f32 = loss.clone().into_scalar();
        let grads = GradientsParams::from_grads(loss.backward(), &net);
        net = optim.step(1e-3, net, grads);
        let after: f32 = loss_of(&net).into_scalar();
        assert!(after < before, "loss did not fall: {before} → {after}");
    }
}

/// The observation length the networks are built for (`obs_dim_for`, `Observation::dim`) is the
/// length the agent writes from a live view, for several team and candidate counts (a grid
/// model's DEP is built with `Observation::dim`, `Model::load`).
#[test]
fn observation_lengths_match_what_the_agent_writes() {
    use madenet_learn::obs::{robot_obs, Observation};
    use madenet_sim::{MapSource, StartSpec, Trial, TrialSpec};
    for (team, goals) in [(2, 2), (3, 4), (4, 6), (6, 3)] {
        // The layout by hand (Sec. IV): own position (2) and teammate-detected flag ϱ_i (1),
        // per teammate previous goal, position, current goal (2 each), |E_j| and a known flag
        // (8), per candidate its cell (2) and validity (1).
        assert_eq!(obs_dim_for(team, goals), 3 + 8 * (team - 1) + 3 * goals);
        assert_eq!(
            Observation::CandidateFeatures.dim(team, goals),
            obs_dim_for(team, goals) + 9 * goals
        );
        let config = madenet_world::ScenarioConfig {
            num_robots: team,
            goal_count: Some(goals),
            ..Default::default()
        };
        let map = MapSource::Generated(7).load(&config).unwrap();
        let spec = TrialSpec {
            starts: StartSpec::Random.cells(&map, team, config.movement),
            map,
            map_name: "generated_7".into(),
            config: config.clone(),
            policy: "spread".into(),
            seed: 3,
        };
        let mut trial = Trial::new(spec).unwrap();
        for _ in 0..5 {
            trial.step();
        }
        for i in 0..team {
            let mut view = trial.agent_mut(i).view(true);
            assert_eq!(view.candidates().slots, goals);
            assert_eq!(robot_obs(&view).vec.len(), obs_dim_for(team, goals));
            for o in [Observation::Paper, Observation::CandidateFeatures] {
                let v = o.vector(&mut view);
                assert_eq!(
                    v.len(),
                    o.dim(team, goals),
                    "{o:?}, {team} robots, {goals} goals"
                );
                // The validity mask closes the paper's part, where the layout says.
                let paper = obs_dim_for(team, goals);
                let mask: Vec<f32> = view
                    .candidates()
                    .valid_mask()
                    .iter()
                    .map(|&m| m as u8 as f32)
                    .collect();
                assert_eq!(&v[paper - goals..paper], &mask[..], "{o:?}");
            }
        }
    }
}
