//! The rmw_zenoh wire (ROS 2 Jazzy, rmw_zenoh_cpp ≥ 0.2.4), written on zenoh directly: what a
//! ROS 2 node with `RMW_IMPLEMENTATION=rmw_zenoh_cpp` expects to see.
//!
//! - **Data** on `<domain>/<topic without leading slash>/<DDS type name>/<RIHS01 hash>`, CDR
//!   payloads ([`crate::msgs`]), and a 33-byte attachment: sequence number (i64, from 1),
//!   source time (i64 ns since the epoch), and the publisher's 16-byte GID, in zenoh-ext's
//!   serialization (little endian; the GID with its length, 16, before it).
//! - **The ROS graph** as liveliness tokens:
//!   `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node name>`
//!   for a node (kind `NN`), followed by `/<topic>/<type>/<hash>/<QoS>` for a publisher (`MP`)
//!   or subscription (`MS`); `/` in names becomes `%`, an empty enclave or namespace is `%`.
//!   Node and entity ids come from one counter per context, as in rmw_zenoh.
//! - **Transient local** durability through zenoh-ext's advanced publisher (a cache of `depth`
//!   samples, publisher detection, sample-miss heartbeats) and advanced subscriber (history
//!   from late-joining publishers), as rmw_zenoh_cpp's `rmw_publisher_data.cpp` does.
//!
//! Written by hand, not with `hiroz`: hiroz needs zenoh as a build dependency (so zenoh was
//! compiled twice) and turns on zenoh's default features (QUIC, TLS, WebSocket, shared memory …);
//! what madenet uses of it is this module (issue 25).

use crate::msgs::RosMessage;
use crate::{middleware, Ros2Error};
use std::marker::PhantomData;
use std::sync::atomic::{AtomicI64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};
use zenoh::bytes::ZBytes;
use zenoh::handlers::RingChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::sample::Sample;
use zenoh::Wait;
use zenoh_ext::{
    AdvancedPublisher, AdvancedPublisherBuilderExt, AdvancedSubscriber,
    AdvancedSubscriberBuilderExt, CacheConfig, HistoryConfig, MissDetectionConfig, RecoveryConfig,
};

/// The liveliness admin space of rmw_zenoh.
const ADMIN_SPACE: &str = "@ros2_lv";
/// rmw_zenoh's placeholder for an empty enclave or namespace.
const EMPTY: &str = "%";
/// rmw_zenoh's history depth that a QoS string leaves out.
const WIRE_DEFAULT_DEPTH: usize = 42;
/// How often a reliable transient-local publisher announces its last sequence number.
const SAMPLE_MISS_HEARTBEAT: Duration = Duration::from_millis(500);

/// Reliability of a topic (ROS `RMW_QOS_POLICY_RELIABILITY_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reliability {
    /// Samples are sent reliably (retransmitted); as rmw_zenoh's keep-last publishers, they
    /// are dropped only when a subscriber stops reading and the queue to it is full.
    #[default]
    Reliable,
    /// Samples may be dropped under congestion.
    BestEffort,
}

/// Durability of a topic (ROS `RMW_QOS_POLICY_DURABILITY_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Durability {
    /// Only subscribers present when a sample is sent get it.
    #[default]
    Volatile,
    /// A subscriber that joins late gets the last `depth` samples.
    TransientLocal,
}

/// The QoS profile of a publisher or subscription: keep-last history of `depth`, infinite
/// deadline, lifespan and lease, automatic liveliness (the parts madenet sets). The default is
/// rclcpp's: reliable, volatile, keep last 10.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QosProfile {
    /// Reliable or best effort.
    pub reliability: Reliability,
    /// Volatile or transient local.
    pub durability: Durability,
    /// Keep-last depth (≥ 1).
    pub depth: usize,
}

impl Default for QosProfile {
    fn default() -> Self {
        QosProfile {
            reliability: Reliability::Reliable,
            durability: Durability::Volatile,
            depth: 10,
        }
    }
}

