//! The continuous world as a team of nav2 robots (issue 57): every simulated robot, in its
//! namespace `/robot<i>`, serves `navigate_to_pose` (`nav2_msgs/action/NavigateToPose`) as
//! nav2's bt_navigator does in Jazzy, and publishes what a real robot's stack would.
//!
//! | name (in `/robot<i>`) | type | what |
//! | --- | --- | --- |
//! | `navigate_to_pose` | action `nav2_msgs/action/NavigateToPose` | goals in `map`, `odom` or `base_link` |
//! | `map`, `map_updates` | `nav_msgs/OccupancyGrid`, `map_msgs/OccupancyGridUpdate` | its own 0.1 m map as slam_toolbox publishes it: 100 above 0.65, 0 below 0.25, −1 between or unseen; transient local |
//! | `scan` | `sensor_msgs/LaserScan` | its lidar, frame `base_link` |
//! | `odom` | `nav_msgs/Odometry` | pose and velocity (odometry is exact here) |
//! | `tf`, `tf_static` | `tf2_msgs/TFMessage` | `map → odom` (identity) and `odom → base_link` ([`TfNaming`]) |
//!
//! and `/clock` (`rosgraph_msgs/Clock`, simulated time) for `use_sim_time`. Every stamp is
//! simulated time. Goals:
//! - a well-formed goal is accepted and preempts the one running, which ends ABORTED (nav2's
//!   `SimpleActionServer` aborts the old goal when it takes a new one); a goal whose pose is
//!   not finite is rejected;
//! - it then ends by its outcome: SUCCEEDED within nav2's goal tolerance (0.25 m), or ABORTED
//!   with the planner's or controller's error code ([`nav2_error`]): GOAL_OUTSIDE_MAP,
//!   GOAL_OCCUPIED, NO_VALID_PATH, FAILED_TO_MAKE_PROGRESS (nav2's progress checker), or
//!   TF_ERROR for a frame the robot does not have; a cancel ends it CANCELED;
//! - feedback (current pose, distance and estimated time remaining, navigation time, no
//!   recoveries) every 0.2 s of simulated time.
//!
//! The navigation itself is [`madenet_continuous::Navigator`]; the ground truth (collisions,
//! the true map) stays inside, in [`Nav2SimRun`].

use crate::actions::{
    nav2_error, status, ActionEvent, ActionServer, NavigateToPose, NavigateToPoseFeedback,
    NavigateToPoseResult, Uuid,
};
use crate::continuous_stand_in::{fine_grid, laser_scan, map_point};
use crate::map_updates::MapPublisher;
use crate::msgs::{
    Clock, Header, LaserScan, Odometry, PoseStamped, Time, Twist, TwistWithCovariance, Vector3,
};
use crate::tf::{planar, TfNaming, TfPublisher};
use crate::{MapFrame, Node, Publisher, QosProfile, Ros2Error, Ros2Options};
use madenet_continuous::{
    Collisions, ContinuousWorld, NavError, NavParams, NavStatus, Navigator, Pose,
};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Seconds of simulated time between two feedback messages of a goal.
const FEEDBACK_PERIOD: f64 = 0.2;

/// How the simulated team runs.
#[derive(Clone, Copy, Debug)]
pub struct Nav2SimOptions {
    /// Simulated seconds per wall-clock second; ≤ 0: as fast as it runs (then follow
    /// `/clock`).
    pub realtime: f64,
    /// How the robots' TF trees are kept apart (default: namespaced `/robot<i>/tf`).
    pub naming: TfNaming,
    /// The navigator's parameters (nav2's defaults).
    pub nav: NavParams,
}

impl Default for Nav2SimOptions {
    fn default() -> Self {
        Nav2SimOptions {
            realtime: 1.0,
            naming: TfNaming::default(),
            nav: NavParams::default(),
        }
    }
}

/// How one goal ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GoalOutcome {
    /// `action_msgs/GoalStatus` final state (SUCCEEDED, ABORTED or CANCELED).
    pub status: i8,
    /// nav2's error code (0 unless aborted).
    pub error_code: u16,
}

/// What a run did: per robot its goals' outcomes in order, the team's collisions (ground
/// truth), the simulated seconds, goals rejected.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Nav2SimRun {
    /// Per robot, how each goal it accepted ended.
    pub outcomes: Vec<Vec<GoalOutcome>>,
    /// Goals rejected (pose not finite).
    pub rejected: usize,
    /// Collisions counted by the world.
    pub collisions: Collisions,
    /// Simulated seconds.
    pub time: f64,
}

