//! ROS 2 services in the rmw_zenoh wire format (Jazzy), beside the topics of [`crate::rmw`].
//!
//! - A **server** is a zenoh queryable, declared *complete*, on
//!   `<domain>/<service>/<DDS service type>/<RIHS01 hash of the service type>` — the hash of
//!   the service type (request, response and event together, [`crate::typehash`]), not of
//!   the request.
//! - A **client** sends each request as a query to all complete queryables, with no
//!   consolidation and no timeout of its own (rmw_zenoh waits as long as the caller does).
//! - Requests carry rmw_zenoh's 33-byte attachment ([`crate::rmw::attachment`]): the call's
//!   sequence number, its time, and the client's GID. The reply's attachment echoes the
//!   sequence number and the client's GID, so a reply is matched to its request.
//! - Both announce themselves with liveliness tokens, `SS` (server) and `SC` (client), so
//!   `ros2 service list` shows them, and a client can wait for a server.
//!
//! A malformed request (no attachment, or a payload that is not the request type) gets an
//! error reply and a warning naming the service; the server keeps serving.

use crate::msgs::{cdr_bytes, dds_type_name, read_cdr};
use crate::rmw::{attachment, data_key, gid, Node, QosProfile};
use crate::{middleware, Ros2Error};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicI64, AtomicUsize, Ordering};
use std::time::{Duration, Instant, SystemTime};
use zenoh::handlers::FifoChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::query::{ConsolidationMode, Query, QueryTarget, Queryable, Reply};
use zenoh::Wait;

/// A ROS 2 service type: its name, and its request and response messages.
pub trait RosService {
    /// The ROS type name, e.g. `example_interfaces/srv/AddTwoInts`.
    const TYPE_NAME: &'static str;
    /// The request (`<Name>_Request`).
    type Request: Serialize + DeserializeOwned;
    /// The response (`<Name>_Response`).
    type Response: Serialize + DeserializeOwned;

    /// The DDS type name in key expressions, e.g. `example_interfaces::srv::dds_::AddTwoInts_`.
    fn dds_type_name() -> String {
        dds_type_name(Self::TYPE_NAME)
    }

    /// The Jazzy type hash of the service type (REP 2011).
    fn type_hash() -> String {
        crate::typehash::jazzy_hash(Self::TYPE_NAME)
    }
}

/// The key expression of service `name` (fully qualified) of type `S` in `domain`.
pub fn service_key<S: RosService>(domain: usize, name: &str) -> String {
    data_key(domain, name, &S::dds_type_name(), &S::type_hash())
}

/// The QoS rmw_zenoh announces for services (rclcpp's services default: reliable,
/// volatile, keep last 10).
fn service_qos() -> QosProfile {
    QosProfile::default()
}

/// Reads rmw_zenoh's attachment: (sequence number, source time in ns, GID).
pub fn read_attachment(bytes: &[u8]) -> Result<(i64, i64, [u8; 16]), String> {
    let zbytes = zenoh::bytes::ZBytes::from(bytes.to_vec());
    let mut d = zenoh_ext::ZDeserializer::new(&zbytes);
    let sn: i64 = d.deserialize().map_err(|_| "no sequence number")?;
    let ns: i64 = d.deserialize().map_err(|_| "no source time")?;
    let g: [u8; 16] = d.deserialize().map_err(|_| "no 16-byte GID")?;
    if !d.done() {
        return Err(format!(
            "{} bytes: longer than rmw_zenoh's 33-byte attachment",
            bytes.len()
        ));
    }
    Ok((sn, ns, g))
}

/// A service server of `S`: take requests with [`ServiceServer::recv_timeout`], answer each
/// with [`ServiceRequest::reply`].
pub struct ServiceServer<S: RosService> {
    queryable: Queryable<FifoChannelHandler<Query>>,
    name: String,
    refused: AtomicUsize,
    _token: LivelinessToken,
    _type: PhantomData<fn() -> S>,
}

/// A request taken by a [`ServiceServer`]: answer it with [`ServiceRequest::reply`] (or drop
/// it, and the client gets no answer from this server).
pub struct ServiceRequest<S: RosService> {
    /// The request.
    pub request: S::Request,
    query: Query,
    sequence_number: i64,
    client_gid: [u8; 16],
}

impl<S: RosService> ServiceRequest<S> {
    /// The client's sequence number of this call.
    pub fn sequence_number(&self) -> i64 {
        self.sequence_number
    }

    /// The calling client's GID.
    pub fn client_gid(&self) -> [u8; 16] {
        self.client_gid
    }

    /// Sends `response` to the caller.
    pub fn reply(self, response: &S::Response) -> Result<(), Ros2Error> {
        let key = self.query.key_expr().clone();
        self.query
            .reply(key, cdr_bytes(response))
            .attachment(attachment(
                self.sequence_number,
                SystemTime::now(),
                &self.client_gid,
            ))
            .wait()
            .map_err(middleware(format!("reply on {}", S::TYPE_NAME)))
    }
}

