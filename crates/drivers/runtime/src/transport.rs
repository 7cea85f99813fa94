//! How nodes reach each other: a [`Transport`] moves encoded envelopes between [`Node`]s. The
//! in-memory [`ChannelBus`] (one `std::sync::mpsc` queue per node, each node on its own thread)
//! is one implementation; [`crate::ZenohBus`] (one process per node) implements the same calls.

use crate::wire::Node;
use std::collections::HashMap;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::time::Duration;

/// A node's connection: send bytes to another node, receive the next bytes sent to this one.
pub trait Transport: Send {
    /// Sends one encoded message to `to`; false if `to` is gone.
    fn send(&self, to: Node, bytes: Vec<u8>) -> bool;
    /// The next message for this node, or `None` after `timeout` (or, for a transport that can
    /// tell, once every sender is gone; an in-memory [`ChannelBus`] endpoint keeps a sender to
    /// its own inbox, so it only times out).
    fn recv(&self, timeout: Duration) -> Option<Vec<u8>>;
    /// Waits until `peers` can be sent to (a network transport: their inboxes are subscribed
    /// and reachable); an error names who is missing after `timeout`.
    fn connect(&self, peers: &[Node], timeout: Duration) -> Result<(), String> {
        let _ = (peers, timeout);
        Ok(())
    }
}

/// In-memory transport for nodes on threads of one process.
pub struct ChannelBus {
    inboxes: HashMap<Node, Sender<Vec<u8>>>,
    me: Receiver<Vec<u8>>,
}

impl ChannelBus {
    /// One connected endpoint per node, in the order given.
    pub fn connect(nodes: &[Node]) -> Vec<ChannelBus> {
        let (senders, receivers): (Vec<_>, Vec<_>) = nodes.iter().map(|_| channel()).unzip();
        let inboxes: HashMap<Node, Sender<Vec<u8>>> = nodes.iter().copied().zip(senders).collect();
        receivers
            .into_iter()
            .map(|me| ChannelBus {
                inboxes: inboxes.clone(),
                me,
            })
            .collect()
    }
}

impl Transport for ChannelBus {
    fn send(&self, to: Node, bytes: Vec<u8>) -> bool {
        self.inboxes.get(&to).is_some_and(|s| s.send(bytes).is_ok())
    }

    fn recv(&self, timeout: Duration) -> Option<Vec<u8>> {
        // A timeout and every sender gone both mean: nothing more is coming in time.
        self.me.recv_timeout(timeout).ok()
    }
}

/// A borrowed transport is one (the owner can close it after the node returns).
impl<T: Transport + Sync> Transport for &T {
    fn send(&self, to: Node, bytes: Vec<u8>) -> bool {
        (**self).send(to, bytes)
    }
    fn recv(&self, timeout: Duration) -> Option<Vec<u8>> {
        (**self).recv(timeout)
    }
    fn connect(&self, peers: &[Node], timeout: Duration) -> Result<(), String> {
        (**self).connect(peers, timeout)
    }
}
