//! [`ZenohBus`]: the [`Transport`] between processes, over Zenoh 1.10 in peer mode.
//!
//! Every node has one key expression, its inbox, and subscribes to it:
//!
//! | node | key expression |
//! |------|----------------|
//! | world | `madenet/<run>/world` |
//! | radio | `madenet/<run>/radio` |
//! | robot i | `madenet/<run>/robot/<i>` |
//!
//! Sending to a node is a reliable, blocking-congestion `put` of one encoded
//! [`crate::wire::Envelope`] on its key. There is no discovery: multicast scouting (which fails
//! in containers and CI) and gossip are off, and each node listens on its own explicit
//! endpoint (`tcp/127.0.0.1:PORT`) and connects to the endpoints of the nodes it sends to
//! ([`Endpoints`]); a connection that fails (the peer is not up yet, or was restarted) is
//! retried in the background every 50–200 ms. Before a node sends anything it waits until each
//! of its addressees' inboxes is matched ([`ZenohBus::wait_for`]), so no message is published
//! into the void.

use crate::transport::Transport;
use crate::wire::Node;
use std::collections::HashMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::sample::Sample;
use zenoh::Wait;

/// Where one node listens and which endpoints it connects to (Zenoh locators such as
/// `tcp/127.0.0.1:7447`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Endpoints {
    /// Locators this node listens on.
    pub listen: Vec<String>,
    /// Locators of the nodes this node dials (Zenoh redials them when a link closes).
    pub connect: Vec<String>,
}

/// The loopback endpoint of each node of a run whose ports start at `base_port`: the world on
/// `base_port`, the radio on `base_port + 1`, robot i on `base_port + 2 + i`.
pub fn loopback_endpoint(base_port: u16, node: Node) -> Result<String, String> {
    let offset = match node {
        Node::World => 0,
        Node::Radio => 1,
        Node::Robot(i) => 2 + i,
    };
    let port = usize::from(base_port) + offset;
    if port > usize::from(u16::MAX) {
        return Err(format!(
            "port {base_port} + {offset} for the {node} is past 65535"
        ));
    }
    Ok(format!("tcp/127.0.0.1:{port}"))
}

/// The endpoints of `node` in a loopback run of `robots` robots: it listens on its own port, and
/// each pair that talks has one connection, opened by one side (world → radio and robots, radio
/// → robots): two peers dialling each other at once can refuse each other's link. Zenoh redials
/// a configured endpoint whose link closed, so a restarted radio or robot is reached again.
pub fn loopback_endpoints(base_port: u16, robots: usize, node: Node) -> Result<Endpoints, String> {
    let connect_to: Vec<Node> = match node {
        Node::World => std::iter::once(Node::Radio)
            .chain((0..robots).map(Node::Robot))
            .collect(),
        Node::Radio => (0..robots).map(Node::Robot).collect(),
        Node::Robot(_) => Vec::new(),
    };
    Ok(Endpoints {
        listen: vec![loopback_endpoint(base_port, node)?],
        connect: connect_to
            .into_iter()
            .map(|n| loopback_endpoint(base_port, n))
            .collect::<Result<_, _>>()?,
    })
}

/// A base port with `count` free loopback ports from it on, as the OS hands them out now (another
/// program may still take one before the run binds it; the run then fails to listen, naming it).
/// Blocks handed out earlier in this process are never handed out again, in part or whole: two
/// runs started side by side (parallel tests) cannot be given overlapping ports.
pub fn free_port_block(count: u16) -> Result<u16, String> {
    static GIVEN: std::sync::Mutex<Vec<(u16, u16)>> = std::sync::Mutex::new(Vec::new());
    let mut given = GIVEN.lock().unwrap_or_else(|e| e.into_inner());
    for _ in 0..100 {
        let first = std::net::TcpListener::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
        let base = first.local_addr().map_err(|e| e.to_string())?.port();
        if base > u16::MAX - count || given.iter().any(|&(b, n)| base < b + n && b < base + count) {
            continue;
        }
        drop(first);
        if (0..count).all(|k| std::net::TcpListener::bind(("127.0.0.1", base + k)).is_ok()) {
            given.push((base, count));
            return Ok(base);
        }
    }
    Err(format!("no block of {count} free loopback ports found"))
}

/// The key expression of `node`'s inbox in run `run`.
pub fn inbox_key(run: &str, node: Node) -> String {
    match node {
        Node::World => format!("madenet/{run}/world"),
        Node::Radio => format!("madenet/{run}/radio"),
        Node::Robot(i) => format!("madenet/{run}/robot/{i}"),
    }
}

/// A zenoh config from `(key, JSON5 value)` pairs over the defaults: the one place madenet fills
/// one (its nodes and the ROS 2 side). A refused pair comes back as `key = value` and zenoh's error.
pub fn zenoh_config<'a>(
    settings: impl IntoIterator<Item = (&'a str, String)>,
) -> Result<zenoh::Config, (String, zenoh::Error)> {
    let mut config = zenoh::Config::default();
    for (key, value) in settings {
        config
            .insert_json5(key, &value)
            .map_err(|e| (format!("{key} = {value}"), e))?;
    }
    Ok(config)
}

/// Checks a run name: one key-expression chunk (letters, digits, `-`, `_`, `.`).
pub fn check_run_name(run: &str) -> Result<(), String> {
    if run.is_empty()
        || !run
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(format!(
            "run name `{run}`: use letters, digits, `-`, `_` and `.` only (it is part of every key expression)"
        ));
    }
    Ok(())
}

