//! The local planner: drives a robot from where it stands into the next cell of its agent's
//! path, on the robot's own fine map, without touching what it has seen or its teammates.
//!
//! Written here rather than taken from a crate: no maintained Rust crate offers DWA or TEB for
//! a differential-drive robot on an occupancy grid. It is a small DWA-like controller:
//! 1. **Local path.** Straight to the target cell's centre when the footprint (plus margin)
//!    sweeps clear on the robot's map; else A* over the map's pixels around the robot and the
//!    target (two cells of margin), the footprint inflated. No path: the target cell is
//!    impassable for this robot ([`Command::Impassable`]).
//! 2. **Pursuit.** Heading to the farthest point of the local path within twice `lookahead`
//!    that the footprint reaches in a straight line (no corner cutting); turn in place
//!    when it lies more than 60° off the heading, else drive at a speed that falls with the
//!    heading error.
//! 3. **Safety.** The commanded motion, under the acceleration limits, is rolled out over
//!    `prediction_horizon` seconds against the robot's map and against each teammate in view
//!    moving at its current velocity (the paper's constant-velocity prediction); slower speeds
//!    are tried down to turning in place, which a round robot can always do.

use crate::config::ContinuousConfig;
use crate::mapping::RobotMap;
use crate::world::{integrate, normalize_angle, Pose};
use madenet_map::Pos;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Path points considered per pursuit step (in thirds of the candidates looked at).
const PATH_STRIDE: usize = 4;

/// The 8 neighbours of a pixel with their step costs in thousandths of a pixel (√2 ≈ 1.414).
pub(crate) const EIGHT_NEIGHBOURS: [(i64, i64, u64); 8] = [
    (-1, 0, 1000),
    (1, 0, 1000),
    (0, -1, 1000),
    (0, 1, 1000),
    (-1, -1, 1414),
    (-1, 1, 1414),
    (1, -1, 1414),
    (1, 1, 1414),
];

/// Metres within which a path point counts as passed.
const PASSED: f64 = 0.15;

/// A teammate in view, as the planner predicts it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    /// Its pose now.
    pub pose: Pose,
    /// Its (v, ω) now.
    pub velocity: (f64, f64),
    /// Whether it has right of way (lower index): this robot does not drive into its
    /// predicted path; one without right of way is only kept off at contact distance.
    pub priority: bool,
}

/// What the planner asks of the base this control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Drive at (v, ω).
    Drive(f64, f64),
    /// Drive at (v, ω), held up: no safe forward motion toward the target this period.
    Held(f64, f64),
    /// The target cell cannot be reached from here on the robot's map.
    Impassable,
}

/// How far past a cell's edge (in cell sides) a robot must be to have entered it: a robot
/// turning on the line between two cells would otherwise enter both by turns, and its agent,
/// asked at every entry, would send it back and forth for ever.
pub const ENTER_DEPTH: f64 = 0.1;

/// One robot's local planner (it keeps its local path between calls).
#[derive(Clone, Debug, Default)]
pub struct LocalPlanner {
    target: Option<Pos>,
    path: Vec<(f64, f64)>,
}

impl LocalPlanner {
    /// The local path being followed (metres), for pictures.
    pub fn path(&self) -> &[(f64, f64)] {
        &self.path
    }

    /// Whether a robot at `pose` has reached the end of its local path (within the distance
    /// at which path points count as passed).
    pub fn arrived(&self, pose: Pose) -> bool {
        self.path
            .last()
            .is_some_and(|&(px, py)| (px - pose.x).hypot(py - pose.y) < PASSED)
    }

    /// Whether a robot at `pose` has entered `cell` (cells of `cell_size` metres): it stands
    /// [`ENTER_DEPTH`] of a cell past the cell's edge, or at the end of its local path there.
    pub fn entered(&self, pose: Pose, cell: Pos, cell_size: f64) -> bool {
        let (x0, y0) = (cell.col as f64 * cell_size, cell.row as f64 * cell_size);
        let depth = (pose.x - x0)
            .min(x0 + cell_size - pose.x)
            .min(pose.y - y0)
            .min(y0 + cell_size - pose.y);
        depth >= ENTER_DEPTH * cell_size || (depth >= 0.0 && self.arrived(pose))
    }

