//! A run of any world as ROS 2 messages in simulated time (published on `/clock`), into a bag
//! ([`crate::bag`]: `madenet run --record DIR`), a live Foxglove view ([`crate::live`]:
//! `madenet run --foxglove`), or both — the same messages, encoded once. One [`Recorder`] reads
//! every world through [`madenet_sim::stepping::Present`] (the grid trial, the continuous
//! trial, a world node), so every world's bag carries the same topics; the continuous world
//! adds its scans and fine maps. A grid timestep is one simulated second.
//!
//! | topic | type | when |
//! | --- | --- | --- |
//! | `/truth_map` | `nav_msgs/msg/OccupancyGrid` | once, at the start: the true map in the agents' cells |
//! | `/fine_truth_map` | `nav_msgs/msg/OccupancyGrid` | continuous world, once: the scene at its fine resolution (0.1 m pixels by default) |
//! | `/team_map` | `nav_msgs/msg/OccupancyGrid` | when it changes (at most once a simulated second): the team's merged map 𝓜 (everything any robot read) |
//! | `/robot<i>/map` | `nav_msgs/msg/OccupancyGrid` | when it changes: the grid robot's belief with the timestep's own observation; the continuous robot's fine map (occupancy %), after a scan, at most every 5 s (slam_toolbox's `map_update_interval`; a world node's robots keep theirs in their own processes) |
//! | `/robot<i>/scan` | `sensor_msgs/msg/LaserScan` | continuous world: each of robot i's scans (all at the start, then staggered), in `robot<i>/base_link` |
//! | `/robot<i>/pose` | `geometry_msgs/msg/PoseStamped` | every timestep (continuous: 10 Hz), the start and the end included |
//! | `/robot<i>/goal_pose` | `geometry_msgs/msg/PoseStamped` | when robot i's goal changes (to none: its own cell) |
//! | `/robot<i>/plan` | `nav_msgs/msg/Path` | when robot i's route or goal changes (not when it only advances along the last route): from its cell to its goal |
//! | `/robot<i>/candidates` | `visualization_msgs/msg/MarkerArray` | when robot i decided with goal candidates 𝒢_i: every candidate (grey spheres, numbered by slot, with the learned policy's score: `2: 0.41`) and the chosen one (the robot's colour) |
//! | `/comms` | `visualization_msgs/msg/MarkerArray` | when it changes: pairs in contact at the last radio round that exchanged β (green lines) and whose exchange dropped out (red) |
//! | `/metrics/explored` | `std_msgs/msg/Float64` | every simulated second and at the end: the share of the explorable cells the team knows, 0–1 |
//! | `/metrics/distance` | `std_msgs/msg/Float64` | as `/metrics/explored`: metres driven by the team so far (TTD) |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | with the poses: `map` → `robot<i>/base_link` |
//! | `/clock` | `rosgraph_msgs/msg/Clock` | with the poses |
//!
//! Every stamp is written once: the final state adds only what its step did not write.
//!
//! ```
//! use madenet_map::paper::{paper_map, Corner};
//! use madenet_ros2::record::Recorder;
//! use madenet_sim::{Trial, TrialSpec};
//!
//! let map = paper_map(3).unwrap();
//! let starts = Corner::TopRight.start_cells(map.height(), map.width()).to_vec();
//! let spec = TrialSpec {
//!     map,
//!     map_name: "test_3".into(),
//!     starts,
//!     config: Default::default(),
//!     policy: "spread".into(),
//!     seed: 1,
//! };
//! let mut trial = Trial::new(spec).unwrap();
//! let dir = std::env::temp_dir().join(format!("madenet-record-doc-{}", std::process::id()));
//! let mut bag = Recorder::start(&dir, &trial).unwrap();
//! while trial.step() {
//!     bag.step(&trial).unwrap();
//! }
//! let (dir, messages) = bag.finish(&trial).unwrap().expect("a bag");
//! assert!(messages > 100 && dir.join("metadata.yaml").is_file());
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

