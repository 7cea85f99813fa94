//! The runtime's nodes, talking only through encoded messages on their own threads, give
//! exactly the in-process trial: the same positions at every timestep and the same metrics.

use madenet_map::paper::{paper_map, Corner};
use madenet_runtime::wire::{Body, Envelope, Node, WireError, PROTOCOL_VERSION};
use madenet_runtime::{run_lockstep, RuntimeError};
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_world::{Move, ScenarioConfig};
use std::sync::LazyLock;
use std::time::Duration;

/// Every shipped method (built-ins, baselines, learned models): the policy catalogue.
static REGISTRY: LazyLock<PolicyRegistry> =
    LazyLock::new(|| madenet_catalogue::shipped().expect("the shipped models load"));

fn spec(map: usize, corner: Corner, policy: &str, csp: f64, seed: u64) -> TrialSpec {
    let grid = paper_map(map).unwrap();
    TrialSpec {
        starts: corner.start_cells(grid.height(), grid.width()).to_vec(),
        map: grid,
        map_name: format!("paper:{map}"),
        config: ScenarioConfig {
            comm_success_prob: csp,
            ..Default::default()
        },
        policy: policy.into(),
        seed,
    }
}

#[test]
fn nodes_over_messages_equal_the_in_process_trial() {
    let mut exchanged = 0;
    let (mut bytes, mut exchanges_total) = (0, 0);
    for policy in ["nf", "made-net", "spread", "pb"] {
        for (map, corner) in [(3, Corner::TopRight), (8, Corner::BottomLeft)] {
            for csp in [1.0, 0.5] {
                for seed in [1, 2] {
                    let s = spec(map, corner, policy, csp, seed);
                    let apart = run_lockstep(s.clone(), &REGISTRY, Duration::from_secs(30))
                        .unwrap_or_else(|e| panic!("{policy} map {map} csp {csp}: {e}"));
                    let together = Trial::with_registry(s, &REGISTRY)
                        .unwrap()
                        .record_trajectory(true)
                        .run();
                    let case = format!("{policy} map {map} {corner:?} csp {csp} seed {seed}");
                    assert_eq!(apart.metrics, together.metrics, "{case}");
                    assert_eq!(apart.positions[0], together.starts, "{case}");
                    assert_eq!(
                        apart.positions.len(),
                        together.trajectory.len() + 1,
                        "{case}"
                    );
                    for (k, r) in together.trajectory.iter().enumerate() {
                        assert_eq!(
                            apart.positions[k + 1],
                            r.positions,
                            "{case}: step {}",
                            k + 1
                        );
                    }
                    let exchanges: usize =
                        together.trajectory.iter().map(|r| r.exchanges.len()).sum();
                    exchanged += exchanges;
                    // Traffic: one observation per robot and one contact list per step plus a
                    // final observation per robot and a stop each from the world; one move per
                    // robot and step, and two β per
                    // exchange, from robots; the radio forwards every robot-to-robot message
                    // (all of them travel along links that are up) and sends links.
                    let (n, steps) = (3, together.trajectory.len());
                    assert_eq!(
                        apart.world_sent.messages,
                        (n + 1) * steps + 2 * n + 1,
                        "{case}"
                    );
                    // Links: one per robot and timestep.
                    assert_eq!(
                        apart.radio_sent.messages,
                        apart.between_robots.messages + n * steps,
                        "{case}"
                    );
                    assert!(apart.between_robots.messages >= 2 * exchanges, "{case}");
                    assert_eq!(
                        apart.robots_sent.messages,
                        n * steps + 2 * n + apart.between_robots.messages,
                        "{case}: a move per robot and step, a hello at the start and a report at the stop"
                    );
                    assert_eq!(apart.absent_robot_steps, 0, "{case}");
                    assert_eq!(apart.timing.decisions, together.timing.decisions, "{case}");
                    // β carries map changes after the first exchange of a pair (at most the 6
                    // pairs' first exchanges carry the whole 400-cell map).
                    if exchanges > 20 {
                        assert!(
                            apart.between_robots.bytes < 2 * exchanges * 400 / 2,
                            "{case}: {} B for {exchanges} exchanges",
                            apart.between_robots.bytes
                        );
                    }
                    bytes += apart.between_robots.bytes;
                    exchanges_total += exchanges;
                }
            }
        }
    }
    eprintln!(
        "robot to robot: {bytes} B for {exchanges_total} exchanges ({:.0} B per exchange)",
        bytes as f64 / exchanges_total as f64
    );
    assert!(
        exchanged > 100,
        "the runs exchanged β ({exchanged} exchanges)"
    );
}

