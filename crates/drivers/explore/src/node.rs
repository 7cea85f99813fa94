//! One robot's exploration node (`madenet explore`): a ROS 2 node `<ns>/explore_node` that
//! reads the robot's map and its pose from TF, chooses goals, and sends them to the robot's
//! nav2 (`navigate_to_pose`). With teammates, it shares its map, position and goal with them
//! and hears theirs ([`crate::team`]).
//!
//! The loop is the same whatever chooses the goals: it waits for the map and the pose (with a
//! log line, not silently), follows `/clock` with `use_sim_time`, takes each goal's end
//! (succeeded, aborted with nav2's codes, canceled), and plans on a timer and at once when a
//! goal ends. The timer is `planner_frequency` for explore-lite and `decision_frequency` for a
//! madenet policy, whose agent decides when its macro action ends (its goal reached or no
//! longer a frontier), which a plan every few seconds would see late. What plans is one of
//! two choosers:
//! - `policy: explore-lite` ([`crate::lite`]): explore_lite's frontiers on the robot's map —
//!   merged with its teammates' maps when it has teammates;
//! - any other madenet policy (`spread`, `made-net-any`, `nf`, …: [`crate::choice`]): the
//!   paper's agent on the map read into its 1 m cells, hearing its teammates' maps, positions
//!   and goals as the paper's β.
//!
//! Both give a goal up when it has not brought the robot nearer for `progress_timeout`
//! seconds; unreachable goals (aborted, given up) go on a [`Blacklist`] that **expires**
//! ([`BLACKLIST_EXPIRY`] seconds), so a door that opens later is tried again, and a goal that
//! fails again after its retry stays on it. Exploration is **complete** only when nothing is
//! left but goals blacklisted for good; then, with `return_to_init`, the robot drives back to
//! where it started. Every goal is on the map.
//!
//! As explore_lite, with `visualize` it publishes what it weighed on `explore/frontiers`
//! (`visualization_msgs/MarkerArray`: options blue, blacklisted red, the goal green), and
//! `explore/resume` (`std_msgs/Bool`) pauses it (false: the goal under way is canceled) and
//! resumes it (true).
//!
//! Its topic, service and action names are remapped as a ROS node's (`-r from:=to`).

use crate::params::ExploreParams;
use crate::team::Team;
use madenet_ros2::actions::{status, ActionClient, NavigateToPose, NavigateToPoseGoal, SentGoal};
use madenet_ros2::map_updates::MapSubscriber;
use madenet_ros2::msgs::{
    Bool, Clock, ColorRGBA, Header, Marker, MarkerArray, OccupancyGrid, Point, Time,
};
use madenet_ros2::tf::{TfListener, TfNaming};
use madenet_ros2::{QosProfile, Ros2Error, Ros2Options, Subscription};
use std::time::{Duration, Instant};

/// Preempted goals whose results are still awaited, at most.
const SUPERSEDED: usize = 32;

/// Wall time without a pose after which the node says why it still waits.
pub const WAIT_WARNING: Duration = Duration::from_secs(5);

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
    /// Goals canceled because `explore/resume` said false.
    pub paused: usize,
    /// Goals no navigation server answered (not sent).
    pub unanswered: usize,
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

/// What went wrong in a run of the node.
#[derive(Debug, thiserror::Error)]
pub enum ExploreError {
    /// The ROS 2 graph.
    #[error(transparent)]
    Ros2(#[from] Ros2Error),
    /// The policy is unknown, or cannot run on this map or team.
    #[error("policy {name:?}: {why}")]
    Policy {
        /// The policy's name.
        name: String,
        /// Why.
        why: String,
    },
}

/// Goals (points of the map's frame) that failed: each until when, and how often.
#[derive(Clone, Debug, Default)]
pub struct Blacklist {
    listed: Vec<(f64, f64, f64, u32)>,
}

impl Blacklist {
    /// Puts `at` on the list until `now` + [`BLACKLIST_EXPIRY`] (a second failure after its
    /// retry, or `for_good`: for good). Points within `tol` of a listed one are that one.
    pub fn list(&mut self, at: (f64, f64), now: f64, tol: f64, for_good: bool) {
        let near =
            |b: &&mut (f64, f64, f64, u32)| (b.0 - at.0).abs() < tol && (b.1 - at.1).abs() < tol;
        let failures = if for_good { 2 } else { 1 };
        match self.listed.iter_mut().find(near) {
            Some(b) => {
                b.3 = (b.3 + 1).max(failures);
                b.2 = now + BLACKLIST_EXPIRY;
            }
            None => self
                .listed
                .push((at.0, at.1, now + BLACKLIST_EXPIRY, failures)),
        }
    }

