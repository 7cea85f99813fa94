//! A run streamed live to Foxglove (`--foxglove`): a server of Foxglove's WebSocket protocol
//! (its published spec, both subprotocol names, `foxglove.sdk.v1` and the older
//! `foxglove.websocket.v1` that `@foxglove/ws-protocol` and Lichtblick offer), on a loopback
//! address by default, with the same channels and encodings as a recorded bag
//! ([`crate::record`]): one channel per topic, `cdr` messages with `ros2msg` schemas, stamped
//! in simulated time. Open it in Foxglove with "Open connection" → Foxglove WebSocket → the URL
//! printed at the start.
//!
//! Written here on `tungstenite` rather than with the `foxglove` crate (0.30.3): that server
//! accepts only the `foxglove.sdk.v1` names and waits on a handshake without a timeout, so one
//! silent TCP client held a run for as long as it stayed connected (issue 59). Here **no client
//! can hold the run**: each client has its own thread; a handshake not done in
//! [`HANDSHAKE_TIMEOUT`] is dropped; the run only ever puts frames on a client's bounded queue
//! ([`QUEUE_BYTES`]) and drops a client whose queue is full or whose socket takes longer than
//! [`WRITE_TIMEOUT`] to take a frame; a client's Close is answered; and the server stops when
//! the run ends, whatever its clients do.
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
use std::collections::BTreeMap;
use std::io::ErrorKind;
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tungstenite::handshake::server::{ErrorResponse, Request, Response};
use tungstenite::protocol::WebSocketConfig;
use tungstenite::{Bytes, HandshakeError, Message, WebSocket};

pub use crate::LiveError;

/// The subprotocol names served, the current first.
pub const SUBPROTOCOLS: [&str; 2] = ["foxglove.sdk.v1", "foxglove.websocket.v1"];
/// A client that has not completed the WebSocket handshake by then is dropped.
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(5);
/// A client whose socket does not take a frame within this is dropped (it stopped reading).
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(2);
/// Bytes of frames waiting for one client at most; a client further behind is dropped.
pub const QUEUE_BYTES: usize = 64 << 20;
/// Clients served at once; more are refused at once.
pub const MAX_CLIENTS: usize = 32;
/// The largest message a client may send (its operations are small JSON).
const MAX_CLIENT_MESSAGE: usize = 1 << 16;
/// How often a client's thread looks at its socket and queue, and the accept loop for
/// connections.
const POLL: Duration = Duration::from_millis(10);
/// How long the end of a run waits for clients to take their Close.
const CLOSE_GRACE: Duration = Duration::from_millis(500);

/// A Foxglove WebSocket server and its channels ([module docs](self)).
pub struct Live {
    hub: Arc<Hub>,
    accept: Option<std::thread::JoinHandle<()>>,
    channels: BTreeMap<String, u32>,
    url: String,
    /// The last message of each [`latched`] topic (its CDR) and its stamp; [`Live::resend`]
    /// sends again those older than the latest stamp.
    latched: BTreeMap<String, (Vec<u8>, u64)>,
    /// The latest stamp sent, and when the latched topics were last sent again.
    now_ns: u64,
    resent: Instant,
}

/// What the run and the clients' threads share.
#[derive(Default)]
struct Hub {
    state: Mutex<HubState>,
    stop: AtomicBool,
    /// Client threads running (handshaking or served).
    threads: AtomicUsize,
}

#[derive(Default)]
struct HubState {
    /// Advertised channels: id → the advertisement's JSON object.
    channels: BTreeMap<u32, serde_json::Value>,
    clients: BTreeMap<u64, Client>,
    next_client: u64,
}

/// A served client as the run sees it.
struct Client {
    queue: SyncSender<Message>,
    /// Bytes on its queue.
    queued: Arc<AtomicUsize>,
    /// Channel id → its subscription id.
    subscriptions: BTreeMap<u32, u32>,
}

impl Hub {
    fn lock(&self) -> MutexGuard<'_, HubState> {
        // A client thread that panicked holding the lock leaves consistent maps behind.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }
}

impl HubState {
    /// Puts `m` on client `id`'s queue; a client whose queue is full is dropped (its thread
    /// sees its queue closed and ends).
    fn send(&mut self, id: u64, m: Message) {
        let Some(c) = self.clients.get(&id) else {
            return;
        };
        let size = m.len();
        // Counted before it can be taken off the queue, so the count never goes below 0.
        let full = c.queued.fetch_add(size, Ordering::Relaxed) + size > QUEUE_BYTES;
        let sent = !full
            && match c.queue.try_send(m) {
                Ok(()) => true,
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => false,
            };
        if !sent {
            tracing::warn!("live view: a client fell behind and was dropped");
            self.clients.remove(&id);
        }
    }