use crate::bag::{Bag, BagError};
use crate::live::Live;
use crate::msgs::RosMessage;
use crate::msgs::{
    Clock, ColorRGBA, Float64, Header, Marker, MarkerArray, Path, Point, TFMessage, Time,
    Transform, TransformStamped, Vector3,
};
use crate::sim_sensors::{fine_grid, laser_scan, pose_stamped, scan_topic};
use crate::{occupancy_grid, MapFrame, FRAME_ID};
use madenet_map::{Occupancy, Pos};
use madenet_sim::stepping::{Present, RobotShown, Sink, SinkError};
use std::ops::ControlFlow;
use std::path::PathBuf;

/// Where the messages go: a bag, a live view, or both (each message encoded once).
struct Outputs {
    bag: Option<Bag>,
    live: Option<Live>,
    /// The encoding buffer, reused message after message.
    cdr: Vec<u8>,
}

impl Outputs {
    /// Writes `msg` on `topic` at `ns` to every output, encoded once.
    fn put<T: RosMessage>(&mut self, topic: &str, msg: &T, ns: u64) -> Result<(), BagError> {
        msg.write_cdr(&mut self.cdr);
        if let Some(live) = &mut self.live {
            live.write_cdr::<T>(topic, &self.cdr, ns);
        }
        match &mut self.bag {
            Some(bag) => bag.write_cdr::<T>(topic, &self.cdr, ns),
            None => Ok(()),
        }
    }

    fn messages(&self) -> u64 {
        self.bag.as_ref().map_or(0, Bag::messages)
    }

    fn finish(&mut self) -> Result<Option<(PathBuf, u64)>, BagError> {
        let Some(bag) = self.bag.take() else {
            return Ok(None);
        };
        let messages = bag.messages();
        Ok(Some((bag.finish()?, messages)))
    }
}

/// Robot i's topic names and `/tf` child frame, made once per recording.
struct RobotTopics {
    map: String,
    pose: String,
    goal: String,
    plan: String,
    candidates: String,
    scan: String,
    base_link: String,
}

impl RobotTopics {
    fn of(i: usize) -> Self {
        let [map, pose, goal] = crate::topics(i);
        RobotTopics {
            map,
            pose,
            goal,
            plan: format!("/robot{i}/plan"),
            candidates: format!("/robot{i}/candidates"),
            scan: scan_topic(i),
            base_link: format!("robot{i}/base_link"),
        }
    }
}

/// Robot i's colour: the palette of madenet's pictures, cycled.
fn robot_color(i: usize) -> ColorRGBA {
    const PALETTE: [[f32; 3]; 6] = [
        [0.89, 0.10, 0.11],
        [0.22, 0.49, 0.72],
        [0.30, 0.69, 0.29],
        [0.60, 0.31, 0.64],
        [1.00, 0.50, 0.00],
        [0.65, 0.34, 0.16],
    ];
    let [r, g, b] = PALETTE[i % PALETTE.len()];
    ColorRGBA { r, g, b, a: 1.0 }
}

/// Seconds between two fine maps of a continuous robot: slam_toolbox's default
/// `map_update_interval` (5 s), as a SLAM node publishes its `map`.
pub const FINE_MAP_PERIOD: f64 = 5.0;

/// How often, in steps, each group of topics is written (a grid timestep is one second: every
/// step for all of them).
#[derive(Clone, Copy, Debug)]
struct Every {
    /// Poses, `/tf`, `/clock` and the radio's lines: 10 Hz.
    pose: u64,
    /// Metrics: once a second.
    metrics: u64,
    /// The team map: at most once a second.
    map: u64,
    /// The continuous robots' fine maps: at most every [`FINE_MAP_PERIOD`].
    fine_map: u64,
    /// The continuous robots' scans (the lidar's period).
    scan: u64,
}