impl QosProfile {
    /// The QoS field of a liveliness token:
    /// `<reliability>:<durability>:<history>,<depth>:<deadline>:<lifespan>:<liveliness>`, each
    /// part empty where it is rmw_zenoh's default (reliable, volatile, keep last 42, infinite
    /// durations, automatic liveliness).
    pub fn encode(&self) -> String {
        let reliability = match self.reliability {
            Reliability::Reliable => "",
            Reliability::BestEffort => "2",
        };
        let durability = match self.durability {
            Durability::Volatile => "",
            Durability::TransientLocal => "1",
        };
        let depth = if self.depth == WIRE_DEFAULT_DEPTH {
            String::new()
        } else {
            self.depth.to_string()
        };
        format!("{reliability}:{durability}:,{depth}:,:,:,,")
    }
}

/// `/` → `%`, as rmw_zenoh writes names inside liveliness tokens.
fn mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// The key expression of `topic`'s data for message type `T` in `domain`.
pub fn topic_key<T: RosMessage>(domain: usize, topic: &str) -> String {
    data_key(domain, topic, &T::dds_type_name(), &T::type_hash())
}

/// The key expression of a topic's or service's data: `<domain>/<name>/<DDS type>/<hash>`,
/// without the name's leading or trailing `/`.
pub(crate) fn data_key(domain: usize, name: &str, dds_type: &str, hash: &str) -> String {
    let name = name.trim_start_matches('/').trim_end_matches('/');
    format!("{domain}/{name}/{dds_type}/{hash}")
}

