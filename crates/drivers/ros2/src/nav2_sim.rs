//! The continuous world as a team of nav2 robots (issue 57): every simulated robot, in its
//! namespace `/robot<i>`, serves `navigate_to_pose` (`nav2_msgs/action/NavigateToPose`) as
//! nav2's bt_navigator does in Jazzy, and publishes what a real robot's stack would.
//!
//! | name (in `/robot<i>`) | type | what |
//! | --- | --- | --- |
//! | `navigate_to_pose` | action `nav2_msgs/action/NavigateToPose` | goals in `map`, `odom` or `base_link` |
//! | `map`, `map_updates` | `nav_msgs/OccupancyGrid`, `map_msgs/OccupancyGridUpdate` | its own 0.1 m map as slam_toolbox publishes it: 100 above 0.65, 0 below 0.25, −1 between or unseen; transient local |
//! | `scan` | `sensor_msgs/LaserScan` | its lidar, frame `base_link` |
//! | `odom` | `nav_msgs/Odometry` | pose and velocity (odometry is exact here), 20 Hz |
//! | `pose` | `geometry_msgs/PoseStamped` | its pose in `map`, 20 Hz (what `launch --ros2-robots` reads) |
//! | `goal_pose` (subscribed) | `geometry_msgs/PoseStamped` | a goal as RViz's "2D Goal Pose" sends it: bt_navigator takes it as a goal of its own (no feedback, same outcomes) |
//! | `tf`, `tf_static` | `tf2_msgs/TFMessage` | `map → odom` (identity) and `odom → base_link` ([`TfNaming`]) |
//!
//! and `/clock` (`rosgraph_msgs/Clock`, simulated time) for `use_sim_time`. Every stamp is
//! simulated time. Goals:
//! - a well-formed goal is accepted and preempts the one running, which ends ABORTED (nav2's
//!   `SimpleActionServer` aborts the old goal when it takes a new one); a goal whose pose is
//!   not finite is rejected;
//! - it then ends by its outcome: SUCCEEDED within nav2's goal tolerance (0.25 m, then the
//!   goal's heading within 0.25 rad, turning in place, as nav2's stateful goal checker), or
//!   ABORTED with the planner's or controller's error code ([`nav2_error`]): GOAL_OUTSIDE_MAP,
//!   GOAL_OCCUPIED (at once, as nav2's tree: no recovery helps those), NO_VALID_PATH or
//!   FAILED_TO_MAKE_PROGRESS (nav2's progress checker) after the tree's six retries, each
//!   after one of its recoveries in turn (clear the costmaps, spin 1.57 rad, wait 5 s, back up
//!   0.3 m), or at once TF_ERROR for a frame the robot does not have; a cancel ends it
//!   CANCELED;
//! - feedback (current pose, distance and estimated time remaining, navigation time, number
//!   of recoveries) every 0.2 s of simulated time, recovering or not.
//!
//! The navigation itself is [`madenet_continuous::Navigator`]; the ground truth (collisions,
//! the true map) stays inside, in [`Nav2SimRun`] and what the run loop's sinks record
//! ([`Nav2Team`] is a driver of the one stepping contract). The same robots stand in for a
//! real team under `launch --ros2-robots` (its world node sends `goal_pose` and reads `map`,
//! `map_updates` and `pose`).

