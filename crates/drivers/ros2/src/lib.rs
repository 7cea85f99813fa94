//! # madenet-ros2 — ROS 2 topics for madenet robots, without a ROS install
//!
//! Each robot's agent publishes what a ROS 2 user wants to see next to nav2 and RViz:
//!
//! | topic | type | QoS | what |
//! | --- | --- | --- | --- |
//! | `/robot<i>/map` | `nav_msgs/msg/OccupancyGrid` | reliable, transient local, depth 1 | the robot's belief m_i: 0 free, 100 occupied, −1 unknown |
//! | `/robot<i>/pose` | `geometry_msgs/msg/PoseStamped` | reliable, volatile | the centre of the robot's cell, frame `map` |
//! | `/robot<i>/goal_pose` | `geometry_msgs/msg/PoseStamped` | reliable, volatile | the goal of its macro action, when it changes (the nav2 / RViz goal convention) |
//!
//! and [`RobotFeed`] reads a real robot's `/robot<i>/map` and `/robot<i>/pose` back into
//! madenet cells ([`cells_from_grid`], [`MapFrame::cell_at`]). [`RealRobots`] puts real robots
//! in place of madenet's simulated world: the world node ([`madenet_runtime::run_ground_with`])
//! observes them through their maps and poses and sends each move as `/robot<i>/goal_pose`.
//! The nav2 sim ([`nav2_sim`]) lets madenet's continuous world be those robots: each simulated
//! robot publishes `/robot<i>/scan` (`sensor_msgs/msg/LaserScan`), its own fine
//! `/robot<i>/map` (with `map_updates`) and `/robot<i>/pose`, and drives to each
//! `/robot<i>/goal_pose` as to a `navigate_to_pose` goal.
//!
//! The wire format is rmw_zenoh's (ROS 2 Jazzy): key expressions
//! `<domain>/<topic>/<type>/<RIHS01 type hash>`, CDR payloads, liveliness tokens for the ROS
//! graph — written by [`rmw`] on madenet's own zenoh, the messages by [`msgs`]. A ROS 2 installation
//! with `RMW_IMPLEMENTATION=rmw_zenoh_cpp` sees the topics through its router (`ros2 run
//! rmw_zenoh_cpp rmw_zenohd`, `tcp/127.0.0.1:7447`, [`Ros2Options::default`]).
//!
//! Beside topics, the same wire carries ROS 2 [`services`] (queryables with rmw_zenoh's
//! attachment), [`actions`] (three services and two topics, as rcl builds them; nav2's
//! `NavigateToPose`) and [`tf`] (`/tf`, `/tf_static` and a buffer composing
//! `map → odom → base_link`), with nodes in namespaces ([`Ros2Context::create_node_in`]) and
//! every type's RIHS01 hash computed from its type description ([`typehash`]).
//!
//! ## Geometry
//! A madenet grid's row 0 is the image's top row and its `origin` is the pose of the lower-left
//! corner (the map_server convention), so cell `(row, col)` of an `H × W` grid with cells of
//! `resolution` metres covers `x ∈ [col·res, (col+1)·res)`, `y ∈ [(H−1−row)·res, (H−row)·res)`
//! in the grid's own frame, rotated by the origin's yaw and shifted by its x, y. An
//! `OccupancyGrid`'s rows run the other way (row 0 at the origin), so rows are flipped.
//!
//! ```
//! use madenet_map::{OccGrid, Occupancy, Pos};
//! use madenet_ros2::{occupancy_grid, MapFrame};
//!
//! let mut grid = OccGrid::new(2, 3, Occupancy::Unknown);
//! grid.set(Pos::new(0, 0), Occupancy::Obstacle); // top-left
//! grid.set(Pos::new(1, 2), Occupancy::Free); // bottom-right
//! let frame = MapFrame::of(&grid);
//! let msg = occupancy_grid(&frame, grid.cells(), Default::default());
//! assert_eq!((msg.info.height, msg.info.width), (2, 3));
//! // ROS row 0 is madenet's bottom row.
//! assert_eq!(msg.data, vec![-1, -1, 0, 100, -1, -1]);
//! assert_eq!(frame.cell_at(2.5, 0.5), Some(Pos::new(1, 2)));
//! ```
#![deny(missing_docs)]

