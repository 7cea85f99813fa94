//! The continuous world as a nav2 robot, driven over the wire by an action client as a ROS 2
//! node would drive nav2: goals reached, aborted with nav2's codes, rejected, preempted and
//! canceled; the robot's map (slam_toolbox's values, transient local) and its TF; a client
//! that subscribes and never reads does not hold the sim up.

use madenet_continuous::{ContinuousConfig, ContinuousWorld, Scene};
use madenet_map::floorplan::{floor_plan, FloorPlanConfig};
use madenet_map::generate::reachable_from_with;
use madenet_map::{Movement, OccGrid, Occupancy};
use madenet_ros2::actions::{
    nav2_error, status, ActionClient, NavigateToPose, NavigateToPoseGoal, SentGoal,
};
use madenet_ros2::map_updates::MapSubscriber;
use madenet_ros2::msgs::Time;
use madenet_ros2::nav2_sim::{Nav2SimOptions, Nav2SimThread};
use madenet_ros2::tf::{from_yaw, yaw, TfListener, TfNaming};
use madenet_ros2::{loopback_router, MapFrame, Ros2Options};
use std::f64::consts::PI;
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::Wait;

const WAIT: Duration = Duration::from_secs(30);

fn goal(frame_id: &str, x: f64, y: f64) -> NavigateToPoseGoal {
    NavigateToPoseGoal::at(frame_id, x, y, 0.0)
}

/// The continuous world of `grid` (1 m cells) with a robot in each of `starts`.
fn world_on(grid: &OccGrid, starts: &[madenet_map::Pos], seed: u64) -> ContinuousWorld {
    let scene = Arc::new(Scene::from_grid(grid, "plan"));
    let scenario = madenet_world::ScenarioConfig {
        num_robots: starts.len(),
        ..Default::default()
    };
    ContinuousWorld::new(scene, starts, scenario, ContinuousConfig::default(), seed).unwrap()
}

/// A zenoh router on loopback, options that reach it, and the nav2 sim of `world` on it at
/// `realtime` × real time.
fn start_sim(
    world: ContinuousWorld,
    realtime: f64,
) -> (zenoh::Session, Ros2Options, Nav2SimThread) {
    let (router, opts) = loopback_router().unwrap();
    let sim = Nav2SimThread::spawn(
        opts.clone(),
        world,
        Nav2SimOptions {
            realtime,
            ..Default::default()
        },
    );
    (router, opts, sim)
}

fn outcome(g: &SentGoal<NavigateToPose>, wait: Duration) -> (i8, u16) {
    let (st, r) = g.result(wait).unwrap().expect("a result");
    (st, r.error_code)
}

