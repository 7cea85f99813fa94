//! TF: where each frame is, as `/tf` and `/tf_static` (`tf2_msgs/msg/TFMessage`) carry it,
//! and a small buffer that composes a chain such as `map → odom → base_link` at a time.
//!
//! A robot team puts each robot's frames apart in one of two ways ([`TfNaming`]):
//! - **namespaced topics** (the default, as nav2's multi-robot bringup does): each robot
//!   publishes `/robot0/tf` and `/robot0/tf_static` (`/tf` remapped to `tf` in the robot's
//!   namespace), with plain frame names `map`, `odom`, `base_link`;
//! - **frame prefixes**: every robot publishes on the global `/tf` and `/tf_static`, with
//!   frames `robot0/map`, `robot0/odom`, `robot0/base_link`.
//!
//! [`TfBuffer::lookup`] answers tf2's `lookupTransform(target, source, time)`: the transform
//! that takes a point in `source` to `target`, through the frames' common ancestor. Each edge
//! is taken at the stored sample nearest `time`, within a tolerance (tf2 interpolates; robots
//! here publish at 10 Hz or faster, so nearest-within-tolerance is what the exploration node
//! needs). `time` zero asks for the latest common sample, as tf2's `TimePointZero`.
//! Written by hand: tf2 itself needs a ROS install, and the few lines of quaternion algebra
//! do not justify a linear-algebra crate.

use crate::msgs::{Quaternion, TFMessage, Time, Transform, TransformStamped, Vector3};
use crate::rmw::{Node, Publisher, QosProfile, Subscription};
use crate::Ros2Error;
use std::collections::{BTreeMap, HashMap};
use std::time::Duration;

/// How robots' TF trees are kept apart (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TfNaming {
    /// `/<ns>/tf` and `/<ns>/tf_static`, frames `map`, `odom`, `base_link` (nav2's
    /// multi-robot default).
    #[default]
    NamespacedTopics,
    /// `/tf` and `/tf_static`, frames `<ns>/map`, `<ns>/odom`, `<ns>/base_link`.
    FramePrefix,
}

impl TfNaming {
    /// The dynamic TF topic of a robot in namespace `ns` (`""` or `/robot0`).
    pub fn tf_topic(self, ns: &str) -> String {
        match self {
            TfNaming::NamespacedTopics if !ns.trim_matches('/').is_empty() => {
                format!("/{}/tf", ns.trim_matches('/'))
            }
            _ => "/tf".into(),
        }
    }

    /// The static TF topic of a robot in namespace `ns`.
    pub fn tf_static_topic(self, ns: &str) -> String {
        format!("{}_static", self.tf_topic(ns))
    }

    /// Frame `name` (`map`, `odom`, `base_link`, …) of the robot in namespace `ns`.
    pub fn frame(self, ns: &str, name: &str) -> String {
        let ns = ns.trim_matches('/');
        match self {
            TfNaming::FramePrefix if !ns.is_empty() => format!("{ns}/{name}"),
            _ => name.to_string(),
        }
    }
}

/// Why a lookup failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TfError {
    /// A frame no transform names.
    #[error("frame `{0}` does not exist")]
    UnknownFrame(String),
    /// The two frames are in different trees.
    #[error("`{target}` and `{source_frame}` are not connected")]
    NotConnected {
        /// Target frame.
        target: String,
        /// Source frame.
        source_frame: String,
    },
    /// No sample of an edge within the tolerance of the time asked.
    #[error("no transform {parent} → {child} within {tolerance:?} of t = {at:.3} s")]
    NoSample {
        /// Parent frame of the edge.
        parent: String,
        /// Child frame of the edge.
        child: String,
        /// The time asked, seconds.
        at: f64,
        /// The tolerance.
        tolerance: Duration,
    },
}

/// `a ∘ b`: first `b`, then `a` (the pose of `b`'s child in `a`'s parent).
pub fn compose(a: &Transform, b: &Transform) -> Transform {
    let t = rotate(&a.rotation, &b.translation);
    Transform {
        translation: Vector3 {
            x: a.translation.x + t.x,
            y: a.translation.y + t.y,
            z: a.translation.z + t.z,
        },
        rotation: mul(&a.rotation, &b.rotation),
    }
}