use madenet_map::discretize::DiscretizeParams;
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_runtime::zenoh_bus::zenoh_config;
use msgs::{Header, MapMetaData, OccupancyGrid, Point, Pose, PoseStamped, Quaternion, Time};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

pub use real::RealRobots;
pub use rmw::{Durability, Node, Publisher, QosProfile, Reliability, Ros2Context, Subscription};
pub use stand_in::run_stand_in;

pub mod actions;
pub mod bag;
#[cfg(feature = "foxglove")]
pub mod live;
#[cfg(not(feature = "foxglove"))]
#[path = "live_off.rs"]
pub mod live;
pub mod map_updates;
pub mod msgdefs;
pub mod msgs;
pub mod nav2_sim;
mod real;
pub mod record;
pub mod rmw;
pub mod services;
pub mod sim_sensors;
mod stand_in;
pub mod study_bags;
pub mod tf;
pub mod typehash;

/// The frame every madenet topic is stamped with (REP 105's `map`).
pub const FRAME_ID: &str = "map";

/// Why the live view ([`live::Live`]) could not start.
#[derive(Debug, thiserror::Error)]
#[error("{addr}: {why}")]
pub struct LiveError {
    /// The address asked for.
    pub addr: String,
    /// What went wrong.
    pub why: String,
}

/// What can go wrong talking ROS 2.
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    /// The zenoh session, node, publisher or subscriber could not be made or used.
    #[error("ROS 2 (rmw_zenoh) {what}: {source}")]
    Middleware {
        /// What was being done.
        what: String,
        /// zenoh's error.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A received message that cannot be read as a map or pose.
    #[error("{topic}: field `{field}`: {why}")]
    BadMessage {
        /// The topic it came on.
        topic: String,
        /// The message field at fault.
        field: &'static str,
        /// Why.
        why: String,
    },
    /// A service or action call that the other side refused, or that got no answer in time.
    #[error("{what}: {why}")]
    Call {
        /// The call (service or action name, and what was asked).
        what: String,
        /// Why it failed: the server's error reply, or the timeout.
        why: String,
    },
}

pub(crate) fn middleware(what: impl Into<String>) -> impl FnOnce(zenoh::Error) -> Ros2Error {
    let what = what.into();
    move |source| Ros2Error::Middleware { what, source }
}

/// How to join the ROS 2 graph. The default: a zenoh client of rmw_zenoh's router on
/// `tcp/127.0.0.1:7447` (a peer when it also listens), multicast scouting off, domain from
/// `ROS_DOMAIN_ID` (0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ros2Options {
    /// Zenoh endpoints to connect to (the rmw_zenoh router, or another peer).
    pub connect: Vec<String>,
    /// Zenoh endpoints to listen on (none: only the connections this side opens).
    pub listen: Vec<String>,
    /// ROS domain id; `None` reads `ROS_DOMAIN_ID` (default 0).
    pub domain_id: Option<usize>,
}

impl Default for Ros2Options {
    fn default() -> Self {
        Ros2Options {
            connect: vec!["tcp/127.0.0.1:7447".into()],
            listen: Vec::new(),
            domain_id: None,
        }
    }
}

/// The zenoh endpoints to connect to as an rmw_zenoh user gives them: `connect/endpoints` in
/// `ZENOH_CONFIG_OVERRIDE` (`connect/endpoints=["tcp/192.168.1.5:7447"];mode="peer"`, pairs
/// separated by `;`), if that variable sets it. `Err` names the variable and what is wrong.
pub fn endpoints_from_env() -> Option<Result<Vec<String>, String>> {
    let text = std::env::var("ZENOH_CONFIG_OVERRIDE").ok()?;
    parse_endpoints_override(&text)
}

/// [`endpoints_from_env`] on the variable's text.
pub fn parse_endpoints_override(text: &str) -> Option<Result<Vec<String>, String>> {
    let value = text.split(';').find_map(|pair| {
        let (k, v) = pair.split_once('=')?;
        (k.trim() == "connect/endpoints").then(|| v.trim())
    })?;
    Some(
        serde_json::from_str::<Vec<String>>(value)
            .map_err(|e| {
                format!("ZENOH_CONFIG_OVERRIDE: connect/endpoints={value}: not a list of quoted endpoints ({e})")
            })
            .and_then(|eps| match eps.is_empty() {
                true => Err("ZENOH_CONFIG_OVERRIDE: connect/endpoints is empty".to_string()),
                false => Ok(eps),
            }),
    )
}

