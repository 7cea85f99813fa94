//! The continuous world of one trial, as a pipeline per control period: motion (acceleration
//! limits, differential-drive kinematics, rapier moves the bodies) → contacts (collisions
//! counted) → sensing (each robot's lidar at its rate, into its own map) — and, asked by the
//! trial, the pairs that can talk (within d_s, line of sight on the true world).

use crate::config::{ConfigError, ContinuousConfig};
use crate::mapping::RobotMap;
use crate::scene::{Scene, Shape};
use madenet_map::{generate::reachable_from_with, OccGrid, Occupancy, Pos};
use madenet_world::rng::{stream, Rng};
use madenet_world::ScenarioConfig;
use rand::RngExt;
use rand_distr::StandardNormal;
use rapier2d::prelude::*;
use std::sync::Arc;

/// Why a continuous trial cannot start.
#[derive(Debug, thiserror::Error)]
pub enum ContinuousError {
    /// A bad [`ContinuousConfig`] field.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A bad scenario field or start.
    #[error("{0}")]
    Scenario(String),
}

/// A robot's pose: position in metres (x right, y down) and heading in radians.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad), `atan2(dy, dx)`.
    pub theta: f64,
}

/// Collisions counted over a trial: a robot starting to touch something.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Collisions {
    /// With an obstacle.
    pub obstacle: u64,
    /// With a teammate (counted once per robot touching).
    pub robot: u64,
}

/// One beam of the last scan, for pictures: angle (rad, world frame), range (m), whether it
/// returned.
pub type Beam = (f64, f64, bool);

/// The world of one continuous trial.
pub struct ContinuousWorld {
    cfg: ContinuousConfig,
    scenario: ScenarioConfig,
    scene: Arc<Scene>,
    physics: PhysicsWorld,
    bodies: Vec<RigidBodyHandle>,
    poses: Vec<Pose>,
    /// Current (v, ω) of each robot.
    velocities: Vec<(f64, f64)>,
    maps: Vec<RobotMap>,
    pending: Vec<Vec<(Pos, Occupancy)>>,
    time: f64,
    ticks: u64,
    scan_every: u64,
    rng_sensor: Vec<Rng>,
    /// Per robot, the localization error of each scan ([`crate::config::MappingConfig::localization_noise_m`]).
    rng_localization: Vec<Rng>,
    coarse_truth: OccGrid,
    explorable: Vec<bool>,
    explorable_count: usize,
    team_known: Vec<bool>,
    team_known_count: usize,
    unread: usize,
    touching: Vec<bool>,
    collisions: Collisions,
    distance: Vec<f64>,
    scans: Vec<Vec<Beam>>,
    /// Scratch of [`ContinuousWorld::scan`]: colliders in range, bearing, angular half-width.
    near: Vec<(ColliderHandle, f64, f64)>,
    /// Scratch of [`ContinuousWorld::scan`]: where its beams end, and whether they returned.
    ends: Vec<(f64, f64, bool)>,
    /// (cos φ_k, sin φ_k) of each beam's angle φ_k from the heading.
    beam_dirs: Vec<(f64, f64)>,
    sensing_m: f64,
}

const GROUP_OBSTACLE: Group = Group::GROUP_1;
const GROUP_ROBOT: Group = Group::GROUP_2;