use crate::actions::{
    nav2_error, status, ActionEvent, ActionServer, NavigateToPose, NavigateToPoseFeedback,
    NavigateToPoseResult, Uuid,
};
use crate::map_updates::MapPublisher;
use crate::msgs::{
    Clock, Header, LaserScan, Odometry, PoseStamped, Time, Twist, TwistWithCovariance, Vector3,
};
use crate::sim_sensors::{fine_grid, laser_scan, map_point, pose_stamped};
use crate::tf::{planar, TfNaming, TfPublisher};
use crate::{MapFrame, Node, Publisher, QosProfile, Ros2Error, Ros2Options, Subscription};
use madenet_agent::{Agent, Decision};
use madenet_continuous::{
    Collisions, ContinuousWorld, NavError, NavParams, NavStatus, Navigator, Pose,
};
use madenet_map::Pos;
use madenet_sim::stepping::{run, Pace, Present, RobotShown, Sink, SinkError, Stepping};
use std::borrow::Cow;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

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
/// truth), the simulated seconds, goals rejected and malformed requests refused.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Nav2SimRun {
    /// Per robot, how each goal it accepted ended.
    pub outcomes: Vec<Vec<GoalOutcome>>,
    /// Goals rejected (pose not finite).
    pub rejected: usize,
    /// Malformed requests from clients, answered with an error reply (and logged).
    pub refused: usize,
    /// Per robot, the cells it passed through, in order (each once per visit).
    pub cells: Vec<Vec<Pos>>,
    /// The share of the explorable cells the robots' maps together know (ground truth), 0–1.
    pub explored: f64,
    /// Collisions counted by the world.
    pub collisions: Collisions,
    /// Simulated seconds.
    pub time: f64,
    /// The explored share (as `explored`) at every whole simulated second (index = second).
    pub curve: Vec<f64>,
    /// Metres the whole team drove.
    pub distance: f64,
}

impl Nav2SimRun {
    /// The first whole simulated second at which the robots' maps together covered `share`
    /// (0–1) of the explorable cells, if they did.
    pub fn covered_at(&self, share: f64) -> Option<f64> {
        self.curve
            .iter()
            .position(|&e| e >= share)
            .map(|s| s as f64)
    }

    /// The run in lines for people: goals by outcome, rejected and refused, collisions, time.
    pub fn summary(&self) -> Vec<String> {
        let count = |st: i8| {
            self.outcomes
                .iter()
                .flatten()
                .filter(|o| o.status == st)
                .count()
        };
        let mut codes: Vec<u16> = self
            .outcomes
            .iter()
            .flatten()
            .filter(|o| o.error_code != 0)
            .map(|o| o.error_code)
            .collect();
        codes.sort_unstable();
        codes.dedup();
        let codes: Vec<String> = codes.iter().map(u16::to_string).collect();
        let Collisions { obstacle, robot } = self.collisions;
        // Aborted without an error code: preempted by a newer goal.
        let preempted = (self.outcomes.iter().flatten())
            .filter(|o| o.status == status::ABORTED && o.error_code == 0)
            .count();
        let mut why = Vec::new();
        if preempted > 0 {
            why.push(format!("{preempted} preempted"));
        }
        if !codes.is_empty() {
            why.push(format!("error codes {}", codes.join(", ")));
        }
        let why = match why.is_empty() {
            true => String::new(),
            false => format!(" ({})", why.join("; ")),
        };
        vec![
            format!(
                "goals      {} succeeded, {} aborted{why}, {} canceled, {} rejected",
                count(status::SUCCEEDED),
                count(status::ABORTED),
                count(status::CANCELED),
                self.rejected
            ),
            format!("refused    {} malformed requests", self.refused),
            format!("collisions {obstacle} with obstacles, {robot} between robots"),
            format!(
                "explored   {:.1} % (the robots' maps together, ground truth)",
                100.0 * self.explored
            ),
            format!(
                "covered    99 % at {}; {:.1} m driven by the team",
                match self.covered_at(0.99) {
                    Some(t) => format!("{t:.0} s"),
                    None => "never".into(),
                },
                self.distance
            ),
            format!("simulated  {:.1} s", self.time),
        ]
    }
}

/// The namespace of robot `i`: `/robot<i>`.
pub fn namespace(i: usize) -> String {
    format!("/robot{i}")
}

/// A goal being pursued.
#[derive(Clone, Copy, Debug)]
struct Active {
    /// Its action id (`None`: it came on `goal_pose`).
    id: GoalId,
    /// Where it is (world x, y) and the heading to face there ([`Pose::theta`]).
    target: (f64, f64, f64),
    /// When it was accepted, and when its last feedback went out (simulated s).
    since: f64,
    last_feedback: f64,
    /// Retries of the navigation so far (at most [`RETRIES`]).
    retries: u16,
    /// Recovery actions run for it so far: feedback's `number_of_recoveries`.
    recoveries: u16,
    /// The recovery under way, if one is.
    recovery: Option<Recovery>,
    /// Metres left along its path at the last step.
    distance_remaining: f64,
}