impl Ros2Options {
    /// The domain: [`Ros2Options::domain_id`], else `ROS_DOMAIN_ID`, else 0.
    pub fn domain(&self) -> Result<usize, Ros2Error> {
        if let Some(d) = self.domain_id {
            return Ok(d);
        }
        match std::env::var("ROS_DOMAIN_ID") {
            Ok(v) if !v.trim().is_empty() => v.trim().parse().map_err(|_| Ros2Error::Middleware {
                what: "ROS_DOMAIN_ID".into(),
                source: format!("{v:?} is not a non-negative integer").into(),
            }),
            _ => Ok(0),
        }
    }

    /// Opens the zenoh session with rmw_zenoh_cpp's session defaults (its
    /// `DEFAULT_RMW_ZENOH_SESSION_CONFIG`: timestamps on, 60 s transport timeouts, no multicast
    /// scouting) and these endpoints.
    pub fn context(&self) -> Result<Ros2Context, Ros2Error> {
        let domain = self.domain()?;
        let what = || {
            format!(
                "session (connect {:?}, listen {:?})",
                self.connect, self.listen
            )
        };
        let json = |v: &[String]| format!("{v:?}");
        // A client of the router (or of the peer it connects to): it listens on no port of its
        // own, so it cannot take one a madenet node is about to bind, and the router carries
        // its data to every ROS 2 node.
        let mode = if self.listen.is_empty() {
            "client"
        } else {
            "peer"
        };
        let c = zenoh_config([
            ("mode", format!("{mode:?}")),
            ("connect/endpoints", json(&self.connect)),
            ("listen/endpoints", json(&self.listen)),
            (
                "connect/timeout_ms",
                r#"{"router": -1, "peer": -1, "client": 0}"#.into(),
            ),
            (
                "connect/exit_on_failure",
                r#"{"router": false, "peer": false, "client": true}"#.into(),
            ),
            ("scouting/multicast/enabled", "false".into()),
            (
                "scouting/gossip/target",
                r#"{"router": ["router", "peer"], "peer": ["router"]}"#.into(),
            ),
            (
                "scouting/gossip/autoconnect_strategy",
                r#"{"peer": {"to_router": "always", "to_peer": "greater-zid"}}"#.into(),
            ),
            (
                "timestamping/enabled",
                r#"{"router": true, "peer": true, "client": true}"#.into(),
            ),
            ("queries_default_timeout", "60000".into()),
            ("transport/unicast/open_timeout", "60000".into()),
            ("transport/unicast/accept_timeout", "60000".into()),
            ("transport/unicast/accept_pending", "10000".into()),
            ("transport/unicast/max_sessions", "10000".into()),
            ("transport/link/tx/lease", "60000".into()),
            ("transport/link/tx/keep_alive", "2".into()),
            (
                "transport/link/tx/queue/congestion_control/block/wait_before_close",
                "60000000".into(),
            ),
        ])
        .map_err(|(pair, e)| middleware(format!("{} ({pair})", what()))(e))?;
        use zenoh::Wait;
        let session = zenoh::open(c).wait().map_err(middleware(what()))?;
        Ok(Ros2Context::new(session, domain))
    }
}

/// A zenoh router on a free loopback port, as rmw_zenoh's `rmw_zenohd` would be, and the
/// options that reach it (domain 0): a ROS 2 graph on one machine for tests, benches and demos.
/// The port is found by binding and releasing it; another program could take it in between.
pub fn loopback_router() -> Result<(zenoh::Session, Ros2Options), Ros2Error> {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map_err(|e| Ros2Error::Middleware {
            what: "a free loopback port".into(),
            source: Box::new(e),
        })?
        .port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let router = router(&endpoint)?;
    let opts = Ros2Options {
        connect: vec![endpoint],
        listen: Vec::new(),
        domain_id: Some(0),
    };
    Ok((router, opts))
}