    /// Sends `m` to every client.
    fn broadcast(&mut self, m: &Message) {
        let ids: Vec<u64> = self.clients.keys().copied().collect();
        for id in ids {
            self.send(id, m.clone());
        }
    }
}

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

fn text(v: serde_json::Value) -> Message {
    Message::text(v.to_string())
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
        let bare = host.trim_start_matches('[').trim_end_matches(']');
        let listener = TcpListener::bind((bare, port)).map_err(|e| err(e.to_string()))?;
        let port = listener
            .local_addr()
            .map_err(|e| err(e.to_string()))?
            .port();
        listener
            .set_nonblocking(true)
            .map_err(|e| err(e.to_string()))?;
        let hub = Arc::new(Hub::default());
        let accept = {
            let hub = hub.clone();
            std::thread::Builder::new()
                .name("live-accept".into())
                .spawn(move || accept_loop(listener, hub))
                .map_err(|e| err(e.to_string()))?
        };
        Ok(Live {
            hub,
            accept: Some(accept),
            channels: BTreeMap::new(),
            url: format!("ws://{}:{port}", url_host(host)),
            latched: BTreeMap::new(),
            now_ns: 0,
            resent: Instant::now(),
        })
    }

    /// The server's URL, `ws://HOST:PORT`.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// Viewers connected now (past the handshake).
    pub fn clients(&self) -> usize {
        self.hub.lock().clients.len()
    }

    /// Sends `cdr` (a message of type `T`, CDR-encoded) on `topic`, stamped `t_ns`; the
    /// topic's channel is advertised on its first message. Topics sent on change are
    /// latched ([module docs](self)). Never waits for a client.
    pub fn write_cdr<T: RosMessage>(&mut self, topic: &str, cdr: &[u8], t_ns: u64) {
        if !self.channels.contains_key(topic) {
            let id = self.channels.len() as u32 + 1;
            let channel = serde_json::json!({
                "id": id,
                "topic": topic,
                "encoding": "cdr",
                "schemaName": T::TYPE_NAME,
                "schema": T::DEFINITION,
                "schemaEncoding": "ros2msg",
            });
            let mut hub = self.hub.lock();
            hub.broadcast(&text(
                serde_json::json!({"op": "advertise", "channels": [channel.clone()]}),
            ));
            hub.channels.insert(id, channel);
            drop(hub);
            self.channels.insert(topic.to_string(), id);
        }
        // A new timestep begins: the one before is complete, so what it did not send is old.
        if t_ns > self.now_ns && self.resent.elapsed() >= RESEND {
            self.resend();
        }
        self.send(self.channels[topic], cdr, t_ns);
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

    /// Sends `cdr` on channel `id` to its subscribers: opcode 1 (message data), the
    /// subscription id (u32), the log time (u64, ns), the payload; little-endian.
    fn send(&self, id: u32, cdr: &[u8], t_ns: u64) {
        let mut hub = self.hub.lock();
        let subscribers: Vec<(u64, u32)> = (hub.clients.iter())
            .filter_map(|(&c, client)| client.subscriptions.get(&id).map(|&s| (c, s)))
            .collect();
        for (client, sub) in subscribers {
            let mut frame = Vec::with_capacity(13 + cdr.len());
            frame.push(1u8);
            frame.extend_from_slice(&sub.to_le_bytes());
            frame.extend_from_slice(&t_ns.to_le_bytes());
            frame.extend_from_slice(cdr);
            hub.send(client, Message::Binary(Bytes::from(frame)));
        }
    }

    /// Sends the last message of every latched topic not sent at the latest time again,
    /// stamped with that time.
    pub fn resend(&mut self) {
        self.resent = Instant::now();
        for (topic, (cdr, _)) in self.latched.iter().filter(|(_, (_, at))| *at < self.now_ns) {
            self.send(self.channels[topic], cdr, self.now_ns);
        }
    }
}

/// How often the latched maps are sent again (wall time).
const RESEND: Duration = Duration::from_secs(1);

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
        self.hub.stop.store(true, Ordering::Relaxed);
        if let Some(a) = self.accept.take() {
            let _ = a.join();
        }
        // Clients get a Close; the run waits a moment for them to take it, never longer.
        let until = Instant::now() + CLOSE_GRACE;
        while self.hub.threads.load(Ordering::Relaxed) > 0 && Instant::now() < until {
            std::thread::sleep(POLL);
        }
    }
}