impl<S: RosService> ServiceServer<S> {
    /// A server of `S` on service `name` (relative names resolve in the node's namespace).
    pub fn new(node: &Node, name: &str) -> Result<Self, Ros2Error> {
        let name = node.resolve(name);
        let what = format!("service server {name}");
        let queryable = node
            .session()
            .declare_queryable(service_key::<S>(node.domain_id(), &name))
            .complete(true)
            .with(zenoh::handlers::FifoChannel::default())
            .wait()
            .map_err(middleware(what.clone()))?;
        let (_, token) = node.announce(
            "SS",
            &name,
            (&S::dds_type_name(), &S::type_hash()),
            &service_qos(),
            &what,
        )?;
        Ok(ServiceServer {
            queryable,
            name,
            refused: AtomicUsize::new(0),
            _token: token,
            _type: PhantomData,
        })
    }

    /// The service's fully qualified name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The next well-formed request, waiting up to `timeout`; `Ok(None)` when none came. A
    /// malformed request is answered with an error reply, logged, counted
    /// ([`ServiceServer::refused`]) and skipped.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<ServiceRequest<S>>, Ros2Error> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let query = self
                .queryable
                .recv_timeout(left)
                .map_err(|e| Ros2Error::Middleware {
                    what: format!("service server {}", self.name),
                    source: e,
                })?;
            let Some(query) = query else { return Ok(None) };
            match self.parse(&query) {
                Ok((request, sequence_number, client_gid)) => {
                    return Ok(Some(ServiceRequest {
                        request,
                        query,
                        sequence_number,
                        client_gid,
                    }))
                }
                Err(why) => {
                    self.refused.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!("{}: refused a malformed request: {why}", self.name);
                    if let Err(e) = query
                        .reply_err(format!("{}: malformed request: {why}", self.name))
                        .wait()
                    {
                        tracing::warn!("{}: could not send the error reply: {e}", self.name);
                    }
                }
            }
        }
    }

    fn parse(&self, query: &Query) -> Result<(S::Request, i64, [u8; 16]), String> {
        let a = query
            .attachment()
            .ok_or("no attachment (sequence number, time, client GID)")?;
        let (sn, _, client) = read_attachment(&a.to_bytes())?;
        let payload = query.payload().ok_or("no payload")?;
        let request = read_cdr(&payload.to_bytes())
            .map_err(|e| format!("payload is not a {}_Request: {e}", S::TYPE_NAME))?;
        Ok((request, sn, client))
    }

    /// Requests refused so far because they were malformed.
    pub fn refused(&self) -> usize {
        self.refused.load(Ordering::Relaxed)
    }
}

/// A service client of `S`.
pub struct ServiceClient<S: RosService> {
    session: zenoh::Session,
    name: String,
    key: String,
    /// Liveliness key expression matching every server of this service.
    servers: String,
    gid: [u8; 16],
    sequence_number: AtomicI64,
    _token: LivelinessToken,
    _type: PhantomData<fn() -> S>,
}

/// A call on its way: its replies arrive on [`PendingCall::recv_timeout`].
pub struct PendingCall<S: RosService> {
    replies: FifoChannelHandler<Reply>,
    sequence_number: i64,
    name: String,
    _type: PhantomData<fn() -> S>,
}

impl<S: RosService> PendingCall<S> {
    /// The response, waiting up to `timeout`: `Ok(None)` if none came yet (the call stays
    /// pending, ask again), an error if the server refused the request or every server
    /// went away without answering.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<S::Response>, Ros2Error> {
        let deadline = Instant::now() + timeout;
        let what = || format!("call to {}", self.name);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let reply = match self.replies.recv_timeout(left) {
                Ok(Some(r)) => r,
                Ok(None) => return Ok(None),
                Err(_) => {
                    return Err(Ros2Error::Call {
                        what: what(),
                        why: "no server answered".into(),
                    })
                }
            };
            match reply.into_result() {
                Ok(sample) => {
                    let matches = sample
                        .attachment()
                        .and_then(|a| read_attachment(&a.to_bytes()).ok())
                        .map(|(sn, _, _)| sn == self.sequence_number);
                    if matches == Some(false) {
                        // A reply to another call of ours: not this one.
                        continue;
                    }
                    return read_cdr(&sample.payload().to_bytes())
                        .map(Some)
                        .map_err(|e| Ros2Error::Call {
                            what: what(),
                            why: format!("the reply is not a {}_Response: {e}", S::TYPE_NAME),
                        });
                }
                Err(e) => {
                    return Err(Ros2Error::Call {
                        what: what(),
                        why: format!(
                            "the server refused: {}",
                            String::from_utf8_lossy(&e.payload().to_bytes())
                        ),
                    })
                }
            }
        }
    }
}

