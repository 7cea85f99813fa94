//! A grid trial as ROS 2 messages in simulated time (timestep t is second t, published on
//! `/clock`), into a bag ([`crate::bag`]: `madenet run --record DIR`), a live Foxglove view
//! (`crate::live`, feature `foxglove`: `madenet run --foxglove`), or both — the same messages,
//! encoded once.
//!
//! | topic | type | when |
//! | --- | --- | --- |
//! | `/truth_map` | `nav_msgs/msg/OccupancyGrid` | once, at the start |
//! | `/team_map` | `nav_msgs/msg/OccupancyGrid` | when it changes: the team's merged map 𝓜 (everything any robot observed) |
//! | `/robot<i>/map` | `nav_msgs/msg/OccupancyGrid` | when it changes: robot i's belief with the timestep's own observation |
//! | `/robot<i>/pose` | `geometry_msgs/msg/PoseStamped` | every timestep, the start and the end included |
//! | `/robot<i>/goal_pose` | `geometry_msgs/msg/PoseStamped` | when robot i's goal changes (to none: its own cell) |
//! | `/robot<i>/plan` | `nav_msgs/msg/Path` | when robot i's route or goal changes (not when it only advances along the last route): from its cell to its goal |
//! | `/robot<i>/candidates` | `visualization_msgs/msg/MarkerArray` | when robot i decided with goal candidates 𝒢_i: every candidate (grey spheres, numbered by slot, with the learned policy's score: `2: 0.41`) and the chosen one (the robot's colour) |
//! | `/comms` | `visualization_msgs/msg/MarkerArray` | when it changes: pairs in contact that exchanged β (green lines) and whose exchange dropped out (red) |
//! | `/metrics/explored` | `std_msgs/msg/Float64` | every timestep: the share of the explorable cells the team knows, 0–1 |
//! | `/metrics/distance` | `std_msgs/msg/Float64` | every timestep: metres driven by the team so far (TTD) |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | every timestep: `map` → `robot<i>/base_link` |
//! | `/clock` | `rosgraph_msgs/msg/Clock` | every timestep |
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
//! let (dir, messages) = bag.finish().unwrap().expect("a bag");
//! assert!(messages > 100 && dir.join("metadata.yaml").is_file());
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

use crate::bag::{Bag, BagError};
use crate::msgs::RosMessage;
use crate::msgs::{
    Clock, ColorRGBA, Float64, Header, Marker, MarkerArray, Path, Point, TFMessage, Time,
    Transform, TransformStamped, Vector3,
};
use crate::{occupancy_grid, pose_stamped, MapFrame, FRAME_ID};
use madenet_map::{Occupancy, Pos};
use madenet_sim::Trial;
use std::path::PathBuf;

/// Where the messages go: a bag, a live view, or both (each message encoded once).
struct Outputs {
    bag: Option<Bag>,
    #[cfg(feature = "foxglove")]
    live: Option<crate::live::Live>,
    /// The encoding buffer, reused message after message.
    cdr: Vec<u8>,
}

impl Outputs {
    fn new(bag: Option<Bag>) -> Self {
        Outputs {
            bag,
            #[cfg(feature = "foxglove")]
            live: None,
            cdr: Vec::new(),
        }
    }

    /// Writes `msg` on `topic` at `ns` to every output, encoded once.
    fn put<T: RosMessage>(&mut self, topic: &str, msg: &T, ns: u64) -> Result<(), BagError> {
        msg.write_cdr(&mut self.cdr);
        #[cfg(feature = "foxglove")]
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

    fn finish(self) -> Result<Option<(PathBuf, u64)>, BagError> {
        let Some(bag) = self.bag else {
            return Ok(None);
        };
        let messages = bag.messages();
        Ok(Some((bag.finish()?, messages)))
    }
}

/// A grid trial being recorded ([module docs](self)).
pub struct Recorder {
    out: Outputs,
    frame: MapFrame,
    maps: Vec<Option<Vec<Occupancy>>>,
    team: Option<Vec<Occupancy>>,
    goals: Vec<Option<Pos>>,
    plans: Vec<Option<Vec<Pos>>>,
    /// Each robot's decision count (a world node's: as its robot shows it) when last recorded.
    decisions: Vec<u64>,
    /// Each robot's topic names and `/tf` child frame, made once.
    names: Vec<RobotTopics>,
    /// The radio's lines last published (pairs exchanged, pairs dropped, as cells).
    comms: Option<(Vec<Pos>, Vec<Pos>)>,
}

/// Robot i's topic names and `/tf` child frame, made once per recording.
struct RobotTopics {
    map: String,
    pose: String,
    goal: String,
    plan: String,
    candidates: String,
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
            base_link: format!("robot{i}/base_link"),
        }
    }
}

