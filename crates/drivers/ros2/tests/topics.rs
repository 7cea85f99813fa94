//! The topics as a ROS 2 node would receive them. The subscriber here is plain zenoh and knows
//! only the ROS 2 message definitions (`nav_msgs/msg/OccupancyGrid`,
//! `geometry_msgs/msg/PoseStamped`) and rmw_zenoh's conventions: key expressions
//! `<domain>/<topic>/<dds type>/<RIHS01 hash>`, little-endian CDR, liveliness tokens under
//! `@ros2_lv`. It decodes the bytes by hand, so it checks the wire, not madenet-ros2 against itself.

use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_ros2::{
    cells_from_grid, loopback_router, occupancy_grid, MapFrame, RobotFeed, RobotTopics,
};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// Little-endian CDR reader; alignment counts from after the 4-byte encapsulation header.
struct Cdr<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Cdr<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        assert_eq!(&bytes[..2], &[0, 1], "encapsulation: CDR little endian");
        Cdr {
            b: &bytes[4..],
            at: 0,
        }
    }
    fn take(&mut self, n: usize, align: usize) -> &'a [u8] {
        self.at = self.at.div_ceil(align) * align;
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        s
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take(4, 4).try_into().unwrap())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4, 4).try_into().unwrap())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take(4, 4).try_into().unwrap())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take(8, 8).try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let n = self.u32() as usize;
        let s = self.take(n, 1);
        assert_eq!(s.last(), Some(&0), "CDR strings end with NUL");
        String::from_utf8(s[..n - 1].to_vec()).unwrap()
    }
    /// std_msgs/Header: builtin_interfaces/Time stamp {int32 sec, uint32 nanosec}, string frame_id.
    fn header(&mut self) -> (i32, u32, String) {
        (self.i32(), self.u32(), self.string())
    }
    /// geometry_msgs/Pose: Point {float64 x, y, z}, Quaternion {float64 x, y, z, w}.
    fn pose(&mut self) -> [f64; 7] {
        std::array::from_fn(|_| self.f64())
    }
    fn done(&self) {
        assert_eq!(self.at, self.b.len(), "trailing bytes after the message");
    }
}

struct Grid {
    frame_id: String,
    resolution: f32,
    width: u32,
    height: u32,
    origin: [f64; 7],
    data: Vec<i8>,
}

/// nav_msgs/OccupancyGrid: Header header, MapMetaData info {Time map_load_time,
/// float32 resolution, uint32 width, uint32 height, Pose origin}, int8[] data.
fn decode_grid(bytes: &[u8]) -> Grid {
    let mut r = Cdr::new(bytes);
    let (sec, _, frame_id) = r.header();
    assert!(sec > 1_700_000_000, "stamped with the wall clock");
    let (_, _) = (r.i32(), r.u32());
    let resolution = r.f32();
    let (width, height) = (r.u32(), r.u32());
    let origin = r.pose();
    let n = r.u32() as usize;
    let data = r.take(n, 1).iter().map(|&b| b as i8).collect();
    r.done();
    Grid {
        frame_id,
        resolution,
        width,
        height,
        origin,
        data,
    }
}

/// geometry_msgs/PoseStamped: Header header, Pose pose.
fn decode_pose(bytes: &[u8]) -> (String, [f64; 7]) {
    let mut r = Cdr::new(bytes);
    let (_, _, frame) = r.header();
    let pose = r.pose();
    r.done();
    (frame, pose)
}

/// A 3 × 4 belief with every kind of cell, its frame shifted and in 0.5 m cells.
fn belief() -> (OccGrid, MapFrame) {
    let mut g = OccGrid::new(3, 4, Occupancy::Unknown);
    for c in 0..4 {
        g.set(Pos::new(2, c), Occupancy::Free);
    }
    g.set(Pos::new(0, 3), Occupancy::Obstacle);
    g.set(Pos::new(1, 1), Occupancy::Obstacle);
    g.resolution = 0.5;
    g.origin = [-1.0, 2.0, 0.0];
    let f = MapFrame::of(&g);
    (g, f)
}

/// A received sample: key expression, payload, attachment.
type Received = (String, Vec<u8>, Vec<u8>);

/// Waits for one sample of each of `want` key-expression prefixes (after the domain) while
/// `publish` runs again every 50 ms (a subscriber that joins late misses volatile samples).
fn collect(
    sub: &zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
    want: &[&str],
    mut publish: impl FnMut(),
) -> Vec<Received> {
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut got: Vec<Option<Received>> = vec![None; want.len()];
    while got.iter().any(Option::is_none) {
        assert!(
            Instant::now() < deadline,
            "no sample on {want:?} within 20 s: got {got:?}"
        );
        publish();
        while let Ok(Some(s)) = sub.recv_timeout(Duration::from_millis(50)) {
            let key = s.key_expr().as_str().to_string();
            for (k, w) in want.iter().enumerate() {
                if key.starts_with(&format!("0/{w}/")) {
                    let attachment = s.attachment().map(|a| a.to_bytes().to_vec());
                    got[k] = Some((
                        key.clone(),
                        s.payload().to_bytes().to_vec(),
                        attachment.unwrap_or_default(),
                    ));
                }
            }
        }
    }
    got.into_iter().map(Option::unwrap).collect()
}

