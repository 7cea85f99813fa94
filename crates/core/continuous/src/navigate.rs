//! Navigation to a point, as nav2's `NavigateToPose` does it for one robot: a global path on
//! the robot's own map, replanned as the map grows, followed by the [`LocalPlanner`], with
//! nav2's goal tolerance and progress checker.
//!
//! A [`Navigator`] per robot. [`Navigator::start`] takes a goal in the world's coordinates
//! (metres, x right, y down, as [`Pose`]) and refuses at once what nav2's planner would refuse:
//! a goal off the map ([`NavError::GoalOutsideMap`]), on an occupied pixel of the robot's map
//! ([`NavError::GoalOccupied`]) or without a path ([`NavError::NoValidPath`]). Then
//! [`Navigator::step`], once per control period before [`ContinuousWorld::step`], gives the
//! command and reports [`NavStatus::Succeeded`] within `xy_goal_tolerance` of the goal point
//! (and, for a goal with a heading, [`Navigator::start_pose`], then turned in place to within
//! `yaw_goal_tolerance` of it), or a failure: the map closed every path ([`NavError::NoValidPath`]), or the robot moved
//! less than `progress_required_movement_radius` in `progress_movement_time_allowance`
//! ([`NavError::FailedToMakeProgress`], nav2's `SimpleProgressChecker`).
//!
//! - **Global path.** A* over the robot's fine map pixels, a pixel passable when the map's
//!   own inflation (the local planner's footprint plus margin) leaves it free, unknown pixels
//!   passable when `allow_unknown`; pixels close to the inflation cost more (nav2's inflation
//!   cost), so paths keep to the middle of doors and corridors.
//! - **Following.** A carrot on the path: the farthest path pixel within `lookahead` metres
//!   (along the path) that the footprint reaches in a straight line on the robot's map, handed
//!   to [`LocalPlanner::command`] as a target *cell* one pixel wide, so that the local planner's
//!   safety rollout (map and teammates) keeps every command. The last carrot is the goal's
//!   own pixel (or, when the footprint cannot stand there, the nearest pixel it can stand on
//!   within the tolerance), so the robot ends within the tolerance of the goal point.
//! - **Replanning.** Every `replan_period` seconds of simulated time, and at once when the
//!   local planner reports [`Command::Impassable`].
//!
//! Deterministic: no random numbers, no hash maps; ties in A* go to the lower pixel index.

use crate::local::{Command, LocalPlanner, Neighbour};
use crate::mapping::{floor, RobotMap};
use crate::world::{ContinuousWorld, Pose};
use madenet_map::Pos;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The navigator's parameters; defaults as nav2 Jazzy has them where nav2 has them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavParams {
    /// Metres from the goal point within which the goal is reached (nav2's goal checker
    /// `xy_goal_tolerance`, default 0.25).
    pub xy_goal_tolerance: f64,
    /// Radians from a goal's heading within which it is reached, once the robot is within
    /// `xy_goal_tolerance` (nav2's `SimpleGoalChecker.yaw_goal_tolerance`, default 0.25; the
    /// checker is stateful, as nav2's default: once in position, the robot only turns).
    pub yaw_goal_tolerance: f64,
    /// Metres the robot must move from where the progress checker last reset (nav2's
    /// `SimpleProgressChecker.required_movement_radius`, default 0.5).
    pub progress_required_movement_radius: f64,
    /// Seconds of simulated time within which it must move that far (nav2's
    /// `SimpleProgressChecker.movement_time_allowance`, default 10).
    pub progress_movement_time_allowance: f64,
    /// Whether the global planner plans through unknown space (nav2's planner
    /// `allow_unknown`, default true).
    pub allow_unknown: bool,
    /// Seconds of simulated time between two global plans (default 1: nav2's default
    /// behaviour tree replans at 1 Hz).
    pub replan_period: f64,
    /// Metres along the path to the carrot handed to the local planner (default 1.0).
    pub lookahead: f64,
}

impl Default for NavParams {
    fn default() -> Self {
        NavParams {
            xy_goal_tolerance: 0.25,
            yaw_goal_tolerance: 0.25,
            progress_required_movement_radius: 0.5,
            progress_movement_time_allowance: 10.0,
            allow_unknown: true,
            replan_period: 1.0,
            lookahead: 1.0,
        }
    }
}