/// Takes connections until the run ends; each client is served on its own thread.
fn accept_loop(listener: TcpListener, hub: Arc<Hub>) {
    while !hub.stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                if hub.threads.load(Ordering::Relaxed) >= MAX_CLIENTS {
                    tracing::warn!("live view: {MAX_CLIENTS} clients already; one refused");
                    continue;
                }
                hub.threads.fetch_add(1, Ordering::Relaxed);
                let h = hub.clone();
                let spawned = std::thread::Builder::new()
                    .name("live-client".into())
                    .spawn(move || {
                        serve(stream, &h);
                        h.threads.fetch_sub(1, Ordering::Relaxed);
                    });
                if spawned.is_err() {
                    hub.threads.fetch_sub(1, Ordering::Relaxed);
                }
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => std::thread::sleep(POLL),
            Err(e) => {
                tracing::warn!("live view: accept: {e}");
                std::thread::sleep(POLL);
            }
        }
    }
}

/// The subprotocol to answer a client offering `offered` (comma-separated), if it offers one
/// served.
fn choose_subprotocol(offered: &str) -> Option<&'static str> {
    offered
        .split(',')
        .map(str::trim)
        .find_map(|o| SUBPROTOCOLS.into_iter().find(|&s| s == o))
}

/// The WebSocket handshake within [`HANDSHAKE_TIMEOUT`], answering a served subprotocol.
#[allow(clippy::result_large_err)] // the callback's type is tungstenite's
fn handshake(stream: TcpStream, hub: &Hub) -> Option<WebSocket<TcpStream>> {
    let until = Instant::now() + HANDSHAKE_TIMEOUT;
    stream.set_nonblocking(false).ok()?;
    stream.set_read_timeout(Some(POLL * 10)).ok()?;
    stream.set_write_timeout(Some(WRITE_TIMEOUT)).ok()?;
    let callback = |req: &Request, mut resp: Response| -> Result<Response, ErrorResponse> {
        let offered = (req.headers().get_all("Sec-WebSocket-Protocol").iter())
            .filter_map(|v| v.to_str().ok())
            .collect::<Vec<_>>()
            .join(",");
        match choose_subprotocol(&offered) {
            Some(p) => {
                resp.headers_mut()
                    .insert("Sec-WebSocket-Protocol", p.parse().expect("a header value"));
                Ok(resp)
            }
            None => {
                let mut e = ErrorResponse::new(Some(format!(
                    "offer the subprotocol {} or {}",
                    SUBPROTOCOLS[0], SUBPROTOCOLS[1]
                )));
                *e.status_mut() = tungstenite::http::StatusCode::BAD_REQUEST;
                Err(e)
            }
        }
    };
    let config = WebSocketConfig::default()
        .max_message_size(Some(MAX_CLIENT_MESSAGE))
        .max_frame_size(Some(MAX_CLIENT_MESSAGE));
    let mut attempt = tungstenite::accept_hdr_with_config(stream, callback, Some(config));
    loop {
        match attempt {
            Ok(ws) => return Some(ws),
            Err(HandshakeError::Interrupted(mid))
                if Instant::now() < until && !hub.stop.load(Ordering::Relaxed) =>
            {
                attempt = mid.handshake();
            }
            Err(_) => return None,
        }
    }
}

/// Serves one client until it leaves, falls behind or the run ends.
fn serve(stream: TcpStream, hub: &Hub) {
    let Some(mut ws) = handshake(stream, hub) else {
        return;
    };
    if ws.get_ref().set_read_timeout(Some(POLL)).is_err() {
        return;
    }
    // Registered and told the channels in one step, so no advertisement is missed.
    let (tx, rx) = sync_channel(4096);
    let queued = Arc::new(AtomicUsize::new(0));
    let id = {
        let mut state = hub.lock();
        let id = state.next_client;
        state.next_client += 1;
        let session = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        state.clients.insert(
            id,
            Client {
                queue: tx,
                queued: queued.clone(),
                subscriptions: BTreeMap::new(),
            },
        );
        state.send(
            id,
            text(serde_json::json!({
                "op": "serverInfo",
                "name": "madenet",
                "capabilities": [],
                "supportedEncodings": [],
                "metadata": {},
                "sessionId": session.to_string(),
            })),
        );
        let channels: Vec<_> = state.channels.values().cloned().collect();
        if !channels.is_empty() {
            let advertise = text(serde_json::json!({"op": "advertise", "channels": channels}));
            state.send(id, advertise);
        }
        id
    };
    let reason = session(&mut ws, hub, id, &rx, &queued);
    hub.lock().clients.remove(&id);
    tracing::debug!("live view: client {id} left: {reason}");
    // A goodbye that cannot wait: the socket's write timeout bounds it.
    if matches!(reason, Left::RunEnded) {
        let _ = ws.close(None);
        let _ = ws.flush();
    }
}