/// Retries of a goal's navigation in nav2's default behaviour tree
/// (`navigate_to_pose_w_replanning_and_recovery.xml`, as of nav2 Jazzy): its outer
/// `RecoveryNode number_of_retries="6"`.
const RETRIES: u16 = 6;

/// That tree's recoveries, taken in turn (its `RoundRobin`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Behaviour {
    /// Clear the local and global costmaps: nothing to clear here (a robot's map is its SLAM
    /// map), done at once.
    ClearCostmaps,
    /// Turn in place 1.57 rad counter-clockwise at 1 rad/s (nav2's `Spin`; 10 s allowed).
    Spin,
    /// Stand still 5 s (nav2's `Wait`).
    Wait,
    /// Back up 0.30 m at 0.15 m/s, stopping short of anything behind (nav2's `BackUp`;
    /// 10 s allowed).
    BackUp,
}

const ROUND_ROBIN: [Behaviour; 4] = [
    Behaviour::ClearCostmaps,
    Behaviour::Spin,
    Behaviour::Wait,
    Behaviour::BackUp,
];

/// A recovery under way.
#[derive(Clone, Copy, Debug)]
struct Recovery {
    behaviour: Behaviour,
    /// When it started (simulated s) and where the robot was.
    since: f64,
    from: Pose,
    /// Radians turned so far (Spin) and the heading at the last step.
    turned: f64,
    last_theta: f64,
}

impl Recovery {
    /// Robot `i`'s command this control period; `None` once the recovery is done.
    fn command(&mut self, world: &ContinuousWorld, i: usize, now: f64) -> Option<(f64, f64)> {
        let pose = world.pose(i);
        let elapsed = now - self.since;
        match self.behaviour {
            Behaviour::ClearCostmaps => None,
            Behaviour::Spin => {
                self.turned +=
                    madenet_continuous::normalize_angle(pose.theta - self.last_theta).abs();
                self.last_theta = pose.theta;
                // Counter-clockwise in `map` (y up) is clockwise in the world (y down).
                (self.turned < 1.57 && elapsed < 10.0).then_some((0.0, -1.0))
            }
            Behaviour::Wait => (elapsed < 5.0).then_some((0.0, 0.0)),
            Behaviour::BackUp => {
                let moved = (pose.x - self.from.x).hypot(pose.y - self.from.y);
                (moved < 0.30 && elapsed < 10.0 && clear_behind(world, i)).then_some((-0.15, 0.0))
            }
        }
    }
}

/// Whether robot `i`'s own map shows nothing occupied within 0.15 m behind its footprint.
fn clear_behind(world: &ContinuousWorld, i: usize) -> bool {
    let (p, map) = (world.pose(i), world.map(i));
    let reach = world.config().robot.radius + 0.15;
    let res = map.resolution();
    let steps = (reach / (res / 2.0)).ceil() as usize;
    (1..=steps).all(|k| {
        let d = k as f64 * res / 2.0;
        let (x, y) = (p.x - d * p.theta.cos(), p.y - d * p.theta.sin());
        let (r, c) = ((y / res).floor(), (x / res).floor());
        r >= 0.0
            && c >= 0.0
            && (r as usize) < map.height()
            && (c as usize) < map.width()
            && !map.occupied(r as usize, c as usize)
    })
}

/// A goal's action id; `None` for one that came on `goal_pose`.
type GoalId = Option<Uuid>;

/// Whether every number of a goal pose is finite.
fn finite(goal: &PoseStamped) -> bool {
    let p = goal.pose;
    [
        p.position.x,
        p.position.y,
        p.position.z,
        p.orientation.x,
        p.orientation.y,
        p.orientation.z,
        p.orientation.w,
    ]
    .iter()
    .all(|v| v.is_finite())
}