impl ContinuousWorld {
    /// Places `scenario.num_robots` robots at the centres of the `starts` cells (of
    /// `scenario.cell_size` metres), heading right, and takes the first scans.
    pub fn new(
        scene: Arc<Scene>,
        starts: &[Pos],
        scenario: ScenarioConfig,
        cfg: ContinuousConfig,
        seed: u64,
    ) -> Result<Self, ContinuousError> {
        cfg.validate()?;
        scenario
            .validate()
            .map_err(|e| ContinuousError::Scenario(e.to_string()))?;
        let n = scenario.num_robots;
        if starts.len() < n {
            return Err(ContinuousError::Scenario(format!(
                "{n} robots but {} start cells (field `num_robots`)",
                starts.len()
            )));
        }
        let (px_h, px_w) = map_pixels(&scene, &cfg);
        check_map_memory(&cfg, n, scene.width_m(), scene.height_m())
            .map_err(ContinuousError::Scenario)?;
        let cell = scenario.cell_size;
        let coarse_truth = scene.coarse_truth(cell, &scenario.discretize);
        // The robots read their maps into cells of `cell` metres as the truth is read: a scene
        // whose raster is coarser than the cells (a built-in map's 1 m cells, say) cannot be.
        let map_cells = |px: usize| {
            let cell_px = (cell / cfg.mapping.resolution).max(1.0);
            ((px.max(1) as f64 - 0.5) / cell_px).floor() as usize + 1
        };
        if (map_cells(px_h), map_cells(px_w)) != (coarse_truth.height(), coarse_truth.width()) {
            let res = scene.fine.resolution;
            return Err(ContinuousError::Scenario(format!(
                "field `cell_size`: {cell} m cells of the scene (its raster has {res} m cells) are {} × {}, but the robots' {} m maps make {} × {}: use a cell_size that is a whole multiple of {res} m",
                coarse_truth.height(),
                coarse_truth.width(),
                cfg.mapping.resolution,
                map_cells(px_h),
                map_cells(px_w),
            )));
        }
        let sensing_m = scenario.sensing_range as f64 * cell;
        let mut physics = PhysicsWorld::new();
        let obstacle_groups =
            InteractionGroups::new(GROUP_OBSTACLE, Group::ALL, InteractionTestMode::And);
        for s in &scene.shapes {
            let builder = match *s {
                Shape::Rect {
                    x,
                    y,
                    hx,
                    hy,
                    angle,
                } => ColliderBuilder::cuboid(hx as f32, hy as f32).position(
                    rapier2d::math::Pose::new(Vector::new(x as f32, y as f32), angle as f32),
                ),
                Shape::Circle { x, y, r } => {
                    ColliderBuilder::ball(r as f32).translation(Vector::new(x as f32, y as f32))
                }
            };
            physics.insert_collider(builder.collision_groups(obstacle_groups).user_data(0), None);
        }
        // The broad phase takes the colliders in on a step.
        physics.integration_parameters.dt = cfg.control_period as f32;
        physics.step();
        let mut poses = Vec::with_capacity(n);
        let mut bodies = Vec::with_capacity(n);
        let radius = cfg.robot.radius;
        for (i, &p) in starts[..n].iter().enumerate() {
            if !coarse_truth.in_bounds(p) {
                return Err(ContinuousError::Scenario(format!(
                    "start cell {p} of robot {i} is outside the {} × {} map",
                    coarse_truth.height(),
                    coarse_truth.width()
                )));
            }
            let (x, y) = Scene::cell_centre(p, cell);
            let pose = Pose { x, y, theta: 0.0 };
            for (j, q) in poses.iter().enumerate() {
                let q: &Pose = q;
                if (q.x - x).hypot(q.y - y) < 2.0 * radius {
                    return Err(ContinuousError::Scenario(format!(
                        "start cell {p} of robot {i} overlaps robot {j}'s footprint"
                    )));
                }
            }
            let ball = Ball::new(radius as f32);
            let at = rapier2d::math::Pose::new(Vector::new(x as f32, y as f32), 0.0);
            if physics
                .intersect_shape(at, &ball, QueryFilter::default())
                .next()
                .is_some()
            {
                return Err(ContinuousError::Scenario(format!(
                    "start cell {p} of robot {i}: a footprint of radius {radius} m at its centre ({x:.2}, {y:.2}) m is inside an obstacle (field `robot.radius`)"
                )));
            }
            let body = physics.insert_body(
                RigidBodyBuilder::kinematic_position_based()
                    .translation(Vector::new(x as f32, y as f32)),
            );
            physics.insert_collider(
                ColliderBuilder::ball(radius as f32)
                    .collision_groups(InteractionGroups::new(
                        GROUP_ROBOT,
                        Group::ALL,
                        InteractionTestMode::And,
                    ))
                    .user_data(i as u128 + 1),
                Some(body),
            );
            bodies.push(body);
            poses.push(pose);
        }
        physics.integration_parameters.dt = cfg.control_period as f32;
        physics.step();
        // Explorable: the true free cells reachable from a start on the cells, into which the
        // local planner can drive on the true geometry (its footprint plus margin reaches a
        // pixel of the cell): a free cell walled in by obstacles no robot can pass or see
        // around is not asked for.
        let drivable = scene.drivable(
            &starts[..n]
                .iter()
                .map(|&p| Scene::cell_centre(p, cell))
                .collect::<Vec<_>>(),
            cfg.robot.radius + cfg.planner.safety_margin,
        );
        let mut enterable = vec![false; coarse_truth.len()];
        {
            let (fw, cell_px) = (scene.fine.width(), cell / scene.fine.resolution);
            let cell_of = |k: usize| ((k as f64 + 0.5) / cell_px).floor() as usize;
            for (k, _) in drivable.iter().enumerate().filter(|(_, &d)| d) {
                let (r, c) = (cell_of(k / fw), cell_of(k % fw));
                if r < coarse_truth.height() && c < coarse_truth.width() {
                    enterable[r * coarse_truth.width() + c] = true;
                }
            }
        }
        // Reachable on the true cells from a start; explorable where a footprint can also drive.
        let mut reachable = vec![false; coarse_truth.len()];
        for &p in &starts[..n] {
            if coarse_truth.get(p) == Occupancy::Free {
                for (e, r) in reachable.iter_mut().zip(reachable_from_with(
                    &coarse_truth,
                    p,
                    scenario.movement,
                )) {
                    *e |= r;
                }
            }
        }
        let explorable: Vec<bool> = reachable
            .iter()
            .zip(&enterable)
            .map(|(&r, &d)| r && d)
            .collect();
        let explorable_count = explorable.iter().filter(|&&e| e).count();
        // A footprint wider than every passage around the starts: nothing to do but wait for
        // the time cap. Refused, naming the field.
        let w = coarse_truth.width();
        let is_start = |k: usize| {
            starts[..n]
                .iter()
                .any(|p| p.row as usize * w + p.col as usize == k)
        };
        let beyond_starts = |v: &[bool]| v.iter().enumerate().any(|(k, &e)| e && !is_start(k));
        if beyond_starts(&reachable) && !beyond_starts(&explorable) {
            let clearance = cfg.robot.radius + cfg.planner.safety_margin;
            return Err(ContinuousError::Scenario(format!(
                "field `robot.radius`: a footprint of radius {} m (with `planner.safety_margin` {} m) cannot leave the start cells: every passage from them is narrower than {:.2} m",
                cfg.robot.radius,
                cfg.planner.safety_margin,
                2.0 * clearance
            )));
        }
        let maps = (0..n)
            .map(|_| {
                RobotMap::new(px_h, px_w, cell, cfg.mapping, &scenario.discretize)
                    .with_inflation(cfg.robot.radius + cfg.planner.safety_margin)
            })
            .collect();
        let scan_every = (1.0 / (cfg.lidar.rate_hz * cfg.control_period))
            .round()
            .max(1.0) as u64;
        let mut w = ContinuousWorld {
            rng_localization: (0..n)
                .map(|i| stream(seed, "continuous-localization", i as u64))
                .collect(),
            rng_sensor: (0..n)
                .map(|i| stream(seed, "continuous-sensor", i as u64))
                .collect(),
            team_known: vec![false; coarse_truth.len()],
            team_known_count: 0,
            unread: 0,
            coarse_truth,
            explorable,
            explorable_count,
            bodies,
            velocities: vec![(0.0, 0.0); n],
            maps,
            pending: vec![Vec::new(); n],
            time: 0.0,
            ticks: 0,
            scan_every,
            touching: vec![false; n],
            collisions: Collisions::default(),
            distance: vec![0.0; n],
            scans: vec![Vec::new(); n],
            near: Vec::new(),
            ends: Vec::new(),
            beam_dirs: (0..cfg.lidar.beams)
                .map(|k| {
                    let fov = cfg.lidar.fov_deg.to_radians();
                    let phi = -fov / 2.0 + (k as f64 + 0.5) * fov / cfg.lidar.beams as f64;
                    (phi.cos(), phi.sin())
                })
                .collect(),
            sensing_m,
            poses,
            physics,
            scene,
            scenario,
            cfg,
        };
        for i in 0..n {
            w.scan(i);
        }
        Ok(w)
    }

