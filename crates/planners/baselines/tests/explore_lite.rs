//! `explore-lite`: explore_lite's choice on whole trials — it explores floor plans to the end,
//! repeats for a seed, waits for a map before it plans, and stops for good when nothing is
//! left, as explore_lite does.

use madenet_agent::{Decision, Policy, ViewScratch};
use madenet_baselines::{ExploreLite, ExploreLiteParams};
use madenet_sim::{MapSource, Trial, TrialSpec};

fn floor_plan_spec(seed: u64, policy: &str) -> TrialSpec {
    let config = madenet_world::ScenarioConfig::default();
    let map = MapSource::FloorPlan(seed).load(&config).unwrap();
    TrialSpec {
        starts: madenet_map::paper::Corner::TopLeft
            .start_cells(map.height(), map.width())
            .to_vec(),
        map,
        map_name: format!("floorplan:{seed}"),
        config,
        policy: policy.into(),
        seed,
    }
}

#[test]
fn it_explores_floor_plans_to_the_end_and_repeats_for_a_seed() {
    let registry = madenet_baselines::registry();
    for seed in [1, 2, 3] {
        let run = || {
            Trial::with_registry(floor_plan_spec(seed, "explore-lite"), &registry)
                .unwrap()
                .run()
        };
        let r = run();
        assert!(r.metrics.completed, "floorplan:{seed}: {:?}", r.metrics);
        assert_eq!(run().metrics, r.metrics, "floorplan:{seed}");
    }
}

/// Before the robot's first reading it waits; on a map with nothing left to explore it
/// stops, and stays stopped.
#[test]
fn it_waits_for_a_map_and_stops_for_good_when_nothing_is_left() {
    use madenet_agent::{Agent, AgentConfig};
    use madenet_map::{Occupancy, Pos};
    let cfg = madenet_world::ScenarioConfig::default();
    let start = Pos::new(1, 1);
    let mut agent = Agent::new(
        AgentConfig::from_scenario(&cfg, 0, 4, 4),
        start,
        Box::new(madenet_agent::NearestFrontier),
    );
    let mut scratch = ViewScratch::new(4, 4);
    let mut el = ExploreLite::new(ExploreLiteParams::default(), 1.0);
    // Before any reading: it waits (and is not stopped).
    assert_eq!(
        el.decide(&mut agent.peek_view(false, &mut scratch)),
        Decision::Idle
    );
    // It reads a 2 × 2 room walled in: no frontier, so it stops, and stays stopped.
    let seen = (0..4)
        .flat_map(|r| (0..4).map(move |c| Pos::new(r, c)))
        .map(|p| {
            let inside = (1..=2).contains(&p.row) && (1..=2).contains(&p.col);
            (
                p,
                if inside {
                    Occupancy::Free
                } else {
                    Occupancy::Obstacle
                },
            )
        })
        .collect();
    agent.observe(&madenet_world::Observation {
        robot: 0,
        t: 0,
        pos: start,
        seen,
        teammates: Vec::new(),
        exchanged_with: Vec::new(),
    });
    let mut view = agent.peek_view(false, &mut scratch);
    assert_eq!(el.decide(&mut view), Decision::Idle);
    // A fresh one on a map with a frontier goes there; the stopped one does not.
    let mut open = Agent::new(
        AgentConfig::from_scenario(&cfg, 0, 4, 4),
        start,
        Box::new(madenet_agent::NearestFrontier),
    );
    open.observe(&madenet_world::Observation {
        robot: 0,
        t: 0,
        pos: start,
        seen: vec![
            (start, Occupancy::Free),
            (Pos::new(1, 2), Occupancy::Free),
            (Pos::new(2, 1), Occupancy::Free),
        ],
        teammates: Vec::new(),
        exchanged_with: Vec::new(),
    });
    let mut view = open.peek_view(false, &mut scratch);
    assert!(matches!(
        ExploreLite::new(ExploreLiteParams::default(), 1.0).decide(&mut view),
        Decision::Goal(_)
    ));
    assert_eq!(el.decide(&mut view), Decision::Idle);
}

#[test]
fn bad_parameters_are_named() {
    let bad = ExploreLiteParams {
        planner_frequency: 0.0,
        ..Default::default()
    };
    let e = bad.validate().unwrap_err();
    assert!(e.contains("explore_lite.planner_frequency"), "{e}");
    let bad = ExploreLiteParams {
        gain_scale: f64::NAN,
        ..Default::default()
    };
    assert!(bad.validate().unwrap_err().contains("gain_scale"));
    assert!(ExploreLiteParams::default().validate().is_ok());
}
