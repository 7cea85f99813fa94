//! **explore-lite**: the choice of explore_lite (`m-explore-ros2`), what ROS 2 users run today
//! to explore with a robot, as a madenet policy, so that it can be compared with madenet's
//! inside one tool (issue 58).
//!
//! Each robot on its own, as explore_lite runs one node per robot: on a timer of
//! `planner_frequency` (and at once when its goal is reached), explore_lite's frontier search
//! ([`madenet_nav::frontiers`]) on the robot's map, the cheapest frontier whose centroid is not
//! blacklisted (within 5 cells in x and y of a blacklisted one) becomes the goal; a goal that
//! has not brought the robot nearer its frontier for `progress_timeout` seconds is
//! blacklisted and the next taken; no frontier, or none off the blacklist, stops the robot for
//! good (explore_lite's "No frontiers found, stopping.").
//!
//! Adapted to the grid world, where a robot plans through its known free cells only (nav2
//! plans through unknown space to the centroid itself): the goal is the known free cell next
//! to the frontier that is nearest its centroid; one the robot cannot reach is blacklisted at
//! once, as nav2 would abort it. Maps are read as explore_lite's costmap at nav2's 0.05 m
//! (each 1 m cell a block of 20 × 20 pixels, so frontier sizes, the blacklist's 5 pixels and
//! the centroid's quirk weigh as on a robot): free 0, obstacle 254, unknown 255, in the `map`
//! frame (y up from the bottom-left corner). Where robots step diagonally between two
//! obstacles (`Movement::CornerCutting`, the default), the search and the frontiers' free
//! neighbours are 8-connected: on 1 m cells a diagonal line of obstacles is no wall, and
//! explore_lite's 4-connected search would stop the robot behind one. Still, a frontier seen
//! only across such a corner touches the free space in one pixel, below `min_frontier_size`,
//! and is ignored, as explore_lite would ignore it: on maps with diagonal squeezes (the
//! generator's random maps) explore-lite can stop with cells unexplored; on floor plans it
//! does not. `return_to_init` is not simulated: a trial's time ends with the exploration.
//!
//! Defaults are those of explore_lite's shipped `params.yaml`, which its launch file loads.

use madenet_agent::{AgentView, Decision, DecisionMode, Policy};
use madenet_map::{Movement, Occupancy, Pos};
use madenet_nav::frontiers::{
    search_from, Connectivity, CostGrid, FrontierParams, FREE_SPACE, LETHAL, NO_INFORMATION,
};
use serde::{Deserialize, Serialize};

/// explore_lite's parameters that shape its choice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExploreLiteParams {
    /// Plans per second (explore_lite's `planner_frequency`; its params.yaml: 0.15).
    pub planner_frequency: f64,
    /// Seconds without progress toward a frontier before it is blacklisted
    /// (`progress_timeout`; 30).
    pub progress_timeout: f64,
    /// Weight of a frontier's distance (`potential_scale`; 3.0).
    pub potential_scale: f64,
    /// Weight of its size (`gain_scale`; 1.0).
    pub gain_scale: f64,
    /// Metres; shorter frontiers are ignored (`min_frontier_size`; 0.75).
    pub min_frontier_size: f64,
}

impl Default for ExploreLiteParams {
    fn default() -> Self {
        ExploreLiteParams {
            planner_frequency: 0.15,
            progress_timeout: 30.0,
            potential_scale: 3.0,
            gain_scale: 1.0,
            min_frontier_size: 0.75,
        }
    }
}

impl ExploreLiteParams {
    /// Checks the ranges; the error names the field (`explore_lite.planner_frequency`, …).
    pub fn validate(&self) -> Result<(), String> {
        for (name, v, lo_open) in [
            ("planner_frequency", self.planner_frequency, true),
            ("progress_timeout", self.progress_timeout, true),
            ("potential_scale", self.potential_scale, false),
            ("gain_scale", self.gain_scale, false),
            ("min_frontier_size", self.min_frontier_size, false),
        ] {
            let ok = v.is_finite() && if lo_open { v > 0.0 } else { v >= 0.0 } && v <= 1e6;
            if !ok {
                let range = if lo_open { "(0, 1e6]" } else { "[0, 1e6]" };
                return Err(format!("explore_lite.{name}: must be in {range}, got {v}"));
            }
        }
        Ok(())
    }
}