    /// The configuration.
    pub fn config(&self) -> &ContinuousConfig {
        &self.cfg
    }
    /// The scenario.
    pub fn scenario(&self) -> &ScenarioConfig {
        &self.scenario
    }
    /// The true geometry.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }
    /// The true map in the agents' cells.
    pub fn coarse_truth(&self) -> &OccGrid {
        &self.coarse_truth
    }
    /// Number of robots.
    pub fn robots(&self) -> usize {
        self.poses.len()
    }
    /// Simulated seconds since the start.
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Robot `i`'s pose.
    pub fn pose(&self, i: usize) -> Pose {
        self.poses[i]
    }
    /// Robot `i`'s current (v, ω).
    pub fn velocity(&self, i: usize) -> (f64, f64) {
        self.velocities[i]
    }
    /// Robot `i`'s own map.
    pub fn map(&self, i: usize) -> &RobotMap {
        &self.maps[i]
    }
    /// Robot `i`'s last scan.
    pub fn scan_beams(&self, i: usize) -> &[Beam] {
        &self.scans[i]
    }
    /// Collisions so far.
    pub fn collisions(&self) -> Collisions {
        self.collisions
    }
    /// Metres robot `i` has driven.
    pub fn distance(&self, i: usize) -> f64 {
        self.distance[i]
    }
    /// d_s in metres.
    pub fn sensing_m(&self) -> f64 {
        self.sensing_m
    }
    /// The agent cell robot `i` stands in.
    pub fn cell_of(&self, i: usize) -> Pos {
        let c = self.scenario.cell_size;
        let p = self.poses[i];
        let max_r = self.coarse_truth.height() as i32 - 1;
        let max_c = self.coarse_truth.width() as i32 - 1;
        Pos::new(
            ((p.y / c).floor() as i32).clamp(0, max_r),
            ((p.x / c).floor() as i32).clamp(0, max_c),
        )
    }
    /// The team's known cells (each robot's own observations, not what it heard) over the
    /// explorable ones.
    pub fn explored_fraction(&self) -> f64 {
        if self.explorable_count == 0 {
            return 1.0;
        }
        let known = self
            .explorable
            .iter()
            .zip(&self.team_known)
            .filter(|(&e, &k)| e && k)
            .count();
        known as f64 / self.explorable_count as f64
    }
    /// Every explorable cell is known to some robot.
    pub fn is_complete(&self) -> bool {
        self.explorable
            .iter()
            .zip(&self.team_known)
            .all(|(&e, &k)| !e || k)
    }
    /// The team's coarse map, every robot's own reading merged (an obstacle to any robot is
    /// one; else free to any is free; else unknown), row-major in the agents' cells.
    pub fn team_map(&self) -> Vec<Occupancy> {
        let (h, w) = self.maps[0].coarse_size();
        let mut team = vec![Occupancy::Unknown; h * w];
        for m in &self.maps {
            for (t, &c) in team.iter_mut().zip(m.coarse()) {
                match c {
                    Occupancy::Obstacle => *t = Occupancy::Obstacle,
                    Occupancy::Free if *t == Occupancy::Unknown => *t = Occupancy::Free,
                    _ => {}
                }
            }
        }
        team
    }
    /// Cells robot `i`'s map has newly read (or turned into obstacles) since the last call.
    pub fn take_observed(&mut self, i: usize, out: &mut Vec<(Pos, Occupancy)>) {
        out.append(&mut self.pending[i]);
    }
    /// Robot `i`'s local planner found cell `p` impassable, or robot `i` stood next to it and
    /// could not read it: an obstacle in its map from now on, and resolved for the team.
    pub fn block(&mut self, i: usize, p: Pos) {
        let k = p.row as usize * self.coarse_truth.width() + p.col as usize;
        if self.explorable.get(k) == Some(&true) && !self.team_known[k] {
            self.unread += 1;
        }
        self.maps[i].block(p);
        // Resolved, as far as the team can: it counts as explored (and as unread).
        self.collect(i);
    }

