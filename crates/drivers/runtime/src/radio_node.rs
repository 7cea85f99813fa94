//! The radio node: the paper's communication model ([`Radio`]) between the robots, and the
//! carrier of every robot-to-robot message. Each timestep it takes the world's contacts, lets
//! the radio decide which exchanges succeed, tells every robot its links, and forwards β and
//! plans of that timestep only along links that are up. [`RadioFaults`] adds loss and delay
//! beyond the paper's model, for fault tests.

use crate::mailbox::{Mailbox, Traffic};
use crate::transport::Transport;
use crate::wire::{Body, Envelope, Node};
use crate::{RuntimeError, Timeouts};
use madenet_world::rng::{stream, Rng};
use madenet_world::Radio;
use rand::RngExt;
use std::collections::VecDeque;

/// Faults the radio injects beyond the paper's model (none by default).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RadioFaults {
    /// Probability that an exchange the paper's model lets through is lost all the same (both
    /// directions; drawn from the stream `radio/loss`, so the CSP draws stay as they were).
    pub loss_prob: f64,
    /// Timesteps by which β is late: an exchange of timestep t reaches the teammates at
    /// t + `delay_steps` (they merge it then; no plans are exchanged over a late link).
    pub delay_steps: u32,
    /// Seed of the loss stream.
    pub seed: u64,
}

impl RadioFaults {
    /// Checks the values, naming the field.
    pub fn validate(&self) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.loss_prob) {
            return Err(format!("loss_prob {} is not a probability", self.loss_prob));
        }
        if self.delay_steps > MAX_DELAY_STEPS {
            return Err(format!(
                "delay_steps {} is more than {MAX_DELAY_STEPS}",
                self.delay_steps
            ));
        }
        Ok(())
    }
}

/// Most timesteps a message may be delayed (the radio holds delayed messages in memory).
pub const MAX_DELAY_STEPS: u32 = 100;

/// How many past timesteps' links the radio remembers: a robot's message of timestep t may
/// arrive after the world's contacts of t + 1 (they travel different connections).
const LINK_MEMORY: usize = 4;

/// The links of one timestep: pairs (i < j) that exchange now, and those whose β arrive late.
struct StepLinks {
    step: u64,
    now: Vec<(usize, usize)>,
    late: Vec<(usize, usize)>,
}

/// Runs the radio node for `robots` robots until the world says stop. Returns what it sent.
pub fn run_radio<T: Transport>(
    radio: Radio,
    robots: usize,
    transport: T,
    timeouts: Timeouts,
) -> Result<Traffic, RuntimeError> {
    run_radio_with(radio, robots, transport, timeouts, RadioFaults::default())
}

/// [`run_radio`] with injected faults.
pub fn run_radio_with<T: Transport>(
    mut radio: Radio,
    robots: usize,
    transport: T,
    timeouts: Timeouts,
    faults: RadioFaults,
) -> Result<Traffic, RuntimeError> {
    let me = Node::Radio;
    let mut mb = Mailbox::new(transport, me);
    mb.connect(
        &(0..robots).map(Node::Robot).collect::<Vec<_>>(),
        timeouts.node,
    )?;
    let mut loss: Rng = stream(faults.seed, "radio/loss", 0);
    // The last few timesteps' links, newest last.
    let mut links: VecDeque<StepLinks> = VecDeque::new();
    // Late β waiting for their timestep: (deliver at, addressee, encoded message).
    let mut held: VecDeque<(u64, usize, Vec<u8>)> = VecDeque::new();
    let mut exchanges = Vec::new();
    // Whether the world asked for each timestep's exchanges (pictures).
    let mut report = false;
    // Until the world's first message, it may be waiting for the other nodes to come up.
    let mut silence = timeouts.world_start();
    loop {
        let bytes = mb
            .transport
            .recv(silence)
            .ok_or_else(|| RuntimeError::Timeout {
                node: me,
                waiting_for: "contacts from the world or a robot's message".into(),
                timeout: silence,
            })?;
        let e = mb.decode(&bytes)?;
        if e.from == Node::World {
            silence = timeouts.world_silence();
        }
        match (e.from, e.to, e.body) {
            (Node::World, _, Body::Waiting) => {}
            (Node::World, _, Body::Contacts(contacts)) => {
                if contacts.iter().any(|&(i, j)| i >= j || j >= robots) {
                    return Err(RuntimeError::Unexpected {
                        node: me,
                        from: Node::World,
                        step: e.step,
                        what: "contacts must be pairs i < j of this team",
                    });
                }
                radio.exchange(&contacts, &mut exchanges);
                if faults.loss_prob > 0.0 {
                    exchanges.retain(|_| loss.random::<f64>() >= faults.loss_prob);
                }
                let linked = std::mem::take(&mut exchanges);
                let (now, late) = if faults.delay_steps > 0 {
                    (Vec::new(), linked)
                } else {
                    (linked, Vec::new())
                };
                // Every robot hears its links each timestep, even none.
                let mut per_robot = vec![(Vec::new(), Vec::new()); robots];
                for &(i, j) in &now {
                    per_robot[i].0.push(j);
                    per_robot[j].0.push(i);
                }
                for &(i, j) in &late {
                    per_robot[i].1.push(j);
                    per_robot[j].1.push(i);
                }
                if report {
                    let pairs = Body::Exchanges(now.clone());
                    mb.send(&Envelope::new(e.step, me, Node::World, pairs))?;
                }
                for (i, (mut now, mut late)) in per_robot.into_iter().enumerate() {
                    now.sort_unstable();
                    late.sort_unstable();
                    let to = Node::Robot(i);
                    gone_is_fine(mb.send(&Envelope::new(e.step, me, to, Body::Links { now, late })))?;
                }
                if links.len() == LINK_MEMORY {
                    links.pop_front();
                }
                links.push_back(StepLinks {
                    step: e.step,
                    now,
                    late,
                });
                // Late β whose time has come.
                while held.front().is_some_and(|&(at, _, _)| at <= e.step) {
                    let (_, to, bytes) = held.pop_front().expect("checked");
                    gone_is_fine(mb.forward(Node::Robot(to), bytes))?;
                }
            }
            (Node::World, _, Body::Stop) => return Ok(mb.sent),
            (Node::World, _, Body::Show) => report = true,
            (Node::Robot(i), Node::Robot(j), body) if i < robots && j < robots => {
                let pair = (i.min(j), i.max(j));
                let at_step = || links.iter().filter(|l| l.step == e.step);
                let now = at_step().any(|l| l.now.contains(&pair));
                let late = at_step().any(|l| l.late.contains(&pair));
                if now {
                    gone_is_fine(mb.forward(Node::Robot(j), bytes))?;
                } else if late && matches!(body, Body::Beta(_)) {
                    let at = e.step + u64::from(faults.delay_steps);
                    held.push_back((at, j, bytes));
                }
            }
            (from, _, _) => {
                return Err(RuntimeError::Unexpected {
                    node: me,
                    from,
                    step: e.step,
                    what: "the radio takes contacts, show, waiting and stop from the world and teammates' messages from robots",
                })
            }
        }
    }
}

/// A robot that has gone (it ended at the world's stop before a message for it left, or it was
/// killed) is not the radio's failure: what was sent to it is counted and dropped, as the world
/// node's heartbeat does; a missing robot is the world's move wait to find.
fn gone_is_fine(sent: Result<(), RuntimeError>) -> Result<(), RuntimeError> {
    match sent {
        Err(RuntimeError::Gone { .. }) => Ok(()),
        other => other,
    }
}
