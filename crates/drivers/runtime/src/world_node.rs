//! The world node: ground truth, motion, sensing and the metrics. It sends each robot its
//! observation and the radio the pairs in contact, and steps once it has every robot's move — or
//! once [`Timeouts::node`] has passed: a robot that sent no move is absent (killed, hung,
//! cut off). An absent robot stays where it is (an obstacle to the others), keeps being sent its
//! observations, is left out of the radio's contacts, and is waited for again once it says hello
//! (restarted). While it waits longer than [`Timeouts::peer`] (for an absent robot's move, a
//! slow ground, its pace), it tells every robot and the radio it is still there
//! ([`Body::Waiting`]), so that they notice a killed world within [`Timeouts::world_silence`].
//!
//! The node is a world of the stepping contract ([`LockstepWorld`]: [`Stepping`] and
//! [`Present`]), driven by [`madenet_sim::stepping::run`] with its sinks like any trial; its
//! agents live in other processes, so none decides here.

use crate::mailbox::{Mailbox, Traffic};
use crate::transport::Transport;
use crate::wire::{Body, Envelope, Node, Shown};
use crate::{Latency, LockstepResult, RuntimeError, Timeouts};
use madenet_agent::{Agent, Decision};
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_metrics::{MetricsRecorder, Timing};
use madenet_sim::stepping::{cell_pose, Pose, Present, RobotShown, Sink, SinkError, Stepping};
use madenet_world::{Move, Observation, World};
use std::borrow::Cow;
use std::cell::Cell;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

/// The ground truth a world node stands on: madenet's simulated [`World`], or real robots
/// (`madenet_ros2::RealRobots`, fed by their own maps and poses). The node asks it, every
/// timestep, for the pairs in contact and each robot's observation, then hands it the moves.
pub trait Ground {
    /// Number of robots.
    fn robots(&self) -> usize;
    /// The current timestep.
    fn t(&self) -> usize;
    /// Every robot's cell.
    fn positions(&self) -> Vec<Pos>;
    /// Whether the trial is over (complete, or at its step cap).
    fn is_done(&self) -> bool;
    /// Whether exploration is complete.
    fn is_complete(&self) -> bool;
    /// The explored fraction the metrics start from.
    fn explored_fraction(&self) -> f64;
    /// Pairs `(i, j)`, `i < j`, that can talk this timestep (within d_s, line of sight).
    fn contacts(&mut self) -> Vec<(usize, usize)>;
    /// Robot `i`'s observation o_i of this timestep.
    fn observation(&mut self, i: usize) -> Observation;
    /// Carries out one move per robot (`Stay` for an absent one) and ends the timestep. A
    /// ground whose step blocks (real robots driving) calls `waiting` at least every few
    /// hundred milliseconds meanwhile: the node tells its robots it is still there.
    fn step(&mut self, moves: &[Move], waiting: &mut dyn FnMut()) -> Result<(), String>;
    /// Records the timestep just ended into the metrics.
    fn record(&self, recorder: &mut MetricsRecorder);
    /// The simulated world this ground is, if it is one: what outputs read of the run's
    /// present (ground truth, team map, contacts as the world decided them). `None`: real
    /// robots, with no ground truth to show.
    fn world(&self) -> Option<&World> {
        None
    }
}

impl Ground for World {
    fn robots(&self) -> usize {
        World::positions(self).len()
    }
    fn t(&self) -> usize {
        World::t(self)
    }
    fn positions(&self) -> Vec<Pos> {
        World::positions(self).to_vec()
    }
    fn is_done(&self) -> bool {
        World::is_done(self)
    }
    fn is_complete(&self) -> bool {
        World::is_complete(self)
    }
    fn explored_fraction(&self) -> f64 {
        World::explored_fraction(self)
    }
    fn contacts(&mut self) -> Vec<(usize, usize)> {
        World::contacts(self).to_vec()
    }
    fn observation(&mut self, i: usize) -> Observation {
        World::observation(self, i).clone()
    }
    fn step(&mut self, moves: &[Move], _waiting: &mut dyn FnMut()) -> Result<(), String> {
        World::step(self, moves);
        Ok(())
    }
    fn record(&self, recorder: &mut MetricsRecorder) {
        // The metrics exactly as the in-process trial records them.
        madenet_sim::record_step(recorder, self);
    }
    fn world(&self) -> Option<&World> {
        Some(self)
    }
}