/// A run being recorded or streamed ([module docs](self)).
pub struct Recorder {
    out: Outputs,
    frame: MapFrame,
    every: Every,
    /// Steps recorded so far.
    ticks: u64,
    /// The tick at which poses and metrics were last written (the final state writes only
    /// what its step did not).
    pose_tick: Option<u64>,
    metrics_tick: Option<u64>,
    /// Each robot's map last written (the grid's cells, the continuous world's fine map) and
    /// the tick of the fine map.
    maps: Vec<Option<Vec<i8>>>,
    map_ticks: Vec<u64>,
    team: Option<Vec<Occupancy>>,
    goals: Vec<Option<Pos>>,
    plans: Vec<Option<Vec<Pos>>>,
    /// Each robot's decision count when last recorded.
    decisions: Vec<u64>,
    names: Vec<RobotTopics>,
    /// The radio's lines last published (pairs exchanged, pairs dropped, as cells).
    comms: Option<(Vec<Pos>, Vec<Pos>)>,
}

impl Recorder {
    /// Starts the bag at `path` (a new path or an empty folder) with the true map and the
    /// run's present.
    pub fn start<S: Present + ?Sized>(path: &std::path::Path, sim: &S) -> Result<Self, BagError> {
        Self::to(Some(Bag::create(path)?), sim)
    }

    /// Starts recording into `bag` (if any) with the true map and the run's present.
    pub fn to<S: Present + ?Sized>(bag: Option<Bag>, sim: &S) -> Result<Self, BagError> {
        Self::to_live(bag, None, sim)
    }

    /// Starts recording into `bag` (if any) and streaming to `live` (if any), with the true
    /// map and the run's present.
    pub fn to_live<S: Present + ?Sized>(
        bag: Option<Bag>,
        live: Option<Live>,
        sim: &S,
    ) -> Result<Self, BagError> {
        let out = Outputs {
            bag,
            live,
            cdr: Vec::new(),
        };
        let step = sim.step_s();
        let every = |s: f64| (s / step).round().max(1.0) as u64;
        let scan = sim
            .continuous()
            .map_or(1, |w| every(1.0 / w.config().lidar.rate_hz));
        let n = sim.robots();
        let truth = sim.truth();
        let mut r = Recorder {
            out,
            frame: MapFrame::of(truth),
            every: Every {
                pose: every(0.1),
                metrics: every(1.0),
                map: every(1.0),
                fine_map: every(FINE_MAP_PERIOD),
                scan,
            },
            ticks: 0,
            pose_tick: None,
            metrics_tick: None,
            maps: vec![None; n],
            map_ticks: vec![0; n],
            team: None,
            goals: vec![None; n],
            plans: vec![None; n],
            decisions: vec![0; n],
            names: (0..n).map(RobotTopics::of).collect(),
            comms: None,
        };
        let msg = occupancy_grid(&r.frame, truth.cells(), Time::default());
        r.out.put("/truth_map", &msg, 0)?;
        if let Some(w) = sim.continuous() {
            // The scene itself at its fine resolution (what the lidar hits), beside the
            // robots' fine maps.
            let fine = &w.scene().fine;
            let msg = occupancy_grid(&MapFrame::of(fine), fine.cells(), Time::default());
            r.out.put("/fine_truth_map", &msg, 0)?;
        }
        r.record(sim, false)?;
        Ok(r)
    }

    /// Records the step the run just took.
    pub fn step<S: Present + ?Sized>(&mut self, sim: &S) -> Result<(), BagError> {
        self.ticks += 1;
        self.record(sim, false)
    }

    /// Messages written to the bag so far.
    pub fn messages(&self) -> u64 {
        self.out.messages()
    }

    /// Records the run's final state (what its last step did not write), then finishes the
    /// bag, if any: where it is, and how many messages it holds.
    pub fn finish<S: Present + ?Sized>(
        mut self,
        sim: &S,
    ) -> Result<Option<(PathBuf, u64)>, BagError> {
        self.record(sim, true)?;
        self.out.finish()
    }

    /// The live view's URL, if streaming.
    pub fn live_url(&self) -> Option<&str> {
        self.out.live.as_ref().map(Live::url)
    }