/// Robot `i`'s part of the sim.
struct Robot {
    ns: String,
    _node: Node,
    server: ActionServer<NavigateToPose>,
    nav: Navigator,
    /// The goal being pursued.
    current: Option<Active>,
    /// `goal_pose`: goals as RViz's "2D Goal Pose" sends them (bt_navigator takes them as
    /// action goals of its own).
    goal_pose: Subscription<PoseStamped>,
    /// `pose`: where it is in `map` (madenet's real-robot interface reads it).
    pose: Publisher<PoseStamped>,
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

/// Where a goal pose is in world coordinates, and its heading there ([`Pose::theta`]), if its
/// frame is one the robot has (`map`, `odom` — the same here —, `base_link`, or empty for
/// `map`). The heading is the quaternion's yaw as tf2's `getYaw` reads it (an all-zero
/// quaternion: 0), as nav2's goal checker does.
fn goal_in_world(
    goal: &PoseStamped,
    robot: Pose,
    frame: &MapFrame,
    ns: &str,
    naming: TfNaming,
) -> Option<(f64, f64, f64)> {
    let f = goal.header.frame_id.trim_start_matches('/');
    let (gx, gy) = (goal.pose.position.x, goal.pose.position.y);
    let gyaw = crate::tf::yaw(&goal.pose.orientation);
    let is = |name: &str| f == naming.frame(ns, name) || f == name;
    let (x, y, yaw) = if f.is_empty() || is("map") || is("odom") {
        (gx, gy, gyaw)
    } else if is("base_link") {
        let (rx, ry, ryaw) = map_pose(frame, robot);
        let (s, c) = ryaw.sin_cos();
        (rx + gx * c - gy * s, ry + gx * s + gy * c, ryaw + gyaw)
    } else {
        return None;
    };
    let (wx, wy) = world_point(frame, x, y);
    Some((wx, wy, frame.origin[2] - yaw))
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

/// The continuous world's robots as nav2 robots (see the module doc): a driver of the one
/// stepping contract ([`madenet_sim::stepping::Stepping`]), so the run loop reports it to the
/// same sinks as every world (a bag and live view of the ground truth, pacing, an interrupt).
/// Its robots wait for goals from outside, never for decisions: it runs until a sink stops
/// it, and [`Nav2Team::finish`] gives what it did.
pub struct Nav2Team {
    world: ContinuousWorld,
    robots: Vec<Robot>,
    clock: Publisher<Clock>,
    _clock_node: Node,
    frame: MapFrame,
    sim: Nav2SimOptions,
    run: Nav2SimRun,
    ticks: u64,
    /// Control periods between two scans (and maps), and between two poses (odom, TF).
    scan_every: u64,
    pose_every: u64,
    /// The middleware error that ended the run, if one did.
    failed: Option<Ros2Error>,
    /// All false: the robots wait for goals, not for decisions.
    deciding: Vec<bool>,
    /// Per robot, for outputs: its goal's cell and its path's cells.
    shown: Vec<(Option<Pos>, Vec<Pos>)>,
}

impl Nav2Team {
    /// Opens every robot's node in `/robot<i>` on the ROS 2 graph `opts` reaches, with its
    /// action server, publishers and static TF.
    pub fn new(
        opts: &Ros2Options,
        world: ContinuousWorld,
        sim: &Nav2SimOptions,
    ) -> Result<Self, Ros2Error> {
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
                goal_pose: node.create_sub("goal_pose", QosProfile::default())?,
                pose: node.create_pub("pose", QosProfile::default())?,
                map: MapPublisher::new(&node, "map")?,
                scan: node.create_pub("scan", QosProfile::default())?,
                odom: node.create_pub("odom", QosProfile::default())?,
                tf,
                _node: node,
                ns,
            });
        }
        let scan_every = (1.0 / (cfg.lidar.rate_hz * cfg.control_period))
            .round()
            .max(1.0) as u64;
        let pose_every = (0.05 / cfg.control_period).round().max(1.0) as u64;
        let cells = (0..n).map(|i| vec![world.cell_of(i)]).collect();
        Ok(Nav2Team {
            world,
            robots,
            clock,
            _clock_node: clock_node,
            frame,
            sim: *sim,
            run: Nav2SimRun {
                outcomes: vec![Vec::new(); n],
                cells,
                ..Default::default()
            },
            ticks: 0,
            scan_every,
            pose_every,
            failed: None,
            deciding: vec![false; n],
            shown: vec![(None, Vec::new()); n],
        })
    }

    /// The simulated world (ground truth).
    pub fn world(&self) -> &ContinuousWorld {
        &self.world
    }

    /// The run so far: goals' outcomes, goals rejected (collisions and time at [`Self::finish`]).
    pub fn outcomes(&self) -> &Nav2SimRun {
        &self.run
    }

    /// What the run did; the middleware error that ended it early, if one did. Goals still
    /// running end ABORTED (UNKNOWN): the robots are gone.
    pub fn finish(mut self) -> Result<Nav2SimRun, Ros2Error> {
        if let Some(e) = self.failed.take() {
            return Err(e);
        }
        for (i, r) in self.robots.iter_mut().enumerate() {
            if let Some(goal) = r.current.take() {
                let why = "the simulation stopped";
                let code = nav2_error::UNKNOWN;
                end(
                    r,
                    &mut self.run.outcomes[i],
                    goal.id,
                    status::ABORTED,
                    code,
                    why,
                )?;
            }
        }
        self.run.refused = self.robots.iter().map(|r| r.server.refused()).sum();
        self.run.collisions = self.world.collisions();
        self.run.time = self.world.time();
        self.run.explored = self.world.explored_fraction();
        self.run.distance = (0..self.robots.len()).map(|i| self.world.distance(i)).sum();
        Ok(self.run)
    }

    /// One control period: goals and cancels, navigation, the world's step, what the robots
    /// publish.
    fn play(&mut self) -> Result<(), Ros2Error> {
        self.take_goals()?;
        let commands = self.navigate()?;
        self.world.step(&commands);
        self.ticks += 1;
        if self.world.time() >= self.run.curve.len() as f64 {
            self.run.curve.push(self.world.explored_fraction());
        }
        for (i, cells) in self.run.cells.iter_mut().enumerate() {
            let cell = self.world.cell_of(i);
            if cells.last() != Some(&cell) {
                cells.push(cell);
            }
        }
        self.publish()
    }

    /// Goals (action goals and `goal_pose` messages) and cancels that came since the last step.
    fn take_goals(&mut self) -> Result<(), Ros2Error> {
        for i in 0..self.robots.len() {
            loop {
                let r = &mut self.robots[i];
                let (id, pose) = match r.server.poll(Duration::ZERO)? {
                    Some(ActionEvent::Goal(g)) => {
                        if !finite(&g.goal().pose) {
                            tracing::warn!("{}: rejected a goal with a non-finite pose", r.ns);
                            self.run.rejected += 1;
                            r.server.reject(g)?;
                            continue;
                        }
                        let pose = g.goal().pose.clone();
                        (Some(r.server.accept(g)?), pose)
                    }
                    Some(ActionEvent::Cancel(id)) => {
                        if r.current.is_some_and(|c| c.id == Some(id)) {
                            r.current = None;
                            r.nav.cancel();
                        }
                        let outcomes = &mut self.run.outcomes[i];
                        end(r, outcomes, Some(id), status::CANCELED, 0, "canceled")?;
                        continue;
                    }
                    None => match r.goal_pose.recv_timeout(Duration::ZERO)? {
                        Some(pose) if finite(&pose) => (None, pose),
                        Some(_) => {
                            tracing::warn!("{}: dropped a goal_pose that is not finite", r.ns);
                            self.run.rejected += 1;
                            continue;
                        }
                        None => break,
                    },
                };
                self.start_goal(i, id, &pose)?;
            }
        }
        Ok(())
    }

    /// Robot `i` takes goal `id` (`None`: from `goal_pose`) to `pose`, preempting the one it
    /// had (which ends ABORTED).
    fn start_goal(&mut self, i: usize, id: GoalId, pose: &PoseStamped) -> Result<(), Ros2Error> {
        let (world, now) = (&self.world, self.world.time());
        let r = &mut self.robots[i];
        let outcomes = &mut self.run.outcomes[i];
        let target = goal_in_world(pose, world.pose(i), &self.frame, &r.ns, self.sim.naming);
        if let Some(old) = r.current.take() {
            let why = "preempted by a new goal";
            end(r, outcomes, old.id, status::ABORTED, 0, why)?;
        }
        let Some(target) = target else {
            let why = "the goal's frame is not in the robot's TF tree";
            return end(r, outcomes, id, status::ABORTED, nav2_error::TF_ERROR, why);
        };
        let mut goal = Active {
            id,
            target,
            since: now,
            last_feedback: f64::NEG_INFINITY,
            retries: 0,
            recoveries: 0,
            recovery: None,
            distance_remaining: 0.0,
        };
        let (x, y, yaw) = target;
        match r.nav.start_pose((x, y), Some(yaw), world, i) {
            Ok(()) => r.current = Some(goal),
            Err(e) => {
                r.current = recover_or_end(r, outcomes, &mut goal, e, world.pose(i), now)?;
            }
        }
        Ok(())
    }

    /// Each robot's command for this step (navigating or recovering), its feedback, and the
    /// goals it ended.
    fn navigate(&mut self) -> Result<Vec<(f64, f64)>, Ros2Error> {
        let (world, frame, sim, now) = (&self.world, &self.frame, &self.sim, self.world.time());
        let speed = world.config().robot.max_speed.max(1e-3);
        let n = self.robots.len();
        let mut commands = vec![(0.0, 0.0); n];
        for (i, command_i) in commands.iter_mut().enumerate() {
            let neighbours = world.neighbours(i);
            let r = &mut self.robots[i];
            let outcomes = &mut self.run.outcomes[i];
            let Some(mut goal) = r.current.take() else {
                self.shown[i] = (None, Vec::new());
                continue;
            };
            let pose = world.pose(i);
            let mut next;
            if let Some(mut rec) = goal.recovery {
                match rec.command(world, i, now) {
                    Some(command) => {
                        *command_i = command;
                        goal.recovery = Some(rec);
                        next = Some(goal);
                    }
                    // Done: the goal again (nav2's RecoveryNode retries its pipeline).
                    None => {
                        goal.recovery = None;
                        let (x, y, yaw) = goal.target;
                        next = match r.nav.start_pose((x, y), Some(yaw), world, i) {
                            Ok(()) => Some(goal),
                            Err(e) => recover_or_end(r, outcomes, &mut goal, e, pose, now)?,
                        };
                    }
                }
            } else {
                match r.nav.step(world, i, &neighbours) {
                    NavStatus::Driving {
                        command,
                        distance_remaining,
                    } => {
                        *command_i = command;
                        goal.distance_remaining = distance_remaining;
                        self.shown[i] = shown(world, &r.nav);
                        next = Some(goal);
                    }
                    NavStatus::Succeeded => {
                        end(r, outcomes, goal.id, status::SUCCEEDED, 0, "")?;
                        next = None;
                    }
                    NavStatus::Failed(e) => {
                        next = recover_or_end(r, outcomes, &mut goal, e, pose, now)?;
                    }
                    NavStatus::Idle => next = None,
                }
            }
            // Feedback every FEEDBACK_PERIOD, recovering or not (action goals only).
            if let Some(g) = next.as_mut() {
                if let Some(id) = g.id.filter(|_| now - g.last_feedback >= FEEDBACK_PERIOD) {
                    g.last_feedback = now;
                    let (x, y, yaw) = map_pose(frame, pose);
                    let mut current_pose = PoseStamped {
                        header: Header {
                            stamp: sim_stamp(now),
                            frame_id: sim.naming.frame(&r.ns, "map"),
                        },
                        ..Default::default()
                    };
                    current_pose.pose = frame.pose(x, y, yaw);
                    r.server.publish_feedback(
                        id,
                        NavigateToPoseFeedback {
                            current_pose,
                            navigation_time: seconds(now - g.since),
                            estimated_time_remaining: seconds(g.distance_remaining / speed),
                            number_of_recoveries: g.recoveries as i16,
                            distance_remaining: g.distance_remaining as f32,
                        },
                    )?;
                }
            }
            r.current = next;
        }
        Ok(commands)
    }

    /// `/clock`, and each robot's scan and map (at the lidar's rate), odom and TF (20 Hz).
    fn publish(&mut self) -> Result<(), Ros2Error> {
        let (world, frame, sim, ticks) = (&self.world, &self.frame, &self.sim, self.ticks);
        let stamp = sim_stamp(world.time());
        self.clock.publish(&Clock { clock: stamp })?;
        for (i, r) in self.robots.iter_mut().enumerate() {
            let base = sim.naming.frame(&r.ns, "base_link");
            if (ticks + i as u64).is_multiple_of(self.scan_every) {
                let mut scan = laser_scan(world, i, stamp);
                scan.header.frame_id = base.clone();
                r.scan.publish(&scan)?;
                let mut grid = thresholded(fine_grid(world, i, frame, stamp));
                grid.header.frame_id = sim.naming.frame(&r.ns, "map");
                r.map.publish(&grid)?;
            }
            if ticks.is_multiple_of(self.pose_every) {
                let (x, y, yaw) = map_pose(frame, world.pose(i));
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
                let mut pose = pose_stamped(world.pose(i), frame, stamp);
                pose.header.frame_id = sim.naming.frame(&r.ns, "map");
                r.pose.publish(&pose)?;
            }
        }
        Ok(())
    }
}