#[test]
fn a_client_drives_a_simulated_nav2_robot() {
    let mut cfg = FloorPlanConfig::for_size(20, 20);
    cfg.door_width = 1;
    let grid: OccGrid = floor_plan(&cfg, 1).unwrap();
    let start = cfg.keep_free[0];
    let world = world_on(&grid, &[start], 1);
    let frame = MapFrame::of(&grid);
    // Goals in the `map` frame: true free cells reachable from the start, off their centres.
    let reach = reachable_from_with(&grid, start, Movement::NoCornerCutting);
    let free_far: Vec<(f64, f64)> = (0..grid.len())
        .filter(|&k| reach[k] && grid.cells()[k] == Occupancy::Free)
        .map(|k| frame.cell_center(grid.pos(k)))
        .collect();
    let (router, opts, sim) = start_sim(world, 40.0);
    // A foreign client that subscribes to everything and never reads: the sim must not wait
    // for it (its queue of one fills at once).
    let stuck = opts.context().unwrap();
    let _never_read = stuck
        .session()
        .declare_subscriber("0/**")
        .with(zenoh::handlers::FifoChannel::new(1))
        .wait()
        .unwrap();
    let ctx = opts.context().unwrap();
    let node = ctx.create_node_in("/robot0", "client").unwrap();
    let client = ActionClient::<NavigateToPose>::new(&node, "navigate_to_pose").unwrap();
    assert!(client.wait_for_server(WAIT).unwrap(), "no navigate_to_pose");
    let send = |g: NavigateToPoseGoal| client.send_goal(g, WAIT).unwrap();

    // Three reachable goals, 4 m or more apart, each reached.
    let mut last = frame.cell_center(start);
    let mut k = 3;
    let mut feedbacks = 0;
    for _ in 0..3 {
        let (x, y) = loop {
            k = (k + 29) % free_far.len();
            let c = free_far[k];
            if (c.0 - last.0).hypot(c.1 - last.1) > 4.0 {
                break c;
            }
        };
        let sent = send(goal("map", x + 0.2, y - 0.1)).expect("accepted");
        while client
            .feedback(Duration::from_millis(50))
            .unwrap()
            .is_some()
        {
            feedbacks += 1;
        }
        assert_eq!(
            outcome(&sent, WAIT),
            (status::SUCCEEDED, 0),
            "goal ({x}, {y})"
        );
        last = (x, y);
    }
    while client
        .feedback(Duration::from_millis(10))
        .unwrap()
        .is_some()
    {
        feedbacks += 1;
    }
    assert!(feedbacks > 0, "no feedback");

    // Off the map: aborted at once with the planner's code (no recovery helps that, in nav2's
    // tree). An unknown frame: TF_ERROR.
    let off = send(goal("map", -50.0, 3.0)).expect("accepted");
    assert_eq!(
        outcome(&off, WAIT),
        (status::ABORTED, nav2_error::GOAL_OUTSIDE_MAP)
    );
    let nowhere = send(goal("robot7/odom", 1.0, 1.0)).expect("accepted");
    assert_eq!(
        outcome(&nowhere, WAIT),
        (status::ABORTED, nav2_error::TF_ERROR)
    );
    // A non-finite pose is rejected.
    assert!(send(goal("map", f64::NAN, 1.0)).is_none());

    // Preemption: the first goal ends aborted, the second is reached.
    let far = free_far[(k + 101) % free_far.len()];
    let first = send(goal("map", far.0, far.1)).expect("accepted");
    let second = send(goal("map", last.0, last.1)).expect("accepted");
    assert_eq!(outcome(&first, WAIT).0, status::ABORTED);
    assert_eq!(outcome(&second, WAIT), (status::SUCCEEDED, 0));

    // Cancel: acknowledged within 1 s, the goal ends CANCELED.
    let far = free_far[(k + 57) % free_far.len()];
    let long = send(goal("map", far.0, far.1)).expect("accepted");
    client
        .feedback(WAIT)
        .unwrap()
        .expect("feedback before the cancel");
    let t = Instant::now();
    let answer = client.cancel(long.id, WAIT).unwrap();
    assert!(t.elapsed() < Duration::from_secs(1), "{:?}", t.elapsed());
    assert_eq!(answer.goals_canceling.len(), 1);
    assert_eq!(outcome(&long, WAIT).0, status::CANCELED);

    // A late subscriber gets the robot's map, with slam_toolbox's values only.
    let mut maps = MapSubscriber::new(&node, "map").unwrap();
    let map = maps.latest(WAIT).unwrap().expect("the map").clone();
    assert!(map.data.iter().all(|v| [-1, 0, 100].contains(v)));
    assert!(map.data.contains(&0) && map.data.contains(&100));
    assert!((map.info.resolution - 0.1).abs() < 1e-6);
    // TF: map → base_link (namespaced /robot0/tf, frames without prefix).
    let mut tf = TfListener::new(&node, "/robot0", TfNaming::NamespacedTopics).unwrap();
    let deadline = Instant::now() + WAIT;
    let pose = loop {
        tf.spin(Duration::from_millis(100)).unwrap();
        if let Ok(t) = tf
            .buffer
            .lookup("map", "base_link", Time::default(), Duration::from_secs(1))
        {
            break t;
        }
        assert!(Instant::now() < deadline, "no map → base_link");
    };
    let (x, y) = (pose.translation.x, pose.translation.y);
    assert!(frame.cell_at(x, y).is_some(), "({x}, {y}) on the map");

    let run = sim.stop().unwrap();
    drop(router);
    assert_eq!(run.rejected, 1);
    assert_eq!(
        run.collisions.obstacle + run.collisions.robot,
        0,
        "{:?}",
        run.collisions
    );
    let codes: Vec<(i8, u16)> = run.outcomes[0]
        .iter()
        .map(|o| (o.status, o.error_code))
        .collect();
    assert_eq!(codes.len(), 8, "{codes:?}");
    eprintln!("{:.0} s simulated; outcomes {codes:?}", run.time);
}