    /// `last`: the run's final state (poses, `/tf`, `/clock` and metrics written whatever
    /// their rate, unless this tick has them already; no scans).
    fn record<S: Present + ?Sized>(&mut self, sim: &S, last: bool) -> Result<(), BagError> {
        let secs = sim.time_s();
        let ns = (secs * 1e9).round() as u64;
        let stamp = Time {
            sec: secs.floor() as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        };
        let k = self.ticks;
        let n = sim.robots();
        let due = |every: u64, done: Option<u64>| {
            if last {
                done != Some(k)
            } else {
                k.is_multiple_of(every)
            }
        };
        if due(self.every.pose, self.pose_tick) {
            self.pose_tick = Some(k);
            self.out.put("/clock", &Clock { clock: stamp }, ns)?;
            let mut transforms = Vec::with_capacity(n);
            for i in 0..n {
                let pose = pose_stamped(sim.pose(i), &self.frame, stamp);
                let p = &pose.pose;
                transforms.push(TransformStamped {
                    header: pose.header.clone(),
                    child_frame_id: self.names[i].base_link.clone(),
                    transform: Transform {
                        translation: Vector3 {
                            x: p.position.x,
                            y: p.position.y,
                            z: 0.0,
                        },
                        rotation: p.orientation,
                    },
                });
                self.out.put(&self.names[i].pose, &pose, ns)?;
            }
            self.out.put("/tf", &TFMessage { transforms }, ns)?;
            self.record_comms(sim, stamp, ns)?;
        }
        let maps_due = last || k.is_multiple_of(self.every.map);
        for i in 0..n {
            self.record_robot_map(sim, i, last, stamp, ns)?;
            self.record_robot(sim, i, stamp, ns)?;
        }
        if maps_due {
            let team = sim.team_map();
            if self.team.as_deref() != Some(&team[..]) {
                let msg = occupancy_grid(&self.frame, &team, stamp);
                self.out.put("/team_map", &msg, ns)?;
                self.team = Some(team.into_owned());
            }
        }
        if due(self.every.metrics, self.metrics_tick) {
            self.metrics_tick = Some(k);
            let explored = Float64 {
                data: sim.explored(),
            };
            self.out.put("/metrics/explored", &explored, ns)?;
            let distance = Float64 {
                data: sim.distance(),
            };
            self.out.put("/metrics/distance", &distance, ns)?;
        }
        Ok(())
    }

    /// Robot `i`'s own map when it changed: the grid's belief every step, the continuous
    /// world's scan and fine map after a scan.
    fn record_robot_map<S: Present + ?Sized>(
        &mut self,
        sim: &S,
        i: usize,
        last: bool,
        stamp: Time,
        ns: u64,
    ) -> Result<(), BagError> {
        let k = self.ticks;
        if let Some(cells) = sim.belief(i) {
            let msg = occupancy_grid(&self.frame, &cells, stamp);
            if self.maps[i].as_ref() != Some(&msg.data) {
                self.out.put(&self.names[i].map, &msg, ns)?;
                self.maps[i] = Some(msg.data);
            }
            return Ok(());
        }
        let Some(world) = sim.continuous() else {
            return Ok(());
        };
        // The world scans every robot at the start and robot i at the end of the periods
        // where (ticks + i) is a multiple of the scan period (the stand-in's rule).
        if last || !(k == 0 || (k + i as u64).is_multiple_of(self.every.scan)) {
            return Ok(());
        }
        self.out
            .put(&self.names[i].scan, &laser_scan(world, i, stamp), ns)?;
        if self.maps[i].is_none() || k - self.map_ticks[i] >= self.every.fine_map {
            let grid = fine_grid(world, i, &self.frame, stamp);
            if self.maps[i].as_ref() != Some(&grid.data) {
                self.out.put(&self.names[i].map, &grid, ns)?;
                self.maps[i] = Some(grid.data);
                self.map_ticks[i] = k;
            }
        }
        Ok(())
    }

