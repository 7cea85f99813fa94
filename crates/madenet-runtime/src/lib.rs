//! Robots as separate nodes that only exchange messages.
//!
//! MADE-Net is decentralized: each robot decides from its own observation and what its
//! teammates manage to tell it. This crate runs a trial that way. The **world node** holds the
//! ground truth (motion, sensing, who is in contact with whom); the **radio node** is the
//! paper's communication model ([`madenet_world::Radio`]: CSP and dropouts) and carries every
//! robot-to-robot message, forwarding it only along a link that is up; each **robot node** holds
//! one [`madenet_agent::Agent`] — belief, teammate records, goal candidates, policy, navigator —
//! and sees the world only through the observations it is sent, hears teammates only through β
//! and plan messages, and acts only by sending a move. Every message is an encoded
//! [`wire::Envelope`] moved by a [`transport::Transport`]; nothing else is shared.
//!
//! One timestep, as messages (the stages of [`madenet_sim::Trial::step`]):
//!
//! 1. world → robot i: `Observation` (o_i with the teammates it detects); world → radio:
//!    `Contacts`;
//! 2. radio → each robot in contact: `Links` (with whom its exchange succeeds this timestep);
//! 3. robot i → each of them, through the radio: `Beta`; robot i merges the β it receives in
//!    sender order;
//! 4. robot i decides if its macro action ended (its own policy);
//! 5. robot i waits for the plans of the higher-priority robots (lower index) it exchanged with,
//!    plans, and sends its plan to the lower-priority ones (through the radio);
//! 6. robot i → world: `Move`; the world steps once it has every move.
//!
//! The runtime is lockstep: with the same seed it gives exactly the in-process trial (tested
//! for trajectories and metrics). [`run_lockstep`] runs every node on its own thread over the
//! in-memory [`transport::ChannelBus`]; [`ZenohBus`] carries the same messages
//! between processes. Every wait has a timeout that names the node and what it was waiting for.
//!
//! ```
//! use madenet_map::paper::{paper_map, Corner};
//! use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
//! use std::time::Duration;
//!
//! let spec = TrialSpec {
//!     map: paper_map(3).unwrap(),
//!     map_name: "paper:3".into(),
//!     starts: Corner::TopLeft.start_cells(20, 20).to_vec(),
//!     config: Default::default(),
//!     policy: "nf".into(),
//!     seed: 7,
//! };
//! let registry = PolicyRegistry::builtin();
//! let apart = madenet_runtime::run_lockstep(spec.clone(), &registry, Duration::from_secs(10)).unwrap();
//! let together = Trial::new(spec).unwrap().run();
//! assert_eq!(apart.metrics, together.metrics);
//! ```

pub mod transport;
pub mod wire;
pub mod zenoh_bus;

use madenet_agent::Agent;
use madenet_map::Pos;
use madenet_metrics::{MetricsRecorder, Timing, TrialMetrics};
use madenet_sim::{PolicyRegistry, TrialSpec};
use madenet_world::{Move, Radio, World};
use std::time::Duration;
use transport::{ChannelBus, Transport};
use wire::{Body, Envelope, Node, WireError};
pub use zenoh_bus::{Endpoints, ZenohBus};

/// Why a node stopped.
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    #[error("{node}: nothing arrived for {timeout:?} while waiting for {waiting_for}")]
    Timeout {
        node: Node,
        waiting_for: String,
        timeout: Duration,
    },
    #[error("{node}: {source}")]
    Wire { node: Node, source: WireError },
    #[error("{node}: unexpected message from {from} at step {step}: {what}")]
    Unexpected {
        node: Node,
        from: Node,
        step: u64,
        what: &'static str,
    },
    #[error("{node}: {to} is gone")]
    Gone { node: Node, to: Node },
    #[error("{node}: {what}")]
    Transport { node: Node, what: String },
    #[error(transparent)]
    Setup(#[from] madenet_sim::SimError),
    #[error("a node thread panicked")]
    Panicked,
}