/// The inverse transform.
pub fn inverse(a: &Transform) -> Transform {
    let q = conj(&a.rotation);
    let t = rotate(&q, &a.translation);
    Transform {
        translation: Vector3 {
            x: -t.x,
            y: -t.y,
            z: -t.z,
        },
        rotation: q,
    }
}

/// The yaw (rad) of a rotation about z.
pub fn yaw(q: &Quaternion) -> f64 {
    (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z))
}

/// A rotation by `yaw` (rad) about z.
pub fn from_yaw(yaw: f64) -> Quaternion {
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: (yaw / 2.0).sin(),
        w: (yaw / 2.0).cos(),
    }
}

fn mul(a: &Quaternion, b: &Quaternion) -> Quaternion {
    Quaternion {
        w: a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
        x: a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
        y: a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
        z: a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
    }
}

fn conj(q: &Quaternion) -> Quaternion {
    Quaternion {
        x: -q.x,
        y: -q.y,
        z: -q.z,
        w: q.w,
    }
}

fn rotate(q: &Quaternion, v: &Vector3) -> Vector3 {
    let p = Quaternion {
        x: v.x,
        y: v.y,
        z: v.z,
        w: 0.0,
    };
    let r = mul(&mul(q, &p), &conj(q));
    Vector3 {
        x: r.x,
        y: r.y,
        z: r.z,
    }
}

/// Whether every number of a transform is finite and its rotation a unit quaternion (±1 %).
pub fn is_valid(t: &Transform) -> bool {
    let q = &t.rotation;
    let v = &t.translation;
    let all = [v.x, v.y, v.z, q.x, q.y, q.z, q.w];
    let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
    all.iter().all(|x| x.is_finite()) && (norm - 1.0).abs() < 0.01
}

/// One edge of the tree: its parent and its samples by time (static: one sample at t = 0).
struct Edge {
    parent: String,
    is_static: bool,
    /// Time (ns since the epoch) → transform.
    samples: BTreeMap<i64, Transform>,
}

/// The frames heard so far, with `cache` of history per edge (tf2's default: 10 s).
pub struct TfBuffer {
    cache: Duration,
    /// Child frame → its edge.
    edges: HashMap<String, Edge>,
    /// Transforms refused because a number was not finite or the rotation not a unit
    /// quaternion.
    refused: usize,
}

impl Default for TfBuffer {
    fn default() -> Self {
        TfBuffer::new(Duration::from_secs(10))
    }
}

fn ns(t: Time) -> i64 {
    t.sec as i64 * 1_000_000_000 + t.nanosec as i64
}

impl TfBuffer {
    /// An empty buffer keeping `cache` of history.
    pub fn new(cache: Duration) -> Self {
        TfBuffer {
            cache,
            edges: HashMap::new(),
            refused: 0,
        }
    }

    /// Adds one transform (static ones hold at every time). A transform with a non-finite
    /// number or a rotation that is not a unit quaternion is refused, logged and counted.
    pub fn insert(&mut self, t: &TransformStamped, is_static: bool) {
        if !is_valid(&t.transform) || t.child_frame_id.is_empty() {
            self.refused += 1;
            tracing::warn!(
                "TF: refused {} → {}: not a finite rigid transform",
                t.header.frame_id,
                t.child_frame_id
            );
            return;
        }
        let edge = self
            .edges
            .entry(t.child_frame_id.clone())
            .or_insert_with(|| Edge {
                parent: t.header.frame_id.clone(),
                is_static,
                samples: BTreeMap::new(),
            });
        if edge.parent != t.header.frame_id || edge.is_static != is_static {
            // A frame that changed parent: the newest word wins, as in tf2.
            edge.parent = t.header.frame_id.clone();
            edge.is_static = is_static;
            edge.samples.clear();
        }
        let at = if is_static { 0 } else { ns(t.header.stamp) };
        if is_static {
            edge.samples.clear();
        }
        edge.samples.insert(at, t.transform);
        if let Some((&newest, _)) = edge.samples.last_key_value() {
            let oldest = newest - self.cache.as_nanos() as i64;
            edge.samples.retain(|&k, _| k >= oldest);
        }
    }

