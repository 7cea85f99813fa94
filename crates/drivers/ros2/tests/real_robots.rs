//! Real robots in place of `madenet world`: three stand-in robot stacks ([`run_stand_in`]), each
//! its own ROS 2 node that publishes `/robot<i>/map` (what its own sensor has seen) and
//! `/robot<i>/pose`, and moves only when a `/robot<i>/goal_pose` names a free neighbouring cell. The world node stands
//! on [`RealRobots`]; the radio and the three nf agents are the runtime's own nodes. The team
//! explores the whole map through ROS 2 alone.

use madenet_map::paper::{paper_map, Corner};
use madenet_map::Pos;
use madenet_ros2::nav2_sim::{run_nav2_sim, Nav2SimOptions};
use madenet_ros2::{loopback_router, run_stand_in, MapFrame, RealRobots, Ros2Options};
use madenet_runtime::transport::ChannelBus;
use madenet_runtime::{
    nodes_of, run_ground_with, run_radio, run_robot, LockstepResult, RuntimeError, Timeouts,
};
use madenet_sim::{PolicyRegistry, TrialSpec};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Step timeout of every node.
const TIMEOUTS: Duration = Duration::from_secs(10);

/// Inside `s`: the radio and `spec`'s agents (its policy from the built-in registry) on the
/// runtime's own nodes, and the world node on [`RealRobots`] over `opts`, run to the trial's
/// end. A robot held up (a teammate in the cell it was sent to, say) stays after 2 s, as a
/// real robot that did not get there.
fn run_team<'scope>(
    s: &'scope std::thread::Scope<'scope, '_>,
    opts: &Ros2Options,
    spec: &TrialSpec,
) -> Result<LockstepResult, RuntimeError> {
    let (n, timeouts) = (spec.starts.len(), Timeouts::new(TIMEOUTS));
    let registry = PolicyRegistry::builtin();
    let mut buses = ChannelBus::connect(&nodes_of(n)).into_iter();
    let (world_bus, radio_bus) = (buses.next().unwrap(), buses.next().unwrap());
    let radio = madenet_world::Radio::new(&spec.config, n, spec.seed);
    s.spawn(move || run_radio(radio, n, radio_bus, timeouts).unwrap());
    for (i, bus) in buses.enumerate() {
        let agent = madenet_sim::build_agent(spec, &registry, i).unwrap();
        s.spawn(move || run_robot(agent, bus, timeouts).unwrap());
    }
    let ctx = opts.context().unwrap();
    let real = RealRobots::new(
        &ctx,
        n,
        MapFrame::of(&spec.map),
        spec.config.clone(),
        Duration::from_secs(2),
        Duration::from_secs(20),
    )
    .unwrap();
    run_ground_with(real, world_bus, timeouts, None, None, |_, _| {
        std::ops::ControlFlow::Continue(())
    })
}

#[test]
fn nf_agents_explore_a_map_through_ros2_alone() {
    let (_router, opts) = loopback_router().unwrap();
    let truth = paper_map(3).unwrap();
    let spec = TrialSpec {
        map: truth.clone(),
        map_name: "paper:3".into(),
        starts: Corner::TopLeft.start_cells(20, 20).to_vec(),
        config: Default::default(),
        policy: "nf".into(),
        seed: 1,
    };
    let n = spec.starts.len();
    let ds = spec.config.sensing_range;
    let stop = AtomicBool::new(false);
    let (result, paths) = std::thread::scope(|s| {
        let stacks: Vec<_> = (0..n)
            .map(|i| {
                let (opts, truth, start, stop) = (&opts, &truth, spec.starts[i], &stop);
                s.spawn(move || run_stand_in(opts, i, truth, start, ds, stop).unwrap())
            })
            .collect();
        let result = run_team(s, &opts, &spec);
        stop.store(true, Ordering::Relaxed);
        let paths: Vec<Vec<Pos>> = stacks.into_iter().map(|h| h.join().unwrap()).collect();
        (result, paths)
    });
    let r = result.unwrap();
    eprintln!(
        "real robots: {} timesteps, {:.1} m travelled, explored {:.3} of the grid",
        r.metrics.tns, r.metrics.ttd, r.metrics.explored
    );
    assert!(r.metrics.completed, "no frontier left: {:?}", r.metrics);
    assert!(r.metrics.tns < spec.config.step_cap, "{}", r.metrics.tns);
    assert_eq!(r.absent_robot_steps, 0);
    // The world node's trajectory is the stacks' own: every robot moved, one cell at a time,
    // only through free cells, and ended where its stack says.
    let last = r.positions.last().unwrap();
    for (i, path) in paths.iter().enumerate() {
        assert!(path.len() > 5, "robot {i} hardly moved: {path:?}");
        assert!(path.windows(2).all(|w| w[0].chebyshev(w[1]) == 1));
        assert!(path.iter().all(|&p| truth.is_free(p)));
        assert_eq!(last[i], *path.last().unwrap(), "robot {i}");
    }
}

