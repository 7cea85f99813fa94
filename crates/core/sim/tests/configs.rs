//! Any scenario config either validates or is refused with a message naming its field, and a
//! config that validates runs whole trials without a panic: the bounds in `validate` are what
//! keep every size a user can type finite (the fuzz target `scenario_toml` does the same from
//! TOML text).

use madenet_map::paper::paper_map;
use madenet_sim::{StartSpec, Trial, TrialSpec};
use madenet_world::{CandidateRule, ScenarioConfig, MAX_PLAN_HORIZON, MAX_SENSING_RANGE};
use proptest::prelude::*;

/// Probabilities in and out of [0, 1], with the special floats.
fn prob() -> impl Strategy<Value = f64> {
    prop_oneof![
        24 => 0.0..=1.0f64,
        1 => -2.0..3.0f64,
        1 => prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(-0.0), Just(1.0 + 1e-12)],
    ]
}

/// Sizes a user might type: small (run), or past any bound (must be refused).
fn size(small: std::ops::Range<usize>, bound: usize) -> impl Strategy<Value = usize> {
    prop_oneof![12 => small, 1 => bound + 1..usize::MAX]
}

prop_compose! {
    fn config()(
        num_robots in size(0..12, madenet_world::MAX_ROBOTS),
        sensing_range in prop_oneof![12 => 0..=12i32, 1 => MAX_SENSING_RANGE + 1..=i32::MAX],
        sensor_miss_prob in prob(),
        motion_success_prob in prob(),
        corner in any::<bool>(),
        slip_when_staying in any::<bool>(),
        comm_success_prob in prob(),
        dropout_steps in prop_oneof![0..20u32, Just(u32::MAX)],
        step_cap in size(0..150, madenet_world::MAX_STEP_CAP),
        cell_size in prop_oneof![8 => Just(1.0), 2 => Just(2.0), 1 => Just(1.5), 1 => Just(0.0), 1 => Just(-1.0), 1 => Just(f64::NAN)],
        goal_count in prop_oneof![Just(None), (0..10usize).prop_map(Some), Just(Some(usize::MAX))],
        nearest in any::<bool>(),
        prioritized_planning in any::<bool>(),
        plan_horizon in size(0..40, MAX_PLAN_HORIZON),
        occupied_prob in prob(),
        obstacle_fraction in prob(),
    ) -> ScenarioConfig {
        let mut c = ScenarioConfig {
            num_robots,
            sensing_range,
            sensor_miss_prob,
            motion_success_prob,
            slip_when_staying,
            comm_success_prob,
            dropout_steps,
            step_cap,
            cell_size,
            goal_count,
            prioritized_planning,
            plan_horizon,
            ..ScenarioConfig::default()
        };
        if corner {
            c.movement = madenet_map::Movement::NoCornerCutting;
        }
        if nearest {
            c.candidate_rule = CandidateRule::NearestClusters;
        }
        c.discretize.occupied_prob = occupied_prob;
        c.discretize.obstacle_fraction = obstacle_fraction;
        c
    }
}

/// The TOML field names a refusal may name.
const FIELDS: [&str; 17] = [
    "num_robots",
    "sensing_range",
    "sensor_miss_prob",
    "motion_success_prob",
    "movement",
    "slip_when_staying",
    "comm_success_prob",
    "dropout_steps",
    "step_cap",
    "cell_size",
    "goal_count",
    "candidate_rule",
    "prioritized_planning",
    "plan_horizon",
    "discretize",
    "occupied_prob",
    "obstacle_fraction",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn a_config_validates_and_runs_or_is_refused_naming_its_field(
        cfg in config(),
        policy in prop_oneof![Just("nf"), Just("spread"), Just("random")],
        seed in any::<u64>(),
    ) {
        match cfg.validate() {
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(FIELDS.iter().any(|f| msg.contains(f)), "no field named: {msg}");
            }
            Ok(()) => {
                // Within every bound: whole trials run, on a paper map read at the cell size.
                let grid = madenet_sim::MapSource::Paper(1 + (seed % 10) as usize)
                    .load(&cfg);
                let Ok(grid) = grid else {
                    // Only a cell size that is not a whole number of metres is refused here.
                    prop_assert!(cfg.cell_size.fract() != 0.0);
                    return Ok(());
                };
                let starts = StartSpec::Random.cells(&grid, cfg.num_robots, cfg.movement);
                if starts.len() < cfg.num_robots {
                    return Ok(()); // no room for this team on this map: refused by `run`
                }
                let spec = TrialSpec {
                    map: grid,
                    map_name: "paper".into(),
                    starts,
                    config: cfg.clone(),
                    policy: policy.to_string(),
                    seed,
                };
                let result = Trial::new(spec).expect("a validated config builds its trial").run();
                prop_assert!(result.metrics.tns <= cfg.step_cap);
                prop_assert!((0.0..=1.0).contains(&result.metrics.explored));
            }
        }
    }
}

#[test]
fn paper_map_one_is_what_the_property_runs_on() {
    // The property reads paper maps through MapSource; check it is the paper's grid at 1 m.
    let grid = madenet_sim::MapSource::Paper(1)
        .load(&ScenarioConfig::default())
        .unwrap();
    assert_eq!(grid, paper_map(1).unwrap());
}
