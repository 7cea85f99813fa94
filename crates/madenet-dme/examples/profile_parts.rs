use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use madenet_dme::nets::DmeConfig;
use std::time::Instant;
fn main() {
    let cfg = DmeConfig::new();
    let ad = Device::flex().autodiff();
    let plain = Device::flex();
    let critic = cfg.critic(&ad);
    let actor = cfg.actor(&ad);
    let b = 100;
    let c = cfg.team_size * cfg.robot_channels();
    let maps = vec![0.5f32; b * c * 400];
    let t = |d: &Device| Tensor::<4>::from_data(TensorData::new(maps.clone(), [b, c, 20, 20]), d);
    let a = |d: &Device| Tensor::<2>::from_data(TensorData::new(vec![0.1f32; b * 24], [b, 24]), d);
    let p = |d: &Device| Tensor::<2>::from_data(TensorData::new(vec![0.1f32; b * 18], [b, 18]), d);
    let cp = critic.valid();
    for _ in 0..3 {
        let s = Instant::now();
        let _ = cp.forward(t(&plain), a(&plain), p(&plain)).into_data();
        println!("critic plain fwd {:?}", s.elapsed());
        let s = Instant::now();
        let _ = cp.features(t(&plain)).into_data();
        println!("critic plain features {:?}", s.elapsed());
        let s = Instant::now();
        let q = critic.forward(t(&ad), a(&ad), p(&ad));
        let g = q.mean().backward();
        println!("critic ad fwd+bwd {:?}", s.elapsed());
        drop(g);
        let s = Instant::now();
        let x = Tensor::<4>::from_data(TensorData::new(vec![0.5f32; b * 12 * 400], [b, 12, 20, 20]), &ad);
        let l = actor.forward(x, Tensor::<2>::from_data(TensorData::new(vec![0.1f32; b * 6], [b, 6]), &ad));
        let g = l.mean().backward();
        println!("actor ad fwd+bwd {:?}", s.elapsed());
        drop(g);
    }
}