/// What the recorder reads of one robot at a timestep.
struct RobotView<'a> {
    /// Its map (None: not known here).
    belief: Option<&'a [Occupancy]>,
    goal: Option<Pos>,
    path: &'a [Pos],
    candidates: &'a [Pos],
    /// The slot of its goal among `candidates`.
    chosen: Option<usize>,
    /// What its policy weighed per slot at the decision (learned policies).
    scores: Option<&'a [f32]>,
    /// Changes when it decides.
    decision: u64,
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

impl Recorder {
    /// Starts the bag at `path` (a new path or an empty folder) with the true map and the
    /// trial's present.
    pub fn start(path: &std::path::Path, trial: &Trial) -> Result<Self, BagError> {
        Self::to(Some(Bag::create(path)?), trial)
    }

    /// Starts recording into `bag` (if any) with the true map and the trial's present.
    pub fn to(bag: Option<Bag>, trial: &Trial) -> Result<Self, BagError> {
        Self::begin(Outputs::new(bag), trial)
    }

    /// Starts recording into `bag` (if any) and streaming to `live`, with the true map and the
    /// trial's present.
    #[cfg(feature = "foxglove")]
    pub fn to_live(
        bag: Option<Bag>,
        live: crate::live::Live,
        trial: &Trial,
    ) -> Result<Self, BagError> {
        Self::begin(
            Outputs {
                live: Some(live),
                ..Outputs::new(bag)
            },
            trial,
        )
    }

    fn begin(out: Outputs, trial: &Trial) -> Result<Self, BagError> {
        let mut r = Self::empty(out, trial.world())?;
        r.step(trial)?;
        Ok(r)
    }

    /// Starts recording a world node's timesteps ([`Recorder::step_world`], the first before
    /// the first timestep) into `bag` (if any), with the true map.
    pub fn for_world(bag: Option<Bag>, world: &madenet_world::World) -> Result<Self, BagError> {
        Self::empty(Outputs::new(bag), world)
    }

    /// [`Recorder::for_world`], streaming to `live` too.
    #[cfg(feature = "foxglove")]
    pub fn for_world_live(
        bag: Option<Bag>,
        live: crate::live::Live,
        world: &madenet_world::World,
    ) -> Result<Self, BagError> {
        Self::empty(
            Outputs {
                live: Some(live),
                ..Outputs::new(bag)
            },
            world,
        )
    }

    /// A recorder of `world`'s robots that has written the true map only.
    fn empty(out: Outputs, world: &madenet_world::World) -> Result<Self, BagError> {
        let truth = world.truth();
        let frame = MapFrame::of(truth);
        let n = world.positions().len();
        let mut r = Recorder {
            out,
            frame,
            maps: vec![None; n],
            team: None,
            goals: vec![None; n],
            plans: vec![None; n],
            decisions: vec![0; n],
            names: (0..n).map(RobotTopics::of).collect(),
            comms: None,
        };
        let msg = occupancy_grid(&r.frame, truth.cells(), Time::default());
        r.put("/truth_map", &msg, 0)?;
        Ok(r)
    }

