//! One fixed batch of recorded episodes, many updates: the CEP loss (Eq. 5), the DEP loss
//! (Eq. 6, targets from the CEP) and MADE-Net-DT's loss fall while the target nets stay fixed.
//! Single test: network initialisation draws from burn's process-wide RNG.

use burn::optim::AdamConfig;
use madenet_learn::env::{ActorNets, EnvKind};
use madenet_learn::learner::{cep_update, dep_update, target_of, RobotWindow, Window};
use madenet_learn::{cpu_autodiff, TrainConfig};

mod support {
    pub mod fixture;
}
use support::fixture::{episodes, params};

fn falls(losses: &[f32]) -> bool {
    let first = losses[0];
    let last = *losses.last().unwrap();
    losses.iter().all(|l| l.is_finite()) && last < 0.5 * first
}

#[test]
fn losses_fall_on_a_fixed_batch() {
    let cfg = TrainConfig::default();
    let device = cpu_autodiff();
    device.seed(7);
    let p = params(&cfg);
    let mut cep = cfg.cep_config().init(&device).unwrap();
    let mut dep = cfg.dep_config().init(&device).unwrap();
    let nets = ActorNets {
        cep: Some(target_of(&cep)),
        deps: vec![target_of(&dep)],
    };
    let scenario = madenet_world::ScenarioConfig {
        step_cap: 60,
        ..cfg.scenario.clone()
    };
    let names = ["t", "test-actor"];
    let cen = episodes(
        &cfg,
        &scenario,
        &nets,
        EnvKind::Centralized,
        (100, 3),
        names,
    );
    let dec = episodes(
        &cfg,
        &scenario,
        &nets,
        EnvKind::Decentralized,
        (100, 3),
        names,
    );
    // Episodes are consistent: every decision step is a primitive step with a decision.
    for e in cen.iter().chain(&dec) {
        assert_eq!(e.cep.len(), e.decisions.len());
        assert!(e
            .decisions
            .iter()
            .all(|d| e.steps[d.t].decided.contains(&true)));
        let total: f32 = e.steps.iter().map(|s| s.team_reward).sum();
        assert!((total - e.team_return as f32).abs() < 1e-2 * total.abs().max(1.0));
    }
    let cen_w: Vec<Window<'_>> = cen.iter().map(|e| Window::new(e, 2, 10)).collect();
    let dec_r: Vec<RobotWindow<'_>> = dec
        .iter()
        .flat_map(|e| (0..3).map(move |i| RobotWindow::new(e, i, 0, 10)))
        .collect();
    let dt_r: Vec<RobotWindow<'_>> = dec.iter().map(|e| RobotWindow::new(e, 1, 1, 10)).collect();

    let cep_target = target_of(&cep);
    let mut optim = AdamConfig::new().init();
    let mut losses = Vec::new();
    for _ in 0..40 {
        let (next, loss) = cep_update(cep, &cep_target, &mut optim, &cen_w, &p);
        cep = next;
        losses.push(loss);
    }
    assert!(falls(&losses), "CEP loss did not fall: {:?}", &losses[..3]);

    let dep_target = target_of(&dep);
    let cep_plain = target_of(&cep);
    let mut optim = AdamConfig::new().init();
    let mut losses = Vec::new();
    for _ in 0..40 {
        let (next, loss) = dep_update(dep, &dep_target, &mut optim, Some(&cep_plain), &dec_r, &p);
        dep = next;
        losses.push(loss);
    }
    assert!(falls(&losses), "DEP loss did not fall: {:?}", &losses[..3]);

    // MADE-Net-DT: no CEP; one robot's own net.
    let mut dt = cfg.dep_config().init(&device).unwrap();
    let dt_target = target_of(&dt);
    let mut optim = AdamConfig::new().init();
    let mut losses = Vec::new();
    for _ in 0..40 {
        let (next, loss) = dep_update(dt, &dt_target, &mut optim, None, &dt_r, &p);
        dt = next;
        losses.push(loss);
    }
    assert!(falls(&losses), "DT loss did not fall: {:?}", &losses[..3]);
}