/// Why navigation to a goal was refused or failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NavError {
    /// The goal is not a finite point on the map.
    #[error("the goal is outside the map")]
    GoalOutsideMap,
    /// The goal's pixel is occupied on the robot's map (observed, probability above the
    /// map's occupied threshold, 0.65 by default as slam_toolbox's and map_server's).
    #[error("the goal is occupied on the robot's map")]
    GoalOccupied,
    /// No path to the goal on the robot's map.
    #[error("no valid path to the goal")]
    NoValidPath,
    /// The robot moved too little for too long (the progress checker).
    #[error("the robot failed to make progress")]
    FailedToMakeProgress,
}

/// What [`Navigator::step`] reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NavStatus {
    /// No goal.
    Idle,
    /// On the way: drive at `command` (v m/s, ω rad/s) this control period.
    Driving {
        /// (v, ω) for the robot this control period.
        command: (f64, f64),
        /// Metres left along the current path.
        distance_remaining: f64,
    },
    /// The robot stands within `xy_goal_tolerance` of the goal, facing its heading if it has
    /// one (the navigator is idle again).
    Succeeded,
    /// Navigation failed (the navigator is idle again).
    Failed(NavError),
}

/// One robot's navigator (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct Navigator {
    params: NavParams,
    goal: Option<(f64, f64)>,
    /// The goal's heading (world frame), if it has one.
    goal_yaw: Option<f64>,
    /// Within `xy_goal_tolerance` once: only the heading is left (stateful goal checker).
    in_position: bool,
    /// The global path, pixel centres in metres, from the robot's pixel to the goal's.
    path: Vec<(f64, f64)>,
    /// Metres along the path from each point to its end.
    remaining: Vec<f64>,
    /// The path point the robot has come closest to (the path before it is done).
    along: usize,
    planned_at: f64,
    local: LocalPlanner,
    /// The progress checker's reset point: where and when.
    progress: ((f64, f64), f64),
    replans: u64,
}

/// Extra A* cost (per step, thousandths of a pixel) of a pixel one and two pixels from the
/// inflation: paths keep off walls where there is room.
const NEAR_COST: [u64; 2] = [1500, 500];

impl Navigator {
    /// An idle navigator with `params`.
    pub fn new(params: NavParams) -> Self {
        Navigator {
            params,
            goal: None,
            goal_yaw: None,
            in_position: false,
            path: Vec::new(),
            remaining: Vec::new(),
            along: 0,
            planned_at: 0.0,
            local: LocalPlanner::default(),
            progress: ((0.0, 0.0), 0.0),
            replans: 0,
        }
    }

    /// The parameters.
    pub fn params(&self) -> &NavParams {
        &self.params
    }

    /// The goal being navigated to, if any (world metres).
    pub fn goal(&self) -> Option<(f64, f64)> {
        self.goal
    }

    /// The current global path (pixel centres, world metres), for pictures and feedback.
    pub fn path(&self) -> &[(f64, f64)] {
        &self.path
    }

    /// Global plans made since this navigator was built.
    pub fn replans(&self) -> u64 {
        self.replans
    }

    /// Starts navigating robot `i` of `world` to `goal` (world metres); refuses a goal off the
    /// map, on an occupied pixel of the robot's map, or without a path on it. A goal already
    /// being navigated to is replaced (nav2's preemption). On refusal the navigator is idle.
    pub fn start(
        &mut self,
        goal: (f64, f64),
        world: &ContinuousWorld,
        i: usize,
    ) -> Result<(), NavError> {
        self.start_pose(goal, None, world, i)
    }