    /// Writes `msg` on `topic` at `ns` to every output.
    fn put<T: RosMessage>(&mut self, topic: &str, msg: &T, ns: u64) -> Result<(), BagError> {
        self.out.put(topic, msg, ns)
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

    /// Records the trial's current timestep.
    pub fn step(&mut self, trial: &Trial) -> Result<(), BagError> {
        let world = trial.world();
        let width = world.truth().width();
        let beliefs: Vec<Vec<Occupancy>> = trial
            .agents()
            .iter()
            .enumerate()
            .map(|(i, a)| {
                // What the robot knows now: its belief and this timestep's observation, which
                // its agent takes in at the start of the next timestep (or never, at the end),
                // as `Belief::observe` takes it in: unknown cells learn, free ones may turn out
                // obstacles.
                let mut cells = a.belief().map().to_vec();
                for &(p, occ) in &world.observation(i).seen {
                    let c = &mut cells[p.row as usize * width + p.col as usize];
                    match (*c, occ) {
                        (_, Occupancy::Unknown) => {}
                        (Occupancy::Unknown, o) => *c = o,
                        (Occupancy::Free, Occupancy::Obstacle) => *c = Occupancy::Obstacle,
                        _ => {}
                    }
                }
                cells
            })
            .collect();
        let robots: Vec<RobotView<'_>> = trial
            .agents()
            .iter()
            .zip(&beliefs)
            .map(|(a, b)| RobotView {
                belief: Some(b),
                goal: a.goal(),
                path: a.path(),
                candidates: &a.candidates().cells,
                chosen: a.action(),
                scores: a.policy_scores(),
                decision: a.stats().decisions as u64,
            })
            .collect();
        self.record(world, &robots, world.exchanges())
    }

    /// Records a world node's timestep (`madenet world`, which `launch` starts): the world,
    /// what each robot shows (goal, path, candidates, a learned policy's scores;
    /// [`madenet_runtime::wire::Shown`]) and the
    /// radio's exchanges. The robots' beliefs live in their own processes: no `/robot<i>/map`.
    pub fn step_world(
        &mut self,
        world: &madenet_world::World,
        shown: &[madenet_runtime::wire::Shown],
        exchanges: &[(usize, usize)],
    ) -> Result<(), BagError> {
        let none = madenet_runtime::wire::Shown::default();
        let robots: Vec<RobotView<'_>> = (0..world.positions().len())
            .map(|i| {
                let s = shown.get(i).unwrap_or(&none);
                RobotView {
                    belief: None,
                    goal: s.goal,
                    path: &s.path,
                    candidates: &s.candidates,
                    chosen: s
                        .goal
                        .and_then(|g| s.candidates.iter().position(|&c| c == g)),
                    scores: (!s.scores.is_empty()).then_some(&s.scores[..]),
                    decision: s.decisions,
                }
            })
            .collect();
        self.record(world, &robots, exchanges)
    }

    fn record(
        &mut self,
        world: &madenet_world::World,
        robots: &[RobotView<'_>],
        exchanges: &[(usize, usize)],
    ) -> Result<(), BagError> {
        let t = world.t() as u64;
        let (ns, stamp) = (
            t * 1_000_000_000,
            Time {
                sec: t as i32,
                nanosec: 0,
            },
        );
        self.put("/clock", &Clock { clock: stamp }, ns)?;
        let positions = world.positions();
        let transforms = positions
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                let (x, y) = self.frame.cell_center(p);
                let q = pose_stamped(&self.frame, p, stamp).pose.orientation;
                TransformStamped {
                    header: Header {
                        stamp,
                        frame_id: FRAME_ID.into(),
                    },
                    child_frame_id: self.names[i].base_link.clone(),
                    transform: Transform {
                        translation: Vector3 { x, y, z: 0.0 },
                        rotation: q,
                    },
                }
            })
            .collect();
        self.put("/tf", &TFMessage { transforms }, ns)?;
        for (i, r) in robots.iter().enumerate() {
            if let Some(cells) = r.belief.filter(|&c| self.maps[i].as_deref() != Some(c)) {
                let msg = occupancy_grid(&self.frame, cells, stamp);
                self.out.put(&self.names[i].map, &msg, ns)?;
                match &mut self.maps[i] {
                    Some(m) => m.copy_from_slice(cells),
                    m => *m = Some(cells.to_vec()),
                }
            }
            let pose = pose_stamped(&self.frame, positions[i], stamp);
            self.out.put(&self.names[i].pose, &pose, ns)?;
            let goal_changed = r.goal != self.goals[i];
            if goal_changed {
                // No goal any more (nothing left to reach): its own cell, so the last goal
                // does not stay shown (PoseStamped has no "none").
                let msg = pose_stamped(&self.frame, r.goal.unwrap_or(positions[i]), stamp);
                self.out.put(&self.names[i].goal, &msg, ns)?;
            }
            self.goals[i] = r.goal;
            // The plan from where the robot stands (the agent plans before it moves, so its
            // path may still begin with the cell it just left); published when the route
            // changes or the goal does (a new goal with no route yet is the plan `[here]`),
            // not when the robot only advances along the last one published.
            let from = r
                .path
                .iter()
                .position(|&p| p == positions[i])
                .map_or(0, |k| k + 1);
            let plan: Vec<Pos> = std::iter::once(positions[i])
                .chain(r.path[from..].iter().copied())
                .collect();
            let advanced = !goal_changed
                && self.plans[i]
                    .as_ref()
                    .is_some_and(|last| last.ends_with(&plan));
            if !advanced {
                let poses = plan
                    .iter()
                    .map(|&p| pose_stamped(&self.frame, p, stamp))
                    .collect();
                let msg = Path {
                    header: pose.header.clone(),
                    poses,
                };
                self.out.put(&self.names[i].plan, &msg, ns)?;
                self.plans[i] = Some(plan);
            }
            if r.decision != self.decisions[i] && !r.candidates.is_empty() {
                let msg = self.candidate_markers(i, r, stamp);
                self.out.put(&self.names[i].candidates, &msg, ns)?;
            }
            self.decisions[i] = r.decision;
        }
        let team = world.team_map();
        if self.team.as_deref() != Some(team) {
            let msg = occupancy_grid(&self.frame, team, stamp);
            self.put("/team_map", &msg, ns)?;
            match &mut self.team {
                Some(m) => m.copy_from_slice(team),
                m => *m = Some(team.to_vec()),
            }
        }
        // The radio's lines when they change (markers stay until replaced).
        let (ok, dropped): (Vec<_>, Vec<_>) = world
            .contacts()
            .iter()
            .copied()
            .partition(|pair| exchanges.contains(pair));
        let ends = |pairs: &[(usize, usize)]| -> Vec<Pos> {
            pairs
                .iter()
                .flat_map(|&(a, b)| [positions[a], positions[b]])
                .collect()
        };
        let lines = (ends(&ok), ends(&dropped));
        if self.comms.as_ref() != Some(&lines) {
            let comms = self.comm_markers(&lines.0, &lines.1, stamp);
            self.put("/comms", &comms, ns)?;
            self.comms = Some(lines);
        }
        let explored = Float64 {
            data: world.explored_fraction(),
        };
        self.put("/metrics/explored", &explored, ns)?;
        let distance = Float64 {
            data: world.distances().iter().sum(),
        };
        self.put("/metrics/distance", &distance, ns)?;
        Ok(())
    }