/// The GID of an entity: XXH3-128 of its liveliness token's key expression, low 64 bits then
/// high 64 bits, little endian — rmw_zenoh_cpp's `generate_gid`.
pub fn gid(liveliness_key: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(liveliness_key.as_bytes());
    let mut g = [0u8; 16];
    g[..8].copy_from_slice(&(h as u64).to_le_bytes());
    g[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    g
}

/// The attachment rmw_zenoh puts on every sample: sequence number, source time (ns since the
/// epoch) and the publisher's GID, in zenoh-ext's serialization (33 bytes).
pub fn attachment(sequence_number: i64, source_time: SystemTime, gid: &[u8; 16]) -> ZBytes {
    let ns = source_time
        .duration_since(UNIX_EPOCH)
        .map(|d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
        .unwrap_or(0);
    let mut s = zenoh_ext::ZSerializer::new();
    s.serialize(sequence_number);
    s.serialize(ns);
    s.serialize(*gid);
    s.finish()
}

/// A ROS 2 context: one zenoh session in a ROS domain, and the counter node and entity ids come
/// from.
pub struct Ros2Context {
    session: zenoh::Session,
    domain_id: usize,
    counter: Arc<AtomicUsize>,
}

impl Ros2Context {
    /// A context on an open session.
    pub fn new(session: zenoh::Session, domain_id: usize) -> Self {
        Ros2Context {
            session,
            domain_id,
            counter: Arc::new(AtomicUsize::new(0)),
        }
    }

    /// The zenoh session.
    pub fn session(&self) -> &zenoh::Session {
        &self.session
    }

    /// The ROS domain id.
    pub fn domain_id(&self) -> usize {
        self.domain_id
    }

    /// A node `name` in the root namespace, announced by its liveliness token.
    pub fn create_node(&self, name: &str) -> Result<Node, Ros2Error> {
        self.create_node_in("", name)
    }

    /// A node `name` in `namespace` (`""` or `/` for the root, else e.g. `/robot0`), announced
    /// by its liveliness token. Its relative topic and service names resolve in the namespace
    /// ([`Node::resolve`]).
    pub fn create_node_in(&self, namespace: &str, name: &str) -> Result<Node, Ros2Error> {
        let ns = namespace.trim_matches('/');
        let namespace = if ns.is_empty() {
            String::new()
        } else {
            format!("/{ns}")
        };
        let id = self.counter.fetch_add(1, Ordering::Relaxed);
        let prefix = format!(
            "{ADMIN_SPACE}/{}/{}/{id}",
            self.domain_id,
            self.session.zid()
        );
        let ns_field = if namespace.is_empty() {
            EMPTY.to_string()
        } else {
            mangle(&namespace)
        };
        let key = format!("{prefix}/{id}/NN/{EMPTY}/{ns_field}/{}", mangle(name));
        let token = self
            .session
            .liveliness()
            .declare_token(key)
            .wait()
            .map_err(middleware(format!("node {namespace}/{name}")))?;
        Ok(Node {
            session: self.session.clone(),
            domain_id: self.domain_id,
            counter: self.counter.clone(),
            prefix,
            name: name.to_string(),
            namespace,
            ns_field,
            remaps: Vec::new(),
            _token: token,
        })
    }
}

/// A ROS 2 node: its publishers and subscriptions are announced under its name.
pub struct Node {
    session: zenoh::Session,
    domain_id: usize,
    counter: Arc<AtomicUsize>,
    /// `@ros2_lv/<domain>/<zid>/<node id>`.
    prefix: String,
    name: String,
    /// `""` (root) or `/robot0`.
    namespace: String,
    /// The namespace as liveliness tokens write it (`%` for the root).
    ns_field: String,
    /// Remapping rules (`-r from:=to`), both names fully qualified.
    remaps: Vec<(String, String)>,
    _token: LivelinessToken,
}

impl Node {
    /// The fully qualified form of a topic or service name: a name that starts with `/` is
    /// absolute; any other is relative to the node's namespace (`map` in `/robot0` is
    /// `/robot0/map`).
    pub fn resolve(&self, name: &str) -> String {
        let full = self.qualify(name);
        match self.remaps.iter().find(|(from, _)| *from == full) {
            Some((_, to)) => to.clone(),
            None => full,
        }
    }

    /// `name` fully qualified in the node's namespace, before remapping.
    fn qualify(&self, name: &str) -> String {
        if name.starts_with('/') {
            format!("/{}", name.trim_matches('/'))
        } else {
            format!("{}/{}", self.namespace, name.trim_matches('/'))
        }
    }

    /// This node with remapping rules, as a ROS node takes `--ros-args -r from:=to`: a topic,
    /// service or action name that resolves to `from` (resolved in the node's namespace)
    /// resolves to `to` instead; the first matching rule applies.
    pub fn with_remaps(mut self, rules: &[(String, String)]) -> Self {
        self.remaps = rules
            .iter()
            .map(|(from, to)| (self.qualify(from), self.qualify(to)))
            .collect();
        self
    }

    /// The node's namespace: `""` (root) or e.g. `/robot0`.
    pub fn namespace(&self) -> &str {
        &self.namespace
    }

    /// Announces a new entity of `kind` (`MP` publisher, `MS` subscription, `SS` service
    /// server, `SC` service client) on `name` of type `(DDS type name, RIHS01 hash)` with its
    /// liveliness token; returns the token's key expression and the token.
    pub(crate) fn announce(
        &self,
        kind: &str,
        name: &str,
        (dds_type, hash): (&str, &str),
        qos: &QosProfile,
        what: &str,
    ) -> Result<(String, LivelinessToken), Ros2Error> {
        let id = self.counter.fetch_add(1, Ordering::Relaxed);
        let key = format!(
            "{}/{id}/{kind}/{EMPTY}/{}/{}/{}/{}/{}/{}",
            self.prefix,
            self.ns_field,
            mangle(&self.name),
            mangle(name.trim_end_matches('/')),
            mangle(dds_type),
            hash,
            qos.encode()
        );
        let token = self
            .session
            .liveliness()
            .declare_token(&key)
            .wait()
            .map_err(middleware(what))?;
        Ok((key, token))
    }

    /// The zenoh session the node's context opened.
    pub(crate) fn session(&self) -> &zenoh::Session {
        &self.session
    }

    /// The ROS domain id.
    pub fn domain_id(&self) -> usize {
        self.domain_id
    }

    /// A publisher of `T` on `topic` (relative names resolve in the node's namespace) with
    /// `qos`.
    pub fn create_pub<T: RosMessage>(
        &self,
        topic: &str,
        qos: QosProfile,
    ) -> Result<Publisher<T>, Ros2Error> {
        let topic = &self.resolve(topic);
        let what = || format!("publisher {topic}");
        let mut b = self
            .session
            .declare_publisher(topic_key::<T>(self.domain_id, topic))
            // As rmw_zenoh_cpp for keep-last history (the only history here): a subscriber
            // that stops reading must not stall the publisher, so congested samples drop.
            .congestion_control(zenoh::qos::CongestionControl::Drop)
            .advanced();
        if qos.durability == Durability::TransientLocal {
            b = b
                .publisher_detection()
                .cache(CacheConfig::default().max_samples(qos.depth));
            if qos.reliability == Reliability::Reliable {
                b = b.sample_miss_detection(
                    MissDetectionConfig::default().sporadic_heartbeat(SAMPLE_MISS_HEARTBEAT),
                );
            }
        }
        let inner = b.wait().map_err(middleware(what()))?;
        let (key, token) = self.announce(
            "MP",
            topic,
            (&T::dds_type_name(), &T::type_hash()),
            &qos,
            &what(),
        )?;
        Ok(Publisher {
            inner,
            gid: gid(&key),
            sequence_number: AtomicI64::new(1),
            _token: token,
            _type: PhantomData,
        })
    }

    /// A subscription to `T` on `topic` with `qos` (transient local: it also asks publishers
    /// that are already there, or join later, for their cached samples).
    pub fn create_sub<T: RosMessage>(
        &self,
        topic: &str,
        qos: QosProfile,
    ) -> Result<Subscription<T>, Ros2Error> {
        let topic = &self.resolve(topic);
        let what = || format!("subscriber {topic}");
        let mut b = self
            .session
            .declare_subscriber(topic_key::<T>(self.domain_id, topic))
            // Keep last `depth` (ROS's history): a reader that falls behind loses the oldest
            // samples, and never stalls the session (whose replies and other topics would
            // wait behind a full queue).
            .with(zenoh::handlers::RingChannel::new(qos.depth.max(1)))
            .advanced();
        if qos.durability == Durability::TransientLocal {
            b = b
                .history(
                    HistoryConfig::default()
                        .detect_late_publishers()
                        .max_samples(qos.depth),
                )
                .query_timeout(Duration::from_millis(u64::MAX))
                .subscriber_detection();
            if qos.reliability == Reliability::Reliable {
                b = b.recovery(RecoveryConfig::default().heartbeat());
            }
        }
        let inner = b.wait().map_err(middleware(what()))?;
        let (_, token) = self.announce(
            "MS",
            topic,
            (&T::dds_type_name(), &T::type_hash()),
            &qos,
            &what(),
        )?;
        Ok(Subscription {
            inner,
            topic: topic.to_string(),
            dropped: AtomicUsize::new(0),
            _token: token,
            _type: PhantomData,
        })
    }
}

/// A publisher of `T` messages.
pub struct Publisher<T> {
    inner: AdvancedPublisher<'static>,
    gid: [u8; 16],
    sequence_number: AtomicI64,
    _token: LivelinessToken,
    _type: PhantomData<fn(&T)>,
}

impl<T: RosMessage> Publisher<T> {
    /// Sends `msg` (CDR, with rmw_zenoh's attachment).
    pub fn publish(&self, msg: &T) -> Result<(), Ros2Error> {
        let sn = self.sequence_number.fetch_add(1, Ordering::Relaxed);
        self.inner
            .put(msg.to_cdr())
            .attachment(attachment(sn, SystemTime::now(), &self.gid))
            .wait()
            .map_err(middleware(format!("publish {}", T::TYPE_NAME)))
    }

    /// The GID the attachment carries.
    pub fn gid(&self) -> [u8; 16] {
        self.gid
    }
}

/// A subscription to `T` messages.
pub struct Subscription<T> {
    inner: AdvancedSubscriber<RingChannelHandler<Sample>>,
    topic: String,
    dropped: AtomicUsize,
    _token: LivelinessToken,
    _type: PhantomData<fn() -> T>,
}

impl<T: RosMessage> Subscription<T> {
    /// The next message, waiting up to `timeout`; `Ok(None)` when none came. A sample that is
    /// not a valid `T` is dropped with a warning naming the topic (and counted in
    /// [`Subscription::dropped`]): one bad publisher must not stop a node.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<T>, Ros2Error> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            let sample = self
                .inner
                .recv_timeout(left)
                .map_err(|e| Ros2Error::Middleware {
                    what: format!("subscriber {}", self.topic),
                    source: e,
                })?;
            let Some(s) = sample else { return Ok(None) };
            match T::from_cdr(&s.payload().to_bytes()) {
                Ok(msg) => return Ok(Some(msg)),
                Err(why) => {
                    self.dropped.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!(
                        "{}: dropped a sample that is not a {}: {why}",
                        self.topic,
                        T::TYPE_NAME
                    );
                }
            }
        }
    }

    /// Samples dropped so far because they did not decode as `T`.
    pub fn dropped(&self) -> usize {
        self.dropped.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{OccupancyGrid, PoseStamped};

    #[test]
    fn topic_keys_are_domain_topic_type_hash() {
        assert_eq!(
            topic_key::<OccupancyGrid>(0, "/robot1/map"),
            "0/robot1/map/nav_msgs::msg::dds_::OccupancyGrid_/\
             RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"
        );
        assert!(topic_key::<PoseStamped>(7, "/a/b/").starts_with("7/a/b/geometry_msgs::"));
    }

    #[test]
    fn qos_strings_leave_out_rmw_zenohs_defaults() {
        // rclcpp's default (reliable, volatile, keep last 10) and the map's (transient local,
        // keep last 1), as rmw_zenoh_cpp writes them into liveliness tokens.
        assert_eq!(QosProfile::default().encode(), "::,10:,:,:,,");
        assert_eq!(crate::map_qos().encode(), ":1:,1:,:,:,,");
        let best_effort = QosProfile {
            reliability: Reliability::BestEffort,
            durability: Durability::Volatile,
            depth: WIRE_DEFAULT_DEPTH,
        };
        assert_eq!(best_effort.encode(), "2::,:,:,:,,");
    }

    #[test]
    fn gid_is_xxh3_128_of_the_token_low_half_first() {
        // Expected bytes from the Python `xxhash` package (xxh3_128, an independent
        // implementation): low 64 bits little endian, then the high 64 bits.
        let key = "@ros2_lv/0/abc/0/1/MP/%/%/madenet_robot1/%robot1%map/\
                   nav_msgs::msg::dds_::OccupancyGrid_/RIHS01_x/:1:,1:,:,:,,";
        assert_eq!(
            gid(key),
            [132, 189, 213, 39, 221, 112, 83, 2, 23, 95, 31, 188, 184, 29, 10, 224]
        );
        // XXH3-128 of nothing is 99aa06d3014798d8_6001c324468d497f.
        let mut empty = 0x6001c324468d497fu64.to_le_bytes().to_vec();
        empty.extend(0x99aa06d3014798d8u64.to_le_bytes());
        assert_eq!(gid("").to_vec(), empty);
    }

    #[test]
    fn attachment_is_33_bytes_sequence_time_gid() {
        let t = UNIX_EPOCH + Duration::from_nanos(0x0102_0304_0506);
        let a = attachment(3, t, &[0xab; 16]).to_bytes().to_vec();
        let mut want = 3i64.to_le_bytes().to_vec();
        want.extend(0x0102_0304_0506i64.to_le_bytes());
        want.push(16);
        want.extend([0xab; 16]);
        assert_eq!(a, want);
    }
}