/// A navigating robot's goal and path as agent cells, for outputs (consecutive repeats
/// dropped).
fn shown(world: &ContinuousWorld, nav: &Navigator) -> (Option<Pos>, Vec<Pos>) {
    let c = world.scenario().cell_size;
    let cell = |(x, y): (f64, f64)| Pos::new((y / c).floor() as i32, (x / c).floor() as i32);
    let mut path: Vec<Pos> = nav.path().iter().map(|&p| cell(p)).collect();
    path.dedup();
    (nav.goal().map(cell), path)
}

impl Present for Nav2Team {
    madenet_sim::present_continuous_world!();
    /// Its goal and path; no candidates (goals come from outside).
    fn robot(&self, i: usize) -> RobotShown<'_> {
        let (goal, path) = &self.shown[i];
        RobotShown {
            goal: *goal,
            path,
            decisions: self.run.outcomes[i].len() as u64,
            ..Default::default()
        }
    }
    /// None: the robots talk over ROS 2, not madenet's radio.
    fn contacts(&self) -> Cow<'_, [(usize, usize)]> {
        Cow::Borrowed(&[])
    }
    fn exchanges(&self) -> &[(usize, usize)] {
        &[]
    }
}

impl Stepping for Nav2Team {
    type Outcome = Result<Nav2SimRun, Ros2Error>;