/// Three robots in `/robot0..2`, each driven at once by its own client (its own zenoh
/// session, as a separate process would have): every goal reached, each robot's TF tree on its
/// own `/robot<i>/tf` puts that robot (not another) at its last goal, and a map subscriber
/// that joins after 30 s gets every robot's map (transient local). A goal for a namespace
/// with no robot gets a clear error, and the sim goes on.
#[test]
fn three_clients_drive_three_robots_at_once() {
    let cfg = FloorPlanConfig::for_size(20, 20);
    let grid: OccGrid = floor_plan(&cfg, 2).unwrap();
    let frame = MapFrame::of(&grid);
    let reach = reachable_from_with(&grid, cfg.keep_free[0], Movement::NoCornerCutting);
    let free: Vec<_> = (0..grid.len())
        .filter(|&k| reach[k] && grid.cells()[k] == Occupancy::Free)
        .map(|k| grid.pos(k))
        .collect();
    // Starts: the free cells nearest three corners; goals: two cells 2–4 cells from the start.
    let nearest = |r: i32, c: i32| {
        *free
            .iter()
            .min_by_key(|p| (p.row - r).abs() + (p.col - c).abs())
            .unwrap()
    };
    let starts = [nearest(0, 0), nearest(0, 19), nearest(19, 0)];
    let goals: Vec<Vec<(f64, f64)>> = starts
        .iter()
        .map(|s| {
            free.iter()
                .filter(|p| (2..=4).contains(&((p.row - s.row).abs() + (p.col - s.col).abs())))
                .step_by(3)
                .take(2)
                .map(|&p| frame.cell_center(p))
                .collect()
        })
        .collect();
    assert!(goals.iter().all(|g| g.len() == 2), "{goals:?}");
    let world = world_on(&grid, &starts, 2);
    let started = Instant::now();
    let (router, opts, sim) = start_sim(world, 10.0);
    let clients: Vec<_> = (0..3)
        .map(|i| {
            let (opts, goals) = (opts.clone(), goals[i].clone());
            std::thread::spawn(move || {
                let ctx = opts.context().unwrap();
                let ns = format!("/robot{i}");
                let node = ctx.create_node_in(&ns, "client").unwrap();
                let client =
                    ActionClient::<NavigateToPose>::new(&node, "navigate_to_pose").unwrap();
                assert!(
                    client.wait_for_server(WAIT).unwrap(),
                    "no {ns}/navigate_to_pose"
                );
                // Each goal with a heading: robot i ends facing 1 + i rad in `map`.
                let heading = 1.0 + i as f64;
                for &(x, y) in &goals {
                    let mut g = goal("map", x, y);
                    g.pose.pose.orientation = from_yaw(heading);
                    let sent = client.send_goal(g, WAIT).unwrap().unwrap();
                    assert_eq!(
                        outcome(&sent, WAIT),
                        (status::SUCCEEDED, 0),
                        "{ns} ({x}, {y})"
                    );
                }
                // Its own TF tree: map → base_link on /robot<i>/tf puts it at its last goal.
                let mut tf = TfListener::new(&node, &ns, TfNaming::NamespacedTopics).unwrap();
                let deadline = Instant::now() + WAIT;
                let at = loop {
                    tf.spin(Duration::from_millis(100)).unwrap();
                    if let Ok(t) = tf.buffer.lookup(
                        "map",
                        "base_link",
                        Time::default(),
                        Duration::from_secs(1),
                    ) {
                        break (t.translation.x, t.translation.y, yaw(&t.rotation));
                    }
                    assert!(Instant::now() < deadline, "{ns}: no map → base_link");
                };
                let turn = (at.2 - heading + PI).rem_euclid(2.0 * PI) - PI;
                assert!(turn.abs() < 0.3, "{ns} faces {} rad, not {heading}", at.2);
                let at = (at.0, at.1);
                let (gx, gy) = goals[1];
                let off = (at.0 - gx).hypot(at.1 - gy);
                assert!(off < 0.4, "{ns} at {at:?}, its goal ({gx}, {gy}): {off} m");
            })
        })
        .collect();
    for c in clients {
        c.join().unwrap();
    }
    // A namespace with no robot: the goal gets an error, not a hang.
    let ctx = opts.context().unwrap();
    let node = ctx.create_node_in("/robot9", "client").unwrap();
    let nobody = ActionClient::<NavigateToPose>::new(&node, "navigate_to_pose").unwrap();
    let t = Instant::now();
    let e = nobody
        .send_goal(goal("map", 1.0, 1.0), WAIT)
        .err()
        .expect("an error");
    assert!(e.to_string().contains("no server answered"), "{e}");
    assert!(t.elapsed() < Duration::from_secs(10), "{:?}", t.elapsed());
    // A subscriber that joins after 30 s gets every robot's map.
    std::thread::sleep(Duration::from_secs(30).saturating_sub(started.elapsed()));
    let late = opts.context().unwrap();
    let node = late.create_node("late_maps").unwrap();
    for i in 0..3 {
        let mut maps = MapSubscriber::new(&node, &format!("/robot{i}/map")).unwrap();
        let map = maps
            .latest(Duration::from_secs(5))
            .unwrap()
            .unwrap_or_else(|| panic!("no /robot{i}/map"));
        assert!(
            map.data.contains(&0) && map.data.contains(&100),
            "/robot{i}/map"
        );
    }
    let run = sim.stop().unwrap();
    drop(router);
    assert_eq!(
        run.collisions.obstacle + run.collisions.robot,
        0,
        "{:?}",
        run.collisions
    );
    for (i, o) in run.outcomes.iter().enumerate() {
        assert_eq!(o.len(), 2, "robot {i}: {o:?}");
    }
}