/// The namespace of robot `i`: `/robot<i>`.
pub fn namespace(i: usize) -> String {
    format!("/robot{i}")
}

/// Robot `i`'s part of the sim.
struct Robot {
    ns: String,
    node: Node,
    server: ActionServer<NavigateToPose>,
    nav: Navigator,
    /// The goal being navigated: id, when it was accepted (simulated s), last feedback.
    current: Option<(Uuid, f64, f64)>,
    map: MapPublisher,
    scan: Publisher<LaserScan>,
    odom: Publisher<Odometry>,
    tf: TfPublisher,
}

/// Simulated time `t` (s) as a ROS stamp.
fn sim_stamp(t: f64) -> Time {
    Time {
        sec: t.floor() as i32,
        nanosec: ((t - t.floor()) * 1e9) as u32,
    }
}

/// The map frame's point `(x, y)` in world coordinates (x right, y down from the top-left
/// corner): the inverse of [`map_point`].
fn world_point(frame: &MapFrame, x: f64, y: f64) -> (f64, f64) {
    let [x0, y0, yaw] = frame.origin;
    let (s, c) = yaw.sin_cos();
    let (dx, dy) = (x - x0, y - y0);
    let (lx, ly) = (dx * c + dy * s, -dx * s + dy * c);
    (lx, frame.height as f64 * frame.resolution - ly)
}

/// A world pose's position and yaw in the `map` frame.
fn map_pose(frame: &MapFrame, p: Pose) -> (f64, f64, f64) {
    let (x, y) = map_point(frame, p.x, p.y);
    (x, y, frame.origin[2] - p.theta)
}

/// slam_toolbox's values from a map of occupancy percentages: 100 above 65, 0 below 25,
/// −1 between or unseen (its `occupied_thresh` / `free_thresh`, as map_server's).
fn thresholded(mut grid: crate::msgs::OccupancyGrid) -> crate::msgs::OccupancyGrid {
    for v in &mut grid.data {
        *v = match *v {
            -1 => -1,
            p if p > 65 => 100,
            p if p < 25 => 0,
            _ => -1,
        };
    }
    grid
}

/// Where a goal pose is in world coordinates, if its frame is one the robot has (`map`,
/// `odom` — the same here —, `base_link`, or empty for `map`).
fn goal_in_world(
    goal: &PoseStamped,
    robot: Pose,
    frame: &MapFrame,
    ns: &str,
    naming: TfNaming,
) -> Option<(f64, f64)> {
    let f = goal.header.frame_id.trim_start_matches('/');
    let (gx, gy) = (goal.pose.position.x, goal.pose.position.y);
    let is = |name: &str| f == naming.frame(ns, name) || f == name;
    if f.is_empty() || is("map") || is("odom") {
        Some(world_point(frame, gx, gy))
    } else if is("base_link") {
        let (rx, ry, ryaw) = map_pose(frame, robot);
        let (s, c) = ryaw.sin_cos();
        Some(world_point(
            frame,
            rx + gx * c - gy * s,
            ry + gx * s + gy * c,
        ))
    } else {
        None
    }
}

fn nav2_code(e: NavError) -> u16 {
    match e {
        NavError::GoalOutsideMap => nav2_error::GOAL_OUTSIDE_MAP,
        NavError::GoalOccupied => nav2_error::GOAL_OCCUPIED,
        NavError::NoValidPath => nav2_error::NO_VALID_PATH,
        NavError::FailedToMakeProgress => nav2_error::FAILED_TO_MAKE_PROGRESS,
    }
}

fn seconds(t: f64) -> crate::msgs::Duration {
    let t = t.max(0.0);
    crate::msgs::Duration {
        sec: t.floor() as i32,
        nanosec: ((t - t.floor()) * 1e9) as u32,
    }
}