#[test]
fn the_wire_format_round_trips_and_refuses_other_versions() {
    let e = Envelope::new(5, Node::Robot(2), Node::World, Body::Move(Move::Stay));
    let bytes = e.encode();
    assert_eq!(Envelope::decode(&bytes).unwrap(), e);
    // The version is the first field: a future version is named, not misread.
    let mut future = Envelope::new(5, Node::World, Node::Radio, Body::Stop);
    future.version = PROTOCOL_VERSION + 1;
    match Envelope::decode(&future.encode()) {
        Err(WireError::Version { got }) => assert_eq!(got, PROTOCOL_VERSION + 1),
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        Envelope::decode(&bytes[..bytes.len() - 1]),
        Err(WireError::Malformed(_))
    ));
    assert!(matches!(
        Envelope::decode(&[]),
        Err(WireError::Malformed(_))
    ));
}

#[test]
fn a_node_that_hears_nothing_times_out_naming_what_it_waited_for() {
    use madenet_runtime::transport::ChannelBus;
    let s = spec(3, Corner::TopLeft, "nf", 1.0, 1);
    let world = madenet_world::World::new(s.map, &s.starts, s.config, 1).unwrap();
    // Robots that never answer: their endpoints exist but nothing runs behind them.
    let nodes = [
        Node::World,
        Node::Radio,
        Node::Robot(0),
        Node::Robot(1),
        Node::Robot(2),
    ];
    let mut buses = ChannelBus::connect(&nodes).into_iter();
    let world_bus = buses.next().unwrap();
    let _silent: Vec<_> = buses.collect();
    let timeouts = madenet_runtime::Timeouts::new(Duration::from_millis(200));
    let err = madenet_runtime::run_world(world, world_bus, timeouts).unwrap_err();
    match &err {
        RuntimeError::Timeout {
            node, waiting_for, ..
        } => {
            assert_eq!(*node, Node::World);
            assert!(waiting_for.contains("every robot is absent"), "{err}");
        }
        other => panic!("{other}"),
    }
    assert!(
        err.to_string().contains("world") && err.to_string().contains("200ms"),
        "{err}"
    );
}

#[test]
fn nodes_over_zenoh_equal_the_in_process_trial() {
    use madenet_runtime::zenoh_bus::loopback_endpoints;
    use madenet_runtime::{nodes_of, run_threads, ZenohBus};
    // Each node its own Zenoh session on its own loopback port, in one process.
    let base = madenet_runtime::zenoh_bus::free_port_block(5).unwrap();
    for (policy, csp) in [("nf", 0.5), ("made-net", 1.0)] {
        let s = spec(3, Corner::TopRight, policy, csp, 1);
        let run = format!("test-{policy}");
        let buses: Vec<ZenohBus> = nodes_of(3)
            .into_iter()
            .map(|node| {
                let ep = loopback_endpoints(base, 3, node).unwrap();
                ZenohBus::open(&run, node, &ep).unwrap()
            })
            .collect();
        let timeouts = madenet_runtime::Timeouts::new(Duration::from_secs(30));
        let apart = run_threads(s.clone(), &REGISTRY, timeouts, buses)
            .unwrap_or_else(|e| panic!("{policy}: {e}"));
        let together = Trial::with_registry(s, &REGISTRY)
            .unwrap()
            .record_trajectory(true)
            .run();
        assert_eq!(apart.metrics, together.metrics, "{policy}");
        let steps: Vec<_> = together
            .trajectory
            .iter()
            .map(|r| r.positions.clone())
            .collect();
        assert_eq!(apart.positions[1..], steps[..], "{policy}");
        assert!(apart.between_robots.messages > 0, "{policy}: robots talked");
    }
}