    /// The cells the team is asked to explore: free in truth, reachable on the cells, and
    /// enterable by a robot's footprint.
    pub fn explorable_count(&self) -> usize {
        self.explorable_count
    }

    /// Explorable cells that count as explored though no robot's map has read them: blocked
    /// ([`ContinuousWorld::block`]) before anyone saw them.
    pub fn unread(&self) -> usize {
        self.unread
    }

    /// Pairs (i < j) within d_s of each other with a clear line of sight on the true world.
    pub fn contacts(&self) -> Vec<(usize, usize)> {
        let n = self.robots();
        let mut out = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                if self.in_view(i, j) {
                    out.push((i, j));
                }
            }
        }
        out
    }

    /// Robot `i`'s teammates in view ([`ContinuousWorld::in_view`]) as its local planner
    /// predicts them; lower indices have right of way.
    pub fn neighbours(&self, i: usize) -> Vec<crate::local::Neighbour> {
        (0..self.robots())
            .filter(|&j| j != i && self.in_view(i, j))
            .map(|j| crate::local::Neighbour {
                pose: self.pose(j),
                velocity: self.velocity(j),
                priority: j < i,
            })
            .collect()
    }

    /// Whether robot `j` is within d_s of robot `i` with a clear line of sight.
    pub fn in_view(&self, i: usize, j: usize) -> bool {
        let (a, b) = (self.poses[i], self.poses[j]);
        let d = (b.x - a.x).hypot(b.y - a.y);
        if d > self.sensing_m {
            return false;
        }
        if d < 1e-9 {
            return true;
        }
        let ray = Ray::new(
            Vector::new(a.x as f32, a.y as f32),
            Vector::new(((b.x - a.x) / d) as f32, ((b.y - a.y) / d) as f32),
        );
        let only_obstacles = QueryFilter::default().groups(InteractionGroups::new(
            Group::ALL,
            GROUP_OBSTACLE,
            InteractionTestMode::And,
        ));
        self.physics
            .cast_ray(&ray, d as f32, true, only_obstacles)
            .is_none()
    }

    /// One control period: each robot's commanded (v, ω) is approached within the
    /// acceleration limits and driven (unicycle kinematics, exact arcs), rapier moves the
    /// bodies, touches are counted, and the robots due a scan take one.
    pub fn step(&mut self, commands: &[(f64, f64)]) {
        let dt = self.cfg.control_period;
        let rc = self.cfg.robot;
        for i in 0..self.robots() {
            let (v0, w0) = self.velocities[i];
            let (vc, wc) = commands.get(i).copied().unwrap_or((0.0, 0.0));
            let vc = vc.clamp(-rc.max_speed, rc.max_speed);
            let wc = wc.clamp(-rc.max_turn_rate, rc.max_turn_rate);
            let v = v0 + (vc - v0).clamp(-rc.max_accel * dt, rc.max_accel * dt);
            let w = w0 + (wc - w0).clamp(-rc.max_turn_accel * dt, rc.max_turn_accel * dt);
            self.velocities[i] = (v, w);
            let p = self.poses[i];
            let (x, y, theta) = integrate(p.x, p.y, p.theta, v, w, dt);
            self.poses[i] = Pose { x, y, theta };
            self.distance[i] += v.abs() * dt;
            if let Some(body) = self.physics.bodies.get_mut(self.bodies[i]) {
                body.set_next_kinematic_position(rapier2d::math::Pose::new(
                    Vector::new(x as f32, y as f32),
                    theta as f32,
                ));
            }
        }
        self.physics.step();
        self.ticks += 1;
        self.time = self.ticks as f64 * dt;
        self.count_touches();
        let n = self.robots();
        for i in 0..n {
            // Scans are staggered over the robots so that they do not all fall on one tick.
            if (self.ticks + i as u64).is_multiple_of(self.scan_every) {
                self.scan(i);
            }
        }
    }

    fn count_touches(&mut self) {
        let radius = self.cfg.robot.radius as f32;
        let ball = Ball::new(radius);
        for i in 0..self.robots() {
            let p = self.poses[i];
            let at = rapier2d::math::Pose::new(Vector::new(p.x as f32, p.y as f32), 0.0);
            let filter = QueryFilter::default().exclude_rigid_body(self.bodies[i]);
            let mut obstacle = false;
            let mut robot = false;
            for (_, co) in self.physics.intersect_shape(at, &ball, filter) {
                if co.user_data == 0 {
                    obstacle = true;
                } else {
                    robot = true;
                }
            }
            let now = obstacle || robot;
            if now && !self.touching[i] {
                tracing::debug!(
                    "robot {i} touched {} at ({:.2}, {:.2}), heading {:.2}, {:.1} s",
                    if obstacle { "an obstacle" } else { "a robot" },
                    p.x,
                    p.y,
                    p.theta,
                    self.time()
                );
                if obstacle {
                    self.collisions.obstacle += 1;
                } else {
                    self.collisions.robot += 1;
                }
            }
            self.touching[i] = now;
        }
    }

    /// Robot `i` scans: each beam that returns from an obstacle marks its end occupied and its
    /// path free; a beam that ends on a teammate frees its path only (robots filter teammates
    /// out of their maps: they know where they are); a beam that returns nothing frees its
    /// whole range; a missed return (`miss_prob`) tells nothing.
    fn scan(&mut self, i: usize) {
        let lidar = self.cfg.lidar;
        let p = self.poses[i];
        let range = self.sensing_m;
        let fov = lidar.fov_deg.to_radians();
        let res = self.cfg.mapping.resolution;
        let filter = QueryFilter::default().exclude_rigid_body(self.bodies[i]);
        let origin = Vector::new(p.x as f32, p.y as f32);
        let mut near = std::mem::take(&mut self.near);
        near_colliders(&self.physics, (p.x, p.y), range, filter, &mut near);
        let mut beams = std::mem::take(&mut self.scans[i]);
        beams.clear();
        let mut ends = std::mem::take(&mut self.ends);
        ends.clear();
        // Beam k points at θ + φ_k: a rotation of the sensor's fixed directions.
        let (cos_t, sin_t) = (p.theta.cos(), p.theta.sin());
        for (k, &(cos_k, sin_k)) in self.beam_dirs.iter().enumerate() {
            let rng = &mut self.rng_sensor[i];
            let missed = rng.random::<f64>() < lidar.miss_prob;
            let noise = rng.sample::<f64, _>(StandardNormal) * lidar.range_noise;
            if missed {
                continue;
            }
            let a = p.theta - fov / 2.0 + (k as f64 + 0.5) * fov / lidar.beams as f64;
            let (dx, dy) = (cos_t * cos_k - sin_t * sin_k, sin_t * cos_k + cos_t * sin_k);
            let ray = Ray::new(origin, Vector::new(dx as f32, dy as f32));
            match cast_beam(&self.physics, &near, &ray, a, range as f32) {
                Some((h, toi)) => {
                    let on_robot = self
                        .physics
                        .colliders
                        .get(h)
                        .is_some_and(|c| c.user_data != 0);
                    let d = (toi as f64 + noise).clamp(0.0, range);
                    if on_robot {
                        let d = (d - res).max(0.0);
                        ends.push((p.x + dx * d, p.y + dy * d, false));
                        beams.push((a, d, false));
                    } else {
                        // A quarter pixel past the surface: the end lands in the obstacle's
                        // pixel from whichever side the beam comes.
                        let e = d + res * 0.25;
                        ends.push((p.x + dx * e, p.y + dy * e, true));
                        beams.push((a, d, true));
                    }
                }
                None => {
                    ends.push((p.x + dx * range, p.y + dy * range, false));
                    beams.push((a, range, false));
                }
            }
        }
        // Where the robot believes it is (the true pose unless localization error is on): the
        // scan is integrated relative to that pose.
        let m = self.cfg.mapping;
        let (mut ox, mut oy) = (p.x, p.y);
        if m.localization_noise_m > 0.0 || m.localization_noise_rad > 0.0 {
            let rng = &mut self.rng_localization[i];
            let mut g = || rng.sample::<f64, _>(StandardNormal);
            let (ex, ey, et) = (
                g() * m.localization_noise_m,
                g() * m.localization_noise_m,
                g() * m.localization_noise_rad,
            );
            let (s, c) = et.sin_cos();
            for e in ends.iter_mut() {
                let (dx, dy) = (e.0 - p.x, e.1 - p.y);
                *e = (p.x + ex + dx * c - dy * s, p.y + ey + dx * s + dy * c, e.2);
            }
            (ox, oy) = (p.x + ex, p.y + ey);
        }
        self.maps[i].integrate_scan(ox, oy, &ends);
        self.ends = ends;
        self.scans[i] = beams;
        self.near = near;
        self.collect(i);
    }

    /// Moves robot `i`'s map changes to its pending observations and the team's knowledge.
    fn collect(&mut self, i: usize) {
        let start = self.pending[i].len();
        self.maps[i].take_changes(&mut self.pending[i]);
        let w = self.coarse_truth.width();
        for &(p, _) in &self.pending[i][start..] {
            let k = p.row as usize * w + p.col as usize;
            if !self.team_known[k] {
                self.team_known[k] = true;
                self.team_known_count += 1;
            }
        }
    }
}