    /// Forgets the local path (the target changed or the map did).
    pub fn reset(&mut self) {
        self.target = None;
        self.path.clear();
    }

    /// The command for a robot at `pose` moving at `velocity` toward cell `target` (cells of
    /// `cell_size` metres), on `map`, with `neighbours` in view.
    #[allow(clippy::too_many_arguments)]
    pub fn command(
        &mut self,
        cfg: &ContinuousConfig,
        cell_size: f64,
        map: &RobotMap,
        pose: Pose,
        velocity: (f64, f64),
        target: Pos,
        neighbours: &[Neighbour],
        replan: bool,
    ) -> Command {
        let clearance = cfg.robot.radius + cfg.planner.safety_margin;
        let goal = (
            (target.col as f64 + 0.5) * cell_size,
            (target.row as f64 + 0.5) * cell_size,
        );
        let mut blocked_by_teammates = false;
        if replan || self.target != Some(target) || self.path.is_empty() {
            self.target = Some(target);
            self.path.clear();
            // Teammates in view stand where they are, in the way of the local path.
            let others: Vec<(f64, f64)> = neighbours.iter().map(|n| (n.pose.x, n.pose.y)).collect();
            let keep = clearance + cfg.robot.radius;
            let from = (pose.x, pose.y);
            if sweep_clear(map, from, goal, clearance, &others, keep) {
                self.path.push(goal);
            } else if let Some(p) =
                local_astar(map, from, target, cell_size, clearance, &others, keep)
            {
                self.path = p;
            } else {
                // Only the map: impassable; the map but not the teammates: wait for them.
                match local_astar(map, from, target, cell_size, clearance, &[], keep) {
                    Some(p) => {
                        self.path = p;
                        blocked_by_teammates = true;
                    }
                    None => return Command::Impassable,
                }
            }
        }
        // Drop the path points passed, then pursue the farthest of the next ones within
        // twice the lookahead that the footprint can reach in a straight line.
        let passed = self
            .path
            .iter()
            .take_while(|&&(px, py)| (px - pose.x).hypot(py - pose.y) < PASSED)
            .count()
            .min(self.path.len() - 1);
        self.path.drain(..passed);
        let here = (pose.x, pose.y);
        let pursuit = self
            .path
            .iter()
            .take(3 * PATH_STRIDE)
            .enumerate()
            .filter(|&(k, &(px, py))| {
                k == 0 || (px - pose.x).hypot(py - pose.y) <= 2.0 * cfg.planner.lookahead
            })
            .rev()
            .find(|&(k, &p)| k == 0 || sweep_clear(map, here, p, clearance, &[], 0.0))
            .map_or(0, |(k, _)| k);
        let (tx, ty) = self.path[pursuit];
        let bearing = (ty - pose.y).atan2(tx - pose.x);
        let err = normalize_angle(bearing - pose.theta);
        let r = cfg.robot;
        let w = (2.5 * err).clamp(-r.max_turn_rate, r.max_turn_rate);
        let v = if err.abs() > std::f64::consts::FRAC_PI_3 {
            0.0
        } else {
            r.max_speed * err.cos().powi(2)
        };
        if blocked_by_teammates {
            return Command::Held(0.0, 0.0);
        }
        // The rollout drives toward the pursuit point, then brakes: the path bends there.
        let reach = (tx - pose.x).hypot(ty - pose.y);
        // Never closer to what the robot has mapped than it stands; only if that leaves no
        // forward motion at all, slowly, a little closer (`CLEARANCE_TOLERANCE`).
        let strict = rollout_clearance(cfg, map, pose, 0.0);
        let moves = |vs: f64, clearance: f64| {
            vs > 0.0
                && safe(
                    cfg,
                    map,
                    pose,
                    velocity,
                    (vs, w),
                    reach,
                    neighbours,
                    (clearance, strict),
                )
        };
        for scale in [1.0, 0.5, 0.25] {
            let vs = v * scale;
            if moves(vs, strict) {
                return if scale == 1.0 {
                    Command::Drive(vs, w)
                } else {
                    Command::Held(vs, w)
                };
            }
        }
        let vs = v * 0.25;
        if moves(vs, rollout_clearance(cfg, map, pose, CLEARANCE_TOLERANCE)) {
            return Command::Held(vs, w);
        }
        Command::Held(0.0, w)
    }
}