/// Runs the world node for its robots and a radio node until the trial is complete or at its
/// step cap, then tells every robot and the radio to stop. The world's own radio is detached:
/// the radio node decides the exchanges.
pub fn run_world<T: Transport>(
    world: World,
    transport: T,
    timeouts: Timeouts,
) -> Result<LockstepResult, RuntimeError> {
    run_world_with(world, transport, timeouts, |_| {})
}

/// [`run_world`], calling `on_step(world)` after each timestep (progress).
pub fn run_world_with<T: Transport>(
    mut world: World,
    transport: T,
    timeouts: Timeouts,
    mut on_step: impl FnMut(&World),
) -> Result<LockstepResult, RuntimeError> {
    world.detach_radio();
    run_ground_with(world, transport, timeouts, None, None, |w, _| {
        on_step(w);
        ControlFlow::Continue(())
    })
}

/// Refuses a robot whose hello carries another scenario digest than this world's (both known).
fn check_hello(me: Node, scenario: Option<u64>, e: &Envelope) -> Result<(), RuntimeError> {
    match (scenario, &e.body) {
        (Some(mine), Body::Hello { scenario: Some(theirs) }) if mine != *theirs => {
            Err(RuntimeError::Unexpected {
                node: me,
                from: e.from,
                step: e.step,
                what: "a hello for another map or scenario (start every node with the same --map, --start and --config)",
            })
        }
        _ => Ok(()),
    }
}

/// The world's life sign: once [`Timeouts::peer`] has passed since it last sent anything to
/// its robots, it sends each robot and the radio a [`Body::Waiting`].
struct Heartbeat {
    every: Duration,
    /// When it last beat or sent everyone something (a cell: outputs beat through a shared
    /// reference to the node, [`LockstepWorld::beat`]).
    last: Cell<Instant>,
    to: Vec<Node>,
}

impl Heartbeat {
    /// Sends `Waiting` to everyone if `every` has passed since the last beat or
    /// [`Heartbeat::sent`]. A node that is gone (a killed robot) is skipped: its absence is the
    /// move wait's to find.
    fn beat<T: Transport>(&self, mb: &Mailbox<T>, step: u64) -> Result<(), RuntimeError> {
        if self.last.get().elapsed() < self.every {
            return Ok(());
        }
        for &to in &self.to {
            match mb.send_uncounted(&Envelope::new(step, Node::World, to, Body::Waiting)) {
                Ok(()) | Err(RuntimeError::Gone { .. }) => {}
                Err(e) => return Err(e),
            }
        }
        self.last.set(Instant::now());
        Ok(())
    }

    /// Everyone was just sent something (their observations).
    fn sent(&self) {
        self.last.set(Instant::now());
    }

    /// [`Mailbox::try_take`] that beats while it waits.
    fn try_take<T: Transport>(
        &self,
        mb: &mut Mailbox<T>,
        step: u64,
        wait: Duration,
        wanted: impl Fn(&Envelope) -> bool,
    ) -> Result<Option<Envelope>, RuntimeError> {
        let deadline = Instant::now() + wait;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let due = self.every.saturating_sub(self.last.get().elapsed());
            if let Some(e) = mb.try_take(left.min(due), &wanted)? {
                return Ok(Some(e));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            self.beat(mb, step)?;
        }
    }
}

/// Runs `f` with a `waiting` callback that beats when due (for work that blocks: a ground's
/// step, a pace); a failed beat is returned after `f`.
fn with_beats<T: Transport, R>(
    heartbeat: &Heartbeat,
    mb: &Mailbox<T>,
    step: u64,
    f: impl FnOnce(&mut dyn FnMut()) -> R,
) -> Result<R, RuntimeError> {
    let mut failed = None;
    let r = f(&mut || {
        if let Err(e) = heartbeat.beat(mb, step) {
            failed.get_or_insert(e);
        }
    });
    failed.map_or(Ok(r), Err)
}