    /// [`Navigator::start`] with a heading to reach as well: `yaw` (rad, the world's
    /// [`Pose::theta`]), within `yaw_goal_tolerance` once in position (turning in place).
    pub fn start_pose(
        &mut self,
        goal: (f64, f64),
        yaw: Option<f64>,
        world: &ContinuousWorld,
        i: usize,
    ) -> Result<(), NavError> {
        self.cancel();
        if yaw.is_some_and(|y| !y.is_finite()) {
            return Err(NavError::GoalOutsideMap);
        }
        let map = world.map(i);
        goal_pixel(map, goal)?;
        let pose = world.pose(i);
        self.plan(map, pose, goal)?;
        self.goal = Some(goal);
        self.goal_yaw = yaw;
        self.planned_at = world.time();
        self.progress = ((pose.x, pose.y), world.time());
        Ok(())
    }

    /// Forgets the goal: the navigator is idle.
    pub fn cancel(&mut self) {
        self.goal = None;
        self.goal_yaw = None;
        self.in_position = false;
        self.path.clear();
        self.remaining.clear();
        self.along = 0;
        self.local.reset();
    }

    /// The command for robot `i` of `world` this control period (call before
    /// [`ContinuousWorld::step`]), with `neighbours` its teammates in view.
    pub fn step(
        &mut self,
        world: &ContinuousWorld,
        i: usize,
        neighbours: &[Neighbour],
    ) -> NavStatus {
        let Some(goal) = self.goal else {
            return NavStatus::Idle;
        };
        let pose = world.pose(i);
        let map = world.map(i);
        let now = world.time();
        let fail = |nav: &mut Self, e: NavError| {
            nav.cancel();
            NavStatus::Failed(e)
        };
        if self.in_position
            || (pose.x - goal.0).hypot(pose.y - goal.1) <= self.params.xy_goal_tolerance
        {
            self.in_position = true;
            let turn = self
                .goal_yaw
                .map_or(0.0, |yaw| crate::world::normalize_angle(yaw - pose.theta));
            if turn.abs() <= self.params.yaw_goal_tolerance {
                self.cancel();
                return NavStatus::Succeeded;
            }
            // Turn in place toward the heading (always safe), proportionally, so the turn
            // rate's acceleration limit does not swing it past.
            let max = world.config().robot.max_turn_rate;
            return NavStatus::Driving {
                command: (0.0, (2.0 * turn).clamp(-max, max)),
                distance_remaining: 0.0,
            };
        }
        // The progress checker (nav2's SimpleProgressChecker).
        let (base, since) = self.progress;
        if (pose.x - base.0).hypot(pose.y - base.1) > self.params.progress_required_movement_radius
        {
            self.progress = ((pose.x, pose.y), now);
        } else if now - since > self.params.progress_movement_time_allowance {
            return fail(self, NavError::FailedToMakeProgress);
        }
        if let Err(e) = goal_pixel(map, goal) {
            return fail(self, e);
        }
        let mut replanned = false;
        if now - self.planned_at >= self.params.replan_period - 1e-9 {
            if let Err(e) = self.plan(map, pose, goal) {
                return fail(self, e);
            }
            self.planned_at = now;
            replanned = true;
        }
        let cfg = world.config();
        let velocity = world.velocity(i);
        let mut command = None;
        for attempt in 0..2 {
            let carrot = self.carrot(map, pose);
            let res = map.resolution();
            let target = Pos::new(floor(carrot.1 / res) as i32, floor(carrot.0 / res) as i32);
            match self
                .local
                .command(cfg, res, map, pose, velocity, target, neighbours, replanned)
            {
                Command::Drive(v, w) | Command::Held(v, w) => {
                    command = Some((v, w));
                    break;
                }
                Command::Impassable if attempt == 0 => {
                    // The map changed under the path: plan again at once.
                    if let Err(e) = self.plan(map, pose, goal) {
                        return fail(self, e);
                    }
                    self.planned_at = now;
                    replanned = true;
                }
                // Still no way to the carrot: hold still (turning in place is always safe)
                // until the next plan or the progress checker decides.
                Command::Impassable => {}
            }
        }
        let command = command.unwrap_or((0.0, 0.0));
        let k = self.along.min(self.path.len().saturating_sub(1));
        let distance_remaining = self.path.get(k).map_or(0.0, |&(px, py)| {
            (px - pose.x).hypot(py - pose.y) + self.remaining[k]
        });
        NavStatus::Driving {
            command,
            distance_remaining,
        }
    }