    /// Robot `i`'s goal candidates as markers: every one a grey sphere labelled with its slot
    /// number (and, when a learned policy decided, its score: `k: 0.42`), the chosen one
    /// larger and in the robot's colour.
    fn candidate_markers(&self, i: usize, r: &RobotView<'_>, stamp: Time) -> MarkerArray {
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

    /// Messages written to the bag so far.
    pub fn messages(&self) -> u64 {
        self.out.messages()
    }

    /// Finishes the bag, if any: where it is, and how many messages it holds.
    pub fn finish(self) -> Result<Option<(PathBuf, u64)>, BagError> {
        self.out.finish()
    }
}

/// Control periods between fine maps of one robot in a continuous recording (at most one a
/// second at the default 0.05 s period: a 20 m world's fine map is 40 kB a message).
const FINE_MAP_EVERY_S: f64 = 1.0;

/// A continuous trial ([`madenet_sim::continuous::ContinuousTrial`]) being recorded or
/// streamed, in simulated time: the topics of the ROS 2 stand-in
/// ([`crate::continuous_stand_in`]) and more —
///
/// | topic | type | when |
/// | --- | --- | --- |
/// | `/truth_map` | `nav_msgs/msg/OccupancyGrid` | once: the true map in 1 m cells |
/// | `/fine_truth_map` | `nav_msgs/msg/OccupancyGrid` | once: the scene at its fine resolution (0.1 m pixels by default) |
/// | `/robot<i>/scan` | `sensor_msgs/msg/LaserScan` | each of robot i's scans (all at the start, then staggered), in `robot<i>/base_link` |
/// | `/robot<i>/map` | `nav_msgs/msg/OccupancyGrid` | robot i's fine map (occupancy %), when it changed, at most once a second |
/// | `/robot<i>/pose`, `/tf`, `/clock` | as the grid's | 10 Hz and at the end, with the robots' headings |
/// | `/robot<i>/goal_pose`, `/robot<i>/plan` | as the grid's | when they change (the agent's cells) |
/// | `/metrics/explored`, `/metrics/distance` | `std_msgs/msg/Float64` | once a second and at the end |
pub struct ContinuousRecorder {
    out: Outputs,
    frame: MapFrame,
    /// Control periods recorded (the world's ticks).
    ticks: u64,
    scan_every: u64,
    pose_every: u64,
    map_every: u64,
    metrics_every: u64,
    maps: Vec<Option<Vec<i8>>>,
    /// The tick of each robot's last fine map.
    map_ticks: Vec<u64>,
    goals: Vec<Option<Pos>>,
    plans: Vec<Option<Vec<Pos>>>,
}

impl ContinuousRecorder {
    /// Starts recording `trial` into `bag` (if any) with the true map and the present.
    pub fn to(
        bag: Option<Bag>,
        trial: &madenet_sim::continuous::ContinuousTrial,
    ) -> Result<Self, BagError> {
        Self::begin(Outputs::new(bag), trial)
    }