/// A zenoh router listening on `endpoint` (as rmw_zenoh's `rmw_zenohd`: ROS 2 nodes with
/// rmw_zenoh, and madenet's, connect to it), with multicast scouting off. It routes while the
/// session lives.
pub fn router(endpoint: &str) -> Result<zenoh::Session, Ros2Error> {
    use zenoh::Wait;
    let c = zenoh_config([
        ("mode", "\"router\"".to_string()),
        ("scouting/multicast/enabled", "false".into()),
        (
            "listen/endpoints",
            serde_json::to_string(&[endpoint]).unwrap_or_default(),
        ),
    ])
    .map_err(|(pair, e)| middleware(format!("router config {pair}"))(e))?;
    zenoh::open(c)
        .wait()
        .map_err(middleware(format!("a router listening on {endpoint}")))
}

/// Where a madenet grid lies in the ROS `map` frame: its size, cell size and origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapFrame {
    /// Rows.
    pub height: usize,
    /// Columns.
    pub width: usize,
    /// Metres per cell (the robot cell, ROS `resolution`).
    pub resolution: f64,
    /// Pose of the grid's lower-left corner: x, y (m), yaw (rad) (ROS `origin`).
    pub origin: [f64; 3],
}

impl MapFrame {
    /// The frame of `grid` (its size, `resolution` and `origin`).
    pub fn of(grid: &OccGrid) -> Self {
        MapFrame {
            height: grid.height(),
            width: grid.width(),
            resolution: grid.resolution,
            origin: grid.origin,
        }
    }

    /// The centre of cell `p` in the `map` frame, metres.
    pub fn cell_center(&self, p: Pos) -> (f64, f64) {
        let lx = (p.col as f64 + 0.5) * self.resolution;
        let ly = ((self.height as f64 - 1.0 - p.row as f64) + 0.5) * self.resolution;
        self.point(lx, ly)
    }

    /// The point `(lx, ly)` metres right of and up from the grid's lower-left corner, in the
    /// `map` frame (rotated by the origin's yaw, shifted by its x, y).
    pub fn point(&self, lx: f64, ly: f64) -> (f64, f64) {
        let [x0, y0, yaw] = self.origin;
        let (s, c) = yaw.sin_cos();
        (x0 + lx * c - ly * s, y0 + lx * s + ly * c)
    }

    /// The cell that holds point `(x, y)` of the `map` frame, if it is on the grid.
    pub fn cell_at(&self, x: f64, y: f64) -> Option<Pos> {
        let [x0, y0, yaw] = self.origin;
        let (s, c) = yaw.sin_cos();
        let (dx, dy) = (x - x0, y - y0);
        let lx = (dx * c + dy * s) / self.resolution;
        let ly = (-dx * s + dy * c) / self.resolution;
        if !(lx.is_finite() && ly.is_finite()) || lx < 0.0 || ly < 0.0 {
            return None;
        }
        let (col, up) = (lx.floor() as usize, ly.floor() as usize);
        (col < self.width && up < self.height)
            .then(|| Pos::new((self.height - 1 - up) as i32, col as i32))
    }

    pub(crate) fn pose(&self, x: f64, y: f64, yaw: f64) -> Pose {
        let (s, c) = (yaw / 2.0).sin_cos();
        Pose {
            position: Point { x, y, z: 0.0 },
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: s,
                w: c,
            },
        }
    }
}

/// A ROS time stamp for `t` (wall clock: what TF and nav2 compare stamps against).
pub fn stamp(t: SystemTime) -> Time {
    let d = t.duration_since(UNIX_EPOCH).unwrap_or(Duration::ZERO);
    Time {
        sec: i32::try_from(d.as_secs()).unwrap_or(i32::MAX),
        nanosec: d.subsec_nanos(),
    }
}

pub(crate) fn header(t: Time) -> Header {
    Header {
        stamp: t,
        frame_id: FRAME_ID.into(),
    }
}

/// The ROS value of a madenet cell: 0 free, 100 occupied, −1 unknown.
pub fn ros_value(o: Occupancy) -> i8 {
    match o {
        Occupancy::Unknown => -1,
        Occupancy::Free => 0,
        Occupancy::Obstacle => 100,
    }
}

/// `cells` (row-major, madenet row 0 on top, `frame.height × frame.width`) as an
/// `OccupancyGrid` in frame `map` stamped `t`.
///
/// # Panics
/// If `cells.len()` is not `frame.height × frame.width` (a programming error).
pub fn occupancy_grid(frame: &MapFrame, cells: &[Occupancy], t: Time) -> OccupancyGrid {
    let (h, w) = (frame.height, frame.width);
    assert_eq!(
        cells.len(),
        h * w,
        "occupancy_grid: cells must be height × width"
    );
    let mut data = Vec::with_capacity(h * w);
    for row in cells.chunks(w.max(1)).rev() {
        data.extend(row.iter().map(|&o| ros_value(o)));
    }
    let [x0, y0, yaw] = frame.origin;
    OccupancyGrid {
        header: header(t),
        info: MapMetaData {
            map_load_time: t,
            resolution: frame.resolution as f32,
            width: w as u32,
            height: h as u32,
            origin: frame.pose(x0, y0, yaw),
        },
        data,
    }
}

