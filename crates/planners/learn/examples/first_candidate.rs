//! Debugging aid: the "always goal candidate 0" macro policy on the validation set; prints the
//! failing trials' last steps.
use madenet_agent::{AgentView, Decision, Policy};
use madenet_learn::TrainConfig;
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_world::rng::derive_seed;
use madenet_world::ScenarioConfig;

struct First;
impl Policy for First {
    fn name(&self) -> &str {
        "first"
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        if view.candidates().valid_mask()[0] {
            Decision::Candidate(0)
        } else {
            Decision::Idle
        }
    }
}

fn main() {
    let cfg = TrainConfig::default();
    // With `cen FROM TO`: the first-candidate team on the centralized env's training episodes
    // FROM..TO (same maps, starts and seeds, CSP 1), to compare with a run's episodes.csv.
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 4 {
        let (from, to): (u64, u64) = (args[2].parse().unwrap(), args[3].parse().unwrap());
        let mut registry = PolicyRegistry::builtin();
        registry.register("first", "", |_| Box::new(First));
        for e in from..to {
            let seed = derive_seed(cfg.seed, &args[1], e);
            let (map, starts) = cfg.scenario_draw().draw(seed).unwrap();
            let spec = TrialSpec {
                map,
                map_name: "t".into(),
                starts,
                config: cfg.scenario.clone(),
                policy: "first".into(),
                seed,
            };
            let r = Trial::with_registry(spec, &registry).unwrap().run();
            println!("{e} {}", r.metrics.tns);
        }
        return;
    }
    let mut registry = PolicyRegistry::builtin();
    registry.register("first", "", |_| Box::new(First));
    for policy in ["first", "nf"] {
        let (mut steps, mut fails) = (0, 0);
        let mut per_csp = [0usize; 3];
        for m in 0..12 {
            let seed = derive_seed(cfg.seed, "validation", m);
            let (map, starts) = cfg.scenario_draw().draw(seed).unwrap();
            for (k, csp) in [1.0, 0.5, 0.0].into_iter().enumerate() {
                let spec = TrialSpec {
                    map: map.clone(),
                    map_name: "v".into(),
                    starts: starts.clone(),
                    config: ScenarioConfig {
                        comm_success_prob: csp,
                        ..cfg.scenario.clone()
                    },
                    policy: policy.into(),
                    seed,
                };
                let r = Trial::with_registry(spec, &registry)
                    .unwrap()
                    .record_trajectory(true)
                    .run();
                steps += r.metrics.tns;
                per_csp[k] += r.metrics.tns;
                if !r.metrics.completed {
                    fails += 1;
                    if fails <= 2 {
                        println!(
                            "{policy} map {m} csp {csp}: explored {:.3}",
                            r.trajectory.last().unwrap().explored
                        );
                        for s in r.trajectory.iter().rev().take(4) {
                            println!(
                                "  t {} pos {:?} goals {:?} decided {:?} moves {:?}",
                                s.t, s.positions, s.goals, s.decided, s.moves
                            );
                        }
                    }
                }
            }
        }
        println!(
            "{policy}: mean steps {:.1} (CSP 1, 0.5, 0: {:?}), failures {fails}/36",
            steps as f64 / 36.0,
            per_csp.map(|s| s as f64 / 12.0)
        );
    }
}