/// nav2's default costmap resolution (m), at which explore_lite's sizes and tolerances are
/// meant: the belief's cells are searched as blocks of pixels this size.
const COSTMAP_RESOLUTION: f64 = 0.05;

/// One robot's explore_lite ([module docs](self)).
#[derive(Clone, Debug)]
pub struct ExploreLite {
    params: ExploreLiteParams,
    /// Metres per costmap pixel, and pixels a side per grid cell.
    resolution: f64,
    upsample: usize,
    /// Metres per grid cell.
    cell_size: f64,
    /// Timesteps between two timer plans.
    period: usize,
    next_plan: usize,
    /// The frontier pursued (its centroid, metres in `map`) and the goal cell sent for it.
    target: Option<(f64, f64)>,
    goal: Option<Pos>,
    prev_distance: f64,
    last_progress: usize,
    blacklist: Vec<(f64, f64)>,
    stopped: bool,
    cost: Vec<u8>,
}

impl ExploreLite {
    /// A robot's explore_lite on cells of `cell_size` metres, one grid timestep a second.
    pub fn new(params: ExploreLiteParams, cell_size: f64) -> Self {
        let period = (1.0 / params.planner_frequency).round().max(1.0) as usize;
        let upsample = (cell_size / COSTMAP_RESOLUTION).round().clamp(1.0, 64.0) as usize;
        ExploreLite {
            params,
            resolution: cell_size / upsample as f64,
            upsample,
            cell_size,
            period,
            next_plan: 0,
            target: None,
            goal: None,
            prev_distance: 0.0,
            last_progress: 0,
            blacklist: Vec::new(),
            stopped: false,
            cost: Vec::new(),
        }
    }

    fn on_blacklist(&self, p: (f64, f64)) -> bool {
        // explore_lite's 5 costmap cells.
        let tol = 5.0 * self.resolution;
        self.blacklist
            .iter()
            .any(|b| (p.0 - b.0).abs() < tol && (p.1 - b.1).abs() < tol)
    }