/// The continuous world in place of real robots: three simulated differential-drive robots
/// (the nav2 sim, [`run_nav2_sim`]) publish their lidar scans, their own fine occupancy grids
/// (slam_toolbox's values, with `map_updates`) and their poses, and drive with the navigator to
/// the cells `/robot<i>/goal_pose` names. The
/// world node stands on [`RealRobots`], which reads the fine maps by the scenario's rule; the nf
/// agents explore the room (a free-standing 2 × 2 m block in a 10 × 10 m room) to completion
/// through ROS 2 alone, without a collision.
#[test]
fn nf_agents_explore_a_continuous_world_through_ros2_alone() {
    use madenet_continuous::{ContinuousConfig, ContinuousWorld, Scene};
    use madenet_map::{OccGrid, Occupancy};
    use std::sync::Arc;

    let (_router, opts) = loopback_router().unwrap();
    let mut truth = OccGrid::new(10, 10, Occupancy::Free);
    for (r, c) in [(4, 4), (4, 5), (5, 4), (5, 5)] {
        truth.set(Pos::new(r, c), Occupancy::Obstacle);
    }
    // A block's face seen from one side fills a tenth of its cell's pixels: read as an
    // obstacle from one side at 15 % (at the paper's 25 % it takes two sides, and the world
    // node has no write-off rule: docs/guide/ros2.md).
    let mut config = madenet_world::ScenarioConfig::default();
    config.discretize.obstacle_fraction = 0.15;
    let spec = TrialSpec {
        map: truth.clone(),
        map_name: "room".into(),
        starts: vec![Pos::new(0, 0), Pos::new(0, 1), Pos::new(1, 0)],
        config,
        policy: "nf".into(),
        seed: 3,
    };
    let scene = Arc::new(Scene::from_grid(&truth, "room"));
    let world = ContinuousWorld::new(
        scene,
        &spec.starts,
        spec.config.clone(),
        ContinuousConfig::default(),
        spec.seed,
    )
    .unwrap();
    let stop = AtomicBool::new(false);
    let (result, run) = std::thread::scope(|s| {
        let (opts, stop) = (&opts, &stop);
        // 20 simulated seconds per second: a cell's drive in a fraction of the step timeout; a
        // robot held up 2 s by the world node is held up 40 s simulated.
        let sim = Nav2SimOptions {
            realtime: 20.0,
            ..Default::default()
        };
        let team = s.spawn(move || run_nav2_sim(opts, world, &sim, stop).unwrap());
        let result = run_team(s, opts, &spec);
        stop.store(true, Ordering::Relaxed);
        (result, team.join().unwrap())
    });
    let r = result.unwrap();
    eprintln!(
        "continuous robots: {} timesteps, {:.1} s simulated, {:?}, explored {:.3}",
        r.metrics.tns,
        run.time,
        run.summary(),
        r.metrics.explored
    );
    assert!(r.metrics.completed, "no frontier left: {:?}", r.metrics);
    assert_eq!(r.absent_robot_steps, 0);
    assert_eq!(run.collisions.obstacle + run.collisions.robot, 0, "{run:?}");
    let last = r.positions.last().unwrap();
    for (i, &at) in last.iter().enumerate() {
        // Each robot drove through free cells only, went where it was sent, and the world
        // node's last position of it is a cell the simulated robot drove through.
        let cells = &run.cells[i];
        assert!(cells.len() > 3, "robot {i} hardly moved: {cells:?}");
        assert!(cells.iter().all(|&p| truth.is_free(p)), "{cells:?}");
        assert!(
            run.outcomes[i].len() > 3,
            "robot {i}: {:?}",
            run.outcomes[i]
        );
        // (A robot that was still driving when the world node ended may have gone on.)
        assert!(cells.contains(&at), "robot {i}: {at:?} not in {cells:?}");
    }
}