/// Rolls out (v, ω) from `pose` at `velocity` under the acceleration limits for `reach` metres,
/// then braking: the disc of `clearance` ([`rollout_clearance`]) touches nothing on the robot's
/// map within the horizon, and no neighbour moving at constant velocity comes too close (one
/// with right of way: within twice `mate_clearance`).
#[allow(clippy::too_many_arguments)] // the rollout's inputs, each used once
fn safe(
    cfg: &ContinuousConfig,
    map: &RobotMap,
    pose: Pose,
    velocity: (f64, f64),
    command: (f64, f64),
    reach: f64,
    neighbours: &[Neighbour],
    (clearance, mate_clearance): (f64, f64),
) -> bool {
    let r = cfg.robot;
    let dt = 0.1;
    let steps = (cfg.planner.prediction_horizon / dt).ceil() as usize;
    let (mut x, mut y, mut th) = (pose.x, pose.y, pose.theta);
    let (mut v, mut w) = velocity;
    let mut others: Vec<(f64, f64, f64)> = neighbours
        .iter()
        .map(|n| (n.pose.x, n.pose.y, n.pose.theta))
        .collect();
    // Contact plus 2 cm; and how far each teammate stands from us now.
    let touch = 2.0 * r.radius + 0.02;
    let apart: Vec<f64> = neighbours
        .iter()
        .map(|n| (n.pose.x - pose.x).hypot(n.pose.y - pose.y))
        .collect();
    let mut driven = 0.0;
    for k in 0..steps {
        let target_v = if driven < reach { command.0 } else { 0.0 };
        v += (target_v - v).clamp(-r.max_accel * dt, r.max_accel * dt);
        driven += v.abs() * dt;
        w += (command.1 - w).clamp(-r.max_turn_accel * dt, r.max_turn_accel * dt);
        (x, y, th) = integrate(x, y, th, v, w, dt);
        if map.disc_hits_occupied(x, y, clearance) {
            return false;
        }
        for ((o, n), &apart) in others.iter_mut().zip(neighbours).zip(&apart) {
            *o = integrate(o.0, o.1, o.2, n.velocity.0, n.velocity.1, dt);
            let gap = (o.0 - x).hypot(o.1 - y);
            // Right of way: keep out of its predicted path by a margin; otherwise only the
            // first second matters (it will keep off us too).
            let keep = if n.priority {
                2.0 * mate_clearance
            } else {
                touch
            };
            if gap < keep && (n.priority || k < 10) {
                // Moving away from it is always allowed.
                let before = (o.0 - pose.x).hypot(o.1 - pose.y);
                if gap < before {
                    return false;
                }
            }
            // It may also stop where it stands (it brakes for us as we do for it, and a
            // prediction at constant velocity then has it elsewhere): within the first second,
            // never closer than a touch plus 2 cm to where it is now, unless moving away.
            if k < 10 {
                let gap_now = (n.pose.x - x).hypot(n.pose.y - y);
                if gap_now < touch && gap_now < apart {
                    return false;
                }
            }
        }
    }
    true
}