    /// One control period; false once a middleware error ended the run.
    fn step(&mut self) -> bool {
        if self.failed.is_some() {
            return false;
        }
        match self.play() {
            Ok(()) => true,
            Err(e) => {
                self.failed = Some(e);
                false
            }
        }
    }
    /// Only after a middleware error: robots wait for goals until a sink stops the run.
    fn is_done(&self) -> bool {
        self.failed.is_some()
    }
    fn is_complete(&self) -> bool {
        self.world.is_complete()
    }
    fn deciding(&self) -> &[bool] {
        &self.deciding
    }
    fn apply_decisions(&mut self, _: &[Option<Decision>]) {}
    /// None: goals come from outside, over ROS 2.
    fn agents(&self) -> &[Agent] {
        &[]
    }
    /// # Panics
    /// Always: the robots have no agents here (goals come over ROS 2).
    fn agent_mut(&mut self, i: usize) -> &mut Agent {
        panic!("robot {i} of the nav2 sim has no agent: its goals come over ROS 2")
    }
    fn finish(self) -> Self::Outcome {
        Nav2Team::finish(self)
    }
}

/// A sink that ends the run once `.0` is set.
pub struct StopFlag<'a>(pub &'a AtomicBool);

impl<S: ?Sized> Sink<S> for StopFlag<'_> {
    fn step(&mut self, _: &S) -> Result<ControlFlow<String>, SinkError> {
        Ok(match self.0.load(Ordering::Relaxed) {
            true => ControlFlow::Break("stopped".into()),
            false => ControlFlow::Continue(()),
        })
    }
}