    /// explore_lite's `makePlan`: the goal after this plan (`None`: stop, or wait for a map).
    fn make_plan(&mut self, view: &mut AgentView<'_>) -> Option<Pos> {
        let b = view.belief;
        if !b.is_free(view.pos) {
            // No map around the robot yet (before its first reading): explore_lite waits for
            // its costmap before it plans.
            return None;
        }
        // The belief as a costmap of `k × k` pixels a cell, in the map frame: row 0 of the
        // costmap is the bottom of the belief's bottom row.
        let (w, h, k) = (b.width(), b.height(), self.upsample);
        let (fw, fh) = (w * k, h * k);
        self.cost.clear();
        self.cost.resize(fw * fh, NO_INFORMATION);
        for row in 0..h {
            for col in 0..w {
                let v = match b.get(Pos::new(row as i32, col as i32)) {
                    Occupancy::Free => FREE_SPACE,
                    Occupancy::Obstacle => LETHAL,
                    Occupancy::Unknown => NO_INFORMATION,
                };
                let my0 = (h - 1 - row) * k;
                for my in my0..my0 + k {
                    self.cost[my * fw + col * k..my * fw + (col + 1) * k].fill(v);
                }
            }
        }
        let grid = CostGrid {
            width: fw,
            height: fh,
            resolution: self.resolution,
            origin: (0.0, 0.0),
            cost: &self.cost,
            // A diagonal line of obstacles is no wall to robots that cut corners.
            connectivity: match b.movement() {
                Movement::CornerCutting => Connectivity::Eight,
                Movement::NoCornerCutting => Connectivity::Four,
            },
        };
        let cell = self.cell_size;
        let to_map = |p: Pos| {
            (
                (p.col as f64 + 0.5) * cell,
                ((h as i32 - 1 - p.row) as f64 + 0.5) * cell,
            )
        };
        let to_cell = |(x, y): (f64, f64)| {
            let (mx, my) = ((x / cell).floor() as i32, (y / cell).floor() as i32);
            Pos::new(h as i32 - 1 - my, mx)
        };
        let params = FrontierParams {
            potential_scale: self.params.potential_scale,
            gain_scale: self.params.gain_scale,
            min_frontier_size: self.params.min_frontier_size,
        };
        let frontiers = search_from(&grid, to_map(view.pos), &params);
        let t = view.t;
        for f in &frontiers {
            if self.on_blacklist(f.centroid) {
                continue;
            }
            let same = self
                .target
                .is_some_and(|p| (p.0 - f.centroid.0).hypot(p.1 - f.centroid.1) < 0.01);
            if !same || self.prev_distance > f.min_distance {
                self.last_progress = t;
                self.prev_distance = f.min_distance;
            }
            self.target = Some(f.centroid);
            if (t - self.last_progress) as f64 > self.params.progress_timeout {
                self.blacklist.push(f.centroid);
                continue;
            }
            if same && self.goal.is_some() {
                return self.goal;
            }
            // The known free cell next to the frontier nearest its centroid that the robot
            // can reach.
            let mut cells: Vec<Pos> = std::iter::once(f.initial)
                .chain(f.points.iter().copied())
                .map(to_cell)
                .collect();
            cells.sort_unstable_by_key(|&c| b.index(c));
            cells.dedup();
            let mut near: Vec<Pos> = cells
                .iter()
                .flat_map(|c| {
                    [
                        (0, -1),
                        (0, 1),
                        (-1, 0),
                        (1, 0),
                        (-1, -1),
                        (-1, 1),
                        (1, -1),
                        (1, 1),
                    ]
                    .map(|(dr, dc)| Pos::new(c.row + dr, c.col + dc))
                })
                .filter(|&c| b.in_bounds(c) && b.get(c) == Occupancy::Free && c != view.pos)
                .collect();
            let d = |p: Pos| {
                let (x, y) = to_map(p);
                (x - f.centroid.0).hypot(y - f.centroid.1)
            };
            near.sort_by(|&a, &c| d(a).total_cmp(&d(c)).then(b.index(a).cmp(&b.index(c))));
            near.dedup();
            // The nearest the robot can reach through its known free cells.
            let goal = near.into_iter().find(|&g| view.path_cost(g).is_some());
            match goal {
                Some(g) => {
                    self.goal = Some(g);
                    return Some(g);
                }
                // Unreachable: nav2 would abort it, and explore_lite blacklists an aborted goal.
                None => self.blacklist.push(f.centroid),
            }
        }
        // "No frontiers found" or "All frontiers traversed/tried out": stopping.
        self.stopped = true;
        self.goal = None;
        None
    }
}

impl Policy for ExploreLite {
    fn name(&self) -> &str {
        "explore-lite"
    }
    /// Asked every timestep: it keeps its own timer.
    fn mode(&self) -> DecisionMode {
        DecisionMode::EveryStep
    }
    fn needs_candidates(&self) -> bool {
        false
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        if self.stopped {
            return Decision::Idle;
        }
        let reached = self.goal.is_some_and(|g| g == view.pos);
        let due = view.t >= self.next_plan;
        if due {
            self.next_plan = view.t + self.period;
        }
        if reached {
            self.goal = None;
            self.target = None;
        }
        let goal = if due || self.goal.is_none() {
            self.make_plan(view)
        } else {
            self.goal
        };
        goal.map_or(Decision::Idle, Decision::Goal)
    }
}