/// The world node as a world of the stepping contract: [`LockstepWorld::connect`] starts it
/// (every node connected, the robots' hellos, the radio's round of timestep 0), each
/// [`Stepping::step`] plays one timestep over the wire, and [`LockstepWorld::finish`] ends it
/// (each robot's last observation, the stop, the robots' reports). Its agents live in other
/// processes: none decides here ([`Stepping::deciding`] is all false), and what each shows is
/// what it reported ([`Shown`]).
///
/// One timestep, as [`Stepping::step`] plays it: each robot is sent its observation; every
/// present robot's move is awaited until one deadline (a robot without one is absent and
/// stays); with `show`, what each robot shows; the ground steps and the metrics record it; the
/// node keeps its pace ([`LockstepWorld::set_pace`]), takes the hellos of robots that
/// (re)joined, and tells the radio the pairs in contact for the next timestep (with `show`,
/// and fetches the exchanges it decided) — one radio round per timestep, where the in-process
/// [`World::step`] draws it, so the radio's draws are the in-process trial's.
///
/// An error (a robot's malformed message, a failed ground, every robot absent for good) ends
/// the stepping; [`LockstepWorld::finish`] returns it.
pub struct LockstepWorld<G: Ground, T: Transport> {
    ground: G,
    mb: Mailbox<T>,
    n: usize,
    timeouts: Timeouts,
    scenario: Option<u64>,
    /// Whether the robots report what they show and the radio its exchanges.
    showing: bool,
    heartbeat: Heartbeat,
    /// Whether each robot's moves are waited for.
    present: Vec<bool>,
    moves: Vec<Move>,
    /// What each robot showed last (with `show`).
    shown: Vec<Shown>,
    /// The radio's exchanges of the current timestep (with `show`).
    exchanges: Vec<(usize, usize)>,
    /// The ground's contacts of the current timestep (all of them, absent robots' too).
    contacts: Vec<(usize, usize)>,
    recorder: MetricsRecorder,
    positions: Vec<Vec<Pos>>,
    absent_steps: usize,
    started: Instant,
    /// At least this long per timestep, counted from `paced_from`.
    pace: Duration,
    paced_from: Instant,
    failed: Option<RuntimeError>,
    /// The truth [`Present`] shows of a ground that is no simulated world: none.
    no_truth: OccGrid,
    /// [`Stepping::deciding`]: no robot, one entry per robot.
    deciding: Vec<bool>,
}

impl<G: Ground, T: Transport> LockstepWorld<G, T> {
    /// Connects the world node on `ground` to its radio and robots over `transport` and plays
    /// up to timestep 0: with `show`, the robots are asked to report what they show after each
    /// move ([`Shown`]: goal, path, candidates) and the radio its exchanges; every robot's first
    /// hello is checked against `scenario` (each waited for at most [`Timeouts::peer`]: a robot
    /// whose hello is late is checked when it comes, with the next timestep's); and the radio
    /// is told timestep 0's contacts.
    pub fn connect(
        ground: G,
        transport: T,
        timeouts: Timeouts,
        scenario: Option<u64>,
        show: bool,
    ) -> Result<Self, RuntimeError> {
        let n = ground.robots();
        let me = Node::World;
        let mut mb = Mailbox::new(transport, me);
        let addressees: Vec<Node> = std::iter::once(Node::Radio)
            .chain((0..n).map(Node::Robot))
            .collect();
        mb.connect(&addressees, timeouts.node)?;
        if show {
            for &to in &addressees {
                mb.send(&Envelope::new(ground.t() as u64, me, to, Body::Show))?;
            }
        }
        let heartbeat = Heartbeat {
            every: timeouts.peer,
            last: Cell::new(Instant::now()),
            to: addressees,
        };
        for i in 0..n {
            let from = Node::Robot(i);
            let step = ground.t() as u64;
            let wanted = |e: &Envelope| e.from == from && matches!(e.body, Body::Hello { .. });
            if let Some(e) = heartbeat.try_take(&mut mb, step, timeouts.peer, wanted)? {
                check_hello(me, scenario, &e)?;
            }
        }
        let now = Instant::now();
        let mut node = LockstepWorld {
            recorder: MetricsRecorder::new(ground.explored_fraction()),
            positions: vec![ground.positions()],
            ground,
            mb,
            n,
            timeouts,
            scenario,
            showing: show,
            heartbeat,
            present: vec![true; n],
            moves: vec![Move::Stay; n],
            shown: vec![Shown::default(); n],
            exchanges: Vec::new(),
            contacts: Vec::new(),
            absent_steps: 0,
            started: now,
            pace: Duration::ZERO,
            paced_from: now,
            failed: None,
            no_truth: OccGrid::new(0, 0, Occupancy::Unknown),
            deciding: vec![false; n],
        };
        if !node.ground.is_done() || show {
            node.radio_round()?;
        }
        Ok(node)
    }

