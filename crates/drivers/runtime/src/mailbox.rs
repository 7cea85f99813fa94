//! A node's connection with its inbox: messages that arrive before they are needed wait in
//! `pending` (a teammate's β may overtake this robot's own observation); messages of timesteps
//! that are over are dropped or handed back.

use crate::transport::Transport;
use crate::wire::{Envelope, Node};
use crate::RuntimeError;
use std::time::{Duration, Instant};

/// Messages and bytes a node sent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    /// Messages sent (by the radio: forwarded ones included).
    pub messages: usize,
    /// Their encoded size in bytes.
    pub bytes: usize,
}

pub(crate) struct Mailbox<T: Transport> {
    pub(crate) transport: T,
    pub(crate) me: Node,
    pub(crate) pending: Vec<Envelope>,
    pub(crate) sent: Traffic,
}

impl<T: Transport> Mailbox<T> {
    pub(crate) fn new(transport: T, me: Node) -> Self {
        Mailbox {
            transport,
            me,
            pending: Vec::new(),
            sent: Traffic::default(),
        }
    }

    /// Sends `e` to its addressee; a robot's message to a teammate goes to the radio.
    pub(crate) fn send(&mut self, e: &Envelope) -> Result<(), RuntimeError> {
        let via = match (e.from, e.to) {
            (Node::Robot(_), Node::Robot(_)) => Node::Radio,
            (_, to) => to,
        };
        self.forward(via, e.encode())
    }

    /// [`Mailbox::send`] without counting it in `sent`: the world's heartbeats, whose number
    /// depends on timing (traffic counts stay a function of the trial).
    pub(crate) fn send_uncounted(&self, e: &Envelope) -> Result<(), RuntimeError> {
        self.deliver(e.to, e.encode())
    }

    pub(crate) fn forward(&mut self, via: Node, bytes: Vec<u8>) -> Result<(), RuntimeError> {
        self.sent.messages += 1;
        self.sent.bytes += bytes.len();
        self.deliver(via, bytes)
    }

    fn deliver(&self, via: Node, bytes: Vec<u8>) -> Result<(), RuntimeError> {
        if self.transport.send(via, bytes) {
            Ok(())
        } else {
            Err(RuntimeError::Gone {
                node: self.me,
                to: via,
            })
        }
    }

    /// Waits until every node in `peers` can be sent to.
    pub(crate) fn connect(&self, peers: &[Node], timeout: Duration) -> Result<(), RuntimeError> {
        self.transport
            .connect(peers, timeout)
            .map_err(|what| RuntimeError::Transport {
                node: self.me,
                what,
            })
    }

    pub(crate) fn decode(&self, bytes: &[u8]) -> Result<Envelope, RuntimeError> {
        Envelope::decode(bytes).map_err(|source| RuntimeError::Wire {
            node: self.me,
            source,
        })
    }

    /// The first message (waiting or arriving within `wait`) for which `wanted` holds, or
    /// `None` once `wait` has passed.
    pub(crate) fn try_take(
        &mut self,
        wait: Duration,
        wanted: impl Fn(&Envelope) -> bool,
    ) -> Result<Option<Envelope>, RuntimeError> {
        if let Some(k) = self.pending.iter().position(&wanted) {
            return Ok(Some(self.pending.remove(k)));
        }
        let deadline = Instant::now() + wait;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(bytes) = self.transport.recv(left) else {
                return Ok(None);
            };
            let e = self.decode(&bytes)?;
            if wanted(&e) {
                return Ok(Some(e));
            }
            self.pending.push(e);
        }
    }

    /// [`Mailbox::try_take`], with the wait's end an error naming what was awaited.
    pub(crate) fn take(
        &mut self,
        waiting_for: &str,
        timeout: Duration,
        wanted: impl Fn(&Envelope) -> bool,
    ) -> Result<Envelope, RuntimeError> {
        self.try_take(timeout, wanted)?
            .ok_or_else(|| RuntimeError::Timeout {
                node: self.me,
                waiting_for: waiting_for.to_string(),
                timeout,
            })
    }

    /// Everything that has already arrived, moved to `pending` without waiting.
    pub(crate) fn drain(&mut self) -> Result<(), RuntimeError> {
        while let Some(bytes) = self.transport.recv(Duration::ZERO) {
            let e = self.decode(&bytes)?;
            self.pending.push(e);
        }
        Ok(())
    }

    /// Removes the waiting messages of timesteps before `step` and returns those `keep` wants
    /// (the others are dropped: the moment they were for is over).
    pub(crate) fn forget_before(
        &mut self,
        step: u64,
        keep: impl Fn(&Envelope) -> bool,
    ) -> Vec<Envelope> {
        let (old, current): (Vec<Envelope>, Vec<Envelope>) = std::mem::take(&mut self.pending)
            .into_iter()
            .partition(|e| e.step < step);
        self.pending = current;
        old.into_iter().filter(keep).collect()
    }
}
