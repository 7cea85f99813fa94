//! DME-DRL's network shapes and a critic regression step (fixed batch, MSE falls).

use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Device, Tensor};
use madenet_dme::nets::DmeConfig;

#[test]
fn shapes_and_critic_learns_a_fixed_batch() {
    let device = Device::flex().autodiff();
    device.seed(5);
    let cfg = DmeConfig::new();
    assert_eq!((cfg.robot_channels(), cfg.pose_len()), (12, 6));
    let actor = cfg.actor(&device);
    let b = 8;
    let logits = actor.forward(
        Tensor::<4>::ones([b, 12, 20, 20], &device),
        Tensor::<2>::zeros([b, 6], &device),
    );
    assert_eq!(logits.dims(), [b, 8]);
    let mut critic = cfg.critic(&device);
    let maps = Tensor::<4>::random(
        [b, cfg.team_size * cfg.critic_robot_channels(), 20, 20],
        burn::tensor::Distribution::Uniform(0.0, 1.0),
        &device,
    );
    let actions = Tensor::<2>::random(
        [b, 24],
        burn::tensor::Distribution::Uniform(0.0, 1.0),
        &device,
    );
    let poses = Tensor::<2>::random(
        [b, 18],
        burn::tensor::Distribution::Uniform(-1.0, 1.0),
        &device,
    );
    let target = Tensor::<2>::random(
        [b, 1],
        burn::tensor::Distribution::Uniform(-1.0, 1.0),
        &device,
    );
    assert_eq!(
        critic
            .forward(maps.clone(), actions.clone(), poses.clone())
            .dims(),
        [b, 1]
    );
    let mut optim = AdamConfig::new().init();
    let mut losses = Vec::new();
    for _ in 0..30 {
        let q = critic.forward(maps.clone(), actions.clone(), poses.clone());
        let loss = (q - target.clone()).powf_scalar(2.0).mean();
        losses.push(loss.clone().into_data().try_into_vec_as::<f32>().unwrap()[0]);
        let grads = GradientsParams::from_grads(loss.backward(), &critic);
        critic = optim.step(1e-3, critic, grads);
    }
    assert!(
        losses.last().unwrap() < &(0.5 * losses[0]),
        "critic loss {:?} → {:?}",
        losses[0],
        losses.last()
    );
}