    /// Takes at least `pace` per timestep (to watch a run live, real robots' pace); the robots
    /// hear the world meanwhile.
    pub fn set_pace(&mut self, pace: Duration) {
        self.pace = pace;
    }

    /// The ground the node stands on.
    pub fn ground(&self) -> &G {
        &self.ground
    }

    /// What each robot showed last, robot i at index i (with `show`; nothing otherwise, and
    /// for a robot that is absent).
    pub fn shown(&self) -> &[Shown] {
        &self.shown
    }

    /// What made the stepping end early, if something did ([`LockstepWorld::finish`] returns
    /// it).
    pub fn failed(&self) -> Option<&RuntimeError> {
        self.failed.as_ref()
    }

    /// Tells the robots and the radio the world is still there, if they have not heard from it
    /// for [`Timeouts::peer`]: for an output that takes its time between timesteps.
    pub fn beat(&self) -> Result<(), RuntimeError> {
        self.heartbeat.beat(&self.mb, self.ground.t() as u64)
    }

    /// The radio's round of the current timestep: the pairs in contact among the robots
    /// present; with `show`, the exchanges the radio decided for them.
    fn radio_round(&mut self) -> Result<(), RuntimeError> {
        let (me, step) = (Node::World, self.ground.t() as u64);
        self.contacts = self.ground.contacts();
        let in_contact: Vec<(usize, usize)> = self
            .contacts
            .iter()
            .copied()
            .filter(|&(i, j)| self.present[i] && self.present[j])
            .collect();
        let contacts = Body::Contacts(in_contact);
        self.mb
            .send(&Envelope::new(step, me, Node::Radio, contacts))?;
        if !self.showing {
            return Ok(());
        }
        let e = self
            .heartbeat
            .try_take(&mut self.mb, step, self.timeouts.peer, |e| {
                e.step == step && e.from == Node::Radio && matches!(e.body, Body::Exchanges(_))
            })?;
        self.exchanges = match e.map(|e| e.body) {
            Some(Body::Exchanges(pairs)) => pairs,
            _ => {
                tracing::warn!(
                    "{me}: no exchanges from the radio for timestep {step}: drawn without"
                );
                Vec::new()
            }
        };
        Ok(())
    }

    /// Robot `j` said hello: its moves are waited for again (and what it shows asked for).
    fn back(&mut self, j: usize, step: u64) -> Result<(), RuntimeError> {
        let me = Node::World;
        tracing::warn!("{me}: robot {j} is back (it said hello) at timestep {step}: waiting for its moves again");
        self.present[j] = true;
        if self.showing {
            self.mb
                .send(&Envelope::new(step, me, Node::Robot(j), Body::Show))?;
        }
        Ok(())
    }

    /// Before a timestep is played: robots that (re)joined are waited for from now on; with
    /// every robot absent, a restarted one is given the time to say hello, then the node gives
    /// up.
    fn hellos(&mut self) -> Result<(), RuntimeError> {
        let (me, n, step) = (Node::World, self.n, self.ground.t() as u64);
        let hellos = self
            .mb
            .forget_before(step, |e| matches!(e.body, Body::Hello { .. }));
        for e in hellos {
            check_hello(me, self.scenario, &e)?;
            if let Node::Robot(j) = e.from {
                if j < n && !self.present[j] {
                    self.back(j, step)?;
                }
            }
        }
        if self.present.iter().any(|&p| p) {
            return Ok(());
        }
        let hello = self
            .heartbeat
            .try_take(&mut self.mb, step, self.timeouts.node, |e| {
                matches!(e.body, Body::Hello { .. })
            })?;
        if let Some(e) = &hello {
            check_hello(me, self.scenario, e)?;
        }
        match hello.map(|e| e.from) {
            Some(Node::Robot(j)) if j < n => self.back(j, step),
            _ => Err(RuntimeError::Timeout {
                node: me,
                waiting_for: "any robot (every robot is absent)".into(),
                timeout: self.timeouts.node,
            }),
        }
    }

