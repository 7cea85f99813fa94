//! One robot's exploration node (`madenet explore`): a ROS 2 node `<ns>/explore_node` that
//! reads the robot's map and its pose from TF, chooses frontiers as explore_lite does
//! ([`madenet_nav::frontiers`]) and sends them to the robot's nav2 (`navigate_to_pose`).
//!
//! As explore_lite, it plans on a timer of `planner_frequency` and at once when a goal ends;
//! it sends the cheapest frontier's centroid (orientation w = 1, in the map's frame); a goal
//! that has not brought the robot nearer its frontier for `progress_timeout` seconds is
//! given up (canceled) and blacklisted. Unlike explore_lite:
//! - the blacklist **expires** ([`BLACKLIST_EXPIRY`] seconds), so a door that opens later is
//!   tried again; a frontier that fails again after its retry stays blacklisted;
//! - it waits for the map and the pose with a log line, rather than silently;
//! - exploration is **complete** only when no frontier is left that is not blacklisted for good
//!   (frontiers waiting out a blacklist keep it going), and then, with `return_to_init`, it
//!   drives back to where it started;
//! - every goal is on the map (a centroid off the map's cells is never sent);
//! - a frontier still there when its goal has been reached cannot be seen from there: it is
//!   blacklisted at once (explore_lite waits out its progress timeout); a frontier whose
//!   centroid moved less than the blacklist's tolerance (5 cells) is the same one, and
//!   progress is getting nearer by a cell (explore_lite: 0.01 m and any decrease, so a
//!   flickering map resends goals for ever).
//!
//! Time is the wall clock, or `/clock` with `use_sim_time`. Still to come (issue 58): madenet's
//! policies and the team's shared maps, positions and goals; `explore/frontiers` markers and
//! `explore/resume`; remapping.

use crate::params::ExploreParams;
use madenet_nav::frontiers::{
    occupancy_to_cost, search_from, Connectivity, CostGrid, FrontierParams,
};
use madenet_ros2::actions::{status, ActionClient, NavigateToPose, NavigateToPoseGoal, SentGoal};
use madenet_ros2::map_updates::MapSubscriber;
use madenet_ros2::msgs::{Clock, Time};
use madenet_ros2::tf::{TfListener, TfNaming};
use madenet_ros2::{QosProfile, Ros2Error, Ros2Options, Subscription};
use std::time::{Duration, Instant};

/// Seconds a blacklisted frontier waits before it is tried again.
pub const BLACKLIST_EXPIRY: f64 = 120.0;

/// How a run of the node ended, for callers and tests.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExploreRun {
    /// Goals sent (and accepted); each ends as one of the counts below, or is still under way.
    pub sent: usize,
    /// Goals that succeeded.
    pub succeeded: usize,
    /// Goals aborted by nav2.
    pub aborted: usize,
    /// Goals nav2 rejected (not counted in `sent`).
    pub rejected: usize,
    /// Goals it gave up for lack of progress (canceled).
    pub given_up: usize,
    /// Goals replaced by a goal to a new frontier before they ended (nav2 aborts them).
    pub preempted: usize,
    /// Whether it found exploration complete (rather than being stopped).
    pub complete: bool,
    /// Whether it went back to its start after (`return_to_init`).
    pub returned: bool,
}

impl ExploreRun {
    /// The run in lines for people.
    pub fn summary(&self) -> Vec<String> {
        vec![
            format!(
                "goals      {} sent: {} succeeded, {} aborted, {} given up, {} preempted; {} rejected",
                self.sent, self.succeeded, self.aborted, self.given_up, self.preempted, self.rejected
            ),
            format!(
                "explored   {}{}",
                if self.complete {
                    "complete: no frontier left"
                } else {
                    "stopped before the end"
                },
                if self.returned {
                    ", back at the start"
                } else {
                    ""
                }
            ),
        ]
    }
}

/// A blacklisted frontier centroid: until when, and how often it failed.
#[derive(Clone, Copy, Debug)]
struct Listed {
    at: (f64, f64),
    until: f64,
    failures: u32,
}

/// The node's clock: the wall clock, or `/clock` (`use_sim_time`).
struct NodeClock {
    started: Instant,
    sim: Option<(Subscription<Clock>, f64)>,
}

impl NodeClock {
    fn now(&mut self) -> Result<f64, Ros2Error> {
        match &mut self.sim {
            None => Ok(self.started.elapsed().as_secs_f64()),
            Some((sub, last)) => {
                while let Some(c) = sub.recv_timeout(Duration::ZERO)? {
                    *last = c.clock.sec as f64 + c.clock.nanosec as f64 * 1e-9;
                }
                Ok(*last)
            }
        }
    }
}