    /// Whether `c` is listed now (within `tol` of a listed point).
    pub fn listed(&self, c: (f64, f64), now: f64, tol: f64) -> bool {
        self.listed
            .iter()
            .any(|b| (b.2 > now || b.3 >= 2) && (b.0 - c.0).abs() < tol && (b.1 - c.1).abs() < tol)
    }

    /// Whether `c` is listed for good.
    pub fn for_good(&self, c: (f64, f64), tol: f64) -> bool {
        self.listed
            .iter()
            .any(|b| b.3 >= 2 && (b.0 - c.0).abs() < tol && (b.1 - c.1).abs() < tol)
    }

    /// Whether a point is listed now but not for good (it will be tried again).
    pub fn pending(&self, now: f64) -> bool {
        self.listed.iter().any(|b| b.3 < 2 && b.2 > now)
    }

    /// Whether a listing that is not for good has expired by `now` (kept, to be counted on a
    /// second failure).
    pub fn expired_since(&self, then: f64, now: f64) -> bool {
        self.listed
            .iter()
            .any(|b| b.3 < 2 && b.2 > then && b.2 <= now)
    }

    /// Points listed.
    pub fn len(&self) -> usize {
        self.listed.len()
    }

    /// Whether none is.
    pub fn is_empty(&self) -> bool {
        self.listed.is_empty()
    }
}

/// What a chooser decides when a plan is due.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Choice {
    /// Keep the goal under way (or, with none, wait).
    Keep,
    /// Send a goal to this point of the map's frame (preempting the one under way).
    Send((f64, f64)),
    /// Give the goal under way up (cancel it) and plan again at once.
    GiveUp,
    /// Nothing left to explore.
    Complete,
}

/// What a plan sees: the robot's map, where it is, the time, its team.
pub(crate) struct PlanInput<'a> {
    pub ns: &'a str,
    pub map: &'a OccupancyGrid,
    pub here: (f64, f64),
    pub now: f64,
    pub team: Option<&'a mut Team>,
    /// When nav2's feedback last showed the goal under way nearer along its path (its
    /// `distance_remaining` down by [`FEEDBACK_PROGRESS`]): a robot on a detour makes progress
    /// though it is no nearer in a straight line.
    pub nav_progress_at: Option<f64>,
}

/// Progress towards the goal under way, as both choosers judge it: the least distance to it
/// so far and when it fell; past `progress_timeout` seconds without progress (nav2's feedback
/// counting too) the goal is given up.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Progress {
    best: f64,
    at: f64,
    timeout: f64,
}

impl Progress {
    /// No goal yet; `timeout` is `progress_timeout`.
    pub fn new(timeout: f64) -> Self {
        Progress {
            best: f64::INFINITY,
            at: 0.0,
            timeout,
        }
    }

    /// A new goal, `d` metres away at `now`.
    pub fn restart(&mut self, d: f64, now: f64) {
        (self.best, self.at) = (d, now);
    }

    /// The robot is `d` metres away at `now`: nearer by more than `step` is progress.
    pub fn update(&mut self, d: f64, now: f64, step: f64) {
        if self.best - d > step {
            self.restart(d, now);
        }
    }

    /// Seconds without progress, once they pass the timeout (`nav_progress_at`: nav2's
    /// feedback last showed progress then).
    pub fn stalled(&self, now: f64, nav_progress_at: Option<f64>) -> Option<f64> {
        let since = self.at.max(nav_progress_at.unwrap_or(f64::MIN));
        (now - since > self.timeout).then_some(now - since)
    }
}

