//! What the baselines' trial tests share.

use madenet_map::paper::Corner;
use madenet_sim::TrialSpec;
use madenet_world::ScenarioConfig;

/// A trial of `policy` on the generated map of `seed` (side × side), `robots` robots from the
/// bottom-left start cells, CSP `csp`, the trial seed `seed`.
pub fn spec(seed: u64, side: usize, robots: usize, csp: f64, policy: &str) -> TrialSpec {
    let map = madenet_map::generate::generate(
        &madenet_map::generate::GeneratorConfig::for_size(side, side),
        seed,
    )
    .unwrap();
    TrialSpec {
        starts: Corner::BottomLeft.start_cells(side, side)[..robots].to_vec(),
        map,
        map_name: format!("generate:{seed}"),
        config: ScenarioConfig {
            num_robots: robots,
            comm_success_prob: csp,
            ..ScenarioConfig::default()
        },
        policy: policy.into(),
        seed,
    }
}