/// Runs the node for the robot in namespace `ns` until exploration is complete (and it is back
/// at its start, with `return_to_init`) or `stop` says so.
pub fn run(
    opts: &Ros2Options,
    ns: &str,
    p: &ExploreParams,
    stop: &dyn Fn() -> bool,
) -> Result<ExploreRun, Ros2Error> {
    let ctx = opts.context()?;
    let node = ctx.create_node_in(ns, "explore_node")?;
    let mut maps = MapSubscriber::with_updates(&node, &p.costmap_topic, &p.costmap_updates_topic)?;
    let mut tf = TfListener::new(&node, ns, TfNaming::NamespacedTopics)?;
    let nav = ActionClient::<NavigateToPose>::new(&node, "navigate_to_pose")?;
    let mut clock = NodeClock {
        started: Instant::now(),
        sim: match p.use_sim_time {
            true => Some((node.create_sub("/clock", QosProfile::default())?, 0.0)),
            false => None,
        },
    };
    let fp = FrontierParams {
        potential_scale: p.potential_scale,
        gain_scale: p.gain_scale,
        min_frontier_size: p.min_frontier_size,
    };
    let mut run = ExploreRun::default();
    let mut blacklist: Vec<Listed> = Vec::new();
    let mut goal: Option<(SentGoal<NavigateToPose>, (f64, f64))> = None;
    // The nearest distance to the current frontier, and when it was reached.
    let mut progress = (f64::INFINITY, 0.0);
    // The frontier last chosen (explore_lite's `prev_goal_`): kept after its goal ends, so a
    // frontier still there after its goal succeeded is not sent again but timed out.
    let mut prev_target: Option<(f64, f64)> = None;
    // The frontier of the last goal reached: still there at the next plan, it cannot be seen
    // from where it is reached, and is blacklisted at once.
    let mut reached: Option<(f64, f64)> = None;
    let mut next_plan = 0.0;
    let mut start: Option<(f64, f64)> = None;
    let mut waiting_logged = (false, false);
    let period = 1.0 / p.planner_frequency;
    let wait = Duration::from_millis(20);
    while !stop() {
        tf.spin(Duration::ZERO)?;
        // The map's frame only, every turn; the map itself is read when a plan is due.
        let frame = maps
            .latest(wait)?
            .map(|m| match m.header.frame_id.as_str() {
                "" => "map".to_string(),
                f => f.to_string(),
            });
        let now = clock.now()?;
        let Some(frame) = frame else {
            if !waiting_logged.0 {
                tracing::info!("{ns}: waiting for the map on {}", maps.topic());
                waiting_logged.0 = true;
            }
            continue;
        };
        let frame = frame.as_str();
        let tol = Duration::from_secs_f64(p.transform_tolerance.max(0.05) + 1.0);
        let Ok(pose) = tf
            .buffer
            .lookup(frame, &p.robot_base_frame, Time::default(), tol)
        else {
            if !waiting_logged.1 {
                tracing::info!("{ns}: waiting for TF {frame} → {}", p.robot_base_frame);
                waiting_logged.1 = true;
            }
            continue;
        };
        let here = (pose.translation.x, pose.translation.y);
        start.get_or_insert(here);
        // The goal's end.
        let mut replan = false;
        if let Some((sent, at)) = &goal {
            if let Some((st, _)) = sent.result(Duration::ZERO)? {
                match st {
                    status::SUCCEEDED => {
                        run.succeeded += 1;
                        reached = Some(*at);
                    }
                    status::CANCELED => {}
                    _ => {
                        run.aborted += 1;
                        list(&mut blacklist, *at, now);
                    }
                }
                goal = None;
                replan = true;
            }
        }
        if !replan && now < next_plan {
            continue;
        }
        next_plan = now + period;
        blacklist.retain(|b| b.failures < 2 || b.until > now);
        let Some(map) = maps.latest(Duration::ZERO)? else {
            continue;
        };
        let cost: Vec<u8> = map.data.iter().map(|&v| occupancy_to_cost(v)).collect();
        let grid = CostGrid {
            width: map.info.width as usize,
            height: map.info.height as usize,
            resolution: map.info.resolution as f64,
            origin: (map.info.origin.position.x, map.info.origin.position.y),
            cost: &cost,
            connectivity: Connectivity::Four,
        };
        if grid.width * grid.height != cost.len() || grid.width == 0 {
            tracing::warn!("{ns}: skipped a map whose size does not match its data");
            continue;
        }
        let frontiers = search_from(&grid, here, &fp);
        let on_map = |(x, y): (f64, f64)| {
            let (lx, ly) = (x - grid.origin.0, y - grid.origin.1);
            lx >= 0.0
                && ly >= 0.0
                && lx < grid.width as f64 * grid.resolution
                && ly < grid.height as f64 * grid.resolution
        };
        let tol = 5.0 * grid.resolution;
        let listed = |c: (f64, f64), now: f64| {
            blacklist
                .iter()
                .any(|b| b.until > now && (b.at.0 - c.0).abs() < tol && (b.at.1 - c.1).abs() < tol)
        };
        let forever = |c: (f64, f64)| {
            blacklist.iter().any(|b| {
                b.failures >= 2 && (b.at.0 - c.0).abs() < tol && (b.at.1 - c.1).abs() < tol
            })
        };
        let open: Vec<_> = frontiers
            .iter()
            .filter(|f| on_map(f.centroid) && !forever(f.centroid))
            .collect();
        let Some(f) = open.iter().find(|f| !listed(f.centroid, now)) else {
            if open.is_empty() {
                // Nothing left but frontiers blacklisted for good: done.
                if let Some((sent, _)) = goal.take() {
                    let _ = nav.cancel(sent.id, Duration::from_secs(5));
                }
                run.complete = true;
                tracing::info!(
                    "{ns}: exploration complete ({} frontiers blacklisted)",
                    blacklist.len()
                );
                if p.return_to_init {
                    if let Some(s) = start {
                        run.returned = go_to(&nav, frame, s, stop)?;
                    }
                }
                return Ok(run);
            }
            // Frontiers wait out their blacklist: keep going.
            continue;
        };
        let target = f.centroid;
        // Within the blacklist's tolerance: the same frontier, its centroid moved a little as
        // the map changed (explore_lite's 0.01 m makes a flickering map resend for ever).
        let near = |a: Option<(f64, f64)>| {
            a.is_some_and(|a| (a.0 - target.0).abs() < tol && (a.1 - target.1).abs() < tol)
        };
        if near(reached.take()) {
            list(&mut blacklist, target, now);
            prev_target = None;
            next_plan = now;
            continue;
        }
        let same = near(prev_target);
        prev_target = Some(target);
        // Progress: nearer by a map cell or more.
        if !same || progress.0 - f.min_distance > grid.resolution {
            progress = (f.min_distance, now);
        }
        if same && now - progress.1 > p.progress_timeout {
            // No progress: give it up (cancel), blacklist it, plan again at once.
            if let Some((sent, _)) = goal.take() {
                let _ = nav.cancel(sent.id, Duration::from_secs(5));
                run.given_up += 1;
            }
            list(&mut blacklist, target, now);
            prev_target = None;
            next_plan = now;
            continue;
        }
        if same {
            continue;
        }
        if goal.take().is_some() {
            // A new frontier preempts the goal (nav2 aborts the old one itself).
            run.preempted += 1;
        }
        // explore_lite's goal: the centroid, orientation w = 1.
        let msg = NavigateToPoseGoal::at(frame, target.0, target.1, 0.0);
        match nav.send_goal(msg, Duration::from_secs(10)) {
            Ok(Some(sent)) => {
                run.sent += 1;
                goal = Some((sent, target));
            }
            Ok(None) => {
                run.rejected += 1;
                list(&mut blacklist, target, now);
            }
            Err(e) => {
                tracing::warn!("{ns}: navigate_to_pose did not answer: {e}");
                next_plan = now + period;
            }
        }
    }
    Ok(run)
}