/// The centre of cell `p` as a `PoseStamped` in frame `map` stamped `t`, facing the grid's +x.
pub fn pose_stamped(frame: &MapFrame, p: Pos, t: Time) -> PoseStamped {
    let (x, y) = frame.cell_center(p);
    PoseStamped {
        header: header(t),
        pose: frame.pose(x, y, frame.origin[2]),
    }
}

/// Reads a real robot's `OccupancyGrid` (any resolution, origin and rotation) into the cells of
/// `frame`, by the paper's rule over the pixels whose centres fall in each cell (Sec. V.B.1) as
/// a map still being built is read ([`madenet_map::discretize::read_partial_cell`], as the
/// continuous world's robots read their own maps): an obstacle when more than 25 % of its
/// known pixels, or of half its pixels while fewer are known, are above 65 (occupancy
/// probability > 0.65); else free once half its pixels are known (not −1); else unknown.
/// `topic` names the source in errors.
pub fn cells_from_grid(
    msg: &OccupancyGrid,
    frame: &MapFrame,
    topic: &str,
) -> Result<Vec<Occupancy>, Ros2Error> {
    cells_from_grid_by(msg, frame, topic, &DiscretizeParams::default())
}

/// [`cells_from_grid`] by `rule`'s thresholds (a pixel is occupied above `occupied_prob` × 100,
/// a cell an obstacle above `obstacle_fraction` of its known pixels, or of half its pixels).
pub fn cells_from_grid_by(
    msg: &OccupancyGrid,
    frame: &MapFrame,
    topic: &str,
    rule: &DiscretizeParams,
) -> Result<Vec<Occupancy>, Ros2Error> {
    let occupied_above = rule.occupied_prob * 100.0;
    let bad = |field, why: String| Ros2Error::BadMessage {
        topic: topic.into(),
        field,
        why,
    };
    let (pw, ph) = (msg.info.width as usize, msg.info.height as usize);
    let res = msg.info.resolution as f64;
    if !(res.is_finite() && res > 0.0) {
        return Err(bad("info.resolution", format!("must be > 0, got {res}")));
    }
    if pw.checked_mul(ph) != Some(msg.data.len()) {
        return Err(bad(
            "data",
            format!("has {} values for a {pw} × {ph} grid", msg.data.len()),
        ));
    }
    let o = &msg.info.origin;
    let q = &o.orientation;
    let yaw = (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z));
    if ![o.position.x, o.position.y, yaw]
        .iter()
        .all(|v| v.is_finite())
    {
        return Err(bad("info.origin", "must be finite".into()));
    }
    let (s, c) = yaw.sin_cos();
    // Per cell: pixels, unknown pixels, occupied pixels.
    let mut counts = vec![[0u32; 3]; frame.height * frame.width];
    for (r, row) in msg.data.chunks(pw.max(1)).enumerate() {
        let ly = (r as f64 + 0.5) * res;
        for (col, &v) in row.iter().enumerate() {
            let lx = (col as f64 + 0.5) * res;
            let x = o.position.x + lx * c - ly * s;
            let y = o.position.y + lx * s + ly * c;
            if let Some(p) = frame.cell_at(x, y) {
                let k = &mut counts[p.row as usize * frame.width + p.col as usize];
                k[0] += 1;
                if v < 0 {
                    k[1] += 1;
                } else if f64::from(v) > occupied_above {
                    k[2] += 1;
                }
            }
        }
    }
    Ok(counts
        .iter()
        .map(|&[n, unknown, occupied]| {
            madenet_map::discretize::read_partial_cell(
                n,
                n - unknown,
                occupied,
                rule.obstacle_fraction,
                0.5,
            )
        })
        .collect())
}