    /// Adds every transform of a `/tf` (or `/tf_static`) message.
    pub fn insert_message(&mut self, msg: &TFMessage, is_static: bool) {
        for t in &msg.transforms {
            self.insert(t, is_static);
        }
    }

    /// Transforms refused so far.
    pub fn refused(&self) -> usize {
        self.refused
    }

    /// `frame` and its ancestors, frame first.
    fn chain(&self, frame: &str) -> Vec<String> {
        let mut out = vec![frame.to_string()];
        while let Some(e) = self.edges.get(out.last().expect("not empty")) {
            if out.contains(&e.parent) || out.len() > 64 {
                break;
            }
            out.push(e.parent.clone());
        }
        out
    }

    fn known(&self, frame: &str) -> bool {
        self.edges.contains_key(frame) || self.edges.values().any(|e| e.parent == frame)
    }

    /// The newest time at which every dynamic edge between `frame` and `up_to` has a sample.
    fn latest(&self, chain: &[String]) -> Option<i64> {
        chain
            .iter()
            .filter_map(|f| self.edges.get(f))
            .filter(|e| !e.is_static)
            .map(|e| e.samples.last_key_value().map(|(&k, _)| k))
            .try_fold(i64::MAX, |m, k| k.map(|k| m.min(k)))
            .map(|m| if m == i64::MAX { 0 } else { m })
    }

    /// The pose of `child` in its parent at `at` (ns), nearest sample within `tolerance`.
    fn edge_at(&self, child: &str, at: i64, tolerance: Duration) -> Result<Transform, TfError> {
        let e = &self.edges[child];
        if e.is_static {
            return Ok(*e
                .samples
                .values()
                .next()
                .expect("a static edge has its sample"));
        }
        let tol = tolerance.as_nanos() as i64;
        let before = e.samples.range(..=at).next_back();
        let after = e.samples.range(at..).next();
        let best = [before, after]
            .into_iter()
            .flatten()
            .min_by_key(|(&k, _)| (k - at).abs());
        match best {
            Some((&k, t)) if (k - at).abs() <= tol => Ok(*t),
            _ => Err(TfError::NoSample {
                parent: e.parent.clone(),
                child: child.to_string(),
                at: at as f64 * 1e-9,
                tolerance,
            }),
        }
    }

    /// tf2's `lookupTransform(target, source, at)`: the pose of `source` in `target` (it takes
    /// a point in `source` to `target`), each edge at the sample nearest `at` within
    /// `tolerance`; `at` zero: the latest time all edges share.
    pub fn lookup(
        &self,
        target: &str,
        source: &str,
        at: Time,
        tolerance: Duration,
    ) -> Result<Transform, TfError> {
        for f in [target, source] {
            if !self.known(f) {
                return Err(TfError::UnknownFrame(f.to_string()));
            }
        }
        let up_s = self.chain(source);
        let up_t = self.chain(target);
        let Some(common) = up_s.iter().find(|f| up_t.contains(f)).cloned() else {
            return Err(TfError::NotConnected {
                target: target.into(),
                source_frame: source.into(),
            });
        };
        let s_path: Vec<String> = up_s.iter().take_while(|f| **f != common).cloned().collect();
        let t_path: Vec<String> = up_t.iter().take_while(|f| **f != common).cloned().collect();
        let at = if at == Time::default() {
            let mut both = s_path.clone();
            both.extend(t_path.iter().cloned());
            self.latest(&both).unwrap_or(0)
        } else {
            ns(at)
        };
        // common → source, and common → target.
        let mut to_source = Transform::default();
        for f in s_path.iter().rev() {
            to_source = compose(&to_source, &self.edge_at(f, at, tolerance)?);
        }
        let mut to_target = Transform::default();
        for f in t_path.iter().rev() {
            to_target = compose(&to_target, &self.edge_at(f, at, tolerance)?);
        }
        Ok(compose(&inverse(&to_target), &to_source))
    }
}