/// Clearance steps, metres: the rollout's clearance is found to this resolution.
const CLEARANCE_STEP: f64 = 0.01;
/// How much closer than it stands a rollout may take a robot to what it has mapped: the
/// local path is planned on pixel centres, and a robot at the edge of its margin would
/// otherwise find every straight line to the path a few centimetres too close, and never move.
const CLEARANCE_TOLERANCE: f64 = 0.02;
/// The least clearance beyond its radius a tolerant rollout may plan for, metres: three
/// standard deviations of the default range noise (a mapped surface can lie that far off).
const CLEARANCE_FLOOR: f64 = 0.03;

/// The clearance a rollout from `pose` must keep from the robot's map: the clearance the robot
/// has now (the margin, radius + `safety_margin`, at most; to [`CLEARANCE_STEP`]) less
/// `tolerance`, but not under [`CLEARANCE_FLOOR`] beyond its radius; a robot already closer
/// than that (something seen late) may not come any closer: it can turn, slide along or
/// leave, which always exists for a round robot.
fn rollout_clearance(cfg: &ContinuousConfig, map: &RobotMap, pose: Pose, tolerance: f64) -> f64 {
    let r = cfg.robot.radius;
    let full = r + cfg.planner.safety_margin;
    let floor = (r + CLEARANCE_FLOOR).min(full);
    let keep = |c: f64| {
        if c >= floor {
            (c - tolerance).max(floor)
        } else {
            c
        }
    };
    if !map.disc_hits_occupied(pose.x, pose.y, full) {
        return keep(full);
    }
    let mut c = full - CLEARANCE_STEP;
    while c > 0.0 {
        if !map.disc_hits_occupied(pose.x, pose.y, c) {
            return keep(c);
        }
        c -= CLEARANCE_STEP;
    }
    0.0
}

/// Whether a disc of `clearance` sweeps from `a` to `b` without touching an occupied pixel,
/// or coming within `keep` of a teammate in `others` (other than one it starts that close to).
fn sweep_clear(
    map: &RobotMap,
    a: (f64, f64),
    b: (f64, f64),
    clearance: f64,
    others: &[(f64, f64)],
    keep: f64,
) -> bool {
    let d = (b.0 - a.0).hypot(b.1 - a.1);
    let n = (d / (map.resolution() * 0.5)).ceil().max(1.0) as usize;
    (0..=n).all(|k| {
        let t = k as f64 / n as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        !map.disc_hits_occupied(x, y, clearance) && !near_teammate(others, (x, y), a, keep)
    })
}

/// Whether `p` lies within `keep` of a teammate that `from` does not already lie that close to.
fn near_teammate(others: &[(f64, f64)], p: (f64, f64), from: (f64, f64), keep: f64) -> bool {
    let near =
        |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).powi(2) + (a.1 - b.1).powi(2) < keep * keep;
    others.iter().any(|&o| near(o, p) && !near(o, from))
}