/// A goal inside a closed box: the robot drives until its map closes every path, then nav2's
/// tree recovers six times (clear, spin, wait, back up, clear, spin: 14 recovery actions with
/// the context clears, counted in the feedback) and aborts with NO_VALID_PATH.
#[test]
fn a_goal_in_a_closed_box_is_aborted_after_nav2s_recoveries() {
    let mut rows = vec!["............".to_string(); 12];
    rows[4] = "....####....".into();
    rows[5] = "....#..#....".into();
    rows[6] = "....#..#....".into();
    rows[7] = "....####....".into();
    let text = rows.join("\n") + "\n";
    let grid = madenet_map::io::parse_text(&text, std::path::Path::new("box.txt")).unwrap();
    let world = world_on(&grid, &[madenet_map::Pos::new(1, 1)], 2);
    let frame = MapFrame::of(&grid);
    let (router, opts, sim) = start_sim(world, 40.0);
    let ctx = opts.context().unwrap();
    let node = ctx.create_node_in("/robot0", "client").unwrap();
    let client = ActionClient::<NavigateToPose>::new(&node, "navigate_to_pose").unwrap();
    assert!(client.wait_for_server(WAIT).unwrap());
    let (x, y) = frame.cell_center(madenet_map::Pos::new(5, 5));
    let sent = client.send_goal(goal("map", x, y), WAIT).unwrap().unwrap();
    let mut most = 0;
    while let Some(fb) = client.feedback(Duration::from_secs(5)).unwrap() {
        most = most.max(fb.feedback.number_of_recoveries);
        if sent.result(Duration::ZERO).unwrap().is_some() {
            break;
        }
    }
    assert_eq!(
        outcome(&sent, WAIT),
        (status::ABORTED, nav2_error::NO_VALID_PATH)
    );
    assert_eq!(most, 14, "recovery actions in the feedback");
    let run = sim.stop().unwrap();
    drop(router);
    assert_eq!(run.collisions.obstacle + run.collisions.robot, 0);
    eprintln!("closed box: aborted after {:.0} s simulated", run.time);
}
