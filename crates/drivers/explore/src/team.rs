//! The team over ROS 2 topics: each node shares what the paper's robots share (Sec. III.C.1:
//! its map, its position, its goal) and follows its teammates'. No central node: every node
//! publishes in its own namespace and subscribes to its teammates' namespaces, so a node that
//! dies leaves the others with the last map it shared.
//!
//! Topics, in each robot's namespace (standard types, so RViz and Foxglove show them):
//! - `explore/shared_map` (`nav_msgs/msg/OccupancyGrid`, transient local) and
//!   `explore/shared_map_updates` (`map_msgs/msg/OccupancyGridUpdate`): the robot's own map as
//!   its nav2 publishes it, in full now and then and otherwise as deltas
//!   ([`madenet_ros2::map_updates::MapPublisher`]);
//! - `explore/pose` (`geometry_msgs/msg/PoseStamped`): where the robot is, each planner period;
//! - `explore/goal` (`geometry_msgs/msg/PoseStamped`): its goal, on each change and each planner
//!   period; an empty `frame_id` says it has none.
//!
//! The team's robots are numbered in the order of their namespaces (sorted), so every node,
//! given the others' namespaces, numbers them alike. Only teammates' topics are subscribed:
//! a robot that is not on the team is never heard. A pose or goal in another frame than the
//! map's, or a map of another geometry, is dropped and logged (once per teammate and topic);
//! samples that do not decode are dropped by the subscription; ROS's keep-last queue (10)
//! bounds what a flooding teammate can queue, and a flood is logged once.

use madenet_ros2::map_updates::{MapPublisher, MapSubscriber};
use madenet_ros2::msgs::{Header, OccupancyGrid, PoseStamped, Time};
use madenet_ros2::{Node, Publisher, QosProfile, Ros2Error, Subscription};
use std::time::Duration;

/// Most poses or goals taken from one teammate per call (a teammate that floods cannot hold
/// the node in its loop; its subscriptions keep the newest [`QUEUE`] anyway, as ROS's keep-last).
const DRAIN_LIMIT: usize = 64;

/// The depth of the pose and goal subscriptions (rclcpp's default, keep last 10).
const QUEUE: usize = 10;

/// Poses and goals a second from one teammate above which it floods (it sends one of each
/// per planner period, and a goal on each change): logged once.
const FLOOD_RATE: usize = 50;

/// What this node knows of one teammate.
pub struct Teammate {
    /// Its namespace.
    pub namespace: String,
    /// Its index on the team.
    pub index: usize,
    /// Its last position, and when (node time) it was heard.
    pub pos: Option<((f64, f64), f64)>,
    /// Its goal (`None`: none, or never heard).
    pub goal: Option<(f64, f64)>,
    /// Its goal before the current one.
    pub prev_goal: Option<(f64, f64)>,
    map: MapSubscriber,
    pose_sub: Subscription<PoseStamped>,
    goal_sub: Subscription<PoseStamped>,
    /// Whether a wrong frame or geometry was logged already (pose, goal, map).
    logged: [bool; 3],
    /// Messages dropped (wrong frame or geometry).
    pub dropped: usize,
    /// Whether its map changed at the last [`Team::poll`].
    pub fresh_map: bool,
    /// Messages taken since `.1` (wall clock), and whether a flood was logged.
    flood: (usize, std::time::Instant, bool),
}

/// This node's side of the team: its publishers and its teammates.
pub struct Team {
    /// This robot's index on the team.
    pub me: usize,
    /// The team's size.
    pub size: usize,
    map_pub: MapPublisher,
    pose_pub: Publisher<PoseStamped>,
    goal_pub: Publisher<PoseStamped>,
    mates: Vec<Teammate>,
    last_goal: Option<Option<(f64, f64)>>,
}

fn pose_msg(frame: &str, at: (f64, f64), stamp: Time) -> PoseStamped {
    let mut m = PoseStamped {
        header: Header {
            stamp,
            frame_id: frame.to_string(),
        },
        ..Default::default()
    };
    m.pose.position.x = at.0;
    m.pose.position.y = at.1;
    m.pose.orientation.w = 1.0;
    m
}

impl Team {
    /// The team of the robot in namespace `ns` and its `teammates`' namespaces (`ns` itself
    /// and repeats are left out).
    pub fn new(node: &Node, ns: &str, teammates: &[String]) -> Result<Self, Ros2Error> {
        let mut all: Vec<String> = teammates.iter().map(|t| t.to_string()).collect();
        all.push(ns.to_string());
        all.sort();
        all.dedup();
        let me = all.iter().position(|n| n == ns).expect("pushed");
        let mut mates = Vec::new();
        for (index, namespace) in all.iter().enumerate() {
            if index == me {
                continue;
            }
            let topic = |t: &str| format!("{}/explore/{t}", namespace.trim_end_matches('/'));
            mates.push(Teammate {
                namespace: namespace.clone(),
                index,
                pos: None,
                goal: None,
                prev_goal: None,
                map: MapSubscriber::new(node, &topic("shared_map"))?,
                pose_sub: node.create_sub(&topic("pose"), QosProfile::default())?,
                goal_sub: node.create_sub(&topic("goal"), QosProfile::default())?,
                logged: [false; 3],
                dropped: 0,
                fresh_map: false,
                flood: (0, std::time::Instant::now(), false),
            });
        }
        Ok(Team {
            me,
            size: all.len(),
            map_pub: MapPublisher::new(node, "explore/shared_map")?.with_full_every(20),
            pose_pub: node.create_pub("explore/pose", QosProfile::default())?,
            goal_pub: node.create_pub("explore/goal", QosProfile::default())?,
            mates,
            last_goal: None,
        })
    }

