//! Debugging aid: the greedy CEP of a run (`RUN/last/cep.bpk`) on the validation maps at full
//! communication, against every robot taking goal candidate 0.
//! `cargo run --release -p madenet-learn --example cep_eval -- RUN_DIR`
use burn::module::Module;
use burn::store::ModuleRecord;
use madenet_learn::env::{run_episode, Actor, ActorNets, EnvKind};
use madenet_learn::train::training_scenario;
use madenet_learn::{cpu, TrainConfig};
use madenet_sim::TrialSpec;
use madenet_world::rng::{derive_seed, stream};
use madenet_world::ScenarioConfig;
use std::path::Path;

struct AllFirst;
impl madenet_agent::JointPolicy for AllFirst {
    fn name(&self) -> &str {
        "all-first"
    }
    fn decide(&mut self, views: &mut [madenet_agent::AgentView<'_>], _needs: &[bool], _map: &[madenet_map::Occupancy]) -> Vec<madenet_agent::Decision> {
        views.iter().map(|_| madenet_agent::Decision::Candidate(0)).collect()
    }
}

fn main() {
    let dir = std::env::args().nth(1).expect("run dir");
    let cfg = TrainConfig::from_toml_file(&Path::new(&dir).join("config.toml")).unwrap();
    let rec = ModuleRecord::load(Path::new(&dir).join("last/cep.bpk")).unwrap();
    let cep = cfg.cep_config().init(&cpu()).unwrap().load_record(rec);
    let dep = cfg.dep_config().init(&cpu()).unwrap();
    let nets = ActorNets { cep: Some(cep), deps: vec![dep] };
    let mut total = 0;
    for m in 0..cfg.validation_maps {
        let seed = derive_seed(cfg.seed, "validation", m as u64);
        let (map, starts) = training_scenario(&cfg, seed).unwrap();
        let spec = TrialSpec { map, map_name: "v".into(), starts, config: ScenarioConfig { comm_success_prob: 1.0, ..cfg.scenario.clone() }, policy: String::new(), seed };
        total += madenet_sim::Trial::with_joint_policy(spec, Box::new(AllFirst)).unwrap().run().metrics.tns;
    }
    println!("all-first through the joint path, CSP 1: mean steps {:.1}", total as f64 / cfg.validation_maps as f64);
    for forget in [false, true] {
    let mut steps = 0;
    let mut hist = [0usize; 4];
    for m in 0..cfg.validation_maps {
        let seed = derive_seed(cfg.seed, "validation", m as u64);
        let (map, starts) = training_scenario(&cfg, seed).unwrap();
        let spec = TrialSpec { map, map_name: "v".into(), starts, config: ScenarioConfig { comm_success_prob: 1.0, ..cfg.scenario.clone() }, policy: String::new(), seed };
        let mut actor = Actor::new(EnvKind::Centralized, nets.clone(), 0.0, false, cfg.goals(), 3, stream(seed, "a", 0));
        if forget {
            actor = actor.forgetful();
        }
        let ep = run_episode(spec, actor).unwrap();
        steps += ep.len();
        for d in &ep.decisions {
            for (i, &a) in d.actions.iter().enumerate() {
                if d.decided[i] {
                    hist[a] += 1;
                }
            }
        }
    }
    println!("CEP greedy, CSP 1, zero state each decision {forget}: mean steps {:.1}, decisions per candidate {hist:?}", steps as f64 / cfg.validation_maps as f64);
    }
}