    /// One timestep over the wire ([`LockstepWorld`]).
    fn play(&mut self) -> Result<(), RuntimeError> {
        let (me, n, step) = (Node::World, self.n, self.ground.t() as u64);
        let timeouts = self.timeouts;
        for i in 0..n {
            let obs = Body::Observation(self.ground.observation(i));
            self.mb
                .send(&Envelope::new(step, me, Node::Robot(i), obs))?;
        }
        self.heartbeat.sent();
        // Every present robot's move by one deadline; an absent robot's only if already here.
        let deadline = Instant::now() + timeouts.node;
        for i in 0..n {
            let wait = if self.present[i] {
                deadline.saturating_duration_since(Instant::now())
            } else {
                Duration::ZERO
            };
            let e = self.heartbeat.try_take(&mut self.mb, step, wait, |e| {
                e.step == step && e.from == Node::Robot(i) && matches!(e.body, Body::Move(_))
            })?;
            self.moves[i] = match e.map(|e| e.body) {
                Some(Body::Move(mv)) => {
                    if !self.present[i] {
                        tracing::warn!("{me}: robot {i} is back (its move arrived) at timestep {step}: waiting for its moves again");
                        self.present[i] = true;
                    }
                    mv
                }
                _ => {
                    if self.present[i] {
                        tracing::warn!(
                            "{me}: robot {i} sent no move for timestep {step} within {:?}: it stays where it is until it says hello",
                            timeouts.node
                        );
                        self.present[i] = false;
                    }
                    Move::Stay
                }
            };
        }
        self.absent_steps += self.present.iter().filter(|&&p| !p).count();
        if self.showing {
            for i in 0..n {
                let here = self.present[i];
                let wait = if here { timeouts.peer } else { Duration::ZERO };
                let e = self.heartbeat.try_take(&mut self.mb, step, wait, |e| {
                    e.step == step && e.from == Node::Robot(i) && matches!(e.body, Body::Shown(_))
                })?;
                match e.map(|e| e.body) {
                    Some(Body::Shown(s)) => self.shown[i] = s,
                    // Late: what it showed last stays; absent: nothing.
                    _ if here => {}
                    _ => self.shown[i] = Shown::default(),
                }
            }
        }
        let (ground, moves) = (&mut self.ground, &self.moves);
        with_beats(&self.heartbeat, &self.mb, step, |waiting| {
            ground.step(moves, waiting)
        })?
        .map_err(|what| RuntimeError::Ground { node: me, what })?;
        self.ground.record(&mut self.recorder);
        self.positions.push(self.ground.positions());
        // The pace in slices, the robots told the world is still there (a pace may be longer
        // than they wait in silence).
        let until = self.paced_from + self.pace;
        loop {
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            std::thread::sleep(left.min(Duration::from_millis(100)));
            self.heartbeat.beat(&self.mb, step)?;
        }
        self.paced_from = Instant::now();
        if !self.ground.is_done() {
            self.hellos()?;
        }
        if !self.ground.is_done() || self.showing {
            self.radio_round()?;
        }
        Ok(())
    }