    /// Robot `i`'s goal, plan and goal candidates, when they change.
    fn record_robot<S: Present + ?Sized>(
        &mut self,
        sim: &S,
        i: usize,
        stamp: Time,
        ns: u64,
    ) -> Result<(), BagError> {
        let r = sim.robot(i);
        let here = sim.cell(i);
        let header = Header {
            stamp,
            frame_id: FRAME_ID.into(),
        };
        let goal_changed = r.goal != self.goals[i];
        if goal_changed {
            // No goal any more (nothing left to reach): its own cell, so the last goal does
            // not stay shown (PoseStamped has no "none").
            let msg = crate::pose_stamped(&self.frame, r.goal.unwrap_or(here), stamp);
            self.out.put(&self.names[i].goal, &msg, ns)?;
            self.goals[i] = r.goal;
        }
        // The route from where the robot stands (the agent plans before it moves, so its
        // path may still begin with the cell it just left); published when the route changes
        // or the goal does (a new goal with no route yet is the plan `[here]`), not when the
        // robot only advances along the last one published.
        let from = r.path.iter().position(|&p| p == here).map_or(0, |k| k + 1);
        let plan: Vec<Pos> = std::iter::once(here)
            .chain(r.path[from..].iter().copied())
            .collect();
        let advanced = !goal_changed
            && self.plans[i]
                .as_ref()
                .is_some_and(|last| last.ends_with(&plan));
        if !advanced {
            let poses = plan
                .iter()
                .map(|&p| crate::pose_stamped(&self.frame, p, stamp))
                .collect();
            let msg = Path { header, poses };
            self.out.put(&self.names[i].plan, &msg, ns)?;
            self.plans[i] = Some(plan);
        }
        if r.decisions != self.decisions[i] && !r.candidates.is_empty() {
            let msg = self.candidate_markers(i, &r, stamp);
            self.out.put(&self.names[i].candidates, &msg, ns)?;
        }
        self.decisions[i] = r.decisions;
        Ok(())
    }

    /// The radio's lines when they change (markers stay until replaced).
    fn record_comms<S: Present + ?Sized>(
        &mut self,
        sim: &S,
        stamp: Time,
        ns: u64,
    ) -> Result<(), BagError> {
        let exchanges = sim.exchanges();
        let (ok, dropped): (Vec<_>, Vec<_>) = sim
            .contacts()
            .iter()
            .copied()
            .partition(|pair| exchanges.contains(pair));
        let ends = |pairs: &[(usize, usize)]| -> Vec<Pos> {
            pairs
                .iter()
                .flat_map(|&(a, b)| [sim.cell(a), sim.cell(b)])
                .collect()
        };
        let lines = (ends(&ok), ends(&dropped));
        if self.comms.as_ref() != Some(&lines) {
            let comms = self.comm_markers(&lines.0, &lines.1, stamp);
            self.out.put("/comms", &comms, ns)?;
            self.comms = Some(lines);
        }
        Ok(())
    }

    /// A marker in the map frame at `stamp`.
    fn marker(stamp: Time, ns: &str, id: i32, kind: i32) -> Marker {
        Marker {
            header: Header {
                stamp,
                frame_id: FRAME_ID.into(),
            },
            ns: ns.into(),
            id,
            kind,
            action: Marker::ADD,
            ..Default::default()
        }
    }

    /// The centre of cell `p` as a point (z: `z` metres).
    fn point(&self, p: Pos, z: f64) -> Point {
        let (x, y) = self.frame.cell_center(p);
        Point { x, y, z }
    }

