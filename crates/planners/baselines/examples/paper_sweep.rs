//! The 40 trials of one CSP (10 paper maps × 4 corners) in one process, with their means and
//! wall time — the quickest way to profile a change (`valgrind --tool=callgrind`):
//!
//! ```sh
//! cargo run --release -p madenet-baselines --example paper_sweep -- [CSP] [POLICY] [SEED]
//! ```

use madenet_baselines::registry;
use madenet_map::paper::{paper_map, Corner, PAPER_MAP_COUNT};
use madenet_sim::{Trial, TrialSpec};
use madenet_world::ScenarioConfig;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let csp: f64 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(1.0);
    let policy = args.get(2).cloned().unwrap_or_else(|| "nf".into());
    let seed: u64 = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(1);
    let config = ScenarioConfig {
        comm_success_prob: csp,
        ..Default::default()
    };
    let mut specs = Vec::new();
    for n in 1..=PAPER_MAP_COUNT {
        let map = paper_map(n)?;
        for corner in Corner::ALL {
            let starts = corner.start_cells(map.height(), map.width()).to_vec();
            specs.push(TrialSpec {
                map: map.clone(),
                map_name: format!("test_{n}"),
                starts,
                config: config.clone(),
                policy: policy.clone(),
                seed,
            });
        }
    }
    let registry = registry();
    let started = std::time::Instant::now();
    let results = specs
        .into_iter()
        .map(|s| Ok(Trial::with_registry(s, &registry)?.run()))
        .collect::<Result<Vec<_>, madenet_sim::SimError>>()?;
    let elapsed = started.elapsed();
    let n = results.len() as f64;
    let mean = |f: &dyn Fn(&madenet_metrics::TrialMetrics) -> f64| {
        results.iter().map(|r| f(&r.metrics)).sum::<f64>() / n
    };
    println!(
        "{} trials ({policy}, CSP {csp}) in {:.1} ms: TNS {:.1}  TTD {:.1} m  NOLI {:.1}  OFV {:.1}  completed {}",
        results.len(),
        elapsed.as_secs_f64() * 1e3,
        mean(&|m| m.tns as f64),
        mean(&|m| m.ttd),
        mean(&|m| m.noli as f64),
        mean(&|m| m.ofv),
        results.iter().filter(|r| r.metrics.completed).count()
    );
    Ok(())
}