/// The nav2 sim on a thread of its own, for tests and tools that drive it from the same
/// process: [`Nav2SimThread::stop`] ends it and gives what it did.
pub struct Nav2SimThread {
    stop: Arc<AtomicBool>,
    handle: std::thread::JoinHandle<Result<Nav2SimRun, Ros2Error>>,
}

impl Nav2SimThread {
    /// Starts [`run_nav2_sim`] on a new thread.
    pub fn spawn(opts: Ros2Options, world: ContinuousWorld, sim: Nav2SimOptions) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let handle = std::thread::spawn(move || run_nav2_sim(&opts, world, &sim, &flag));
        Nav2SimThread { stop, handle }
    }

    /// The flag that ends the run (set it to stop the sim from elsewhere).
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        self.stop.clone()
    }

    /// Ends the run and gives what it did.
    pub fn stop(self) -> Result<Nav2SimRun, Ros2Error> {
        self.stop.store(true, Ordering::Relaxed);
        self.handle.join().unwrap_or_else(|_| {
            Err(Ros2Error::Middleware {
                what: "nav2 sim".into(),
                source: "its thread panicked".into(),
            })
        })
    }
}

/// Runs `world`'s robots as nav2 robots ([`Nav2Team`]) until `stop` is set, paced at
/// `sim.realtime`.
pub fn run_nav2_sim(
    opts: &Ros2Options,
    world: ContinuousWorld,
    sim: &Nav2SimOptions,
    stop: &AtomicBool,
) -> Result<Nav2SimRun, Ros2Error> {
    let mut team = Nav2Team::new(opts, world, sim)?;
    let mut halt = StopFlag(stop);
    let mut pace = Pace::RealTime(sim.realtime);
    let mut sinks: Vec<&mut dyn Sink<Nav2Team>> = vec![&mut halt];
    if sim.realtime > 0.0 {
        sinks.push(&mut pace);
    }
    run(&mut team, &mut sinks).map_err(|e| Ros2Error::Middleware {
        what: "nav2 sim".into(),
        source: e,
    })?;
    team.finish()
}