/// A `TransformStamped` of `child` in `parent` at `stamp`: translation (x, y, 0), rotation
/// `yaw` about z.
pub fn planar(
    parent: &str,
    child: &str,
    stamp: Time,
    x: f64,
    y: f64,
    yaw: f64,
) -> TransformStamped {
    TransformStamped {
        header: crate::msgs::Header {
            stamp,
            frame_id: parent.to_string(),
        },
        child_frame_id: child.to_string(),
        transform: Transform {
            translation: Vector3 { x, y, z: 0.0 },
            rotation: from_yaw(yaw),
        },
    }
}

/// tf2's QoS of `/tf`: reliable, volatile, keep last 100.
pub fn tf_qos() -> QosProfile {
    QosProfile {
        depth: 100,
        ..QosProfile::default()
    }
}

/// tf2's QoS of `/tf_static`: reliable, transient local, keep last 1 (a late joiner gets
/// the static frames).
pub fn tf_static_qos() -> QosProfile {
    crate::map_qos()
}

/// A robot's TF publishers: `/tf` and `/tf_static` (or the namespaced pair, [`TfNaming`]).
pub struct TfPublisher {
    tf: Publisher<TFMessage>,
    tf_static: Publisher<TFMessage>,
}

impl TfPublisher {
    /// Publishers for the robot in `node`'s namespace, named by `naming`.
    pub fn new(node: &Node, naming: TfNaming) -> Result<Self, Ros2Error> {
        let ns = node.namespace();
        Ok(TfPublisher {
            tf: node.create_pub(&naming.tf_topic(ns), tf_qos())?,
            tf_static: node.create_pub(&naming.tf_static_topic(ns), tf_static_qos())?,
        })
    }

    /// Sends dynamic transforms.
    pub fn send(&self, transforms: Vec<TransformStamped>) -> Result<(), Ros2Error> {
        self.tf.publish(&TFMessage { transforms })
    }

    /// Sends the static transforms (all of them: a late joiner gets only the last message).
    pub fn send_static(&self, transforms: Vec<TransformStamped>) -> Result<(), Ros2Error> {
        self.tf_static.publish(&TFMessage { transforms })
    }
}

/// Listens to a TF pair of topics into a [`TfBuffer`].
pub struct TfListener {
    tf: Subscription<TFMessage>,
    tf_static: Subscription<TFMessage>,
    /// What was heard.
    pub buffer: TfBuffer,
}

impl TfListener {
    /// Listens to the TF topics of the robot in namespace `ns`, named by `naming`.
    pub fn new(node: &Node, ns: &str, naming: TfNaming) -> Result<Self, Ros2Error> {
        Ok(TfListener {
            tf: node.create_sub(&naming.tf_topic(ns), tf_qos())?,
            // tf2's StaticListenerQoS: transient local, keep last 100 (each broadcaster keeps
            // its own last message; the listener hears every broadcaster's).
            tf_static: node.create_sub(
                &naming.tf_static_topic(ns),
                QosProfile {
                    depth: 100,
                    ..tf_static_qos()
                },
            )?,
            buffer: TfBuffer::default(),
        })
    }