/// One node's Zenoh session: its inbox subscriber and a publisher per addressee.
pub struct ZenohBus {
    session: zenoh::Session,
    run: String,
    me: Node,
    inbox: Subscriber<FifoChannelHandler<Sample>>,
    publishers: Mutex<HashMap<Node, Publisher<'static>>>,
}

impl ZenohBus {
    /// Opens node `me`'s session of run `run` with `endpoints` and subscribes to its inbox.
    pub fn open(run: &str, me: Node, endpoints: &Endpoints) -> Result<ZenohBus, String> {
        check_run_name(run)?;
        let json_list = |v: &[String]| serde_json_list(v.iter().map(String::as_str));
        let settings = [
            ("mode", "\"peer\"".to_string()),
            ("scouting/multicast/enabled", "false".into()),
            ("scouting/gossip/enabled", "false".into()),
            ("listen/endpoints", json_list(&endpoints.listen)),
            ("connect/endpoints", json_list(&endpoints.connect)),
            // Peers that are not up yet (or restart) are retried in the background, quickly.
            (
                "connect/retry",
                "{ period_init_ms: 50, period_max_ms: 200, period_increase_factor: 1.5 }".into(),
            ),
        ];
        let config =
            zenoh_config(settings).map_err(|(pair, e)| format!("zenoh config {pair}: {e}"))?;
        let session = zenoh::open(config)
            .wait()
            .map_err(|e| format!("{me}: opening the zenoh session ({endpoints:?}): {e}"))?;
        let inbox = session
            .declare_subscriber(inbox_key(run, me))
            .wait()
            .map_err(|e| format!("{me}: subscribing to its inbox: {e}"))?;
        Ok(ZenohBus {
            session,
            run: run.to_string(),
            me,
            inbox,
            publishers: Mutex::new(HashMap::new()),
        })
    }

    fn with_publisher<R>(
        &self,
        to: Node,
        f: impl FnOnce(&Publisher<'static>) -> R,
    ) -> Result<R, String> {
        let mut publishers = self.publishers.lock().map_err(|e| e.to_string())?;
        let publisher = match publishers.entry(to) {
            std::collections::hash_map::Entry::Occupied(p) => p.into_mut(),
            std::collections::hash_map::Entry::Vacant(slot) => slot.insert(
                self.session
                    .declare_publisher(inbox_key(&self.run, to))
                    .congestion_control(CongestionControl::Block)
                    .wait()
                    .map_err(|e| format!("{}: publisher to {to}: {e}", self.me))?,
            ),
        };
        Ok(f(publisher))
    }

    /// Waits until every node in `peers` has its inbox subscribed and reachable from here, or
    /// `timeout` passes (then names the ones still missing).
    pub fn wait_for(&self, peers: &[Node], timeout: Duration) -> Result<(), String> {
        let deadline = Instant::now() + timeout;
        let mut missing: Vec<Node> = peers.to_vec();
        loop {
            let mut still = Vec::new();
            for &p in &missing {
                let matched = self.with_publisher(p, |publ| {
                    publ.matching_status().wait().map(|m| m.matching())
                })?;
                if !matched.map_err(|e| format!("{}: matching status of {p}: {e}", self.me))? {
                    still.push(p);
                }
            }
            missing = still;
            if missing.is_empty() {
                return Ok(());
            }
            if Instant::now() >= deadline {
                let names: Vec<String> = missing.iter().map(|n| n.to_string()).collect();
                return Err(format!(
                    "{}: after {timeout:?} still no connection to {}",
                    self.me,
                    names.join(", ")
                ));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Closes the session (flushing what was sent).
    pub fn close(self) {
        drop(self.inbox);
        drop(self.publishers);
        let _ = self.session.close().wait();
    }
}

/// `["a","b"]` for the config (endpoints contain no quotes or backslashes to escape).
fn serde_json_list<'a>(items: impl Iterator<Item = &'a str>) -> String {
    let quoted: Vec<String> = items.map(|s| format!("{s:?}")).collect();
    format!("[{}]", quoted.join(","))
}

impl Transport for ZenohBus {
    fn send(&self, to: Node, bytes: Vec<u8>) -> bool {
        self.with_publisher(to, |p| p.put(bytes).wait().is_ok())
            .unwrap_or(false)
    }

    fn recv(&self, timeout: Duration) -> Option<Vec<u8>> {
        match self.inbox.recv_timeout(timeout) {
            Ok(Some(sample)) => Some(sample.payload().to_bytes().into_owned()),
            _ => None,
        }
    }

    fn connect(&self, peers: &[Node], timeout: Duration) -> Result<(), String> {
        self.wait_for(peers, timeout)
    }
}

#[cfg(test)]
mod tests {
    /// Blocks asked for side by side (parallel tests, each starting a run) never overlap: two
    /// runs' nodes once listened on the same ports ("Address already in use").
    #[test]
    fn port_blocks_handed_out_in_one_process_never_overlap() {
        let blocks: Vec<u16> = std::thread::scope(|s| {
            let asks: Vec<_> = (0..16)
                .map(|_| s.spawn(|| super::free_port_block(5).unwrap()))
                .collect();
            asks.into_iter().map(|a| a.join().unwrap()).collect()
        });
        for (i, &a) in blocks.iter().enumerate() {
            for &b in &blocks[i + 1..] {
                assert!(a + 5 <= b || b + 5 <= a, "{a} and {b} overlap");
            }
        }
    }
}
