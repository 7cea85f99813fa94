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

/// What a sink reads of a grid run's present ([`madenet_sim::stepping::Present`]), for
/// comparing what the in-process run shows with what the world node shows.
#[derive(Clone, Debug, PartialEq)]
struct Seen {
    when: String,
    cells: Vec<madenet_map::Pos>,
    contacts: Vec<(usize, usize)>,
    exchanges: Vec<(usize, usize)>,
    explored: f64,
    distance: f64,
    /// Per robot: goal, path, candidates, decisions.
    robots: Vec<RobotSeen>,
}

type RobotSeen = (
    Option<madenet_map::Pos>,
    Vec<madenet_map::Pos>,
    Vec<madenet_map::Pos>,
    u64,
);

/// Per robot, the candidate its goal was chosen as, where it says (the world node knows only
/// the goal and the candidates, so names the first candidate equal to the goal).
type ChosenSeen = Vec<Option<madenet_map::Pos>>;

fn seen<S: madenet_sim::stepping::Present + ?Sized>(s: &S) -> (Seen, ChosenSeen) {
    let n = s.robots();
    let shown: Vec<_> = (0..n).map(|i| s.robot(i)).collect();
    (
        Seen {
            when: s.when(),
            cells: (0..n).map(|i| s.cell(i)).collect(),
            contacts: s.contacts().to_vec(),
            exchanges: s.exchanges().to_vec(),
            explored: s.explored(),
            distance: s.distance(),
            robots: shown
                .iter()
                .map(|r| (r.goal, r.path.to_vec(), r.candidates.to_vec(), r.decisions))
                .collect(),
        },
        shown
            .iter()
            .map(|r| r.chosen.map(|k| r.candidates[k]))
            .collect(),
    )
}

/// A sink that records what it is shown at the start, after every step and at the end.
#[derive(Default)]
struct Recording(Vec<(&'static str, Seen, ChosenSeen)>);

impl Recording {
    fn push<S: madenet_sim::stepping::Present + ?Sized>(&mut self, what: &'static str, s: &S) {
        let (seen, chosen) = seen(s);
        self.0.push((what, seen, chosen));
    }
}

impl<S: madenet_sim::stepping::Present + ?Sized> madenet_sim::stepping::Sink<S> for Recording {
    fn begin(&mut self, s: &S) -> Result<(), madenet_sim::stepping::SinkError> {
        self.push("begin", s);
        Ok(())
    }
    fn step(
        &mut self,
        s: &S,
    ) -> Result<std::ops::ControlFlow<String>, madenet_sim::stepping::SinkError> {
        self.push("step", s);
        Ok(std::ops::ControlFlow::Continue(()))
    }
    fn finish(&mut self, s: &S) -> Result<Vec<String>, madenet_sim::stepping::SinkError> {
        self.push("finish", s);
        Ok(Vec::new())
    }
}

/// The world node, its radio and robots on threads over [`ChannelBus`], showing: what it shows
/// (before the first timestep, after each and at the end, as a run loop's sink is shown it),
/// its result and what the radio sent.
fn world_node_shows(
    s: &TrialSpec,
) -> (
    Recording,
    madenet_runtime::LockstepResult,
    madenet_runtime::Traffic,
) {
    use madenet_runtime::transport::ChannelBus;
    use madenet_runtime::wire::Shown;
    use madenet_runtime::{nodes_of, run_ground_with, run_radio, run_robot, Timeouts};
    use madenet_sim::stepping::{Sink, WorldView};
    let n = s.starts.len();
    let radio = madenet_world::Radio::new(&s.config, n, s.seed);
    let (mut world, agents) = madenet_sim::build(s.clone(), &REGISTRY).unwrap();
    world.detach_radio();
    let timeouts = Timeouts::new(Duration::from_secs(30));
    let mut buses = ChannelBus::connect(&nodes_of(n)).into_iter();
    let (world_bus, radio_bus) = (buses.next().unwrap(), buses.next().unwrap());
    let mut rec = Recording::default();
    let mut started = false;
    let mut show = |w: &madenet_world::World, shown: &[Shown], links: &[(usize, usize)]| {
        let view = WorldView {
            world: w,
            robots: shown.iter().map(Shown::view).collect(),
            exchanges: links,
        };
        if std::mem::replace(&mut started, true) {
            assert!(rec.step(&view).unwrap().is_continue());
        } else {
            rec.begin(&view).unwrap();
        }
    };
    let (result, radio_sent, between) = std::thread::scope(|sc| {
        let radio = sc.spawn(move || run_radio(radio, n, radio_bus, timeouts));
        let robots: Vec<_> = agents
            .into_iter()
            .zip(buses)
            .map(|(agent, bus)| sc.spawn(move || run_robot(agent, bus, timeouts)))
            .collect();
        let result = run_ground_with(world, world_bus, timeouts, None, Some(&mut show), |_, _| {
            std::ops::ControlFlow::Continue(())
        })
        .unwrap();
        let between: usize = robots
            .into_iter()
            .map(|r| r.join().unwrap().unwrap().1.messages)
            .sum();
        (result, radio.join().unwrap().unwrap(), between)
    });
    // The end is the last state shown.
    let (_, last, chosen) = rec.0.last().cloned().expect("something was shown");
    rec.0.push(("finish", last, chosen));
    let mut result = result;
    result.between_robots.messages = between;
    (rec, result, radio_sent)
}

#[test]
fn world_node_shows_what_the_in_process_run_shows() {
    for policy in ["nf", "made-net"] {
        for (map, corner) in [(3, Corner::TopRight), (8, Corner::BottomLeft)] {
            for csp in [0.5, 1.0] {
                let case = format!("{policy} map {map} {corner:?} csp {csp}");
                let s = spec(map, corner, policy, csp, 1);
                let mut trial = Trial::with_registry(s.clone(), &REGISTRY).unwrap();
                let mut together = Recording::default();
                let end = madenet_sim::stepping::run(&mut trial, &mut [&mut together]).unwrap();
                assert!(end.stopped.is_none(), "{case}");
                let metrics = madenet_sim::stepping::Stepping::finish(trial).metrics;
                let (apart, result, radio_sent) = world_node_shows(&s);
                assert_eq!(result.metrics, metrics, "{case}");
                let steps = metrics.tns;
                assert_eq!(together.0.len(), steps + 2, "{case}");
                assert_eq!(apart.0.len(), together.0.len(), "{case}: shown as often");
                let mut compared = 0;
                for (k, (a, t)) in apart.0.iter().zip(&together.0).enumerate() {
                    assert_eq!(a.0, t.0, "{case}: call {k}");
                    assert_eq!(a.1, t.1, "{case}: {} {k}", t.0);
                    // The chosen candidate where the in-process agent names one and it is its
                    // goal (a decision that named a cell has none).
                    for (i, (ca, ct)) in a.2.iter().zip(&t.2).enumerate() {
                        if ct.is_some() && *ct == t.1.robots[i].0 {
                            assert_eq!(ca, ct, "{case}: {} {k}, robot {i}'s choice", t.0);
                            compared += 1;
                        }
                    }
                }
                assert!(
                    policy == "nf" || compared > 0,
                    "{case}: some choices compared"
                );
                // One radio round per timestep and one for the last picture: n links and the
                // exchanges to the world per round, and the robots' messages forwarded.
                let n = s.starts.len();
                assert_eq!(
                    radio_sent.messages,
                    result.between_robots.messages + (n + 1) * (steps + 1),
                    "{case}"
                );
            }
        }
    }
}