    /// Ends the run: each robot is sent where the trial ended (its last observation, for what
    /// it shows: its ROS 2 topics), then the robots and the radio are told to stop, and the
    /// robots' reports are collected. The result holds the run so far (all of it, unless a
    /// sink stopped it early); or the error that ended the stepping.
    pub fn finish(mut self) -> Result<LockstepResult, RuntimeError> {
        if let Some(e) = self.failed.take() {
            return Err(e);
        }
        let (me, n, step) = (Node::World, self.n, self.ground.t() as u64);
        let mb = &mut self.mb;
        for i in 0..n {
            let last = Body::Final(self.ground.observation(i));
            mb.send(&Envelope::new(step, me, Node::Robot(i), last))?;
        }
        for to in (0..n).map(Node::Robot).chain([Node::Radio]) {
            mb.send(&Envelope::new(step, me, to, Body::Stop))?;
        }
        let trial_s = self.started.elapsed().as_secs_f64();
        let (mut decisions, mut decision_s) = (0, 0.0);
        let mut latency = Latency::default();
        let mut latency_s = 0.0;
        for i in (0..n).filter(|&i| self.present[i]) {
            let e = mb.try_take(self.timeouts.node, |e| {
                e.from == Node::Robot(i) && matches!(e.body, Body::Done { .. })
            })?;
            match e.map(|e| e.body) {
                Some(Body::Done {
                    decisions: d,
                    decision_s: s,
                    acted,
                    latency_s: total,
                    latency_max_s,
                }) => {
                    decisions += d;
                    decision_s += s;
                    latency.acted += acted;
                    latency_s += total;
                    latency.max_s = latency.max_s.max(latency_max_s);
                }
                _ => tracing::warn!("{me}: robot {i} did not report after the stop"),
            }
        }
        Ok(LockstepResult {
            metrics: self.recorder.finish(self.ground.is_complete()),
            positions: self.positions,
            world_sent: self.mb.sent,
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
            absent_robot_steps: self.absent_steps,
            latency: Latency {
                mean_s: if latency.acted > 0 {
                    latency_s / latency.acted as f64
                } else {
                    0.0
                },
                ..latency
            },
        })
    }
}

/// What outputs read of the node's present: the simulated world's ground truth, team map and
/// contacts ([`Ground::world`]; a ground without one shows an empty truth and team map, its
/// contacts and no distance), each robot's cell, what each robot reported it shows, and the
/// radio's exchanges (with `show`).
impl<G: Ground, T: Transport> Present for LockstepWorld<G, T> {
    fn robots(&self) -> usize {
        self.n
    }
    fn time_s(&self) -> f64 {
        self.ground.t() as f64
    }
    fn step_s(&self) -> f64 {
        1.0
    }
    fn truth(&self) -> &OccGrid {
        self.ground.world().map_or(&self.no_truth, World::truth)
    }
    fn pose(&self, i: usize) -> Pose {
        cell_pose(self.cell(i), self.truth().resolution)
    }
    fn cell(&self, i: usize) -> Pos {
        self.positions.last().expect("the starts")[i]
    }
    fn robot(&self, i: usize) -> RobotShown<'_> {
        self.shown.get(i).map(Shown::view).unwrap_or_default()
    }
    /// None: the robots' beliefs live in their own processes.
    fn belief(&self, _: usize) -> Option<Cow<'_, [Occupancy]>> {
        None
    }
    fn team_map(&self) -> Cow<'_, [Occupancy]> {
        Cow::Borrowed(self.ground.world().map_or(&[][..], World::team_map))
    }
    fn contacts(&self) -> Cow<'_, [(usize, usize)]> {
        Cow::Borrowed(
            self.ground
                .world()
                .map_or(&self.contacts[..], World::contacts),
        )
    }
    fn exchanges(&self) -> &[(usize, usize)] {
        &self.exchanges
    }
    fn explored(&self) -> f64 {
        self.ground.explored_fraction()
    }
    fn distance(&self) -> f64 {
        self.ground
            .world()
            .map_or(0.0, |w| w.distances().iter().sum())
    }
    fn when(&self) -> String {
        format!("timestep {}", self.ground.t())
    }
}

impl<G: Ground, T: Transport> Stepping for LockstepWorld<G, T> {
    type Outcome = Result<LockstepResult, RuntimeError>;

