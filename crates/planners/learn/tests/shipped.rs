//! The shipped models load, play a paper map to completion, and refuse scenarios they were not
//! built for with a message naming the mismatch — but for the agnostic model, which plays them.

use madenet_map::paper::Corner;
use madenet_sim::{PolicyRegistry, SimError, Trial, TrialSpec};
use madenet_world::ScenarioConfig;

#[test]
fn shipped_models_play_and_refuse_other_sizes() {
    let mut registry = PolicyRegistry::builtin();
    madenet_learn::shipped::register(&mut registry);
    for name in madenet_learn::shipped::names() {
        let map = madenet_map::paper::paper_map(3).unwrap();
        let spec = TrialSpec {
            starts: Corner::TopLeft
                .start_cells(map.height(), map.width())
                .to_vec(),
            map,
            map_name: "test_3".into(),
            config: ScenarioConfig::default(),
            policy: name.into(),
            seed: 1,
        };
        let r = Trial::with_registry(spec.clone(), &registry).unwrap().run();
        assert!(r.metrics.completed, "{name} did not complete paper map 3");
        // Four robots: the model was built for three.
        let four = TrialSpec {
            starts: vec![
                madenet_map::Pos::new(0, 0),
                madenet_map::Pos::new(0, 1),
                madenet_map::Pos::new(1, 0),
                madenet_map::Pos::new(1, 1),
            ],
            config: ScenarioConfig {
                num_robots: 4,
                ..ScenarioConfig::default()
            },
            ..spec
        };
        let agnostic = madenet_learn::shipped::model(name)
            .unwrap()
            .agnostic()
            .is_some();
        let four = if agnostic {
            // Four free cells next to each other (the corner block above holds an obstacle).
            let starts =
                madenet_map::generate::random_starts(&four.map, 4, Default::default(), 1).unwrap();
            TrialSpec { starts, ..four }
        } else {
            four
        };
        match Trial::with_registry(four, &registry) {
            Err(e @ SimError::PolicyUnavailable { .. }) if !agnostic => {
                assert!(e.to_string().contains("3 robots"), "{e}")
            }
            Err(e) => panic!("{name}: unexpected error {e}"),
            // The agnostic model plays any team: four robots explore the map too.
            Ok(t) if agnostic => assert!(t.run().metrics.completed, "{name} with 4 robots"),
            Ok(_) => panic!("{name} accepted 4 robots"),
        }
    }
    assert!(madenet_learn::shipped::model("nope").is_err());
}