/// The colliders that a scan from `at` with `range` can hit (`filter` passing), each with the
/// bearing and angular half-width of its bounding circle, into `out`: one broad-phase query per
/// scan instead of one per beam, so that a beam is cast only against the few shapes around its
/// bearing.
fn near_colliders(
    physics: &PhysicsWorld,
    at: (f64, f64),
    range: f64,
    filter: QueryFilter,
    out: &mut Vec<(ColliderHandle, f64, f64)>,
) {
    out.clear();
    let reach = Aabb::new(
        Vector::new((at.0 - range) as f32, (at.1 - range) as f32),
        Vector::new((at.0 + range) as f32, (at.1 + range) as f32),
    );
    for (h, co) in physics.intersect_aabb_conservative(reach, filter) {
        let b = co.compute_aabb();
        let (c, half) = (b.center(), b.half_extents());
        let (cx, cy) = (c.x as f64 - at.0, c.y as f64 - at.1);
        // A millimetre of slack against rounding in the f32 boxes.
        let (d, rc) = (cx.hypot(cy), (half.x as f64).hypot(half.y as f64) + 1e-3);
        if d - rc > range {
            continue;
        }
        let spread = if d <= rc {
            std::f64::consts::PI
        } else {
            (rc / d).asin()
        };
        out.push((h, cy.atan2(cx), spread));
    }
}