/// After failure `e` of `goal`, as nav2's default behaviour tree goes on: a failure recovery
/// can help (`WouldAPlannerRecoveryHelp`: NO_VALID_PATH; `WouldAControllerRecoveryHelp`:
/// FAILED_TO_MAKE_PROGRESS) clears the costmap in context, then, while retries are left
/// ([`RETRIES`]), runs the next of the tree's recoveries; otherwise the goal ends ABORTED with
/// `e`'s code and text. (nav2 retries the planner or controller once after the context clear;
/// clearing changes nothing here, so that retry is the same failure and is not simulated.)
fn recover_or_end(
    r: &mut Robot,
    outcomes: &mut Vec<GoalOutcome>,
    goal: &mut Active,
    e: NavError,
    pose: Pose,
    now: f64,
) -> Result<Option<Active>, Ros2Error> {
    let helps = matches!(e, NavError::NoValidPath | NavError::FailedToMakeProgress);
    if helps {
        goal.recoveries += 1; // the context clear
    }
    if !helps || goal.retries >= RETRIES {
        end(
            r,
            outcomes,
            goal.id,
            status::ABORTED,
            nav2_code(e),
            &e.to_string(),
        )?;
        return Ok(None);
    }
    let behaviour = ROUND_ROBIN[goal.retries as usize % ROUND_ROBIN.len()];
    goal.retries += 1;
    // Each costmap clear and each behaviour counts (nav2's `increment_recovery_count`).
    goal.recoveries += match behaviour {
        Behaviour::ClearCostmaps => 2,
        _ => 1,
    };
    tracing::debug!("{}: {e}; retry {} after {behaviour:?}", r.ns, goal.retries);
    goal.recovery = Some(Recovery {
        behaviour,
        since: now,
        from: pose,
        turned: 0.0,
        last_theta: pose.theta,
    });
    Ok(Some(*goal))
}

/// Ends goal `id` of robot `r` and notes its outcome (an unknown or ended action goal:
/// nothing).
fn end(
    r: &mut Robot,
    outcomes: &mut Vec<GoalOutcome>,
    id: GoalId,
    final_status: i8,
    error_code: u16,
    why: &str,
) -> Result<(), Ros2Error> {
    let result = NavigateToPoseResult {
        error_code,
        error_msg: why.to_string(),
    };
    let known = match id {
        Some(id) => r.server.end(id, final_status, result)?,
        None => true,
    };
    if known {
        outcomes.push(GoalOutcome {
            status: final_status,
            error_code,
        });
    }
    Ok(())
}