impl<S: RosService> ServiceClient<S> {
    /// A client of `S` for service `name` (relative names resolve in the node's namespace).
    pub fn new(node: &Node, name: &str) -> Result<Self, Ros2Error> {
        let name = node.resolve(name);
        let what = format!("service client {name}");
        let (dds, hash) = (S::dds_type_name(), S::type_hash());
        let (token_key, token) =
            node.announce("SC", &name, (&dds, &hash), &service_qos(), &what)?;
        let servers = format!(
            "@ros2_lv/{}/*/*/*/SS/*/*/*/{}/{}/{}/*",
            node.domain_id(),
            name.replace('/', "%"),
            dds.replace('/', "%"),
            hash
        );
        Ok(ServiceClient {
            session: node.session().clone(),
            key: service_key::<S>(node.domain_id(), &name),
            name,
            servers,
            gid: gid(&token_key),
            sequence_number: AtomicI64::new(1),
            _token: token,
            _type: PhantomData,
        })
    }

    /// The service's fully qualified name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether a server of this service is in the ROS graph, waiting up to `timeout`.
    pub fn wait_for_server(&self, timeout: Duration) -> Result<bool, Ros2Error> {
        let deadline = Instant::now() + timeout;
        loop {
            let replies = self
                .session
                .liveliness()
                .get(&self.servers)
                .timeout(Duration::from_millis(500))
                .wait()
                .map_err(middleware(format!("service client {}", self.name)))?;
            if replies.recv().is_ok() {
                return Ok(true);
            }
            if Instant::now() >= deadline {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(50).min(deadline - Instant::now()));
        }
    }

    /// Sends `request`; the response comes on the returned [`PendingCall`].
    pub fn send(&self, request: &S::Request) -> Result<PendingCall<S>, Ros2Error> {
        let sn = self.sequence_number.fetch_add(1, Ordering::Relaxed);
        let replies = self
            .session
            .get(&self.key)
            .payload(cdr_bytes(request))
            .attachment(attachment(sn, SystemTime::now(), &self.gid))
            .target(QueryTarget::AllComplete)
            .consolidation(ConsolidationMode::None)
            // As rmw_zenoh: the query itself never times out; the caller decides how long
            // to wait (a long action result must still arrive).
            .timeout(Duration::from_millis(u64::MAX))
            .with(zenoh::handlers::FifoChannel::default())
            .wait()
            .map_err(middleware(format!("call to {}", self.name)))?;
        Ok(PendingCall {
            replies,
            sequence_number: sn,
            name: self.name.clone(),
            _type: PhantomData,
        })
    }

    /// Sends `request` and waits up to `timeout` for the response.
    pub fn call(&self, request: &S::Request, timeout: Duration) -> Result<S::Response, Ros2Error> {
        self.send(request)?
            .recv_timeout(timeout)?
            .ok_or_else(|| Ros2Error::Call {
                what: format!("call to {}", self.name),
                why: format!("no response within {timeout:?}"),
            })
    }

    /// The client's GID (the requests' attachments carry it).
    pub fn gid(&self) -> [u8; 16] {
        self.gid
    }
}

/// `example_interfaces/srv/AddTwoInts`: the service of ROS 2's tutorials, for tests and
/// interoperability checks.
pub struct AddTwoInts;

/// `example_interfaces/srv/AddTwoInts_Request`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct AddTwoIntsRequest {
    /// First addend.
    pub a: i64,
    /// Second addend.
    pub b: i64,
}

/// `example_interfaces/srv/AddTwoInts_Response`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct AddTwoIntsResponse {
    /// a + b.
    pub sum: i64,
}

impl RosService for AddTwoInts {
    const TYPE_NAME: &'static str = "example_interfaces/srv/AddTwoInts";
    type Request = AddTwoIntsRequest;
    type Response = AddTwoIntsResponse;
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::UNIX_EPOCH;

    #[test]
    fn attachments_round_trip_and_refuse_garbage() {
        let a = attachment(7, UNIX_EPOCH + Duration::from_nanos(99), &[3; 16]);
        assert_eq!(read_attachment(&a.to_bytes()).unwrap(), (7, 99, [3; 16]));
        assert!(read_attachment(&[1, 2, 3]).is_err());
        let mut long = a.to_bytes().to_vec();
        long.push(0);
        assert!(read_attachment(&long).unwrap_err().contains("34 bytes"));
    }

    #[test]
    fn service_keys_carry_the_service_types_hash() {
        let key = service_key::<AddTwoInts>(0, "/add_two_ints");
        assert_eq!(
            key,
            "0/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/\
             RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
        );
    }
}