#[test]
fn a_plain_ros2_subscriber_reads_map_pose_and_goal() {
    let (router, opts) = loopback_router().unwrap();
    let sub = router.declare_subscriber("0/robot1/**").wait().unwrap();
    let ctx = opts.context().unwrap();
    let (g, frame) = belief();
    let mut topics = RobotTopics::new(&ctx, 1, frame).unwrap();
    let mut goal = 0;
    let got = collect(
        &sub,
        &["robot1/map", "robot1/pose", "robot1/goal_pose"],
        || {
            // The map is published when it changes and the goal when it moves: move both.
            let mut cells = g.cells().to_vec();
            cells[0] = [Occupancy::Unknown, Occupancy::Free][goal % 2];
            goal += 1;
            topics
                .publish(&cells, Pos::new(2, 0), Some(Pos::new(goal as i32 % 3, 3)))
                .unwrap();
        },
    );
    // Key expressions: domain / topic / DDS type name / Jazzy type hash (RIHS01).
    let (map_key, map_bytes, map_attachment) = &got[0];
    let parts: Vec<&str> = map_key.split('/').collect();
    assert_eq!(
        parts[..4],
        ["0", "robot1", "map", "nav_msgs::msg::dds_::OccupancyGrid_"]
    );
    assert!(
        parts[4].starts_with("RIHS01_") && parts[4].len() == 7 + 64,
        "{map_key}"
    );
    let m = decode_grid(map_bytes);
    assert_eq!(m.frame_id, "map");
    assert_eq!((m.width, m.height, m.resolution), (4, 3, 0.5));
    // Origin: the lower-left corner, no rotation (quaternion 0 0 0 1).
    assert_eq!(m.origin, [-1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    // ROS row 0 is the bottom row (madenet row 2, all free); madenet's top-right obstacle
    // is the last value. Cell 0 (top-left) is whichever of unknown / free was sent last.
    assert_eq!(m.data[..8], [0, 0, 0, 0, -1, 100, -1, -1]);
    assert_eq!(m.data[11], 100);
    assert!(m.data[8] == -1 || m.data[8] == 0);
    assert_eq!(m.data[9..11], [-1, -1]);
    // The pose: the centre of cell (2, 0) — 0.25 m into the grid from its lower-left corner.
    let (pose_key, pose_bytes, _) = &got[1];
    assert!(
        pose_key.contains("/geometry_msgs::msg::dds_::PoseStamped_/RIHS01_"),
        "{pose_key}"
    );
    let (frame_id, p) = decode_pose(pose_bytes);
    assert_eq!(frame_id, "map");
    assert_eq!(p, [-0.75, 2.25, 0.0, 0.0, 0.0, 0.0, 1.0]);
    // The goal: a cell centre in column 3.
    let (_, g) = decode_pose(&got[2].1);
    assert_eq!(g[0], -1.0 + 3.5 * 0.5);
    assert!([2.25, 2.75, 3.25].contains(&g[1]), "{g:?}");
    // The ROS graph: liveliness tokens announce node and publishers (what `ros2 topic list`
    // reads), with the type and hash of the map's publisher.
    let tokens: Vec<String> = router
        .liveliness()
        .get("@ros2_lv/0/**")
        .timeout(Duration::from_secs(5))
        .wait()
        .unwrap()
        .iter()
        .filter_map(|r| r.into_result().ok().map(|s| s.key_expr().to_string()))
        .collect();
    let map_token = tokens
        .iter()
        .find(|t| t.contains("/MP/") && t.contains("%robot1%map/"))
        .unwrap_or_else(|| panic!("no publisher token for /robot1/map in {tokens:?}"));
    // rmw_zenoh's layout: admin space, domain, zid, node id, entity id, kind, enclave and
    // namespace (empty: %), node, topic with / as %, type, hash, QoS (reliable, transient
    // local, keep last 1).
    let fields: Vec<&str> = map_token.split('/').collect();
    assert_eq!(fields.len(), 13, "{map_token}");
    assert_eq!(fields[..2], ["@ros2_lv", "0"]);
    assert!(fields[3].parse::<u32>().is_ok() && fields[4].parse::<u32>().is_ok());
    assert_eq!(
        fields[5..],
        [
            "MP",
            "%",
            "%",
            "madenet_robot1",
            "%robot1%map",
            "nav_msgs::msg::dds_::OccupancyGrid_",
            parts[4],
            ":1:,1:,:,:,,"
        ]
    );
    // The attachment (rmw_zenoh_cpp ≥ 0.2.4): sequence number (i64, from 1), source time
    // (i64 ns), GID length 16 and the GID, XXH3-128 of the publisher's liveliness token.
    assert_eq!(map_attachment.len(), 33, "{map_attachment:?}");
    let sn = i64::from_le_bytes(map_attachment[..8].try_into().unwrap());
    assert!(sn >= 1, "sequence numbers start at 1: {sn}");
    let ns = i64::from_le_bytes(map_attachment[8..16].try_into().unwrap());
    assert!(ns > 1_700_000_000_000_000_000, "source time in ns: {ns}");
    assert_eq!(map_attachment[16], 16);
    assert_eq!(map_attachment[17..], madenet_ros2::rmw::gid(map_token));
    assert!(tokens
        .iter()
        .any(|t| t.contains("/NN/") && t.contains("madenet_robot1")));
}

#[test]
fn a_late_subscriber_still_gets_the_newest_map_transient_local() {
    let (_router, opts) = loopback_router().unwrap();
    let (g, frame) = belief();
    // Two peers that reach each other through the router only.
    let ctx = opts.context().unwrap();
    let mut topics = RobotTopics::new(&ctx, 0, frame).unwrap();
    topics.publish(g.cells(), Pos::new(2, 1), None).unwrap();
    // Only now does a subscriber (madenet's own feed, as a real robot's consumer) join.
    std::thread::sleep(Duration::from_millis(300));
    let other = opts.context().unwrap();
    let mut feed = RobotFeed::new(&other, 0, frame).unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut poses = 1;
    let (cells, at) = loop {
        // The pose is volatile: keep sending it, never the map again.
        topics.publish(g.cells(), Pos::new(2, 1), None).unwrap();
        poses += 1;
        if let Some((c, p)) = feed.latest(Duration::from_millis(100)).unwrap() {
            break (c.to_vec(), p);
        }
        assert!(Instant::now() < deadline, "no map and pose within 20 s");
    };
    // One map (unchanged afterwards, so never sent again) and one pose per publish.
    assert_eq!(topics.published(), 1 + poses);
    assert_eq!(
        cells,
        g.cells(),
        "the map published once, before the subscriber existed"
    );
    assert_eq!(at, Pos::new(2, 1));
}

#[test]
fn a_finer_rotated_robot_map_reads_back_into_the_same_cells() {
    // A belief published at 1 m cells, then re-read from a 0.25 m copy of it (each cell 4 × 4
    // pixels) whose frame is rotated by 90°: every cell comes back.
    let (mut g, _) = belief();
    g.resolution = 1.0;
    g.origin = [3.0, -2.0, std::f64::consts::FRAC_PI_2];
    let frame = MapFrame::of(&g);
    let coarse = occupancy_grid(&frame, g.cells(), Default::default());
    let (w, h) = (coarse.info.width as usize, coarse.info.height as usize);
    let mut fine = coarse.clone();
    fine.info.resolution = 0.25;
    fine.info.width *= 4;
    fine.info.height *= 4;
    fine.data = (0..h * 4)
        .flat_map(|r| (0..w * 4).map(move |c| (r / 4) * w + c / 4))
        .map(|i| coarse.data[i])
        .collect();
    assert_eq!(
        cells_from_grid(&fine, &frame, "/robot0/map").unwrap(),
        g.cells()
    );
    // One occupied pixel of 16 (6 %) is not enough for an obstacle; five (31 %) are.
    let mut one = fine.clone();
    let free_cell_px = (0..fine.data.len()).find(|&i| fine.data[i] == 0).unwrap();
    one.data[free_cell_px] = 100;
    assert_eq!(cells_from_grid(&one, &frame, "t").unwrap(), g.cells());
    // An obstacle cell as SLAM maps it, its surface seen from one side: one row of 4 pixels
    // occupied, the rest unknown. Read over half its pixels it is an obstacle (4 > 25 % of
    // 8), not unknown for ever (a frontier beside every box a robot drives by).
    // The top-left fine pixel of the first cell whose coarse value is `value`.
    let first_cell = |value, what: &str| {
        let cell = (0..h * w).find(|&i| coarse.data[i] == value).expect(what);
        ((cell / w) * 4, (cell % w) * 4)
    };
    let mut surface = fine.clone();
    let (r0, c0) = first_cell(100, "an obstacle cell");
    for r in 0..4 {
        for c in 0..4 {
            surface.data[(r0 + r) * w * 4 + c0 + c] = if r == 0 { 100 } else { -1 };
        }
    }
    assert_eq!(
        cells_from_grid(&surface, &frame, "t").unwrap(),
        g.cells(),
        "the cell seen from one side reads as the obstacle it is"
    );
    // A glimpse of a free cell (3 of 16 pixels seen) stays unknown.
    let mut glimpse = fine.clone();
    let (r0, c0) = first_cell(0, "a free cell");
    for k in 3..16 {
        glimpse.data[(r0 + k / 4) * w * 4 + c0 + k % 4] = -1;
    }
    let read = cells_from_grid(&glimpse, &frame, "t").unwrap();
    let changed: Vec<_> = read.iter().zip(g.cells()).filter(|(a, b)| a != b).collect();
    assert_eq!(
        changed,
        [(
            &madenet_map::Occupancy::Unknown,
            &madenet_map::Occupancy::Free
        )]
    );
    // A message whose data does not fit its size is refused, naming topic and field.
    let mut bad = fine;
    bad.data.pop();
    let e = cells_from_grid(&bad, &frame, "/robot0/map")
        .unwrap_err()
        .to_string();
    assert!(e.contains("/robot0/map") && e.contains("data"), "{e}");
}