/// Why a client's session ended.
#[derive(Debug)]
enum Left {
    /// The run ended.
    RunEnded,
    /// The client closed, or its connection failed.
    Gone,
    /// It fell behind: its queue was full, or its socket took no frame for [`WRITE_TIMEOUT`].
    Behind,
}

impl std::fmt::Display for Left {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Left::RunEnded => "the run ended",
            Left::Gone => "it closed the connection",
            Left::Behind => "it fell behind",
        })
    }
}

fn session(
    ws: &mut WebSocket<TcpStream>,
    hub: &Hub,
    id: u64,
    rx: &Receiver<Message>,
    queued: &AtomicUsize,
) -> Left {
    loop {
        if hub.stop.load(Ordering::Relaxed) {
            return Left::RunEnded;
        }
        // What the run queued, written out.
        let mut wrote = false;
        loop {
            match rx.try_recv() {
                Ok(m) => {
                    queued.fetch_sub(m.len(), Ordering::Relaxed);
                    if let Err(e) = ws.write(m) {
                        tracing::debug!("live view: client {id}: {e}");
                        return Left::Behind;
                    }
                    wrote = true;
                }
                Err(std::sync::mpsc::TryRecvError::Empty) => break,
                // Dropped by the run (its queue was full).
                Err(std::sync::mpsc::TryRecvError::Disconnected) => return Left::Behind,
            }
        }
        if wrote {
            if let Err(e) = ws.flush() {
                tracing::debug!("live view: client {id}: {e}");
                return Left::Behind;
            }
        }
        // What the client said (a Close is answered by tungstenite on the next flush).
        match ws.read() {
            Ok(Message::Text(t)) => {
                if let Some(reply) = operation(hub, id, t.as_str()) {
                    if ws.send(reply).is_err() {
                        return Left::Behind;
                    }
                }
            }
            Ok(Message::Close(_)) => {
                let _ = ws.flush();
                return Left::Gone;
            }
            Ok(_) => {}
            Err(tungstenite::Error::Io(e))
                if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) => {
                tracing::debug!("live view: client {id}: {e}");
                return Left::Gone;
            }
        }
    }
}

/// Carries out a client's operation (`subscribe`, `unsubscribe`); anything else is answered
/// with a status message (level 1, warning), as the protocol asks.
fn operation(hub: &Hub, id: u64, text: &str) -> Option<Message> {
    let status = |message: String| {
        Some(self::text(
            serde_json::json!({"op": "status", "level": 1, "message": message}),
        ))
    };
    let Ok(v) = serde_json::from_str::<serde_json::Value>(text) else {
        return status("not JSON".into());
    };
    let mut state = hub.lock();
    let known: Vec<u32> = state.channels.keys().copied().collect();
    let client = state.clients.get_mut(&id)?;
    match v["op"].as_str() {
        Some("subscribe") => {
            let mut refused = Vec::new();
            for s in v["subscriptions"].as_array().into_iter().flatten() {
                let (Some(sub), Some(ch)) = (s["id"].as_u64(), s["channelId"].as_u64()) else {
                    refused.push(s.to_string());
                    continue;
                };
                let (sub, ch) = (sub as u32, ch as u32);
                if !known.contains(&ch) || client.subscriptions.values().any(|&x| x == sub) {
                    refused.push(format!("subscription {sub} to channel {ch}"));
                    continue;
                }
                client.subscriptions.insert(ch, sub);
            }
            (!refused.is_empty())
                .then(|| refused.join(", "))
                .and_then(|r| {
                    status(format!(
                        "refused (unknown channel or subscription id in use): {r}"
                    ))
                })
        }
        Some("unsubscribe") => {
            let ids: Vec<u64> = (v["subscriptionIds"].as_array().into_iter().flatten())
                .filter_map(|x| x.as_u64())
                .collect();
            client
                .subscriptions
                .retain(|_, s| !ids.contains(&u64::from(*s)));
            None
        }
        Some(op) => status(format!("operation `{op}` is not supported")),
        None => status("no `op`".into()),
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

    #[test]
    fn both_subprotocol_names_are_served() {
        use super::choose_subprotocol as c;
        assert_eq!(c("foxglove.websocket.v1"), Some("foxglove.websocket.v1"));
        assert_eq!(c("foxglove.sdk.v1"), Some("foxglove.sdk.v1"));
        assert_eq!(c("x, foxglove.websocket.v1"), Some("foxglove.websocket.v1"));
        assert_eq!(c("chat"), None);
        assert_eq!(c(""), None);
    }
}