/// The topic names of robot `i`: `/robot<i>/map`, `/robot<i>/pose`, `/robot<i>/goal_pose`.
pub fn topics(i: usize) -> [String; 3] {
    ["map", "pose", "goal_pose"].map(|t| format!("/robot{i}/{t}"))
}

/// The QoS a recorded or streamed topic is offered with: the maps (topics ending in `map`:
/// `/truth_map`, `/team_map`, `/robot<i>/map`) latched as [`map_qos`], everything else
/// [`QosProfile::default`] (reliable, volatile, keep last 10).
pub fn recorded_qos(topic: &str) -> QosProfile {
    if topic.ends_with("map") {
        map_qos()
    } else {
        QosProfile::default()
    }
}

/// QoS of `/robot<i>/map`: reliable, transient local, keep last 1 — like map_server, so RViz
/// and nav2 that start late still get the newest map.
pub fn map_qos() -> QosProfile {
    QosProfile {
        reliability: Reliability::Reliable,
        durability: Durability::TransientLocal,
        depth: 1,
    }
}

/// One robot's publishers: its belief as `/robot<i>/map`, its cell as `/robot<i>/pose`, its
/// macro action's goal as `/robot<i>/goal_pose`.
pub struct RobotTopics {
    _node: Node,
    frame: MapFrame,
    map: Publisher<OccupancyGrid>,
    pose: Publisher<PoseStamped>,
    goal: Publisher<PoseStamped>,
    last_map: Option<Vec<Occupancy>>,
    last_goal: Option<Pos>,
    published: usize,
}

impl RobotTopics {
    /// A node `madenet_robot<i>` on `ctx` with robot `i`'s three publishers; cells are placed
    /// by `frame`.
    pub fn new(ctx: &Ros2Context, i: usize, frame: MapFrame) -> Result<Self, Ros2Error> {
        let node = ctx.create_node(&format!("madenet_robot{i}"))?;
        let [map_t, pose_t, goal_t] = topics(i);
        let map = node.create_pub::<OccupancyGrid>(&map_t, map_qos())?;
        let pose = node.create_pub::<PoseStamped>(&pose_t, QosProfile::default())?;
        let goal = node.create_pub::<PoseStamped>(&goal_t, QosProfile::default())?;
        Ok(RobotTopics {
            _node: node,
            frame,
            map,
            pose,
            goal,
            last_map: None,
            last_goal: None,
            published: 0,
        })
    }

    /// Publishes the robot's pose at `pos`; its map `belief` when it changed since the last
    /// one published; its goal when it changed to a new cell.
    pub fn publish(
        &mut self,
        belief: &[Occupancy],
        pos: Pos,
        goal: Option<Pos>,
    ) -> Result<(), Ros2Error> {
        let t = stamp(SystemTime::now());
        if self.last_map.as_deref() != Some(belief) {
            let msg = occupancy_grid(&self.frame, belief, t);
            self.map.publish(&msg)?;
            self.last_map = Some(belief.to_vec());
            self.published += 1;
        }
        let msg = pose_stamped(&self.frame, pos, t);
        self.pose.publish(&msg)?;
        self.published += 1;
        if let Some(g) = goal.filter(|&g| Some(g) != self.last_goal) {
            let msg = pose_stamped(&self.frame, g, t);
            self.goal.publish(&msg)?;
            self.last_goal = Some(g);
            self.published += 1;
        }
        Ok(())
    }

    /// Messages published so far (all three topics).
    pub fn published(&self) -> usize {
        self.published
    }
}

/// A robot process's own ROS 2 output (`madenet agent --ros2`): its session on one zenoh
/// endpoint and its [`RobotTopics`]. A message that cannot be published is a warning, not the
/// end of the robot: exploring goes on without the view.
pub struct RobotPublisher {
    _ctx: Ros2Context,
    robot: usize,
    topics: RobotTopics,
}

impl RobotPublisher {
    /// Robot `robot`'s topics on a map of `map`'s size, through a zenoh session connected to
    /// `endpoint` (the rmw_zenoh router, e.g. `tcp/127.0.0.1:7447`).
    pub fn connect(
        endpoint: &str,
        robot: usize,
        map: &madenet_map::OccGrid,
    ) -> Result<Self, Ros2Error> {
        let opts = Ros2Options {
            connect: vec![endpoint.to_string()],
            ..Default::default()
        };
        let ctx = opts.context()?;
        let topics = RobotTopics::new(&ctx, robot, MapFrame::of(map))?;
        Ok(RobotPublisher {
            _ctx: ctx,
            robot,
            topics,
        })
    }