    /// Starts recording into `bag` (if any) and streaming to `live`, with the true map and the
    /// present.
    #[cfg(feature = "foxglove")]
    pub fn to_live(
        bag: Option<Bag>,
        live: crate::live::Live,
        trial: &madenet_sim::continuous::ContinuousTrial,
    ) -> Result<Self, BagError> {
        Self::begin(
            Outputs {
                live: Some(live),
                ..Outputs::new(bag)
            },
            trial,
        )
    }

    fn begin(
        out: Outputs,
        trial: &madenet_sim::continuous::ContinuousTrial,
    ) -> Result<Self, BagError> {
        let world = trial.world();
        let cfg = world.config();
        let period = cfg.control_period;
        let every = |s: f64| (s / period).round().max(1.0) as u64;
        let n = world.robots();
        let mut r = ContinuousRecorder {
            out,
            frame: MapFrame::of(world.coarse_truth()),
            ticks: 0,
            scan_every: every(1.0 / cfg.lidar.rate_hz),
            pose_every: every(0.1),
            map_every: every(FINE_MAP_EVERY_S),
            metrics_every: every(1.0),
            maps: vec![None; n],
            map_ticks: vec![0; n],
            goals: vec![None; n],
            plans: vec![None; n],
        };
        let truth = occupancy_grid(&r.frame, world.coarse_truth().cells(), Time::default());
        r.out.put("/truth_map", &truth, 0)?;
        // The scene itself at its fine resolution (what the lidar hits), beside the robots'
        // fine maps.
        let fine = &world.scene().fine;
        let truth = occupancy_grid(&MapFrame::of(fine), fine.cells(), Time::default());
        r.out.put("/fine_truth_map", &truth, 0)?;
        r.record(trial, false)?;
        Ok(r)
    }

    /// Records the control period the trial just finished.
    pub fn step(
        &mut self,
        trial: &madenet_sim::continuous::ContinuousTrial,
    ) -> Result<(), BagError> {
        self.ticks += 1;
        self.record(trial, false)
    }