    /// Robot `i`'s goal candidates as markers: every one a grey sphere labelled with its slot
    /// number (and, when a learned policy decided, its score: `k: 0.42`), the chosen one
    /// larger and in the robot's colour.
    fn candidate_markers(&self, i: usize, r: &RobotShown<'_>, stamp: Time) -> MarkerArray {
        let (cells, chosen) = (r.candidates, r.chosen);
        let ns = format!("robot{i}/candidates");
        let mut all = Self::marker(stamp, &ns, 0, Marker::SPHERE_LIST);
        all.scale = Vector3 {
            x: 0.35,
            y: 0.35,
            z: 0.35,
        };
        all.color = ColorRGBA {
            r: 0.5,
            g: 0.5,
            b: 0.5,
            a: 0.8,
        };
        all.points = cells.iter().map(|&p| self.point(p, 0.2)).collect();
        // The previous decision's markers go first (it may have had more slots).
        let mut markers = vec![Self::marker(stamp, &ns, 0, 0), all];
        markers[0].action = Marker::DELETEALL;
        for (k, &p) in cells.iter().enumerate() {
            let mut label = Self::marker(stamp, &ns, 2 + k as i32, Marker::TEXT_VIEW_FACING);
            label.pose.position = self.point(p, 0.6);
            label.scale.z = 0.4;
            label.color = ColorRGBA {
                r: 1.0,
                g: 1.0,
                b: 1.0,
                a: 1.0,
            };
            label.text = match r.scores.and_then(|q| q.get(k)).filter(|v| v.is_finite()) {
                Some(v) => format!("{k}: {v:.2}"),
                None => k.to_string(),
            };
            markers.push(label);
        }
        if let Some(&p) = chosen.and_then(|k| cells.get(k)) {
            let mut pick = Self::marker(stamp, &ns, 1, Marker::SPHERE);
            pick.pose.position = self.point(p, 0.2);
            pick.scale = Vector3 {
                x: 0.6,
                y: 0.6,
                z: 0.6,
            };
            pick.color = robot_color(i);
            markers.push(pick);
        }
        MarkerArray { markers }
    }

    /// The radio's lines: one per pair in contact (`ok`, `dropped`: their end cells, two a
    /// pair), green where β was exchanged, red where the exchange dropped out.
    fn comm_markers(&self, ok: &[Pos], dropped: &[Pos], stamp: Time) -> MarkerArray {
        let lines = |id: i32, ends: &[Pos], color: ColorRGBA| {
            let mut m = Self::marker(stamp, "comms", id, Marker::LINE_LIST);
            m.scale.x = 0.08;
            m.color = color;
            m.points = ends.iter().map(|&p| self.point(p, 0.1)).collect();
            if m.points.is_empty() {
                // No lines of this colour: remove the last ones (a LINE_LIST without points is
                // an error to Foxglove / Lichtblick).
                m.action = Marker::DELETE;
            }
            m
        };
        let green = ColorRGBA {
            r: 0.1,
            g: 0.8,
            b: 0.2,
            a: 1.0,
        };
        let red = ColorRGBA {
            r: 0.9,
            g: 0.1,
            b: 0.1,
            a: 1.0,
        };
        MarkerArray {
            markers: vec![lines(0, ok, green), lines(1, dropped, red)],
        }
    }
}

/// The recorder as a sink of the run loop ([`madenet_sim::stepping::run`]): started by its
/// owner (which makes its outputs, so a refused path fails before the run), told of every
/// step, and finished with the final state. `finish` gives the line to print about the bag.
pub struct RecorderSink(Option<Recorder>);

impl RecorderSink {
    /// Wraps a started recorder.
    pub fn new(recorder: Recorder) -> Self {
        RecorderSink(Some(recorder))
    }
}

impl<S: Present + ?Sized> Sink<S> for RecorderSink {
    fn step(&mut self, sim: &S) -> Result<ControlFlow<String>, SinkError> {
        if let Some(r) = self.0.as_mut() {
            r.step(sim).map_err(|e| format!("--record: {e}"))?;
        }
        Ok(ControlFlow::Continue(()))
    }

    fn finish(&mut self, sim: &S) -> Result<Vec<String>, SinkError> {
        let Some(r) = self.0.take() else {
            return Ok(Vec::new());
        };
        let done = r.finish(sim).map_err(|e| format!("--record: {e}"))?;
        Ok(done
            .map(|(dir, messages)| wrote_line(&dir, messages))
            .into_iter()
            .collect())
    }
}

/// The line printed about a finished bag at `dir` holding `messages`.
pub fn wrote_line(dir: &std::path::Path, messages: u64) -> String {
    let bytes: u64 = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok()?.metadata().ok())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0);
    format!(
        "wrote      {} (ROS 2 bag, {messages} messages, {:.1} kB)",
        dir.display(),
        bytes as f64 / 1e3
    )
}