    /// One timestep over the wire; false once done, or after an error (kept for
    /// [`LockstepWorld::finish`]).
    fn step(&mut self) -> bool {
        if self.failed.is_some() || self.ground.is_done() {
            return false;
        }
        match self.play() {
            Ok(()) => true,
            Err(e) => {
                self.failed = Some(e);
                false
            }
        }
    }
    fn is_done(&self) -> bool {
        self.ground.is_done()
    }
    fn is_complete(&self) -> bool {
        self.ground.is_complete()
    }
    /// All false: every robot decides in its own process.
    fn deciding(&self) -> &[bool] {
        &self.deciding
    }
    fn apply_decisions(&mut self, _: &[Option<Decision>]) {}
    /// None here: they live in their own processes.
    fn agents(&self) -> &[Agent] {
        &[]
    }
    /// # Panics
    /// Always: the agents live in their own processes.
    fn agent_mut(&mut self, i: usize) -> &mut Agent {
        panic!("robot {i}'s agent lives in its own process, not in the world node")
    }
    fn finish(self) -> Self::Outcome {
        LockstepWorld::finish(self)
    }
}

/// What a picture of a timestep draws besides the ground: what each robot shows, and the pairs
/// exchanging.
pub type ShowFn<'a, G> = &'a mut dyn FnMut(&G, &[Shown], &[(usize, usize)]);

/// [`run_ground_with`]'s callbacks as a sink of the run loop.
struct Callbacks<'a, G, F> {
    show: Option<ShowFn<'a, G>>,
    on_step: F,
    /// A heartbeat that failed while `on_step` took its time.
    failed: Option<RuntimeError>,
}

impl<G, T, F> Sink<LockstepWorld<G, T>> for Callbacks<'_, G, F>
where
    G: Ground,
    T: Transport,
    F: FnMut(&G, &mut dyn FnMut()) -> ControlFlow<()>,
{
    fn begin(&mut self, w: &LockstepWorld<G, T>) -> Result<(), SinkError> {
        if let Some(show) = self.show.as_mut() {
            show(&w.ground, &w.shown, &w.exchanges);
        }
        Ok(())
    }

    fn step(&mut self, w: &LockstepWorld<G, T>) -> Result<ControlFlow<String>, SinkError> {
        if let Some(show) = self.show.as_mut() {
            show(&w.ground, &w.shown, &w.exchanges);
        }
        // The caller may take its time here: the robots hear the world meanwhile.
        let mut failed = None;
        let next = (self.on_step)(&w.ground, &mut || {
            if let Err(e) = w.beat() {
                failed.get_or_insert(e);
            }
        });
        if let Some(e) = failed {
            self.failed = Some(e);
            return Ok(ControlFlow::Break("a heartbeat failed".into()));
        }
        Ok(next.map_break(|()| "stopped by the caller".into()))
    }
}

/// The world node on any [`Ground`] (real robots, say), calling `on_step(ground, waiting)` after
/// each timestep (`waiting` tells the robots the world is still there, for a caller that takes
/// its time); `on_step` returning `Break` ends the run there (the robots and the radio get the
/// last outcome and stop as after the last timestep, the result holds the run so far). With
/// `show`, the robots send what they show after each move ([`Shown`]: goal, path, candidates)
/// and the radio the pairs exchanging each timestep, and `show(ground, shown, exchanges)` is
/// called once before the first timestep and once after each — the state `madenet run` draws:
/// the ground after the step, the robots' choices in it, and the exchanges of the next
/// timestep (a robot that sent nothing in time shows what it showed last; an absent robot,
/// nothing). [`LockstepWorld`] driven by [`madenet_sim::stepping::run`], with the callbacks as
/// its sink.
pub fn run_ground_with<G: Ground, T: Transport>(
    world: G,
    transport: T,
    timeouts: Timeouts,
    scenario: Option<u64>,
    show: Option<ShowFn<'_, G>>,
    on_step: impl FnMut(&G, &mut dyn FnMut()) -> ControlFlow<()>,
) -> Result<LockstepResult, RuntimeError> {
    let mut node = LockstepWorld::connect(world, transport, timeouts, scenario, show.is_some())?;
    let mut callbacks = Callbacks {
        show,
        on_step,
        failed: None,
    };
    madenet_sim::stepping::run(&mut node, &mut [&mut callbacks])
        .expect("the callbacks' sink never fails");
    if let Some(e) = callbacks.failed {
        return Err(e);
    }
    node.finish()
}
