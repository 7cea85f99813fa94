//! One MADDPG update lowers the critics' TD loss on fixed batches (discounts 0: the targets are
//! the rewards, so the loss each update reports is measured against the same targets), and the
//! actors' soft Gumbel actions respect the masks; soft target updates interpolate.

use burn::tensor::{Device, Tensor, TensorData};
use madenet_dme::maddpg::{gumbel_softmax, soft_update, Batch, Maddpg, UpdateParams};
use madenet_dme::nets::DmeConfig;
use madenet_dme::SECTORS;
use rand::RngExt;

fn fixed_batch(cfg: &DmeConfig, b: usize) -> Batch {
    let mut rng = madenet_world::rng::stream(9, "test/batch", 0);
    let n = cfg.team_size;
    let maps = b * n * cfg.robot_channels() * cfg.map_height * cfg.map_width;
    let mut bits = |len: usize| {
        (0..len)
            .map(|_| (rng.random::<f32>() < 0.3) as u8 as f32)
            .collect::<Vec<f32>>()
    };
    let (m, nm) = (bits(maps), bits(maps));
    let mut rng = madenet_world::rng::stream(9, "test/batch", 1);
    let mut actions = vec![0.0; b * n * SECTORS];
    let mut masks = vec![0.0; b * n * SECTORS];
    for k in 0..b * n {
        actions[k * SECTORS + rng.random_range(0..SECTORS)] = 1.0;
        for a in 0..SECTORS {
            masks[k * SECTORS + a] = (rng.random::<f32>() < 0.6) as u8 as f32;
        }
    }
    Batch {
        size: b,
        maps: m,
        next_maps: nm,
        poses: (0..b * n * cfg.pose_len())
            .map(|_| rng.random::<f32>())
            .collect(),
        next_poses: (0..b * n * cfg.pose_len())
            .map(|_| rng.random::<f32>())
            .collect(),
        next_actions: actions.clone(),
        actions,
        masks: masks.clone(),
        next_masks: masks,
        next_deciding: (0..b * n).map(|k| (k % 2) as f32).collect(),
        rewards: (0..b).map(|_| rng.random::<f32>() - 0.5).collect(),
        discounts: vec![0.0; b],
    }
}

#[test]
fn updates_lower_the_critic_loss_and_actions_respect_masks() {
    let device = Device::flex().autodiff();
    device.seed(11);
    let cfg = DmeConfig::new().with_hidden(64);
    let mut nets = Maddpg::new(&cfg, &device);
    let batches: Vec<Batch> = (0..cfg.team_size).map(|_| fixed_batch(&cfg, 32)).collect();
    let p = UpdateParams {
        tau: 0.01,
        actor_lr: 1e-3,
        critic_lr: 1e-3,
        temperature: 1.0,
        logit_penalty: 1e-3,
    };
    let mut noise = madenet_world::rng::stream(9, "test/noise", 0);
    let losses: Vec<f32> = (0..25)
        .map(|_| nets.update(&batches, &mut noise, &p).critic_loss)
        .collect();
    assert!(losses.iter().all(|l| l.is_finite()));
    assert!(
        losses[1] < losses[0],
        "one update lowers the critic loss: {losses:?}"
    );
    assert!(
        losses[24] < 0.5 * losses[0],
        "critic loss {} → {}",
        losses[0],
        losses[24]
    );

    // Gumbel-softmax: a distribution over the valid sectors, zero where no sector is valid.
    let plain = Device::flex();
    let logits = Tensor::<2>::from_data(
        TensorData::new(vec![3.0f32; 2 * SECTORS], [2, SECTORS]),
        &plain,
    );
    let mask: Vec<f32> = (0..SECTORS)
        .map(|k| (k % 3 == 0) as u8 as f32)
        .chain(std::iter::repeat_n(0.0, SECTORS))
        .collect();
    let mask = Tensor::<2>::from_data(TensorData::new(mask, [2, SECTORS]), &plain);
    let g = Tensor::<2>::from_data(
        TensorData::new(
            (0..2 * SECTORS)
                .map(|k| (k as f32 * 0.37).sin())
                .collect::<Vec<f32>>(),
            [2, SECTORS],
        ),
        &plain,
    );
    let y = gumbel_softmax(logits, mask, g, 1.0)
        .into_data()
        .try_to_vec::<f32>()
        .unwrap();
    let valid: f32 = (0..SECTORS).filter(|k| k % 3 == 0).map(|k| y[k]).sum();
    assert!(
        (valid - 1.0).abs() < 1e-5 && (0..SECTORS).filter(|k| k % 3 != 0).all(|k| y[k] == 0.0),
        "{y:?}"
    );
    assert!(y[SECTORS..].iter().all(|&v| v == 0.0));

    // Soft update: τ = 1 copies the online net, τ → 0 keeps the target.
    let actor = cfg.actor(&plain);
    let other = cfg.actor(&plain);
    let x = Tensor::<4>::ones([1, cfg.robot_channels(), 20, 20], &plain);
    let pose = Tensor::<2>::zeros([1, cfg.pose_len()], &plain);
    let out = |a: &madenet_dme::nets::Actor| {
        a.forward(x.clone(), pose.clone())
            .into_data()
            .try_to_vec::<f32>()
            .unwrap()
    };
    assert_eq!(out(&soft_update(other.clone(), &actor, 1.0)), out(&actor));
    assert_eq!(out(&soft_update(other.clone(), &actor, 0.0)), out(&other));
}