/// Puts `at` on the blacklist until `now` + [`BLACKLIST_EXPIRY`] (a second failure after its
/// retry: for good).
fn list(blacklist: &mut Vec<Listed>, at: (f64, f64), now: f64) {
    let near = |b: &&mut Listed| (b.at.0 - at.0).hypot(b.at.1 - at.1) < 0.01;
    match blacklist.iter_mut().find(|b| near(b)) {
        Some(b) => {
            b.failures += 1;
            b.until = now + BLACKLIST_EXPIRY;
        }
        None => blacklist.push(Listed {
            at,
            until: now + BLACKLIST_EXPIRY,
            failures: 1,
        }),
    }
}

/// Sends the robot to `to` and waits for the result; whether it got there.
fn go_to(
    nav: &ActionClient<NavigateToPose>,
    frame: &str,
    to: (f64, f64),
    stop: &dyn Fn() -> bool,
) -> Result<bool, Ros2Error> {
    let goal = NavigateToPoseGoal::at(frame, to.0, to.1, 0.0);
    let Some(sent) = nav.send_goal(goal, Duration::from_secs(10))? else {
        return Ok(false);
    };
    while !stop() {
        if let Some((st, _)) = sent.result(Duration::from_millis(100))? {
            return Ok(st == status::SUCCEEDED);
        }
    }
    Ok(false)
}