/// A node's inbox: messages that arrive before they are needed wait here (a teammate's β may
/// overtake this robot's own observation).
struct Mailbox<T: Transport> {
    transport: T,
    me: Node,
    pending: Vec<Envelope>,
    timeout: Duration,
    sent: Traffic,
}

/// Messages and bytes a node sent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    pub messages: usize,
    pub bytes: usize,
}

impl<T: Transport> Mailbox<T> {
    fn new(transport: T, me: Node, timeout: Duration) -> Self {
        Mailbox {
            transport,
            me,
            pending: Vec::new(),
            timeout,
            sent: Traffic::default(),
        }
    }

    /// Sends `e` to its addressee; a robot's message to a teammate goes to the radio.
    fn send(&mut self, e: &Envelope) -> Result<(), RuntimeError> {
        let via = match (e.from, e.to) {
            (Node::Robot(_), Node::Robot(_)) => Node::Radio,
            (_, to) => to,
        };
        self.forward(via, e.encode())
    }

    fn forward(&mut self, via: Node, bytes: Vec<u8>) -> Result<(), RuntimeError> {
        self.sent.messages += 1;
        self.sent.bytes += bytes.len();
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
    fn connect(&self, peers: &[Node]) -> Result<(), RuntimeError> {
        self.transport
            .connect(peers, self.timeout)
            .map_err(|what| RuntimeError::Transport {
                node: self.me,
                what,
            })
    }

    fn decode(&self, bytes: &[u8]) -> Result<Envelope, RuntimeError> {
        Envelope::decode(bytes).map_err(|source| RuntimeError::Wire {
            node: self.me,
            source,
        })
    }

    /// The first message (waiting or arriving) for which `wanted` holds.
    fn take(
        &mut self,
        waiting_for: &str,
        wanted: impl Fn(&Envelope) -> bool,
    ) -> Result<Envelope, RuntimeError> {
        if let Some(k) = self.pending.iter().position(&wanted) {
            return Ok(self.pending.remove(k));
        }
        loop {
            let bytes = self
                .transport
                .recv(self.timeout)
                .ok_or_else(|| RuntimeError::Timeout {
                    node: self.me,
                    waiting_for: waiting_for.to_string(),
                    timeout: self.timeout,
                })?;
            let e = self.decode(&bytes)?;
            if wanted(&e) {
                return Ok(e);
            }
            self.pending.push(e);
        }
    }
}

/// What the world node saw of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct LockstepResult {
    pub metrics: TrialMetrics,
    /// Robot positions before the first move and after every timestep.
    pub positions: Vec<Vec<Pos>>,
    /// What the world node sent (observations, contacts and stops).
    pub world_sent: Traffic,
    /// What the robot nodes sent: to the world (moves) and to each other (β and plans).
    pub robots_sent: Traffic,
    /// Of that, robot to robot: β and plans along successful exchanges.
    pub between_robots: Traffic,
    /// What the radio node sent: links and the robots' messages it forwarded.
    pub radio_sent: Traffic,
    /// The world's wall time from its first message to the stop, and the robots' decisions
    /// (as they reported them when stopped).
    pub timing: Timing,
}

/// Runs robot `agent`'s node until the world says stop; returns what it sent (all of it, and
/// the part that went to teammates).
pub fn run_robot<T: Transport>(
    agent: Agent,
    transport: T,
    timeout: Duration,
) -> Result<(Traffic, Traffic), RuntimeError> {
    run_robot_with(agent, transport, timeout, |_, _| {})
}