/// Metres by which nav2's `distance_remaining` must fall to count as progress.
pub const FEEDBACK_PROGRESS: f32 = 0.25;

/// Chooses the robot's goals ([`crate::lite`], [`crate::choice`]).
pub(crate) trait Chooser {
    /// A plan is due.
    fn plan(&mut self, at: PlanInput<'_>) -> Result<Choice, ExploreError>;
    /// The robot is at `here` (every turn of the node's loop: cells it stood in).
    fn passed(&mut self, _here: (f64, f64)) {}
    /// The goal sent last ended with `status` (`action_msgs/msg/GoalStatus`), or was rejected.
    fn ended(&mut self, status: i8, now: f64);
    /// How many goals are blacklisted (for the log).
    fn blacklisted(&self) -> usize;
    /// What to show on `explore/frontiers`: the points the last plan weighed (frontiers, or
    /// goal candidates) and the blacklisted ones, in the map's frame.
    fn shown(&self) -> Shown;
}

/// What the node shows on `explore/frontiers` (with `visualize`).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Shown {
    /// Frontiers (explore-lite) or goal candidates (madenet policies).
    pub options: Vec<(f64, f64)>,
    /// Points on the blacklist now.
    pub blacklisted: Vec<(f64, f64)>,
}

impl Blacklist {
    /// The points listed now (for good, or not yet expired).
    pub fn points(&self, now: f64) -> Vec<(f64, f64)> {
        self.listed
            .iter()
            .filter(|b| b.2 > now || b.3 >= 2)
            .map(|b| (b.0, b.1))
            .collect()
    }
}