    /// Takes every message that has arrived, waiting up to `timeout` for the first.
    pub fn spin(&mut self, timeout: Duration) -> Result<usize, Ros2Error> {
        let mut n = 0;
        while let Some(m) = self.tf_static.recv_timeout(Duration::ZERO)? {
            self.buffer.insert_message(&m, true);
            n += 1;
        }
        let mut wait = timeout;
        while let Some(m) = self.tf.recv_timeout(wait)? {
            self.buffer.insert_message(&m, false);
            wait = Duration::ZERO;
            n += 1;
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(sec: i32) -> Time {
        Time { sec, nanosec: 0 }
    }

    const TOL: Duration = Duration::from_millis(200);

    #[test]
    fn map_odom_base_link_composes() {
        let mut b = TfBuffer::default();
        // odom 2 m east of map, turned 90°; base_link 1 m ahead (odom's x) of odom.
        b.insert(
            &planar("map", "odom", t(0), 2.0, 0.0, std::f64::consts::FRAC_PI_2),
            true,
        );
        b.insert(&planar("odom", "base_link", t(10), 1.0, 0.0, 0.0), false);
        b.insert(&planar("odom", "base_link", t(11), 3.0, 0.0, 0.0), false);
        let p = b.lookup("map", "base_link", t(10), TOL).unwrap();
        assert!((p.translation.x - 2.0).abs() < 1e-9 && (p.translation.y - 1.0).abs() < 1e-9);
        assert!((yaw(&p.rotation) - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        // Latest: t = 11.
        let p = b.lookup("map", "base_link", Time::default(), TOL).unwrap();
        assert!((p.translation.y - 3.0).abs() < 1e-9);
        // The other way round is the inverse.
        let q = b.lookup("base_link", "map", t(11), TOL).unwrap();
        let id = compose(&p, &q);
        assert!(id.translation.x.abs() < 1e-9 && id.translation.y.abs() < 1e-9);
        // Between samples, beyond the tolerance: no answer; within it: the nearest.
        assert!(matches!(
            b.lookup(
                "map",
                "base_link",
                Time {
                    sec: 10,
                    nanosec: 500_000_000
                },
                TOL
            ),
            Err(TfError::NoSample { .. })
        ));
        let near = Time {
            sec: 10,
            nanosec: 900_000_000,
        };
        assert!(
            (b.lookup("map", "base_link", near, TOL)
                .unwrap()
                .translation
                .y
                - 3.0)
                .abs()
                < 1e-9
        );
    }

    #[test]
    fn robots_in_prefixed_frames_stay_apart() {
        let mut b = TfBuffer::default();
        let n = TfNaming::FramePrefix;
        for (i, x) in [(0, 1.0), (1, 5.0)] {
            let ns = format!("/robot{i}");
            b.insert(
                &planar("map", &n.frame(&ns, "odom"), t(0), 0.0, 0.0, 0.0),
                true,
            );
            b.insert(
                &planar(
                    &n.frame(&ns, "odom"),
                    &n.frame(&ns, "base_link"),
                    t(1),
                    x,
                    0.0,
                    0.0,
                ),
                false,
            );
        }
        let x = |f: &str| {
            b.lookup("map", f, Time::default(), TOL)
                .unwrap()
                .translation
                .x
        };
        assert_eq!((x("robot0/base_link"), x("robot1/base_link")), (1.0, 5.0));
        let rel = b
            .lookup("robot0/base_link", "robot1/base_link", t(1), TOL)
            .unwrap();
        assert!((rel.translation.x - 4.0).abs() < 1e-9);
        assert_eq!(
            b.lookup("map", "robot7/base_link", t(1), TOL),
            Err(TfError::UnknownFrame("robot7/base_link".into()))
        );
        assert_eq!(TfNaming::NamespacedTopics.tf_topic("/robot2"), "/robot2/tf");
        assert_eq!(
            TfNaming::NamespacedTopics.tf_static_topic("robot2"),
            "/robot2/tf_static"
        );
        assert_eq!(TfNaming::FramePrefix.tf_topic("/robot2"), "/tf");
        assert_eq!(TfNaming::NamespacedTopics.frame("/robot2", "odom"), "odom");
    }

    #[test]
    fn bad_transforms_are_refused_and_trees_that_do_not_meet_say_so() {
        let mut b = TfBuffer::default();
        let mut nan = planar("map", "odom", t(1), f64::NAN, 0.0, 0.0);
        b.insert(&nan, false);
        nan.transform.translation.x = 0.0;
        nan.transform.rotation.w = 3.0;
        b.insert(&nan, false);
        assert_eq!(b.refused(), 2);
        b.insert(&planar("a", "b", t(1), 0.0, 0.0, 0.0), false);
        b.insert(&planar("c", "d", t(1), 0.0, 0.0, 0.0), false);
        assert!(matches!(
            b.lookup("b", "d", t(1), TOL),
            Err(TfError::NotConnected { .. })
        ));
        // Old samples leave the cache.
        let mut b = TfBuffer::new(Duration::from_secs(2));
        for s in 0..10 {
            b.insert(
                &planar("odom", "base_link", t(s), s as f64, 0.0, 0.0),
                false,
            );
        }
        assert!(b.lookup("odom", "base_link", t(3), TOL).is_err());
        assert!(b.lookup("odom", "base_link", t(8), TOL).is_ok());
    }
}