    /// Plans the global path for a robot at `pose` to `goal` on `map`.
    fn plan(&mut self, map: &RobotMap, pose: Pose, goal: (f64, f64)) -> Result<(), NavError> {
        self.replans += 1;
        let path =
            global_path(map, (pose.x, pose.y), goal, &self.params).ok_or(NavError::NoValidPath)?;
        let mut remaining = vec![0.0; path.len()];
        for k in (0..path.len().saturating_sub(1)).rev() {
            let (a, b) = (path[k], path[k + 1]);
            remaining[k] = remaining[k + 1] + (a.0 - b.0).hypot(a.1 - b.1);
        }
        self.path = path;
        self.remaining = remaining;
        self.along = 0;
        Ok(())
    }

    /// The point of the path to drive to: the farthest within `lookahead` metres along the
    /// path from the point nearest the robot that the footprint reaches in a straight line.
    fn carrot(&mut self, map: &RobotMap, pose: Pose) -> (f64, f64) {
        let here = (pose.x, pose.y);
        let d = |p: (f64, f64)| (p.0 - here.0).hypot(p.1 - here.1);
        // Move `along` forward to the nearest point within the next lookahead of path.
        let start = self.along;
        let mut best = (d(self.path[start]), start);
        for k in start..self.path.len() {
            if self.remaining[start] - self.remaining[k] > self.params.lookahead {
                break;
            }
            if d(self.path[k]) < best.0 {
                best = (d(self.path[k]), k);
            }
        }
        self.along = best.1;
        let from = self.along;
        let clearance = map.inflation();
        let mut pick = (from + 1).min(self.path.len() - 1);
        for k in from + 1..self.path.len() {
            if self.remaining[from] - self.remaining[k] > self.params.lookahead {
                break;
            }
            if sweep_clear(map, here, self.path[k], clearance) {
                pick = k;
            }
        }
        self.path[pick]
    }
}

/// The pixel (row, column) of `goal` on `map`, or why it cannot be a goal.
fn goal_pixel(map: &RobotMap, goal: (f64, f64)) -> Result<(usize, usize), NavError> {
    let res = map.resolution();
    let (w, h) = (map.width() as f64 * res, map.height() as f64 * res);
    if !(goal.0.is_finite() && goal.1.is_finite())
        || goal.0 < 0.0
        || goal.1 < 0.0
        || goal.0 >= w
        || goal.1 >= h
    {
        return Err(NavError::GoalOutsideMap);
    }
    let (r, c) = (
        (floor(goal.1 / res) as usize).min(map.height() - 1),
        (floor(goal.0 / res) as usize).min(map.width() - 1),
    );
    if map.observed(r, c) && map.occupied(r, c) {
        return Err(NavError::GoalOccupied);
    }
    Ok((r, c))
}

/// Whether the disc of `clearance` sweeps from `a` to `b` without touching an occupied pixel
/// (the local planner's straight-line test: samples every half pixel).
fn sweep_clear(map: &RobotMap, a: (f64, f64), b: (f64, f64), clearance: f64) -> bool {
    let d = (b.0 - a.0).hypot(b.1 - a.1);
    let n = (d / (map.resolution() * 0.5)).ceil().max(1.0) as usize;
    (0..=n).all(|k| {
        let t = k as f64 / n as f64;
        !map.disc_hits_occupied(a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t, clearance)
    })
}