/// Runs `world`'s robots as nav2 robots until `stop` is set (see the module doc).
pub fn run_nav2_sim(
    opts: &Ros2Options,
    mut world: ContinuousWorld,
    sim: &Nav2SimOptions,
    stop: &AtomicBool,
) -> Result<Nav2SimRun, Ros2Error> {
    let ctx = opts.context()?;
    let n = world.robots();
    let frame = MapFrame::of(world.coarse_truth());
    let cfg = *world.config();
    let clock_node = ctx.create_node("madenet_nav2_sim")?;
    let clock: Publisher<Clock> = clock_node.create_pub("/clock", QosProfile::default())?;
    let mut robots = Vec::with_capacity(n);
    for i in 0..n {
        let ns = namespace(i);
        let node = ctx.create_node_in(&ns, "bt_navigator")?;
        let tf = TfPublisher::new(&node, sim.naming)?;
        let frame_of = |name: &str| sim.naming.frame(&ns, name);
        // map → odom: odometry is exact, so identity (static: it never moves).
        tf.send_static(vec![planar(
            &frame_of("map"),
            &frame_of("odom"),
            Time::default(),
            0.0,
            0.0,
            0.0,
        )])?;
        robots.push(Robot {
            server: ActionServer::new(&node, "navigate_to_pose")?,
            nav: Navigator::new(sim.nav),
            current: None,
            map: MapPublisher::new(&node, "map")?,
            scan: node.create_pub("scan", QosProfile::default())?,
            odom: node.create_pub("odom", QosProfile::default())?,
            tf,
            node,
            ns,
        });
    }
    let mut run = Nav2SimRun {
        outcomes: vec![Vec::new(); n],
        ..Default::default()
    };
    let scan_every = (1.0 / (cfg.lidar.rate_hz * cfg.control_period))
        .round()
        .max(1.0) as u64;
    let pose_every = (0.05 / cfg.control_period).round().max(1.0) as u64;
    let started = Instant::now();
    let mut ticks: u64 = 0;
    while !stop.load(Ordering::Relaxed) {
        let now = world.time();
        // Goals and cancels.
        for (i, r) in robots.iter_mut().enumerate() {
            while let Some(event) = r.server.poll(Duration::ZERO)? {
                match event {
                    ActionEvent::Goal(g) => {
                        let p = g.goal().pose.pose;
                        let finite = [
                            p.position.x,
                            p.position.y,
                            p.position.z,
                            p.orientation.x,
                            p.orientation.y,
                            p.orientation.z,
                            p.orientation.w,
                        ]
                        .iter()
                        .all(|v| v.is_finite());
                        if !finite {
                            tracing::warn!("{}: rejected a goal with a non-finite pose", r.ns);
                            run.rejected += 1;
                            r.server.reject(g)?;
                            continue;
                        }
                        let target =
                            goal_in_world(&g.goal().pose, world.pose(i), &frame, &r.ns, sim.naming);
                        let id = r.server.accept(g)?;
                        if let Some((old, _, _)) = r.current.take() {
                            let why = "preempted by a new goal";
                            end(r, &mut run.outcomes[i], old, status::ABORTED, 0, why)?;
                        }
                        let Some(target) = target else {
                            let why = "the goal's frame is not in the robot's TF tree";
                            end(
                                r,
                                &mut run.outcomes[i],
                                id,
                                status::ABORTED,
                                nav2_error::TF_ERROR,
                                why,
                            )?;
                            continue;
                        };
                        match r.nav.start(target, &world, i) {
                            Ok(()) => r.current = Some((id, now, f64::NEG_INFINITY)),
                            Err(e) => {
                                failed(r, &mut run.outcomes[i], id, e)?;
                            }
                        }
                    }
                    ActionEvent::Cancel(id) => {
                        if r.current.is_some_and(|c| c.0 == id) {
                            r.current = None;
                            r.nav.cancel();
                        }
                        end(r, &mut run.outcomes[i], id, status::CANCELED, 0, "canceled")?;
                    }
                }
            }
        }
        // Navigation.
        let mut commands = vec![(0.0, 0.0); n];
        for i in 0..n {
            let neighbours = world.neighbours(i);
            let r = &mut robots[i];
            let Some((id, since, last_fb)) = r.current else {
                continue;
            };
            match r.nav.step(&world, i, &neighbours) {
                NavStatus::Driving {
                    command,
                    distance_remaining,
                } => {
                    commands[i] = command;
                    if now - last_fb >= FEEDBACK_PERIOD {
                        r.current = Some((id, since, now));
                        let (x, y, yaw) = map_pose(&frame, world.pose(i));
                        let mut current_pose = PoseStamped {
                            header: Header {
                                stamp: sim_stamp(now),
                                frame_id: sim.naming.frame(&r.ns, "map"),
                            },
                            ..Default::default()
                        };
                        current_pose.pose = frame.pose(x, y, yaw);
                        let speed = cfg.robot.max_speed.max(1e-3);
                        r.server.publish_feedback(
                            id,
                            NavigateToPoseFeedback {
                                current_pose,
                                navigation_time: seconds(now - since),
                                estimated_time_remaining: seconds(distance_remaining / speed),
                                number_of_recoveries: 0,
                                distance_remaining: distance_remaining as f32,
                            },
                        )?;
                    }
                }
                NavStatus::Succeeded => {
                    r.current = None;
                    end(r, &mut run.outcomes[i], id, status::SUCCEEDED, 0, "")?;
                }
                NavStatus::Failed(e) => {
                    r.current = None;
                    failed(r, &mut run.outcomes[i], id, e)?;
                }
                NavStatus::Idle => r.current = None,
            }
        }
        world.step(&commands);
        ticks += 1;
        let t = world.time();
        let stamp = sim_stamp(t);
        clock.publish(&Clock { clock: stamp })?;
        for (i, r) in robots.iter_mut().enumerate() {
            let base = sim.naming.frame(&r.ns, "base_link");
            if (ticks + i as u64).is_multiple_of(scan_every) {
                let mut scan = laser_scan(&world, i, stamp);
                scan.header.frame_id = base.clone();
                r.scan.publish(&scan)?;
                let mut grid = thresholded(fine_grid(&world, i, &frame, stamp));
                grid.header.frame_id = sim.naming.frame(&r.ns, "map");
                r.map.publish(&grid)?;
            }
            if ticks.is_multiple_of(pose_every) {
                let (x, y, yaw) = map_pose(&frame, world.pose(i));
                let odom_frame = sim.naming.frame(&r.ns, "odom");
                r.tf.send(vec![planar(&odom_frame, &base, stamp, x, y, yaw)])?;
                let (v, w) = world.velocity(i);
                let mut odom = Odometry {
                    header: Header {
                        stamp,
                        frame_id: odom_frame,
                    },
                    child_frame_id: base,
                    twist: TwistWithCovariance {
                        twist: Twist {
                            linear: Vector3 {
                                x: v,
                                y: 0.0,
                                z: 0.0,
                            },
                            // The world's yaw turns clockwise in ROS's y-up frame.
                            angular: Vector3 {
                                x: 0.0,
                                y: 0.0,
                                z: -w,
                            },
                        },
                        ..Default::default()
                    },
                    ..Default::default()
                };
                odom.pose.pose = frame.pose(x, y, yaw);
                r.odom.publish(&odom)?;
            }
        }
        if sim.realtime > 0.0 {
            let due = Duration::from_secs_f64(t / sim.realtime);
            if let Some(wait) = due.checked_sub(started.elapsed()) {
                std::thread::sleep(wait);
            }
        }
    }
    // Goals still running end as aborted: the robots are gone.
    for (i, r) in robots.iter_mut().enumerate() {
        if let Some((id, _, _)) = r.current.take() {
            let why = "the simulation stopped";
            end(
                r,
                &mut run.outcomes[i],
                id,
                status::ABORTED,
                nav2_error::UNKNOWN,
                why,
            )?;
        }
        let _ = &r.node;
    }
    run.collisions = world.collisions();
    run.time = world.time();
    Ok(run)
}

/// Ends goal `id` of robot `r` as ABORTED with the code and text of `e`.
fn failed(
    r: &mut Robot,
    outcomes: &mut Vec<GoalOutcome>,
    id: Uuid,
    e: NavError,
) -> Result<(), Ros2Error> {
    end(
        r,
        outcomes,
        id,
        status::ABORTED,
        nav2_code(e),
        &e.to_string(),
    )
}

/// Ends goal `id` of robot `r` and notes its outcome (an unknown or ended goal: nothing).
fn end(
    r: &mut Robot,
    outcomes: &mut Vec<GoalOutcome>,
    id: Uuid,
    final_status: i8,
    error_code: u16,
    why: &str,
) -> Result<(), Ros2Error> {
    let result = NavigateToPoseResult {
        error_code,
        error_msg: why.to_string(),
    };
    if r.server.end(id, final_status, result)? {
        outcomes.push(GoalOutcome {
            status: final_status,
            error_code,
        });
    }
    Ok(())
}
