//! Real robots in place of `madenet world`: a [`Ground`] whose truth is what each robot's own
//! stack publishes — `/robot<i>/map` and `/robot<i>/pose` — and whose moves go out as
//! `/robot<i>/goal_pose` (the next cell's centre, for nav2 or any controller to reach).

use crate::msgs::PoseStamped;
use crate::{
    pose_stamped, stamp, MapFrame, Node, Publisher, QosProfile, RobotFeed, Ros2Context, Ros2Error,
};
use madenet_map::{Occupancy, Pos};
use madenet_metrics::MetricsRecorder;
use madenet_runtime::Ground;
use madenet_world::geometry::line_of_sight;
use madenet_world::{Move, Observation, ScenarioConfig};
use std::time::{Duration, Instant, SystemTime};

/// The team as the world node sees it through ROS 2. Every timestep: robot i observes the
/// cells of its own map that changed since it was last told (its own cell included) and the
/// teammates within d_s (Chebyshev) in line of sight on its map; two robots can talk when each
/// sees the other; each move is sent as a goal, and the timestep ends when every robot that was
/// sent one reports the goal's cell, or after `step_timeout` (a robot that did not get there is
/// where its pose says, as a failed move in the simulator). Exploration is complete when the
/// union of the robots' maps has no frontier (a free cell next to an unknown one).
pub struct RealRobots {
    _node: Node,
    feeds: Vec<RobotFeed>,
    goals: Vec<Publisher<PoseStamped>>,
    frame: MapFrame,
    config: ScenarioConfig,
    step_timeout: Duration,
    t: usize,
    maps: Vec<Vec<Occupancy>>,
    positions: Vec<Pos>,
    /// Per robot: the map as last sent in its observations.
    told: Vec<Vec<Occupancy>>,
    distance: f64,
}

impl RealRobots {
    /// Subscribes to `robots` robots' maps and poses and waits up to `first_wait` for each
    /// one's first map and pose. `config` gives d_s, the movement rule and the step cap.
    pub fn new(
        ctx: &Ros2Context,
        robots: usize,
        frame: MapFrame,
        config: ScenarioConfig,
        step_timeout: Duration,
        first_wait: Duration,
    ) -> Result<Self, Ros2Error> {
        let node = ctx.create_node("madenet_world")?;
        let mut feeds = Vec::with_capacity(robots);
        let mut goals = Vec::with_capacity(robots);
        for i in 0..robots {
            feeds.push(RobotFeed::new(ctx, i, frame)?.with_rule(config.discretize));
            let topic = &crate::topics(i)[2];
            goals.push(node.create_pub::<PoseStamped>(topic, QosProfile::default())?);
        }
        let cells = frame.height * frame.width;
        let mut real = RealRobots {
            _node: node,
            feeds,
            goals,
            frame,
            config,
            step_timeout,
            t: 0,
            maps: vec![vec![Occupancy::Unknown; cells]; robots],
            positions: vec![Pos::new(0, 0); robots],
            told: vec![vec![Occupancy::Unknown; cells]; robots],
            distance: 0.0,
        };
        for i in 0..robots {
            if !real.read(i, first_wait)? {
                let [map, pose, _] = crate::topics(i);
                return Err(Ros2Error::BadMessage {
                    topic: format!("{map}, {pose}"),
                    field: "(none)",
                    why: format!("no map and pose within {first_wait:?}"),
                });
            }
        }
        Ok(real)
    }

    /// Takes robot `i`'s newest map and pose; false if it has not sent both within `wait`.
    fn read(&mut self, i: usize, wait: Duration) -> Result<bool, Ros2Error> {
        Ok(match self.feeds[i].latest(wait)? {
            Some((cells, at)) => {
                self.maps[i].copy_from_slice(cells);
                self.positions[i] = at;
                true
            }
            None => false,
        })
    }

    fn sees(&self, i: usize, j: usize) -> bool {
        let (a, b) = (self.positions[i], self.positions[j]);
        let (w, map) = (self.frame.width, &self.maps[i]);
        let blocked = |p: Pos| {
            p.row < 0
                || p.col < 0
                || p.row as usize >= self.frame.height
                || p.col as usize >= w
                || map[p.row as usize * w + p.col as usize] == Occupancy::Obstacle
        };
        a.chebyshev(b) <= self.config.sensing_range
            && line_of_sight(blocked, a, b, self.config.movement)
    }