/// [`run_robot`], calling `on_step(timestep, agent)` after each move it sends (progress).
pub fn run_robot_with<T: Transport>(
    mut agent: Agent,
    transport: T,
    timeout: Duration,
    mut on_step: impl FnMut(u64, &Agent),
) -> Result<(Traffic, Traffic), RuntimeError> {
    let i = agent.id();
    let me = Node::Robot(i);
    let mut mb = Mailbox::new(transport, me, timeout);
    mb.connect(&[Node::World, Node::Radio])?;
    let mut to_world = Traffic::default();
    loop {
        let e = mb.take("an observation from the world", |e| e.from == Node::World)?;
        let step = e.step;
        let mut obs = match e.body {
            Body::Observation(o) => o,
            Body::Stop => {
                let between = Traffic {
                    messages: mb.sent.messages - to_world.messages,
                    bytes: mb.sent.bytes - to_world.bytes,
                };
                let stats = agent.stats();
                let done = Body::Done {
                    decisions: stats.decisions,
                    decision_s: stats.decision_time.as_secs_f64(),
                };
                mb.send(&Envelope::new(step, me, Node::World, done))?;
                return Ok((mb.sent, between));
            }
            _ => {
                return Err(RuntimeError::Unexpected {
                    node: me,
                    from: e.from,
                    step,
                    what: "the world sends observations and stop only",
                })
            }
        };
        // 1–2. observe; in contact with a teammate, the radio says which links are up.
        if !obs.teammates.is_empty() {
            let e = mb.take("this timestep's links from the radio", |e| {
                e.step == step && e.from == Node::Radio && matches!(e.body, Body::Links(_))
            })?;
            if let Body::Links(with) = e.body {
                obs.exchanged_with = with;
            }
        }
        agent.observe(&obs);
        // 3. β along this timestep's exchanges, merged in sender order.
        let partners = agent.exchanged_with().to_vec();
        if !partners.is_empty() {
            for &j in &partners {
                let to = Node::Robot(j);
                mb.send(&Envelope::new(step, me, to, Body::Beta(agent.beta())))?;
            }
            let mut heard = Vec::with_capacity(partners.len());
            for &j in &partners {
                let e = mb.take("β from a teammate", |e| {
                    e.step == step && e.from == Node::Robot(j) && matches!(e.body, Body::Beta(_))
                })?;
                if let Body::Beta(b) = e.body {
                    heard.push(b);
                }
            }
            heard.sort_by_key(|b| b.from);
            for b in &heard {
                agent.receive_beta(b);
            }
        }
        // 4. decide (own policy) when the macro action ended
        if agent.needs_decision() {
            agent.decide();
        }
        // 5. plan in priority order: the plans of higher-priority partners first.
        let mut higher: Vec<usize> = partners.iter().copied().filter(|&j| j < i).collect();
        higher.sort_unstable();
        for j in higher {
            let e = mb.take("a plan from a higher-priority teammate", |e| {
                e.step == step && e.from == Node::Robot(j) && matches!(e.body, Body::Plan(_))
            })?;
            if let Body::Plan(p) = e.body {
                agent.receive_plan(&p);
            }
        }
        agent.plan();
        if partners.iter().any(|&j| j > i) {
            let plan = agent.plan_message();
            for &j in partners.iter().filter(|&&j| j > i) {
                let to = Node::Robot(j);
                mb.send(&Envelope::new(step, me, to, Body::Plan(plan.clone())))?;
            }
        }
        // 6. act
        let before = mb.sent;
        let mv = Body::Move(agent.next_move());
        mb.send(&Envelope::new(step, me, Node::World, mv))?;
        to_world.messages += mb.sent.messages - before.messages;
        to_world.bytes += mb.sent.bytes - before.bytes;
        on_step(step, &agent);
    }
}

/// How many past timesteps' links the radio remembers: a robot's message of timestep t may
/// arrive after the world's contacts of t + 1 (they travel different connections).
const LINK_MEMORY: usize = 4;

