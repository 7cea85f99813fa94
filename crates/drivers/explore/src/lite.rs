//! `policy: explore-lite`: explore_lite's choice of frontier ([`madenet_nav::frontiers`]: its
//! search, its cost of size, distance and the same scales) on the robot's map — with
//! teammates, on the robot's map merged with theirs ([`crate::team::Team::merged`]).
//!
//! As explore_lite, it sends the cheapest frontier's centroid (orientation w = 1), and a goal
//! that has not brought the robot nearer its frontier for `progress_timeout` seconds is given
//! up and blacklisted. Unlike explore_lite:
//! - the blacklist expires ([`crate::node::Blacklist`]);
//! - a frontier still there when its goal has been reached cannot be seen from there: it is
//!   blacklisted at once (explore_lite waits out its progress timeout);
//! - a frontier whose centroid moved less than the blacklist's tolerance (5 map cells) is the
//!   same one, and progress is getting nearer by a map cell (explore_lite: 0.01 m and any
//!   decrease, so a flickering map resends goals for ever);
//! - a centroid off the map's cells is never sent.

use crate::node::{Blacklist, Choice, Chooser, ExploreError, PlanInput, Progress, Shown};
use crate::params::ExploreParams;
use madenet_nav::frontiers::{
    occupancy_to_cost, search_from, Connectivity, CostGrid, FrontierParams,
};
use madenet_ros2::actions::status;

/// explore_lite's chooser.
pub(crate) struct Lite {
    fp: FrontierParams,
    blacklist: Blacklist,
    /// The frontier of the goal under way, if any.
    goal: Option<(f64, f64)>,
    /// The frontier last chosen (explore_lite's `prev_goal_`): kept after its goal ends, so a
    /// frontier still there after its goal succeeded is not sent again but timed out.
    prev_target: Option<(f64, f64)>,
    /// The frontier of the last goal reached: still there at the next plan, it cannot be seen
    /// from where it is reached, and is blacklisted at once.
    reached: Option<(f64, f64)>,
    /// The nearest distance to the current frontier, and when it was reached.
    progress: Progress,
    /// The blacklist's tolerance (5 map cells), set at each plan.
    tol: f64,
    /// What the last plan weighed.
    shown: Shown,
}

impl Lite {
    pub(crate) fn new(p: &ExploreParams) -> Self {
        Lite {
            fp: FrontierParams {
                potential_scale: p.potential_scale,
                gain_scale: p.gain_scale,
                min_frontier_size: p.min_frontier_size,
            },
            blacklist: Blacklist::default(),
            goal: None,
            prev_target: None,
            reached: None,
            progress: Progress::new(p.progress_timeout),
            tol: 0.25,
            shown: Shown::default(),
        }
    }
}

impl Chooser for Lite {
    fn ended(&mut self, st: i8, now: f64) {
        let Some(at) = self.goal.take() else {
            return;
        };
        match st {
            status::SUCCEEDED => self.reached = Some(at),
            // Canceled, or never answered: not a failure of the frontier.
            status::CANCELED | status::UNKNOWN => {}
            _ => self.blacklist.list(at, now, self.tol, false),
        }
    }

    fn blacklisted(&self) -> usize {
        self.blacklist.len()
    }

    fn shown(&self) -> Shown {
        self.shown.clone()
    }

    fn plan(&mut self, at: PlanInput<'_>) -> Result<Choice, ExploreError> {
        let (ns, here, now, nav_progress_at) = (at.ns, at.here, at.now, at.nav_progress_at);
        let merged;
        let map = match at.team {
            Some(team) => {
                merged = team.merged(at.map, ns);
                &merged
            }
            None => at.map,
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
        let frontiers = search_from(&grid, here, &self.fp);
        let on_map = |(x, y): (f64, f64)| {
            let (lx, ly) = (x - grid.origin.0, y - grid.origin.1);
            lx >= 0.0
                && ly >= 0.0
                && lx < grid.width as f64 * grid.resolution
                && ly < grid.height as f64 * grid.resolution
        };
        let tol = 5.0 * grid.resolution;
        self.tol = tol;
        let open: Vec<_> = frontiers
            .iter()
            .filter(|f| on_map(f.centroid) && !self.blacklist.for_good(f.centroid, tol))
            .collect();
        self.shown = Shown {
            options: open.iter().map(|f| f.centroid).collect(),
            blacklisted: self.blacklist.points(now),
        };
        let Some(f) = open
            .iter()
            .find(|f| !self.blacklist.listed(f.centroid, now, tol))
        else {
            // Nothing left but frontiers blacklisted for good: done. Frontiers waiting out
            // their blacklist keep it going.
            return Ok(match open.is_empty() {
                true => Choice::Complete,
                false => Choice::Keep,
            });
        };
        let target = f.centroid;
        // Within the blacklist's tolerance: the same frontier, its centroid moved a little as
        // the map changed (explore_lite's 0.01 m makes a flickering map resend for ever).
        let near = |a: Option<(f64, f64)>| {
            a.is_some_and(|a| (a.0 - target.0).abs() < tol && (a.1 - target.1).abs() < tol)
        };
        if near(self.reached.take()) {
            self.blacklist.list(target, now, tol, false);
            self.prev_target = None;
            return Ok(Choice::GiveUp);
        }
        let same = near(self.prev_target);
        self.prev_target = Some(target);
        // Progress: nearer by a map cell or more.
        match same {
            true => (self.progress).update(f.min_distance, now, grid.resolution),
            false => self.progress.restart(f.min_distance, now),
        }
        let stalled = (self.progress).stalled(now, nav_progress_at);
        if let Some(waited) = stalled.filter(|_| same) {
            // No progress: give it up (cancel), blacklist it, plan again at once.
            tracing::info!(
                "{ns}: gave up the frontier at ({:.2}, {:.2}): no progress for {waited:.0} s",
                target.0,
                target.1,
            );
            self.blacklist.list(target, now, tol, false);
            self.prev_target = None;
            self.goal = None;
            return Ok(Choice::GiveUp);
        }
        if same {
            return Ok(Choice::Keep);
        }
        self.goal = Some(target);
        Ok(Choice::Send(target))
    }
}