/// The first of `near` (from [`near_colliders`]) that `ray` at bearing `angle` hits within
/// `range`, and the distance: what `physics.cast_ray` answers, without the per-beam tree walk.
fn cast_beam(
    physics: &PhysicsWorld,
    near: &[(ColliderHandle, f64, f64)],
    ray: &Ray,
    angle: f64,
    range: f32,
) -> Option<(ColliderHandle, f32)> {
    let mut hit: Option<(ColliderHandle, f32)> = None;
    let angle = normalize_angle(angle);
    for &(h, bearing, spread) in near {
        // Both in (−π, π]: one turn at most between them.
        let mut off = (angle - bearing).abs();
        if off > std::f64::consts::PI {
            off = std::f64::consts::TAU - off;
        }
        if off > spread {
            continue;
        }
        let Some(co) = physics.colliders.get(h) else {
            continue;
        };
        let max = hit.map_or(range, |(_, t)| t);
        if let Some(t) = co.shape().cast_ray(co.position(), ray, max, true) {
            if hit.is_none_or(|(_, best)| t < best) {
                hit = Some((h, t));
            }
        }
    }
    hit
}

/// Bytes a robot's map takes per pixel (log-odds, the observed flag, the scan's hit mark, the
/// inflation count).
const MAP_BYTES_PER_PIXEL: f64 = 10.0;
/// The most memory the robots' maps of one trial may take (4 GB).
const MAX_MAP_BYTES: f64 = 4.0e9;

/// Refuses a trial whose `robots` maps of a `width_m` × `height_m` world at `cfg`'s
/// resolution would take more than 4 GB, naming the fields to change.
pub fn check_map_memory(
    cfg: &ContinuousConfig,
    robots: usize,
    width_m: f64,
    height_m: f64,
) -> Result<(), String> {
    let res = cfg.mapping.resolution;
    let bytes =
        robots as f64 * (height_m / res).round() * (width_m / res).round() * MAP_BYTES_PER_PIXEL;
    if bytes > MAX_MAP_BYTES {
        return Err(format!(
            "the maps of {robots} robots at {res} m per pixel on a {width_m:.0} × {height_m:.0} m world would take {:.1} GB, more than the {:.0} GB allowed: raise `mapping.resolution`, lower `num_robots`, or use a smaller world",
            bytes / 1e9,
            MAX_MAP_BYTES / 1e9
        ));
    }
    Ok(())
}

/// A robot map's rows and columns on `scene`.
fn map_pixels(scene: &Scene, cfg: &ContinuousConfig) -> (usize, usize) {
    (
        (scene.height_m() / cfg.mapping.resolution).round() as usize,
        (scene.width_m() / cfg.mapping.resolution).round() as usize,
    )
}