/// Runs the radio node for `robots` robots until the world says stop: each timestep it takes
/// the world's contacts, lets `radio` decide which exchanges succeed, tells every robot in
/// contact its links, and forwards robot-to-robot messages of that timestep along links that
/// are up (anything else is dropped). Returns what it sent.
pub fn run_radio<T: Transport>(
    mut radio: Radio,
    robots: usize,
    transport: T,
    timeout: Duration,
) -> Result<Traffic, RuntimeError> {
    let me = Node::Radio;
    let mut mb = Mailbox::new(transport, me, timeout);
    mb.connect(&(0..robots).map(Node::Robot).collect::<Vec<_>>())?;
    // (timestep, pairs that exchange), newest last.
    let mut links: std::collections::VecDeque<(u64, Vec<(usize, usize)>)> = Default::default();
    let mut exchanges = Vec::new();
    loop {
        let bytes = mb
            .transport
            .recv(timeout)
            .ok_or_else(|| RuntimeError::Timeout {
                node: me,
                waiting_for: "contacts from the world or a robot's message".into(),
                timeout,
            })?;
        let e = mb.decode(&bytes)?;
        match (e.from, e.to, e.body) {
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
                // Every robot in contact hears its links, even none.
                let mut per_robot: Vec<Option<Vec<usize>>> = vec![None; robots];
                for &(i, j) in &contacts {
                    per_robot[i].get_or_insert_with(Vec::new);
                    per_robot[j].get_or_insert_with(Vec::new);
                }
                for &(i, j) in &exchanges {
                    per_robot[i].as_mut().expect("in contact").push(j);
                    per_robot[j].as_mut().expect("in contact").push(i);
                }
                for (i, with) in per_robot.into_iter().enumerate() {
                    if let Some(mut with) = with {
                        with.sort_unstable();
                        let to = Node::Robot(i);
                        mb.send(&Envelope::new(e.step, me, to, Body::Links(with)))?;
                    }
                }
                if links.len() == LINK_MEMORY {
                    links.pop_front();
                }
                links.push_back((e.step, exchanges.clone()));
            }
            (Node::World, _, Body::Stop) => return Ok(mb.sent),
            (Node::Robot(i), Node::Robot(j), _) if i < robots && j < robots => {
                let pair = (i.min(j), i.max(j));
                let up = links
                    .iter()
                    .any(|(step, pairs)| *step == e.step && pairs.contains(&pair));
                if up {
                    mb.forward(Node::Robot(j), bytes)?;
                }
            }
            (from, _, _) => {
                return Err(RuntimeError::Unexpected {
                    node: me,
                    from,
                    step: e.step,
                    what: "the radio takes contacts and stop from the world and teammates' messages from robots",
                })
            }
        }
    }
}

/// Runs the world node for `robots` robot nodes and a radio node until the trial is complete or
/// at its step cap, then tells every robot and the radio to stop. The world's own radio is
/// detached: the radio node decides the exchanges.
pub fn run_world<T: Transport>(
    world: World,
    transport: T,
    timeout: Duration,
) -> Result<LockstepResult, RuntimeError> {
    run_world_with(world, transport, timeout, |_| {})
}

/// [`run_world`], calling `on_step(world)` after each timestep (progress).
pub fn run_world_with<T: Transport>(
    mut world: World,
    transport: T,
    timeout: Duration,
    mut on_step: impl FnMut(&World),
) -> Result<LockstepResult, RuntimeError> {
    world.detach_radio();
    let n = world.positions().len();
    let me = Node::World;
    let mut mb = Mailbox::new(transport, me, timeout);
    let addressees: Vec<Node> = std::iter::once(Node::Radio)
        .chain((0..n).map(Node::Robot))
        .collect();
    mb.connect(&addressees)?;
    let started = std::time::Instant::now();
    let mut recorder = MetricsRecorder::new(world.explored_fraction());
    let mut positions = vec![world.positions().to_vec()];
    let mut moves = vec![Move::Stay; n];
    while !world.is_done() {
        let step = world.t() as u64;
        let contacts = Body::Contacts(world.contacts().to_vec());
        mb.send(&Envelope::new(step, me, Node::Radio, contacts))?;
        for i in 0..n {
            let obs = Body::Observation(world.observation(i).clone());
            mb.send(&Envelope::new(step, me, Node::Robot(i), obs))?;
        }
        for (i, m) in moves.iter_mut().enumerate() {
            let e = mb.take("a robot's move", |e| {
                e.step == step && e.from == Node::Robot(i) && matches!(e.body, Body::Move(_))
            })?;
            if let Body::Move(mv) = e.body {
                *m = mv;
            }
        }
        world.step(&moves);
        // The metrics exactly as the in-process trial records them.
        madenet_sim::record_step(&mut recorder, &world);
        positions.push(world.positions().to_vec());
        on_step(&world);
    }
    let step = world.t() as u64;
    for to in (0..n).map(Node::Robot).chain([Node::Radio]) {
        mb.send(&Envelope::new(step, me, to, Body::Stop))?;
    }
    let trial_s = started.elapsed().as_secs_f64();
    let (mut decisions, mut decision_s) = (0, 0.0);
    for i in 0..n {
        let e = mb.take("a robot's report after the stop", |e| {
            e.from == Node::Robot(i) && matches!(e.body, Body::Done { .. })
        })?;
        if let Body::Done {
            decisions: d,
            decision_s: s,
        } = e.body
        {
            decisions += d;
            decision_s += s;
        }
    }
    Ok(LockstepResult {
        metrics: recorder.finish(world.is_complete()),
        positions,
        world_sent: mb.sent,
        robots_sent: Traffic::default(),
        between_robots: Traffic::default(),
        radio_sent: Traffic::default(),
        timing: Timing {
            trial_s,
            decisions,
            per_decision_s: if decisions > 0 {
                decision_s / decisions as f64
            } else {
                0.0
            },
        },
    })
}