    /// [`RobotTopics::publish`]; a failure is logged as a warning.
    pub fn publish(&mut self, belief: &[Occupancy], pos: Pos, goal: Option<Pos>) {
        if let Err(e) = self.topics.publish(belief, pos, goal) {
            tracing::warn!("robot {}: ROS 2: {e}", self.robot);
        }
    }
}

/// A real robot's `/robot<i>/map` (with `/robot<i>/map_updates`, as costmaps and the nav2 sim
/// send them) and `/robot<i>/pose`, read into madenet cells of `frame`: what a robot stack
/// provides in place of madenet's simulated world.
pub struct RobotFeed {
    _node: Node,
    frame: MapFrame,
    topics: [String; 3],
    map: map_updates::MapSubscriber,
    pose: Subscription<PoseStamped>,
    cells: Option<Vec<Occupancy>>,
    at: Option<Pos>,
    rule: DiscretizeParams,
}

impl RobotFeed {
    /// A node `madenet_feed<i>` on `ctx` subscribed to robot `i`'s map and pose.
    pub fn new(ctx: &Ros2Context, i: usize, frame: MapFrame) -> Result<Self, Ros2Error> {
        let node = ctx.create_node(&format!("madenet_feed{i}"))?;
        let topics = topics(i);
        let map = map_updates::MapSubscriber::new(&node, &topics[0])?;
        let pose = node.create_sub::<PoseStamped>(&topics[1], QosProfile::default())?;
        Ok(RobotFeed {
            _node: node,
            frame,
            topics,
            map,
            pose,
            cells: None,
            at: None,
            rule: DiscretizeParams::default(),
        })
    }

    /// This feed reading maps by `rule` ([`cells_from_grid_by`]; default: the paper's).
    pub fn with_rule(mut self, rule: DiscretizeParams) -> Self {
        self.rule = rule;
        self
    }

    /// Takes what arrived (waiting up to `wait` for the first map and pose) and returns the
    /// newest map in madenet cells and the robot's cell, once both have been heard. A pose off
    /// the grid is an error naming the topic.
    pub fn latest(&mut self, wait: Duration) -> Result<Option<(&[Occupancy], Pos)>, Ros2Error> {
        let deadline = std::time::Instant::now() + wait;
        loop {
            // Only the newest map counts (full grids and `map_updates` applied): read the
            // cells of that one alone.
            if let Some(m) = self.map.poll()? {
                let topic = &self.topics[0];
                self.cells = Some(cells_from_grid_by(m, &self.frame, topic, &self.rule)?);
            }
            while let Some(p) = self.pose.recv_timeout(Duration::ZERO)? {
                let (x, y) = (p.pose.position.x, p.pose.position.y);
                self.at = Some(
                    self.frame
                        .cell_at(x, y)
                        .ok_or_else(|| Ros2Error::BadMessage {
                            topic: self.topics[1].clone(),
                            field: "pose.position",
                            why: format!("({x}, {y}) is off the map"),
                        })?,
                );
            }
            if self.cells.is_some() && self.at.is_some() {
                break;
            }
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            std::thread::sleep(left.min(Duration::from_millis(5)));
        }
        Ok(self.cells.as_deref().zip(self.at))
    }
}

#[cfg(test)]
mod tests {
    use super::parse_endpoints_override;

    #[test]
    fn endpoints_are_read_from_zenoh_config_override_as_rmw_zenoh_reads_them() {
        let eps = |t: &str| parse_endpoints_override(t);
        assert_eq!(
            eps(r#"mode="peer";connect/endpoints=["tcp/192.168.1.5:7447", "tcp/10.0.0.2:7447"]"#),
            Some(Ok(vec![
                "tcp/192.168.1.5:7447".to_string(),
                "tcp/10.0.0.2:7447".to_string()
            ]))
        );
        assert_eq!(eps(r#"mode="client""#), None);
        for bad in [
            "connect/endpoints=[tcp/1.2.3.4:7447]",
            "connect/endpoints=[]",
        ] {
            let e = eps(bad).unwrap().unwrap_err();
            assert!(
                e.contains("ZENOH_CONFIG_OVERRIDE") && e.contains("connect/endpoints"),
                "{e}"
            );
        }
    }
}
