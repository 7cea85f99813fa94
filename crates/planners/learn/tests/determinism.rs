//! Same seed ⇒ same network. burn's `flex` device draws every random tensor from one
//! process-wide RNG set by `Device::seed`, so this is the only test in its binary (tests in one
//! binary run on parallel threads and would interleave their draws).

use madenet_learn::{cpu, cpu_autodiff, Device, NetConfig, Tensor};

fn q_after_seed(device: &Device, seed: u64) -> Vec<f32> {
    device.seed(seed);
    let cfg = NetConfig::cep(20, 20, 3, 4);
    let net = cfg.init(device).unwrap();
    let maps = Tensor::<4>::ones([1, 4, 20, 20], device);
    let obs = Tensor::<2>::ones([1, cfg.obs_dim], device);
    let (q, _) = net.act(maps, obs, None);
    q.into_data().try_into_vec_as::<f32>().unwrap()
}

#[test]
fn same_seed_same_network() {
    for device in [cpu(), cpu_autodiff()] {
        let a = q_after_seed(&device, 42);
        let b = q_after_seed(&device, 42);
        let c = q_after_seed(&device, 43);
        assert_eq!(a, b, "same seed gave different Q values");
        assert_ne!(a, c, "different seeds gave the same Q values");
    }
}