    /// Pairs that can talk: each sees the other.
    fn pairs(&self) -> Vec<(usize, usize)> {
        let n = self.positions.len();
        (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .filter(|&(i, j)| self.sees(i, j) && self.sees(j, i))
            .collect()
    }

    /// Known cells of the union of the robots' maps (a cell known to anyone).
    fn union(&self) -> Vec<Occupancy> {
        let mut u = vec![Occupancy::Unknown; self.frame.height * self.frame.width];
        for m in &self.maps {
            for (u, &c) in u.iter_mut().zip(m) {
                if !u.is_known() {
                    *u = c;
                }
            }
        }
        u
    }
}

impl Ground for RealRobots {
    fn robots(&self) -> usize {
        self.positions.len()
    }
    fn t(&self) -> usize {
        self.t
    }
    fn positions(&self) -> Vec<Pos> {
        self.positions.clone()
    }
    fn is_done(&self) -> bool {
        self.t >= self.config.step_cap || self.is_complete()
    }
    fn is_complete(&self) -> bool {
        let (h, w) = (self.frame.height as i32, self.frame.width as i32);
        let u = self.union();
        let at = |r: i32, c: i32| u[(r * w + c) as usize];
        !(0..h).any(|r| {
            (0..w).any(|c| {
                at(r, c) == Occupancy::Free
                    && [(-1, 0), (1, 0), (0, -1), (0, 1)].iter().any(|&(dr, dc)| {
                        let (r2, c2) = (r + dr, c + dc);
                        (0..h).contains(&r2) && (0..w).contains(&c2) && !at(r2, c2).is_known()
                    })
            })
        })
    }
    fn explored_fraction(&self) -> f64 {
        let u = self.union();
        u.iter().filter(|c| c.is_known()).count() as f64 / u.len().max(1) as f64
    }
    fn contacts(&mut self) -> Vec<(usize, usize)> {
        self.pairs()
    }
    fn observation(&mut self, i: usize) -> Observation {
        let w = self.frame.width;
        let pos = self.positions[i];
        let mut seen: Vec<(Pos, Occupancy)> = vec![(pos, Occupancy::Free)];
        for (k, (&now, told)) in self.maps[i].iter().zip(self.told[i].iter_mut()).enumerate() {
            if now.is_known() && now != *told {
                let p = Pos::new((k / w) as i32, (k % w) as i32);
                if p != pos {
                    seen.push((p, now));
                }
                *told = now;
            }
        }
        let teammates = (0..self.robots())
            .filter(|&j| j != i && self.sees(i, j))
            .map(|j| (j, self.positions[j]))
            .collect();
        Observation {
            robot: i,
            t: self.t,
            pos,
            seen,
            teammates,
            exchanged_with: Vec::new(),
        }
    }
    fn step(&mut self, moves: &[Move], waiting: &mut dyn FnMut()) -> Result<(), String> {
        let t = stamp(SystemTime::now());
        let targets: Vec<Option<Pos>> = moves
            .iter()
            .zip(&self.positions)
            .map(|(&m, &p)| (m != Move::Stay).then(|| m.apply(p)))
            .collect();
        for (i, target) in targets.iter().enumerate() {
            if let Some(g) = target {
                // Facing the way it moves: a nav2 robot turns to a goal's heading once there.
                let (p, mut msg) = (self.positions[i], pose_stamped(&self.frame, *g, t));
                let (dx, dy) = ((g.col - p.col) as f64, (p.row - g.row) as f64);
                msg.pose.orientation = crate::tf::from_yaw(self.frame.origin[2] + dy.atan2(dx));
                self.goals[i]
                    .publish(&msg)
                    .map_err(|e| format!("publishing {}: {e}", crate::topics(i)[2]))?;
            }
        }
        let before = self.positions.clone();
        let deadline = Instant::now() + self.step_timeout;
        loop {
            for i in 0..self.robots() {
                self.read(i, Duration::ZERO).map_err(|e| e.to_string())?;
            }
            let arrived = targets
                .iter()
                .zip(&self.positions)
                .all(|(g, p)| g.is_none_or(|g| g == *p));
            if arrived || Instant::now() >= deadline {
                break;
            }
            waiting();
            std::thread::sleep(Duration::from_millis(2));
        }
        self.distance += before
            .iter()
            .zip(&self.positions)
            .map(|(a, b)| a.euclid(*b))
            .sum::<f64>();
        self.t += 1;
        Ok(())
    }
    fn record(&self, recorder: &mut MetricsRecorder) {
        let ds = self.config.sensing_range;
        let contacts = self.pairs();
        let closer = contacts
            .iter()
            .filter(|&&(i, j)| self.positions[i].chebyshev(self.positions[j]) < ds)
            .count();
        recorder.record(
            self.explored_fraction(),
            self.distance,
            contacts.len(),
            closer,
        );
    }
}