    /// `last`: the trial's final state (poses, `/tf`, `/clock` and metrics written whatever
    /// their rate).
    fn record(
        &mut self,
        trial: &madenet_sim::continuous::ContinuousTrial,
        last: bool,
    ) -> Result<(), BagError> {
        use crate::continuous_stand_in::{fine_grid, laser_scan, pose_stamped, scan_topic};
        let world = trial.world();
        let secs = world.time();
        let ns = (secs * 1e9).round() as u64;
        let stamp = Time {
            sec: secs.floor() as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        };
        let k = self.ticks;
        let n = world.robots();
        if last || k.is_multiple_of(self.pose_every) {
            self.out.put("/clock", &Clock { clock: stamp }, ns)?;
            let mut transforms = Vec::with_capacity(n);
            for i in 0..n {
                let pose = pose_stamped(world.pose(i), &self.frame, stamp);
                let p = pose.pose;
                transforms.push(TransformStamped {
                    header: pose.header.clone(),
                    child_frame_id: format!("robot{i}/base_link"),
                    transform: Transform {
                        translation: Vector3 {
                            x: p.position.x,
                            y: p.position.y,
                            z: 0.0,
                        },
                        rotation: p.orientation,
                    },
                });
                self.out.put(&format!("/robot{i}/pose"), &pose, ns)?;
            }
            self.out.put("/tf", &TFMessage { transforms }, ns)?;
        }
        for (i, agent) in trial.agents().iter().enumerate() {
            // The world scans every robot at the start and robot i at the end of the periods
            // where (ticks + i) is a multiple of the scan period (the stand-in's rule).
            if !last && (k == 0 || (k + i as u64).is_multiple_of(self.scan_every)) {
                self.out
                    .put(&scan_topic(i), &laser_scan(world, i, stamp), ns)?;
                if self.maps[i].is_none() || k - self.map_ticks[i] >= self.map_every {
                    let grid = fine_grid(world, i, &self.frame, stamp);
                    if self.maps[i].as_ref() != Some(&grid.data) {
                        self.out.put(&format!("/robot{i}/map"), &grid, ns)?;
                        self.maps[i] = Some(grid.data);
                        self.map_ticks[i] = k;
                    }
                }
            }
            if agent.goal() != self.goals[i] {
                // No goal any more: its own cell (as the grid's).
                let at = agent.goal().unwrap_or_else(|| world.cell_of(i));
                let msg = crate::pose_stamped(&self.frame, at, stamp);
                self.out.put(&format!("/robot{i}/goal_pose"), &msg, ns)?;
            }
            self.goals[i] = agent.goal();
            let plan = agent.path().to_vec();
            if self.plans[i].as_ref() != Some(&plan) {
                let poses = std::iter::once(world.cell_of(i))
                    .chain(plan.iter().copied())
                    .map(|p| crate::pose_stamped(&self.frame, p, stamp))
                    .collect();
                let header = Header {
                    stamp,
                    frame_id: FRAME_ID.into(),
                };
                self.out
                    .put(&format!("/robot{i}/plan"), &Path { header, poses }, ns)?;
                self.plans[i] = Some(plan);
            }
        }
        if last || k.is_multiple_of(self.metrics_every) {
            let explored = Float64 {
                data: world.explored_fraction(),
            };
            self.out.put("/metrics/explored", &explored, ns)?;
            let distance = Float64 {
                data: (0..n).map(|i| world.distance(i)).sum(),
            };
            self.out.put("/metrics/distance", &distance, ns)?;
        }
        Ok(())
    }

    /// Messages written to the bag so far.
    pub fn messages(&self) -> u64 {
        self.out.messages()
    }

    /// Records `trial`'s final state (poses and metrics at its last tick, whatever their
    /// rate), then finishes the bag, if any: where it is, and how many messages it holds.
    pub fn finish(
        mut self,
        trial: &madenet_sim::continuous::ContinuousTrial,
    ) -> Result<Option<(PathBuf, u64)>, BagError> {
        if !(self.ticks.is_multiple_of(self.pose_every)
            && self.ticks.is_multiple_of(self.metrics_every))
        {
            self.record(trial, true)?;
        }
        self.out.finish()
    }
}