/// Runs `spec` with the world, the radio and every robot as separate nodes on their own
/// threads, talking only through encoded messages over [`ChannelBus`]; world and agents come
/// from [`madenet_sim::build`], as for [`madenet_sim::Trial`], and the radio is the trial's
/// [`Radio`], so the result equals the in-process trial's.
pub fn run_lockstep(
    spec: TrialSpec,
    registry: &PolicyRegistry,
    timeout: Duration,
) -> Result<LockstepResult, RuntimeError> {
    let nodes = nodes_of(spec.starts.len());
    run_threads(spec, registry, timeout, ChannelBus::connect(&nodes))
}

/// The nodes of a trial with `robots` robots, in the order [`run_threads`] takes their
/// transports: world, radio, robot 0, robot 1, …
pub fn nodes_of(robots: usize) -> Vec<Node> {
    [Node::World, Node::Radio]
        .into_iter()
        .chain((0..robots).map(Node::Robot))
        .collect()
}

/// [`run_lockstep`] over any transport: one endpoint per node of [`nodes_of`], in that order.
pub fn run_threads<T: Transport>(
    spec: TrialSpec,
    registry: &PolicyRegistry,
    timeout: Duration,
    transports: Vec<T>,
) -> Result<LockstepResult, RuntimeError> {
    let radio = Radio::new(&spec.config, spec.starts.len(), spec.seed);
    let (world, agents) = madenet_sim::build(spec, registry)?;
    let n = agents.len();
    assert_eq!(
        transports.len(),
        n + 2,
        "one transport per node of nodes_of"
    );
    let mut buses = transports.into_iter();
    let world_bus = buses.next().expect("the world's endpoint");
    let radio_bus = buses.next().expect("the radio's endpoint");
    std::thread::scope(|s| {
        let radio = s.spawn(move || run_radio(radio, n, radio_bus, timeout));
        let robots: Vec<_> = agents
            .into_iter()
            .zip(buses)
            .map(|(agent, bus)| s.spawn(move || run_robot(agent, bus, timeout)))
            .collect();
        let mut result = run_world(world, world_bus, timeout);
        for r in robots {
            let (all, between) = r.join().map_err(|_| RuntimeError::Panicked)??;
            if let Ok(res) = result.as_mut() {
                res.robots_sent.messages += all.messages;
                res.robots_sent.bytes += all.bytes;
                res.between_robots.messages += between.messages;
                res.between_robots.bytes += between.bytes;
            }
        }
        let radio_sent = radio.join().map_err(|_| RuntimeError::Panicked)??;
        if let Ok(res) = result.as_mut() {
            res.radio_sent = radio_sent;
        }
        result
    })
}