/// `explore/frontiers` as explore_lite draws it: the options as blue spheres, blacklisted
/// points red, the goal under way green (one `SPHERE_LIST` each, after a `DELETEALL`).
fn markers(frame: &str, stamp: Time, shown: &Shown, goal: Option<(f64, f64)>) -> MarkerArray {
    let header = Header {
        stamp,
        frame_id: frame.to_string(),
    };
    let list = |id: i32, pts: &[(f64, f64)], (r, g, b): (f32, f32, f32), size: f64| {
        let mut m = Marker {
            header: header.clone(),
            ns: "frontiers".into(),
            id,
            kind: Marker::SPHERE_LIST,
            action: Marker::ADD,
            color: ColorRGBA { r, g, b, a: 1.0 },
            points: pts.iter().map(|&(x, y)| Point { x, y, z: 0.0 }).collect(),
            ..Default::default()
        };
        m.pose.orientation.w = 1.0;
        (m.scale.x, m.scale.y, m.scale.z) = (size, size, size);
        m
    };
    let clear = Marker {
        header: header.clone(),
        ns: "frontiers".into(),
        action: Marker::DELETEALL,
        ..Default::default()
    };
    MarkerArray {
        markers: vec![
            clear,
            list(0, &shown.options, (0.0, 0.4, 1.0), 0.25),
            list(1, &shown.blacklisted, (1.0, 0.0, 0.0), 0.25),
            list(
                2,
                &goal.into_iter().collect::<Vec<_>>(),
                (0.0, 0.8, 0.2),
                0.35,
            ),
        ],
    }
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
/// at its start, with `return_to_init`) or `stop` says so; its topic, service and action names
/// remapped by `remaps` (`from`, `to`), as a ROS node's `-r from:=to`.
pub fn run(
    opts: &Ros2Options,
    ns: &str,
    p: &ExploreParams,
    remaps: &[(String, String)],
    stop: &dyn Fn() -> bool,
) -> Result<ExploreRun, ExploreError> {
    let mut chooser: Box<dyn Chooser> = match p.policy.as_str() {
        "explore-lite" => Box::new(crate::lite::Lite::new(p)),
        name => Box::new(crate::choice::AgentChoice::new(name, p, ns)?),
    };
    let ctx = opts.context()?;
    let node = ctx.create_node_in(ns, "explore_node")?.with_remaps(remaps);
    let mut maps = MapSubscriber::with_updates(&node, &p.costmap_topic, &p.costmap_updates_topic)?;
    let mut tf = TfListener::new(&node, ns, TfNaming::NamespacedTopics)?;
    let nav = ActionClient::<NavigateToPose>::new(&node, "navigate_to_pose")?;
    let mut team = match p.teammates.is_empty() {
        true => None,
        false => Some(Team::new(&node, ns, &p.teammates)?),
    };
    let frontiers = match p.visualize {
        true => Some(node.create_pub::<MarkerArray>("explore/frontiers", QosProfile::default())?),
        false => None,
    };
    let resume = node.create_sub::<Bool>("explore/resume", QosProfile::default())?;
    let mut paused = false;
    // Whether the last goal found no navigation server.
    let mut unanswered = false;
    let mut clock = NodeClock {
        started: Instant::now(),
        sim: match p.use_sim_time {
            true => Some((node.create_sub("/clock", QosProfile::default())?, 0.0)),
            false => None,
        },
    };
    let mut run = ExploreRun::default();
    let mut goal: Option<(SentGoal<NavigateToPose>, (f64, f64))> = None;
    let mut superseded: Vec<SentGoal<NavigateToPose>> = Vec::new();
    // The goal under way's least distance_remaining in nav2's feedback, and when it fell.
    let (mut nav_best, mut nav_progress_at) = (f32::INFINITY, None);
    let mut next_plan = 0.0;
    let mut start: Option<(f64, f64)> = None;
    let mut waiting_logged = (false, false, false);
    let mut waiting_since: Option<Instant> = None;
    // explore_lite plans on its clock; a madenet policy's agent checks whether its macro
    // action ended (it decides then, as the paper's agents do) at decision_frequency.
    let period = match p.policy.as_str() {
        "explore-lite" => 1.0 / p.planner_frequency,
        _ => 1.0 / p.decision_frequency,
    };
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
        let pose = match tf
            .buffer
            .lookup(frame, &p.robot_base_frame, Time::default(), tol)
        {
            Ok(pose) => pose,
            Err(e) => {
                // Said at once, and why after WAIT_WARNING: a map in another frame than TF's,
                // or a pose that never arrives, is named rather than waited on in silence.
                let waited = waiting_since.get_or_insert_with(Instant::now).elapsed();
                if !waiting_logged.1 {
                    tracing::info!("{ns}: waiting for TF {frame} → {}", p.robot_base_frame);
                    waiting_logged.1 = true;
                } else if waited > WAIT_WARNING && !waiting_logged.2 {
                    tracing::warn!(
                        "{ns}: still no pose after {:.0} s: {e} (the map {} is in frame {frame:?}; TF on {})",
                        waited.as_secs_f64(),
                        maps.topic(),
                        TfNaming::NamespacedTopics.tf_topic(ns),
                    );
                    waiting_logged.2 = true;
                }
                continue;
            }
        };
        waiting_since = None;
        let here = (pose.translation.x, pose.translation.y);
        start.get_or_insert(here);
        chooser.passed(here);
        // explore/resume: false stops (the goal under way canceled), true goes on.
        while let Some(b) = resume.recv_timeout(Duration::ZERO)? {
            if paused == b.data {
                paused = !b.data;
                tracing::info!(
                    "{ns}: exploration {}",
                    if paused { "paused" } else { "resumed" }
                );
                if paused {
                    if let Some((sent, _)) = goal.take() {
                        let _ = nav.cancel(sent.id, Duration::from_secs(5));
                        run.paused += 1;
                        superseded.push(sent);
                    }
                    chooser.ended(status::CANCELED, now);
                }
                next_plan = now;
            }
        }
        if paused {
            continue;
        }
        if let Some(team) = &mut team {
            team.poll(now, frame, ns)?;
        }
        // nav2's feedback on the goal under way: progress along its path.
        while let Some(fb) = nav.feedback(Duration::ZERO)? {
            if goal.as_ref().is_some_and(|(g, _)| g.id == fb.goal_id) {
                let d = fb.feedback.distance_remaining;
                if d.is_finite() && d < nav_best - FEEDBACK_PROGRESS {
                    nav_best = d;
                    nav_progress_at = Some(now);
                }
            }
        }
        // Preempted goals' results, taken as they come (at most SUPERSEDED kept waiting).
        superseded.retain(|g| matches!(g.result(Duration::ZERO), Ok(None)));
        if superseded.len() > SUPERSEDED {
            superseded.remove(0);
        }
        // The goal's end.
        let mut replan = false;
        if let Some((sent, _)) = &goal {
            if let Some((st, _)) = sent.result(Duration::ZERO)? {
                match st {
                    status::SUCCEEDED => run.succeeded += 1,
                    status::CANCELED => {}
                    _ => run.aborted += 1,
                }
                chooser.ended(st, now);
                goal = None;
                replan = true;
            }
        }
        if !replan && now < next_plan {
            continue;
        }
        next_plan = now + period;
        let Some(map) = maps.latest(Duration::ZERO)? else {
            continue;
        };
        if map.info.width as u64 * map.info.height as u64 != map.data.len() as u64
            || map.info.width == 0
        {
            tracing::warn!("{ns}: skipped a map whose size does not match its data");
            continue;
        }
        let stamp = map.header.stamp;
        if let Some(team) = &mut team {
            team.share(map, frame, here, goal.as_ref().map(|g| g.1), stamp)?;
        }
        let choice = chooser.plan(PlanInput {
            ns,
            map,
            here,
            now,
            team: team.as_mut(),
            nav_progress_at,
        })?;
        if let Some(publisher) = &frontiers {
            let under_way = match choice {
                Choice::Send(t) => Some(t),
                Choice::Keep => goal.as_ref().map(|g| g.1),
                _ => None,
            };
            publisher.publish(&markers(frame, stamp, &chooser.shown(), under_way))?;
        }
        match choice {
            Choice::Keep => {}
            Choice::GiveUp => {
                if let Some((sent, _)) = goal.take() {
                    let _ = nav.cancel(sent.id, Duration::from_secs(5));
                    run.given_up += 1;
                    superseded.push(sent);
                }
                next_plan = now;
            }
            Choice::Complete => {
                if let Some((sent, _)) = goal.take() {
                    let _ = nav.cancel(sent.id, Duration::from_secs(5));
                }
                run.complete = true;
                tracing::info!(
                    "{ns}: exploration complete ({} goals blacklisted)",
                    chooser.blacklisted()
                );
                if let Some(team) = &mut team {
                    team.share_goal(frame, None, stamp)?;
                }
                if p.return_to_init {
                    if let Some(s) = start {
                        run.returned = go_to(&nav, frame, s, stop)?;
                    }
                }
                return Ok(run);
            }
            Choice::Send(target) => {
                if let Some((old, _)) = goal.take() {
                    // A new goal preempts the one under way (nav2 aborts the old one itself);
                    // its result is still awaited, so that the answer finds its receiver.
                    run.preempted += 1;
                    superseded.push(old);
                }
                // explore_lite's goal: the point, orientation w = 1.
                let msg = NavigateToPoseGoal::at(frame, target.0, target.1, 0.0);
                match nav.send_goal(msg, Duration::from_secs(10)) {
                    Ok(Some(sent)) => {
                        (nav_best, nav_progress_at) = (f32::INFINITY, None);
                        if std::mem::replace(&mut unanswered, false) {
                            tracing::info!("{ns}: navigate_to_pose answers again");
                        }
                        run.sent += 1;
                        goal = Some((sent, target));
                        if let Some(team) = &mut team {
                            team.share_goal(frame, Some(target), stamp)?;
                        }
                    }
                    Ok(None) => {
                        run.rejected += 1;
                        chooser.ended(status::ABORTED, now);
                    }
                    Err(e) => {
                        // Said when it stops answering, not at every plan after.
                        if !std::mem::replace(&mut unanswered, true) {
                            tracing::warn!("{ns}: navigate_to_pose did not answer: {e} (trying again at each plan)");
                        }
                        run.unanswered += 1;
                        chooser.ended(status::UNKNOWN, now);
                    }
                }
            }
        }
    }
    Ok(run)
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