/// The global planner: A* over `map`'s pixels from `from` to `goal` (metres), 8-connected
/// without cutting blocked corners. A pixel is passable when the map's inflation leaves it
/// free (the local planner's own footprint test, so a path exists exactly where the robot
/// fits: 1 m doors pass, and a coarse cell half filled by a wall's end blocks nothing) and,
/// unless `allow_unknown`, it is observed. The robot may leave a blocked start within its
/// footprint's reach. The path ends at the goal's pixel, or when the footprint cannot stand
/// there, at the nearest pixel within 80 % of the goal tolerance it can stand on. Pixel
/// centres in metres, the start's first.
fn global_path(
    map: &RobotMap,
    from: (f64, f64),
    goal: (f64, f64),
    params: &NavParams,
) -> Option<Vec<(f64, f64)>> {
    let res = map.resolution();
    let (h, w) = (map.height(), map.width());
    let pixel = |p: (f64, f64)| {
        (
            floor(p.1 / res).clamp(0, h as i64 - 1) as usize,
            floor(p.0 / res).clamp(0, w as i64 - 1) as usize,
        )
    };
    let centre = |k: usize| (((k % w) as f64 + 0.5) * res, ((k / w) as f64 + 0.5) * res);
    let (sr, sc) = pixel(from);
    let (gr, gc) = pixel(goal);
    let start = sr * w + sc;
    let escape = map.inflation() + res;
    let passable = |r: usize, c: usize| {
        if !params.allow_unknown && !map.observed(r, c) {
            return false;
        }
        if !map.blocked(r, c) {
            return true;
        }
        // Leaving a start inside the inflation (something seen late): never onto an
        // occupied pixel.
        let (x, y) = centre(r * w + c);
        !map.occupied(r, c) && (x - from.0).hypot(y - from.1) < escape
    };
    // Goal pixels: the goal's, or the passable ones near it when the footprint cannot stand
    // there.
    let goal_ok = passable(gr, gc) && !map.blocked(gr, gc);
    let near_goal = 0.8 * params.xy_goal_tolerance;
    let is_goal = |k: usize| {
        if goal_ok {
            k == gr * w + gc
        } else {
            let (x, y) = centre(k);
            !map.blocked(k / w, k % w) && (x - goal.0).hypot(y - goal.1) <= near_goal
        }
    };
    let slack = if goal_ok { 0.0 } else { near_goal };
    let h_cost = |k: usize| {
        let (x, y) = centre(k);
        let d = ((x - goal.0).hypot(y - goal.1) - slack).max(0.0);
        (d / res * 1000.0) as u64
    };
    // Extra cost near the inflation (nav2's inflation cost): 0, 1 or 2 pixels from it.
    let near = |r: usize, c: usize| -> u64 {
        let ring = |d: i64| {
            (-d..=d).any(|dr| {
                (-d..=d).any(|dc| {
                    let (nr, nc) = (r as i64 + dr, c as i64 + dc);
                    nr >= 0
                        && nc >= 0
                        && (nr as usize) < h
                        && (nc as usize) < w
                        && map.blocked(nr as usize, nc as usize)
                })
            })
        };
        if ring(1) {
            NEAR_COST[0]
        } else if ring(2) {
            NEAR_COST[1]
        } else {
            0
        }
    };
    let mut g = vec![u64::MAX; h * w];
    let mut parent = vec![usize::MAX; h * w];
    let mut closed = vec![false; h * w];
    let mut heap = BinaryHeap::new();
    g[start] = 0;
    heap.push(Reverse((h_cost(start), start)));
    let mut reached = None;
    while let Some(Reverse((_, k))) = heap.pop() {
        if closed[k] {
            continue;
        }
        closed[k] = true;
        if is_goal(k) {
            reached = Some(k);
            break;
        }
        let (r, c) = ((k / w) as i64, (k % w) as i64);
        let open = |dr: i64, dc: i64| {
            let (nr, nc) = (r + dr, c + dc);
            nr >= 0
                && nc >= 0
                && (nr as usize) < h
                && (nc as usize) < w
                && passable(nr as usize, nc as usize)
        };
        for (dr, dc, step) in crate::local::EIGHT_NEIGHBOURS {
            if !open(dr, dc) || (dr != 0 && dc != 0 && !(open(dr, 0) && open(0, dc))) {
                continue;
            }
            let (nr, nc) = ((r + dr) as usize, (c + dc) as usize);
            let j = nr * w + nc;
            if closed[j] {
                continue;
            }
            let ng = g[k] + step + near(nr, nc) * step / 1000;
            if ng < g[j] {
                g[j] = ng;
                parent[j] = k;
                heap.push(Reverse((ng + h_cost(j), j)));
            }
        }
    }
    let end = reached?;
    let mut cells = vec![end];
    while parent[*cells.last().unwrap()] != usize::MAX {
        cells.push(parent[*cells.last().unwrap()]);
    }
    cells.reverse();
    Some(cells.into_iter().map(centre).collect())
}