/// Unicycle motion over `dt` at constant (v, ω): exact arcs, straight lines when ω ≈ 0.
pub fn integrate(x: f64, y: f64, theta: f64, v: f64, w: f64, dt: f64) -> (f64, f64, f64) {
    if w.abs() < 1e-9 {
        (x + v * dt * theta.cos(), y + v * dt * theta.sin(), theta)
    } else {
        let th = theta + w * dt;
        (
            x + v / w * (th.sin() - theta.sin()),
            y - v / w * (th.cos() - theta.cos()),
            normalize_angle(th),
        )
    }
}

/// `a` in (−π, π].
pub fn normalize_angle(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let mut a = a % t;
    if a <= -std::f64::consts::PI {
        a += t;
    } else if a > std::f64::consts::PI {
        a -= t;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::generate_cluttered;

    /// The message of [`ContinuousWorld::new`]'s error (seed 1), which must refuse.
    fn refusal(
        scene: Arc<Scene>,
        starts: &[Pos],
        scenario: ScenarioConfig,
        cfg: ContinuousConfig,
    ) -> String {
        ContinuousWorld::new(scene, starts, scenario, cfg, 1)
            .err()
            .unwrap()
            .to_string()
    }

    fn world(seed: u64) -> ContinuousWorld {
        let scene = Arc::new(generate_cluttered(20.0, 0.1, 1));
        let starts = [Pos::new(17, 2), Pos::new(17, 3), Pos::new(18, 2)];
        ContinuousWorld::new(
            scene,
            &starts,
            ScenarioConfig::default(),
            ContinuousConfig::default(),
            seed,
        )
        .unwrap()
    }

    #[test]
    fn a_beam_cast_against_the_colliders_near_a_scan_hits_what_the_broad_phase_hits() {
        let w = world(1);
        let range = w.sensing_m();
        let mut near = Vec::new();
        let (mut hits, mut rays) = (0, 0);
        // Positions over the whole 20 m world (some inside obstacles, some by the border),
        // and robot 0 excluded as in its own scan.
        for py in 0..40 {
            for px in 0..40 {
                let at = (px as f64 * 0.5 + 0.13, py as f64 * 0.5 + 0.29);
                let filter = QueryFilter::default().exclude_rigid_body(w.bodies[0]);
                near_colliders(&w.physics, at, range, filter, &mut near);
                for k in 0..90 {
                    let a = normalize_angle(k as f64 * 4.0f64.to_radians() - 2.0);
                    let ray = Ray::new(
                        Vector::new(at.0 as f32, at.1 as f32),
                        Vector::new(a.cos() as f32, a.sin() as f32),
                    );
                    let fast = cast_beam(&w.physics, &near, &ray, a, range as f32);
                    let slow = w.physics.cast_ray(&ray, range as f32, true, filter);
                    assert_eq!(
                        fast.map(|(_, t)| t),
                        slow.map(|(_, t)| t),
                        "beam at {a} rad from {at:?}"
                    );
                    rays += 1;
                    hits += usize::from(slow.is_some());
                }
            }
        }
        // Both outcomes were exercised.
        assert!(hits > rays / 10 && hits < rays, "{hits} of {rays}");
    }

    #[test]
    fn the_first_scan_maps_the_surroundings_and_nothing_far() {
        let mut w = world(1);
        let mut seen = Vec::new();
        w.take_observed(0, &mut seen);
        assert!(!seen.is_empty());
        let here = w.cell_of(0);
        assert!(seen.contains(&(here, Occupancy::Free)), "{seen:?}");
        // Nothing beyond d_s (4 m) plus a cell.
        assert!(seen.iter().all(|(p, _)| p.chebyshev(here) <= 5), "{seen:?}");
        assert!(w.explored_fraction() > 0.0 && !w.is_complete());
    }

    #[test]
    fn driving_follows_the_kinematics_and_limits() {
        let mut w = world(1);
        for _ in 0..40 {
            w.step(&[(0.5, 0.0), (0.0, 1.0), (0.0, 0.0)]);
        }
        // 2 s: accelerating at 1 m/s² for 0.5 s then cruising at 0.5 m/s: 0.875 m.
        let p = w.pose(0);
        assert!((p.x - (2.5 + 0.875)).abs() < 0.03, "{p:?}");
        assert!((w.velocity(0).0 - 0.5).abs() < 1e-9);
        assert!((w.pose(1).theta - normalize_angle(2.0 - 1.0 / 6.0)).abs() < 0.05);
        assert_eq!(
            w.pose(2),
            Pose {
                x: 2.5,
                y: 18.5,
                theta: 0.0
            }
        );
        assert!((w.time() - 2.0).abs() < 1e-9);
    }

    #[test]
    fn driving_into_a_wall_counts_one_collision() {
        let mut w = world(1);
        for _ in 0..1000 {
            w.step(&[(0.0, 0.0), (0.0, 0.0), (0.5, 0.0)]);
        }
        // Robot 2 drove right along row 18 until it touched something (the first obstacle in
        // its row or the east wall).
        assert!(w.collisions().obstacle >= 1, "{:?}", w.collisions());
    }

    #[test]
    fn same_seed_same_world() {
        let run = |seed| {
            let mut w = world(seed);
            for k in 0..100 {
                w.step(&[(0.3, 0.2), (0.2, -0.3), ((k % 5) as f64 * 0.1, 0.0)]);
            }
            let mut seen = Vec::new();
            w.take_observed(1, &mut seen);
            (w.pose(0), w.pose(2), seen, w.map(2).probabilities())
        };
        assert_eq!(run(5), run(5));
        assert_ne!(run(5).3, run(6).3);
    }

    #[test]
    fn maps_too_large_for_memory_are_refused_before_any_is_built() {
        let scene = Arc::new(Scene::from_shapes(Vec::new(), 400.0, 400.0, 1.0, "big"));
        let mut cfg = ContinuousConfig::default();
        cfg.mapping.resolution = 0.01;
        let err = refusal(
            scene,
            &[Pos::new(1, 1), Pos::new(1, 3), Pos::new(3, 1)],
            ScenarioConfig::default(),
            cfg,
        );
        assert!(
            err.contains("mapping.resolution") && err.contains("GB"),
            "{err}"
        );
    }

    #[test]
    fn a_start_inside_an_obstacle_is_refused() {
        let scene = Arc::new(generate_cluttered(20.0, 0.1, 1));
        let coarse = scene.coarse_truth(1.0, &Default::default());
        let blocked = (0..400)
            .map(|k| Pos::new(k / 20, k % 20))
            .find(|&p| coarse.get(p) == Occupancy::Obstacle)
            .unwrap();
        let err = refusal(
            scene,
            &[blocked, Pos::new(17, 3), Pos::new(18, 2)],
            ScenarioConfig::default(),
            ContinuousConfig::default(),
        );
        assert!(err.contains("inside an obstacle"), "{err}");
    }

    #[test]
    fn localization_error_blurs_the_map_and_repeats_itself() {
        let noisy = |seed: u64| {
            let mut cfg = ContinuousConfig::default();
            cfg.mapping.localization_noise_m = 0.1;
            cfg.mapping.localization_noise_rad = 0.05;
            let scene = Arc::new(generate_cluttered(20.0, 0.1, 1));
            let starts = [Pos::new(17, 2), Pos::new(17, 3), Pos::new(18, 2)];
            let mut w =
                ContinuousWorld::new(scene, &starts, ScenarioConfig::default(), cfg, seed).unwrap();
            for _ in 0..40 {
                w.step(&[(0.0, 0.0); 3]);
            }
            w.map(0).probabilities()
        };
        let mut exact = world(1);
        for _ in 0..40 {
            exact.step(&[(0.0, 0.0); 3]);
        }
        let occupied = |p: &[f64]| p.iter().filter(|&&v| v > 0.65).count();
        let (a, b, truth) = (noisy(1), noisy(1), exact.map(0).probabilities());
        assert_eq!(a, b, "same seed, same map");
        assert_ne!(a, truth);
        // Ten scans from a standing robot at jittered poses smear each surface over the pixels
        // around it: the map differs from the exact one but keeps its walls (the occupied
        // count stays of the same order).
        let (n, m) = (occupied(&a), occupied(&truth));
        assert!(n > m / 4 && n < m * 4, "{n} vs {m}");
        let mut bad = ContinuousConfig::default();
        bad.mapping.localization_noise_m = f64::NAN;
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("mapping.localization_noise_m"), "{e}");
    }

    #[test]
    fn a_footprint_wider_than_every_passage_is_refused() {
        // A 9 m plus of 1 m corridors at 0.1 m per pixel: a footprint of 0.48 m fits at the
        // start cell's centre, but with the 0.05 m margin (1.06 m across) it cannot drive.
        let (side, px) = (9usize, 10usize);
        let cells = (0..side * px * side * px)
            .map(|k| {
                let (r, c) = (k / (side * px) / px, k % (side * px) / px);
                let corridor = (r == 4 && (1..8).contains(&c)) || (c == 4 && (1..8).contains(&r));
                if corridor {
                    Occupancy::Free
                } else {
                    Occupancy::Obstacle
                }
            })
            .collect();
        let mut grid = madenet_map::OccGrid::from_cells(side * px, side * px, cells);
        grid.resolution = 0.1;
        let scene = Arc::new(Scene::from_grid(&grid, "plus"));
        let scenario = ScenarioConfig {
            num_robots: 1,
            ..Default::default()
        };
        let mut cfg = ContinuousConfig::default();
        cfg.robot.radius = 0.48;
        let err = refusal(scene.clone(), &[Pos::new(4, 4)], scenario.clone(), cfg);
        assert!(
            err.contains("`robot.radius`") && err.contains("cannot leave"),
            "{err}"
        );
        // A footprint that fits drives.
        cfg.robot.radius = 0.3;
        assert!(ContinuousWorld::new(scene, &[Pos::new(4, 4)], scenario, cfg, 1).is_ok());
    }
}
