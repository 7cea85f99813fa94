//! Robots as separate nodes that only exchange messages.
//!
//! MADE-Net is decentralized: each robot decides from its own observation and what its
//! teammates manage to tell it. This crate runs a trial that way. The **world node** holds the
//! ground truth (motion, sensing, and for now the paper's radio model: who exchanges β this
//! timestep); each **robot node** holds one [`madenet_agent::Agent`] — belief, teammate records,
//! goal candidates, policy, navigator — and sees the world only through the observations it is
//! sent, hears teammates only through β and plan messages, and acts only by sending a move.
//! Every message is an encoded [`wire::Envelope`] moved by a [`transport::Transport`]; nothing
//! else is shared.
//!
//! One timestep, as messages (the stages of [`madenet_sim::Trial::step`]):
//!
//! 1. world → robot i: `Observation` (o_i, including the teammates it exchanged with);
//! 2. robot i → each of them: `Beta`; robot i merges the β it receives in sender order;
//! 3. robot i decides if its macro action ended (its own policy);
//! 4. robot i waits for the plans of the higher-priority robots (lower index) it exchanged with,
//!    plans, and sends its plan to the lower-priority ones;
//! 5. robot i → world: `Move`; the world steps once it has every move.
//!
//! The runtime is lockstep: with the same seed it gives exactly the in-process trial (tested
//! for trajectories and metrics). [`run_lockstep`] runs every node on its own thread over the
//! in-memory [`transport::ChannelBus`]; every wait has a timeout that names the node and what it
//! was waiting for.
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

use madenet_agent::Agent;
use madenet_map::Pos;
use madenet_metrics::{MetricsRecorder, TrialMetrics};
use madenet_sim::{PolicyRegistry, TrialSpec};
use madenet_world::{Move, World};
use std::time::Duration;
use transport::{ChannelBus, Transport};
use wire::{Body, Envelope, Node, WireError};

/// Why a node stopped.
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    #[error("{node:?}: nothing arrived for {timeout:?} while waiting for {waiting_for}")]
    Timeout {
        node: Node,
        waiting_for: String,
        timeout: Duration,
    },
    #[error("{node:?}: {source}")]
    Wire { node: Node, source: WireError },
    #[error("{node:?}: unexpected message from {from:?} at step {step}: {what}")]
    Unexpected {
        node: Node,
        from: Node,
        step: u64,
        what: &'static str,
    },
    #[error("{node:?}: {to:?} is gone")]
    Gone { node: Node, to: Node },
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
    fn send(&mut self, to: Node, e: &Envelope) -> Result<(), RuntimeError> {
        let bytes = e.encode();
        self.sent.messages += 1;
        self.sent.bytes += bytes.len();
        if self.transport.send(to, bytes) {
            Ok(())
        } else {
            Err(RuntimeError::Gone { node: self.me, to })
        }
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
            let e = Envelope::decode(&bytes).map_err(|source| RuntimeError::Wire {
                node: self.me,
                source,
            })?;
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
    /// What the world node sent (observations and stops).
    pub world_sent: Traffic,
    /// What the robot nodes sent: to the world (moves) and to each other (β and plans).
    pub robots_sent: Traffic,
    /// Of that, robot to robot: β and plans along successful exchanges.
    pub between_robots: Traffic,
}

/// Runs robot `agent`'s node until the world says stop; returns what it sent (all of it, and
/// the part that went to teammates).
pub fn run_robot<T: Transport>(
    mut agent: Agent,
    transport: T,
    timeout: Duration,
) -> Result<(Traffic, Traffic), RuntimeError> {
    let i = agent.id();
    let me = Node::Robot(i);
    let mut mb = Mailbox {
        transport,
        me,
        pending: Vec::new(),
        timeout,
        sent: Traffic::default(),
    };
    let mut to_world = Traffic::default();
    loop {
        let e = mb.take("an observation from the world", |e| e.from == Node::World)?;
        let step = e.step;
        let obs = match e.body {
            Body::Observation(o) => o,
            Body::Stop => {
                let between = Traffic {
                    messages: mb.sent.messages - to_world.messages,
                    bytes: mb.sent.bytes - to_world.bytes,
                };
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
        // 1. observe
        agent.observe(&obs);
        // 2. β along this timestep's exchanges, merged in sender order.
        let partners = agent.exchanged_with().to_vec();
        if !partners.is_empty() {
            let beta = Envelope::new(step, me, Body::Beta(agent.beta()));
            for &j in &partners {
                mb.send(Node::Robot(j), &beta)?;
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
        // 3. decide (own policy) when the macro action ended
        if agent.needs_decision() {
            agent.decide();
        }
        // 4. plan in priority order: the plans of higher-priority partners first.
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
            let plan = Envelope::new(step, me, Body::Plan(agent.plan_message()));
            for &j in partners.iter().filter(|&&j| j > i) {
                mb.send(Node::Robot(j), &plan)?;
            }
        }
        // 5. act
        let before = mb.sent;
        mb.send(
            Node::World,
            &Envelope::new(step, me, Body::Move(agent.next_move())),
        )?;
        to_world.messages += mb.sent.messages - before.messages;
        to_world.bytes += mb.sent.bytes - before.bytes;
    }
}

/// Runs the world node for `robots` robot nodes until the trial is complete or at its step cap,
/// then tells every robot to stop.
pub fn run_world<T: Transport>(
    mut world: World,
    transport: T,
    timeout: Duration,
) -> Result<LockstepResult, RuntimeError> {
    let n = world.positions().len();
    let mut mb = Mailbox {
        transport,
        me: Node::World,
        pending: Vec::new(),
        timeout,
        sent: Traffic::default(),
    };
    let mut recorder = MetricsRecorder::new(world.explored_fraction());
    let mut positions = vec![world.positions().to_vec()];
    let mut moves = vec![Move::Stay; n];
    while !world.is_done() {
        let step = world.t() as u64;
        for i in 0..n {
            let obs = Body::Observation(world.observation(i).clone());
            mb.send(Node::Robot(i), &Envelope::new(step, Node::World, obs))?;
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
    }
    let step = world.t() as u64;
    for i in 0..n {
        mb.send(
            Node::Robot(i),
            &Envelope::new(step, Node::World, Body::Stop),
        )?;
    }
    Ok(LockstepResult {
        metrics: recorder.finish(world.is_complete()),
        positions,
        world_sent: mb.sent,
        robots_sent: Traffic::default(),
        between_robots: Traffic::default(),
    })
}

/// Runs `spec` with the world and every robot as separate nodes on their own threads, talking
/// only through encoded messages over [`ChannelBus`]; world and agents come from
/// [`madenet_sim::build`], as for [`madenet_sim::Trial`], so the result equals the in-process trial's.
pub fn run_lockstep(
    spec: TrialSpec,
    registry: &PolicyRegistry,
    timeout: Duration,
) -> Result<LockstepResult, RuntimeError> {
    let (world, agents) = madenet_sim::build(spec, registry)?;
    let n = agents.len();
    let nodes: Vec<Node> = std::iter::once(Node::World)
        .chain((0..n).map(Node::Robot))
        .collect();
    let mut buses = ChannelBus::connect(&nodes).into_iter();
    let world_bus = buses.next().expect("the world's endpoint");
    std::thread::scope(|s| {
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
        result
    })
}