    /// The teammates.
    pub fn mates(&self) -> &[Teammate] {
        &self.mates
    }

    /// Shares this robot's map, position and goal (`None`: none) in `frame`.
    pub fn share(
        &mut self,
        own: &OccupancyGrid,
        frame: &str,
        here: (f64, f64),
        goal: Option<(f64, f64)>,
        stamp: Time,
    ) -> Result<(), Ros2Error> {
        if self.mates.is_empty() {
            return Ok(());
        }
        self.map_pub.publish(own)?;
        self.pose_pub.publish(&pose_msg(frame, here, stamp))?;
        self.share_goal(frame, goal, stamp)
    }

    /// Shares this robot's goal now (on a change, between periods).
    pub fn share_goal(
        &mut self,
        frame: &str,
        goal: Option<(f64, f64)>,
        stamp: Time,
    ) -> Result<(), Ros2Error> {
        if self.mates.is_empty() {
            return Ok(());
        }
        self.last_goal = Some(goal);
        let msg = match goal {
            Some(g) => pose_msg(frame, g, stamp),
            None => pose_msg("", (0.0, 0.0), stamp),
        };
        self.goal_pub.publish(&msg)
    }

    /// Takes what teammates sent (node time `now`); poses and goals must be in `frame`.
    pub fn poll(&mut self, now: f64, frame: &str, ns: &str) -> Result<(), Ros2Error> {
        for m in &mut self.mates {
            let mut taken = 0;
            for _ in 0..DRAIN_LIMIT {
                let Some(p) = m.pose_sub.recv_timeout(Duration::ZERO)? else {
                    break;
                };
                taken += 1;
                match p.header.frame_id == frame && finite(&p) {
                    true => m.pos = Some(((p.pose.position.x, p.pose.position.y), now)),
                    false => drop_logged(m, 0, ns, "pose", &p.header.frame_id, frame),
                }
            }
            for _ in 0..DRAIN_LIMIT {
                let Some(g) = m.goal_sub.recv_timeout(Duration::ZERO)? else {
                    break;
                };
                taken += 1;
                let goal = match g.header.frame_id.as_str() {
                    "" => None,
                    f if f == frame && finite(&g) => Some((g.pose.position.x, g.pose.position.y)),
                    f => {
                        let f = f.to_string();
                        drop_logged(m, 1, ns, "goal", &f, frame);
                        continue;
                    }
                };
                if goal != m.goal {
                    m.prev_goal = m.goal;
                    m.goal = goal;
                }
            }
            m.flood.0 += taken;
            if m.flood.1.elapsed() >= Duration::from_secs(1) {
                if m.flood.0 > FLOOD_RATE && !std::mem::replace(&mut m.flood.2, true) {
                    tracing::warn!(
                        "{ns}: {} floods explore/pose or explore/goal ({} messages in a second): only the newest {QUEUE} of each are kept between turns, the rest dropped (logged once)",
                        m.namespace,
                        m.flood.0
                    );
                }
                m.flood = (0, std::time::Instant::now(), m.flood.2);
            }
            m.fresh_map = m.map.poll()?.is_some();
        }
        Ok(())
    }

    /// Teammate `k`'s map (of [`Team::mates`]) as last shared, if one arrived.
    pub fn map_of(&mut self, k: usize) -> Option<&OccupancyGrid> {
        self.mates[k].map.latest(Duration::ZERO).ok().flatten()
    }

    /// `own` with each cell it does not know taken from the teammates' maps (the first
    /// teammate, in team order, that knows it); teammates' maps of another geometry or frame
    /// are left out (logged once).
    pub fn merged(&mut self, own: &OccupancyGrid, ns: &str) -> OccupancyGrid {
        let mut out = own.clone();
        for m in &mut self.mates {
            let Some(theirs) = m.map.latest(Duration::ZERO).ok().flatten() else {
                continue;
            };
            let fits = theirs.info.width == own.info.width
                && theirs.info.height == own.info.height
                && theirs.info.resolution == own.info.resolution
                && theirs.info.origin == own.info.origin
                && theirs.data.len() == own.data.len()
                && frame_of(&theirs.header) == frame_of(&own.header);
            if !fits {
                let what = format!(
                    "{} × {} at {:?} in {:?}",
                    theirs.info.width,
                    theirs.info.height,
                    (theirs.info.origin.position.x, theirs.info.origin.position.y),
                    frame_of(&theirs.header)
                );
                drop_logged(m, 2, ns, "shared_map", &what, "this robot's map geometry");
                continue;
            }
            for (o, &t) in out.data.iter_mut().zip(&theirs.data) {
                if *o < 0 {
                    *o = t;
                }
            }
        }
        out
    }
}

fn frame_of(h: &Header) -> &str {
    match h.frame_id.as_str() {
        "" => "map",
        f => f,
    }
}

fn finite(p: &PoseStamped) -> bool {
    p.pose.position.x.is_finite() && p.pose.position.y.is_finite()
}

fn drop_logged(m: &mut Teammate, which: usize, ns: &str, topic: &str, got: &str, want: &str) {
    m.dropped += 1;
    if !std::mem::replace(&mut m.logged[which], true) {
        tracing::warn!(
            "{ns}: dropped {}'s explore/{topic}: {got:?}, not {want:?} (logged once)",
            m.namespace
        );
    }
}
