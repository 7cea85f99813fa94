//! A run streamed live to Foxglove (`--foxglove`): the official `foxglove` crate's WebSocket
//! server (Foxglove's `foxglove.sdk.v1` protocol) on a loopback address by default, with the
//! same channels and encodings as a recorded bag ([`crate::record`]): one channel per topic,
//! `cdr` messages with `ros2msg` schemas, stamped in simulated time. Open it in Foxglove with
//! "Open connection" → Foxglove WebSocket → the URL printed at the start.
//!
//! Topics published once or on change — the maps, `/comms`, each robot's `goal_pose`, `plan`
//! and `candidates` ([`latched`]) — are latched: when the first message of a new timestep
//! arrives and a second of wall time has passed since the last time, the last message of each
//! latched topic not sent in the timestep just completed is sent again, stamped with that
//! timestep, so a viewer that joins late sees the true map, every robot's map, goal and plan and
//! the radio's lines within a second — as transient-local QoS keeps the maps for a late ROS
//! subscriber. Topics sent every timestep (poses, `/tf`, `/clock`, metrics, scans) are never
//! sent again: they arrive with the next timestep.

use crate::msgs::RosMessage;
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel, Schema, WebSocketServer};
use std::collections::BTreeMap;
use std::sync::Arc;

pub use crate::LiveError;

/// A Foxglove WebSocket server and its channels ([module docs](self)).
pub struct Live {
    ctx: Arc<Context>,
    server: Option<foxglove::WebSocketServerHandle>,
    channels: BTreeMap<String, Arc<RawChannel>>,
    url: String,
    /// The last message of each [`latched`] topic (its CDR) and its stamp; [`Live::resend`]
    /// sends again those older than the latest stamp.
    latched: BTreeMap<String, (Vec<u8>, u64)>,
    /// The latest stamp sent, and when the latched topics were last sent again.
    now_ns: u64,
    resent: std::time::Instant,
}

/// How often the latched maps are sent again (wall time).
const RESEND: std::time::Duration = std::time::Duration::from_secs(1);

/// The host of the server's URL for a bind address: a wildcard bind is reached through
/// loopback on this machine, and an IPv6 address goes in brackets (RFC 3986: ws://[::1]:8765).
fn url_host(host: &str) -> String {
    match host {
        "0.0.0.0" => "127.0.0.1".to_string(),
        "::" | "[::]" => "[::1]".to_string(),
        h if h.contains(':') && !h.starts_with('[') => format!("[{h}]"),
        h => h.to_string(),
    }
}

impl Live {
    /// Serves at `addr` (`HOST:PORT`; port 0 picks a free one).
    pub fn start(addr: &str) -> Result<Self, LiveError> {
        let err = |why: String| LiveError {
            addr: addr.to_string(),
            why,
        };
        let (host, port) = addr
            .rsplit_once(':')
            .ok_or_else(|| err("expected HOST:PORT, e.g. 127.0.0.1:8765".into()))?;
        let port: u16 = port
            .parse()
            .map_err(|_| err(format!("`{port}` is not a port (0–65535)")))?;
        let ctx = Context::new();
        let server = WebSocketServer::new()
            .name("madenet")
            .context(&ctx)
            .bind(host, port)
            .start_blocking()
            .map_err(|e| err(e.to_string()))?;
        let url = format!("ws://{}:{}", url_host(host), server.port());
        Ok(Live {
            ctx,
            server: Some(server),
            channels: BTreeMap::new(),
            url,
            latched: BTreeMap::new(),
            now_ns: 0,
            resent: std::time::Instant::now(),
        })
    }

    /// The server's URL, `ws://HOST:PORT`.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// Viewers connected now.
    pub fn clients(&self) -> usize {
        self.server.as_ref().map_or(0, |s| s.client_count())
    }

    /// Sends `cdr` (a message of type `T`, CDR-encoded) on `topic`, stamped `t_ns`; the
    /// topic's channel is advertised on its first message. Topics sent on change are
    /// latched ([module docs](self)).
    pub fn write_cdr<T: RosMessage>(&mut self, topic: &str, cdr: &[u8], t_ns: u64) {
        if !self.channels.contains_key(topic) {
            let schema = Schema::new(T::TYPE_NAME, "ros2msg", T::DEFINITION.as_bytes());
            let Ok(c) = ChannelBuilder::new(topic)
                .message_encoding("cdr")
                .schema(schema)
                .context(&self.ctx)
                .build_raw()
            else {
                // Only a topic advertised twice with another schema fails: ours never do.
                return;
            };
            self.channels.insert(topic.to_string(), c);
        }
        // A new timestep begins: the one before is complete, so what it did not send is old.
        if t_ns > self.now_ns && self.resent.elapsed() >= RESEND {
            self.resend();
        }
        self.channels[topic].log_with_meta(
            cdr,
            PartialMetadata {
                log_time: Some(t_ns),
            },
        );
        if latched(topic) {
            match self.latched.get_mut(topic) {
                Some((last, at)) => {
                    last.clear();
                    last.extend_from_slice(cdr);
                    *at = t_ns;
                }
                None => {
                    self.latched.insert(topic.to_string(), (cdr.to_vec(), t_ns));
                }
            }
        }
        self.now_ns = self.now_ns.max(t_ns);
    }

    /// Sends the last message of every latched topic not sent at the latest time again,
    /// stamped with that time.
    pub fn resend(&mut self) {
        self.resent = std::time::Instant::now();
        for (topic, (cdr, _)) in self.latched.iter().filter(|(_, (_, at))| *at < self.now_ns) {
            self.channels[topic].log_with_meta(
                cdr,
                PartialMetadata {
                    log_time: Some(self.now_ns),
                },
            );
        }
    }
}

/// Whether the live view keeps `topic`'s last message for late viewers: the topics sent once or
/// on change (the maps — transient local in a bag —, `/comms`, a robot's goal, plan and
/// candidates), not those sent every timestep.
pub fn latched(topic: &str) -> bool {
    crate::recorded_qos(topic).durability == crate::rmw::Durability::TransientLocal
        || topic == "/comms"
        || ["/goal_pose", "/plan", "/candidates"]
            .iter()
            .any(|t| topic.starts_with("/robot") && topic.ends_with(t))
}

impl Drop for Live {
    fn drop(&mut self) {
        if let Some(server) = self.server.take() {
            server.stop().wait_blocking();
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn url_hosts_are_usable_in_a_url() {
        for (bind, shown) in [
            ("127.0.0.1", "127.0.0.1"),
            ("0.0.0.0", "127.0.0.1"),
            ("::", "[::1]"),
            ("::1", "[::1]"),
            ("[::1]", "[::1]"),
            ("fe80::2", "[fe80::2]"),
            ("localhost", "localhost"),
        ] {
            assert_eq!(super::url_host(bind), shown, "{bind}");
        }
    }
}