/// A* over map pixels in the window of cells around `from` and `target` (two cells of margin):
/// 8-connected, a pixel passable when the inflated footprint at its centre touches nothing
/// occupied and keeps `keep` from the teammates in `others` (unknown pixels are passable: the sensor sees them long before the robot gets
/// there). The path ends at the target cell's centre or, if that is blocked, at its passable
/// pixel nearest the centre; it is returned as waypoints in metres (the start excluded).
fn local_astar(
    map: &RobotMap,
    from: (f64, f64),
    target: Pos,
    cell_size: f64,
    clearance: f64,
    others: &[(f64, f64)],
    keep: f64,
) -> Option<Vec<(f64, f64)>> {
    let res = map.resolution();
    let px = |m: f64| crate::mapping::floor(m / res);
    let cell_px = cell_size / res;
    let (fr, fc) = (px(from.1), px(from.0));
    let tr0 = (target.row as f64 * cell_px).floor() as i64;
    let tc0 = (target.col as f64 * cell_px).floor() as i64;
    let tr1 = ((target.row + 1) as f64 * cell_px).ceil() as i64;
    let tc1 = ((target.col + 1) as f64 * cell_px).ceil() as i64;
    let margin = (2.0 * cell_px).ceil() as i64;
    let r0 = (fr.min(tr0) - margin).max(0);
    let c0 = (fc.min(tc0) - margin).max(0);
    let r1 = (fr.max(tr1) + margin).min(map.height() as i64);
    let c1 = (fc.max(tc1) + margin).min(map.width() as i64);
    let (h, w) = ((r1 - r0) as usize, (c1 - c0) as usize);
    if h == 0 || w == 0 {
        return None;
    }
    let centre = |r: i64, c: i64| ((c as f64 + 0.5) * res, (r as f64 + 0.5) * res);
    // The map's inflation answers the footprint test when it is this clearance.
    let inflated = (map.inflation() - clearance).abs() < 1e-12;
    let free: Vec<bool> = (0..h * w)
        .map(|k| {
            let (r, c) = (r0 + (k / w) as i64, c0 + (k % w) as i64);
            let (x, y) = centre(r, c);
            let clear = if inflated {
                !map.blocked(r as usize, c as usize)
            } else {
                !map.disc_hits_occupied(x, y, clearance)
            };
            clear && !near_teammate(others, (x, y), from, keep)
        })
        .collect();
    let idx = |r: i64, c: i64| ((r - r0) as usize) * w + (c - c0) as usize;
    let in_target = |r: i64, c: i64| (tr0..tr1).contains(&r) && (tc0..tc1).contains(&c);
    let goal_centre = (
        (target.col as f64 + 0.5) * cell_size,
        (target.row as f64 + 0.5) * cell_size,
    );
    // The start pixel may lie within the inflation of something the robot brushed past: let
    // it leave.
    let start = (fr.clamp(r0, r1 - 1), fc.clamp(c0, c1 - 1));
    let h_cost = |r: i64, c: i64| {
        let (x, y) = centre(r, c);
        ((x - goal_centre.0).hypot(y - goal_centre.1) / res * 1000.0) as u64
    };
    let mut g = vec![u64::MAX; h * w];
    let mut parent = vec![usize::MAX; h * w];
    let mut heap = BinaryHeap::new();
    let s = idx(start.0, start.1);
    g[s] = 0;
    heap.push(Reverse((h_cost(start.0, start.1), s)));
    let mut reached = None;
    while let Some(Reverse((_, k))) = heap.pop() {
        let (r, c) = (r0 + (k / w) as i64, c0 + (k % w) as i64);
        if in_target(r, c) && free[k] {
            reached = Some(k);
            break;
        }
        for (dr, dc, cost) in EIGHT_NEIGHBOURS {
            let (nr, nc) = (r + dr, c + dc);
            if nr < r0 || nr >= r1 || nc < c0 || nc >= c1 {
                continue;
            }
            let j = idx(nr, nc);
            if !free[j] {
                continue;
            }
            let ng = g[k] + cost;
            if ng < g[j] {
                g[j] = ng;
                parent[j] = k;
                heap.push(Reverse((ng + h_cost(nr, nc), j)));
            }
        }
    }
    let end = reached?;
    let mut cells = vec![end];
    while parent[*cells.last().unwrap()] != usize::MAX {
        cells.push(parent[*cells.last().unwrap()]);
    }
    cells.reverse();
    let mut out: Vec<(f64, f64)> = cells
        .iter()
        .skip(1)
        .map(|&k| centre(r0 + (k / w) as i64, c0 + (k % w) as i64))
        .collect();
    if out.is_empty() {
        out.push(centre(start.0, start.1));
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use madenet_map::discretize::DiscretizeParams;

    /// A pose at (`x`, `y`) facing +x.
    fn facing_east(x: f64, y: f64) -> Pose {
        Pose { x, y, theta: 0.0 }
    }

    fn map_with_wall() -> RobotMap {
        // 4 m × 4 m, 1 m cells; a wall along x = 2.0–2.1 from y = 0 to 3.0 (a gap below).
        let mut m = RobotMap::new(
            40,
            40,
            1.0,
            crate::config::MappingConfig::default(),
            &DiscretizeParams::default(),
        );
        for r in 0..30 {
            let y = r as f64 * 0.1 + 0.05;
            for _ in 0..2 {
                m.integrate_beam(2.05, y, 2.05, y, true);
            }
        }
        m
    }

    #[test]
    fn a_clear_line_is_driven_straight_and_a_wall_is_gone_around() {
        let cfg = ContinuousConfig::default();
        let m = map_with_wall();
        let mut lp = LocalPlanner::default();
        let pose = facing_east(1.5, 3.5);
        // Cell (3, 2) is straight ahead below the wall: a clear line.
        let c = lp.command(&cfg, 1.0, &m, pose, (0.0, 0.0), Pos::new(3, 2), &[], false);
        assert!(matches!(c, Command::Drive(v, _) if v > 0.0), "{c:?}");
        assert_eq!(lp.path().len(), 1);
        // Cell (1, 2) lies behind the wall from (1, 1): around through the gap below.
        let pose = facing_east(1.5, 1.5);
        let c = lp.command(&cfg, 1.0, &m, pose, (0.0, 0.0), Pos::new(1, 2), &[], true);
        assert!(!matches!(c, Command::Impassable), "{c:?}");
        assert!(lp.path().iter().any(|&(_, y)| y > 3.0), "{:?}", lp.path());
    }

    #[test]
    fn a_teammate_that_may_stop_where_it_stands_is_not_driven_into() {
        let cfg = ContinuousConfig::default();
        let m = RobotMap::new(
            40,
            40,
            1.0,
            crate::config::MappingConfig::default(),
            &DiscretizeParams::default(),
        );
        // 0.6 m ahead, driving away at full speed: at constant velocity it stays ahead, but
        // if it stops where it stands we would touch it within the second.
        let ahead = Neighbour {
            pose: facing_east(1.6, 2.0),
            velocity: (0.5, 0.0),
            priority: false,
        };
        let at = |theta: f64| Pose {
            x: 1.0,
            y: 2.0,
            theta,
        };
        let strict = rollout_clearance(&cfg, &m, at(0.0), 0.0);
        let go = |pose: Pose, n: Neighbour| {
            safe(
                &cfg,
                &m,
                pose,
                (0.3, 0.0),
                (0.5, 0.0),
                0.5,
                &[n],
                (strict, strict),
            )
        };
        assert!(!go(at(0.0), ahead), "towards where it stands");
        // Away from it, always; and beside it, out of reach, too.
        assert!(go(at(std::f64::consts::PI), ahead));
        let mut beside = ahead;
        beside.pose.y = 2.5;
        assert!(go(at(0.0), beside));
    }

    #[test]
    fn a_walled_off_cell_is_impassable_and_a_teammate_ahead_holds_us() {
        let cfg = ContinuousConfig::default();
        let mut m = map_with_wall();
        // Close the gap: the wall now runs the whole height.
        for r in 30..40 {
            let y = r as f64 * 0.1 + 0.05;
            for _ in 0..2 {
                m.integrate_beam(2.05, y, 2.05, y, true);
            }
        }
        let mut lp = LocalPlanner::default();
        let pose = facing_east(1.5, 1.5);
        let c = lp.command(&cfg, 1.0, &m, pose, (0.0, 0.0), Pos::new(1, 2), &[], true);
        assert_eq!(c, Command::Impassable);
        let mate = Neighbour {
            pose: Pose {
                x: 1.5,
                y: 1.0,
                theta: std::f64::consts::FRAC_PI_2,
            },
            velocity: (0.0, 0.0),
            priority: true,
        };
        let pose = Pose {
            x: 1.5,
            y: 1.5,
            theta: -std::f64::consts::FRAC_PI_2,
        };
        let c = lp.command(
            &cfg,
            1.0,
            &m,
            pose,
            (0.0, 0.0),
            Pos::new(0, 1),
            &[mate],
            true,
        );
        assert!(matches!(c, Command::Held(v, _) if v == 0.0), "{c:?}");
    }
}