#[test]
fn map_changes_fit_only_on_the_map_they_build_on() {
    use madenet_agent::Beta;
    use madenet_map::{Occupancy, Pos};
    use madenet_runtime::wire::{BetaMessage, MapUpdate};
    let (u, f, o) = (Occupancy::Unknown, Occupancy::Free, Occupancy::Obstacle);
    let beta = |t: usize, map: Vec<Occupancy>| Beta {
        from: 1,
        t,
        prev_goal: None,
        pos: Pos::new(0, 0),
        goal: Some(Pos::new(1, 1)),
        map,
        explored: 0,
    };
    let first = beta(3, vec![f, u, u, o]);
    let later = beta(7, vec![f, f, u, o]);
    // No base: the whole map.
    let m = BetaMessage::new(&first, None, false);
    assert_eq!(m.map, MapUpdate::Full(first.map.clone()));
    assert_eq!(m.to_beta(None, 4).unwrap(), (first.clone(), true));
    // On the base: only the changed cell, and merging it is merging the whole map.
    let m = BetaMessage::new(&later, Some((3, &first.map)), false);
    assert_eq!(
        m.map,
        MapUpdate::Changes {
            base: 3,
            cells: vec![(1, f)]
        }
    );
    let (got, fitted) = m.to_beta(Some(3), 4).unwrap();
    assert!(fitted);
    assert_eq!(got.map, vec![u, f, u, u]);
    assert_eq!((got.t, got.goal), (7, later.goal));
    // A receiver that missed the base (heard timestep 2, or nothing) is told it did not fit.
    assert!(!m.to_beta(Some(2), 4).unwrap().1);
    assert!(!m.to_beta(None, 4).unwrap().1);
    // A map of another size is refused, not merged.
    assert!(m.to_beta(Some(3), 1).is_err());
    assert!(BetaMessage::new(&first, None, false)
        .to_beta(None, 9)
        .is_err());
}

#[test]
fn a_robot_refuses_malformed_messages_with_an_error() {
    use madenet_runtime::transport::{ChannelBus, Transport};
    use madenet_runtime::{run_robot, Timeouts};
    use madenet_world::Observation;
    let s = spec(3, Corner::TopLeft, "nf", 1.0, 1);
    let bad_observations = [
        Observation {
            robot: 2, // robot 0's node gets robot 2's observation
            ..Default::default()
        },
        Observation {
            robot: 0,
            pos: madenet_map::Pos::new(25, 3), // outside the 20 × 20 map
            ..Default::default()
        },
        Observation {
            robot: 0,
            teammates: vec![(7, madenet_map::Pos::new(1, 1))], // a team of 3
            ..Default::default()
        },
    ];
    for obs in bad_observations {
        let agent = madenet_sim::build_agent(&s, &REGISTRY, 0).unwrap();
        let nodes = [Node::World, Node::Radio, Node::Robot(0)];
        let mut buses = ChannelBus::connect(&nodes).into_iter();
        let (world, _radio, robot) = (
            buses.next().unwrap(),
            buses.next().unwrap(),
            buses.next().unwrap(),
        );
        let timeouts = Timeouts::new(Duration::from_secs(5));
        let node = std::thread::spawn(move || run_robot(agent, robot, timeouts));
        let e = Envelope::new(
            0,
            Node::World,
            Node::Robot(0),
            Body::Observation(obs.clone()),
        );
        assert!(world.send(Node::Robot(0), e.encode()));
        let err = node.join().expect("no panic").unwrap_err();
        assert!(
            matches!(err, RuntimeError::Unexpected { .. }),
            "{obs:?}: {err}"
        );
    }
}
