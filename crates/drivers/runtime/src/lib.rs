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
//! 2. radio → each robot: `Links` (with whom its exchange succeeds this timestep);
//! 3. robot i → each of them, through the radio: `Beta` (its map as the changes since the last
//!    map it sent that teammate); robot i merges the β it receives in sender order;
//! 4. robot i decides if its macro action ended (its own policy);
//! 5. robot i waits for the plans of the higher-priority robots (lower index) it exchanged with,
//!    plans, and sends its plan to the lower-priority ones (through the radio);
//! 6. robot i → world: `Move`; the world steps once it has every move.
//!
//! The runtime is lockstep: with the same seed it gives exactly the in-process trial (tested
//! for trajectories and metrics). [`run_lockstep`] runs every node on its own thread over the
//! in-memory [`transport::ChannelBus`]; [`ZenohBus`] carries the same messages between
//! processes. Every wait is bounded ([`Timeouts`]): a robot that sends no move in time is
//! absent (it stays where it is) until it says hello again, a robot does without a silent
//! teammate or radio for that timestep, and whatever cannot go on ends with an error naming the
//! node and what it waited for. [`RadioFaults`] injects loss and delay for fault tests.
//!
//! The world node stands on a [`Ground`]: madenet's simulated [`madenet_world::World`]
//! ([`run_world`]), or anything else that can say what each robot observes and carry out its
//! moves — real robots through ROS 2 (`madenet_ros2::RealRobots`, [`run_ground_with`]). It is a
//! world of the stepping contract ([`LockstepWorld`]), driven by the one run loop
//! ([`madenet_sim::stepping::run`]) with its sinks, as any trial ([`serve`]).
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

#![deny(missing_docs)]

pub mod launch;
mod mailbox;
mod radio_node;
mod report;
mod robot;
pub mod serve;
pub mod signals;
pub mod transport;
pub mod wire;
mod world_node;
pub mod zenoh_bus;

pub use mailbox::Traffic;
pub use radio_node::{run_radio, run_radio_with, RadioFaults, MAX_DELAY_STEPS};
pub use report::{RuntimeReport, WorldOutput};
pub use robot::{run_robot, run_robot_with};
pub use world_node::{run_ground_with, run_world, run_world_with, Ground, LockstepWorld, ShowFn};

use madenet_map::Pos;
use madenet_metrics::{Timing, TrialMetrics};
use madenet_sim::{PolicyRegistry, TrialSpec};
use madenet_world::Radio;
use std::time::Duration;
use transport::{ChannelBus, Transport};
pub use wire::Node;
use wire::WireError;
pub use zenoh_bus::{Endpoints, ZenohBus};

/// Why a node stopped.
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    /// A node waited in vain for something it cannot go on without (see [`Timeouts`]).
    #[error("{node}: nothing arrived for {timeout:?} while waiting for {waiting_for}")]
    Timeout {
        /// The node that gave up.
        node: Node,
        /// What it waited for, in words.
        waiting_for: String,
        /// How long it waited.
        timeout: Duration,
    },
    /// A node received bytes it could not read.
    #[error("{node}: {source}")]
    Wire {
        /// The receiving node.
        node: Node,
        /// What was wrong with the message.
        source: WireError,
    },
    /// A node received a message it does not take, or one naming robots or cells that do not
    /// exist.
    #[error("{node}: unexpected message from {from} at step {step}: {what}")]
    Unexpected {
        /// The receiving node.
        node: Node,
        /// The sender.
        from: Node,
        /// The message's timestep.
        step: u64,
        /// What was wrong with it.
        what: &'static str,
    },
    /// The transport could not deliver a message: the addressee's endpoint is gone.
    #[error("{node}: {to} is gone")]
    Gone {
        /// The sending node.
        node: Node,
        /// Where the message went (the radio, for a robot's message to a teammate).
        to: Node,
    },
    /// The transport could not connect a node to its peers in time
    /// ([`Transport::connect`]).
    #[error("{node}: {what}")]
    Transport {
        /// The node connecting.
        node: Node,
        /// The transport's explanation (who is missing).
        what: String,
    },
    /// The ground truth failed (real robots: a feed went silent or sent a bad map).
    #[error("{node}: {what}")]
    Ground {
        /// The world node.
        node: Node,
        /// The [`Ground`]'s explanation.
        what: String,
    },
    /// The world and agents could not be built from the trial spec.
    #[error(transparent)]
    Setup(#[from] madenet_sim::SimError),
    /// A node's thread panicked ([`run_threads`]).
    #[error("a node thread panicked")]
    Panicked,
}

/// What the world node saw of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct LockstepResult {
    /// The trial's metrics, recorded by the world node (for the simulated world, as the
    /// in-process trial records them).
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
    /// Robot-timesteps a robot was absent (sent no move in time; 0 in a run without faults).
    pub absent_robot_steps: usize,
    /// The robots' latency from observation to move (waits for teammates included).
    pub latency: Latency,
}

/// Wall time from a robot's observation to its move, over every robot and timestep it acted.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Latency {
    /// Robot-timesteps in which a robot sent a move.
    pub acted: usize,
    /// Mean latency in seconds (0 if no robot acted).
    pub mean_s: f64,
    /// Longest latency in seconds.
    pub max_s: f64,
}

/// How long nodes wait.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timeouts {
    /// The longest wait for what must come: the world for a robot's move (after which the robot
    /// counts as absent), any node for its peers to connect. Without faults nothing waits long.
    pub node: Duration,
    /// The longest a robot waits for a teammate's β or plan or for its links from the radio
    /// before doing without for that timestep; shorter than `node`, so a robot waiting for a
    /// silent teammate still moves in time.
    pub peer: Duration,
}

impl Timeouts {
    /// `node` for the world's waits, a quarter of it (at most 2 s) for teammates.
    pub fn new(node: Duration) -> Self {
        Timeouts {
            node,
            peer: (node / 4).min(Duration::from_secs(2)),
        }
    }

    /// How long a node waits to hear from the world during a trial: the world tells it every
    /// `peer` that it is still there ([`wire::Body::Waiting`]), so twice that and a second.
    pub fn world_silence(&self) -> Duration {
        self.peer * 2 + Duration::from_secs(1)
    }

    /// How long a node waits for the world's first message: the world may itself be waiting
    /// `node` for the other nodes to come up.
    pub fn world_start(&self) -> Duration {
        self.node * 2 + Duration::from_secs(1)
    }
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
    run_threads(
        spec,
        registry,
        Timeouts::new(timeout),
        ChannelBus::connect(&nodes),
    )
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
    timeouts: Timeouts,
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
        let radio = s.spawn(move || run_radio(radio, n, radio_bus, timeouts));
        let robots: Vec<_> = agents
            .into_iter()
            .zip(buses)
            .map(|(agent, bus)| s.spawn(move || run_robot(agent, bus, timeouts)))
            .collect();
        let world_result = run_world(world, world_bus, timeouts);
        let robot_results: Vec<_> = robots.into_iter().map(|r| r.join()).collect();
        let radio_result = radio.join();
        // The world's own error first: the others' (a panic aside) are usually its
        // consequences, e.g. a robot timing out because the world stopped.
        let mut res = world_result?;
        let radio_result = radio_result.map_err(|_| RuntimeError::Panicked)?;
        for r in robot_results {
            let (all, between) = r.map_err(|_| RuntimeError::Panicked)??;
            res.robots_sent.messages += all.messages;
            res.robots_sent.bytes += all.bytes;
            res.between_robots.messages += between.messages;
            res.between_robots.bytes += between.bytes;
        }
        res.radio_sent = radio_result?;
        Ok(res)
    })
}
