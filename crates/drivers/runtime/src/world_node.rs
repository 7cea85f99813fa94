//! The world node: ground truth, motion, sensing and the metrics. It sends each robot its
//! observation and the radio the pairs in contact, and steps once it has every robot's move — or
//! once [`Timeouts::node`] has passed: a robot that sent no move is absent (killed, hung,
//! cut off). An absent robot stays where it is (an obstacle to the others), keeps being sent its
//! observations, is left out of the radio's contacts, and is waited for again once it says hello
//! (restarted). While it waits longer than [`Timeouts::peer`] (for an absent robot's move, a
//! slow ground), it tells every robot and the radio it is still there ([`Body::Waiting`]), so
//! that they notice a killed world within [`Timeouts::world_silence`].

use crate::mailbox::{Mailbox, Traffic};
use crate::transport::Transport;
use crate::wire::{Body, Envelope, Node, Shown};
use crate::{Latency, LockstepResult, RuntimeError, Timeouts};
use madenet_map::Pos;
use madenet_metrics::{MetricsRecorder, Timing};
use madenet_world::{Move, Observation, World};
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
    last: Instant,
    to: Vec<Node>,
}

impl Heartbeat {
    /// Sends `Waiting` to everyone if `every` has passed since the last beat or
    /// [`Heartbeat::sent`]. A node that is gone (a killed robot) is skipped: its absence is the
    /// move wait's to find.
    fn beat<T: Transport>(&mut self, mb: &mut Mailbox<T>, step: u64) -> Result<(), RuntimeError> {
        if self.last.elapsed() < self.every {
            return Ok(());
        }
        for &to in &self.to {
            match mb.send_uncounted(&Envelope::new(step, Node::World, to, Body::Waiting)) {
                Ok(()) | Err(RuntimeError::Gone { .. }) => {}
                Err(e) => return Err(e),
            }
        }
        self.last = Instant::now();
        Ok(())
    }

    /// Everyone was just sent something (their observations).
    fn sent(&mut self) {
        self.last = Instant::now();
    }

    /// [`Mailbox::try_take`] that beats while it waits.
    fn try_take<T: Transport>(
        &mut self,
        mb: &mut Mailbox<T>,
        step: u64,
        wait: Duration,
        wanted: impl Fn(&Envelope) -> bool,
    ) -> Result<Option<Envelope>, RuntimeError> {
        let deadline = Instant::now() + wait;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let due = self.every.saturating_sub(self.last.elapsed());
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
/// step, the caller's pace); a failed beat is returned after `f`.
fn with_beats<T: Transport, R>(
    heartbeat: &mut Heartbeat,
    mb: &mut Mailbox<T>,
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

/// What a picture of a timestep draws besides the ground: what each robot shows, and the pairs
/// exchanging.
pub type ShowFn<'a, G> = &'a mut dyn FnMut(&G, &[Shown], &[(usize, usize)]);

/// The world node on any [`Ground`] (real robots, say), calling `on_step(ground)` after each
/// timestep; `on_step` returning `Break` ends the run there (Ctrl-C: the robots and the radio
/// get the last outcome and stop as after the last timestep, the result holds the run so far). With `show`, the robots send what they show after each move ([`Shown`]: goal,
/// path, candidates) and the radio the pairs exchanging each timestep, and `show(ground,
/// shown, exchanges)` is called once before the first timestep and once after each — the
/// state `madenet run` draws: the ground after the step, the robots' choices in it, and the
/// exchanges of the next timestep (a robot that sent nothing in time shows what it showed
/// last; an absent robot, nothing).
pub fn run_ground_with<G: Ground, T: Transport>(
    mut world: G,
    transport: T,
    timeouts: Timeouts,
    scenario: Option<u64>,
    mut show: Option<ShowFn<'_, G>>,
    mut on_step: impl FnMut(&G, &mut dyn FnMut()) -> ControlFlow<()>,
) -> Result<LockstepResult, RuntimeError> {
    let n = world.robots();
    let me = Node::World;
    let mut mb = Mailbox::new(transport, me);
    let addressees: Vec<Node> = std::iter::once(Node::Radio)
        .chain((0..n).map(Node::Robot))
        .collect();
    mb.connect(&addressees, timeouts.node)?;
    let showing = show.is_some();
    let ask_to_show = |mb: &mut Mailbox<T>, to: Node, step: u64| -> Result<(), RuntimeError> {
        if showing {
            mb.send(&Envelope::new(step, me, to, Body::Show))?;
        }
        Ok(())
    };
    for &to in &addressees {
        ask_to_show(&mut mb, to, world.t() as u64)?;
    }
    let mut shown: Vec<Shown> = vec![Shown::default(); n];
    let mut heartbeat = Heartbeat {
        every: timeouts.peer,
        last: Instant::now(),
        to: addressees.clone(),
    };
    // The radio is told the pairs in contact among the robots present.
    let send_contacts = |mb: &mut Mailbox<T>, world: &mut G, present: &[bool], step: u64| {
        let in_contact: Vec<(usize, usize)> = world
            .contacts()
            .into_iter()
            .filter(|&(i, j)| present[i] && present[j])
            .collect();
        mb.send(&Envelope::new(
            step,
            me,
            Node::Radio,
            Body::Contacts(in_contact),
        ))
    };
    // The radio's exchanges of `step` (pictures only).
    let exchanges = |mb: &mut Mailbox<T>,
                     heartbeat: &mut Heartbeat,
                     step: u64|
     -> Result<Vec<(usize, usize)>, RuntimeError> {
        let e = heartbeat.try_take(mb, step, timeouts.peer, |e| {
            e.step == step && e.from == Node::Radio && matches!(e.body, Body::Exchanges(_))
        })?;
        Ok(match e.map(|e| e.body) {
            Some(Body::Exchanges(pairs)) => pairs,
            _ => {
                tracing::warn!(
                    "{me}: no exchanges from the radio for timestep {step}: drawn without"
                );
                Vec::new()
            }
        })
    };
    // Every robot's first hello, checked before timestep 0 is played (each waited for at most
    // `peer`: a robot whose hello is late is checked when it comes, with the next timestep's).
    for i in 0..n {
        let from = Node::Robot(i);
        let step = world.t() as u64;
        let wanted = |e: &Envelope| e.from == from && matches!(e.body, Body::Hello { .. });
        if let Some(e) = heartbeat.try_take(&mut mb, step, timeouts.peer, wanted)? {
            check_hello(me, scenario, &e)?;
        }
    }
    let started = Instant::now();
    let mut recorder = MetricsRecorder::new(world.explored_fraction());
    let mut positions = vec![world.positions()];
    let mut moves = vec![Move::Stay; n];
    let mut present = vec![true; n];
    let mut absent_steps = 0usize;
    while !world.is_done() {
        let step = world.t() as u64;
        // Hellos: robots that (re)joined are waited for from now on.
        for e in mb.forget_before(step, |e| matches!(e.body, Body::Hello { .. })) {
            check_hello(me, scenario, &e)?;
            if let Node::Robot(j) = e.from {
                if j < n && !present[j] {
                    tracing::warn!("{me}: robot {j} is back (it said hello) at timestep {step}: waiting for its moves again");
                    present[j] = true;
                    ask_to_show(&mut mb, Node::Robot(j), step)?;
                }
            }
        }
        if present.iter().all(|&p| !p) {
            // Nobody to wait for: give a restarted robot the time to say hello, then give up.
            let hello = heartbeat.try_take(&mut mb, step, timeouts.node, |e| {
                matches!(e.body, Body::Hello { .. })
            })?;
            if let Some(e) = &hello {
                check_hello(me, scenario, e)?;
            }
            match hello.map(|e| e.from) {
                Some(Node::Robot(j)) if j < n => {
                    tracing::warn!("{me}: robot {j} is back (it said hello) at timestep {step}: waiting for its moves again");
                    present[j] = true;
                    ask_to_show(&mut mb, Node::Robot(j), step)?;
                }
                _ => {
                    return Err(RuntimeError::Timeout {
                        node: me,
                        waiting_for: "any robot (every robot is absent)".into(),
                        timeout: timeouts.node,
                    })
                }
            }
        }
        send_contacts(&mut mb, &mut world, &present, step)?;
        for i in 0..n {
            let obs = Body::Observation(world.observation(i));
            mb.send(&Envelope::new(step, me, Node::Robot(i), obs))?;
        }
        heartbeat.sent();
        if let Some(show) = show.as_mut() {
            let pairs = exchanges(&mut mb, &mut heartbeat, step)?;
            show(&world, &shown, &pairs);
            heartbeat.beat(&mut mb, step)?;
        }
        // Every present robot's move by one deadline; an absent robot's only if already here.
        let deadline = Instant::now() + timeouts.node;
        for (i, m) in moves.iter_mut().enumerate() {
            let wait = if present[i] {
                deadline.saturating_duration_since(Instant::now())
            } else {
                Duration::ZERO
            };
            let e = heartbeat.try_take(&mut mb, step, wait, |e| {
                e.step == step && e.from == Node::Robot(i) && matches!(e.body, Body::Move(_))
            })?;
            *m = match e.map(|e| e.body) {
                Some(Body::Move(mv)) => {
                    if !present[i] {
                        tracing::warn!("{me}: robot {i} is back (its move arrived) at timestep {step}: waiting for its moves again");
                        present[i] = true;
                    }
                    mv
                }
                _ => {
                    if present[i] {
                        tracing::warn!(
                            "{me}: robot {i} sent no move for timestep {step} within {:?}: it stays where it is until it says hello",
                            timeouts.node
                        );
                        present[i] = false;
                    }
                    Move::Stay
                }
            };
        }
        absent_steps += present.iter().filter(|&&p| !p).count();
        if showing {
            for (i, &here) in present.iter().enumerate() {
                let wait = if here { timeouts.peer } else { Duration::ZERO };
                let e = heartbeat.try_take(&mut mb, step, wait, |e| {
                    e.step == step && e.from == Node::Robot(i) && matches!(e.body, Body::Shown(_))
                })?;
                match e.map(|e| e.body) {
                    Some(Body::Shown(s)) => shown[i] = s,
                    // Late: what it showed last stays; absent: nothing.
                    _ if here => {}
                    _ => shown[i] = Shown::default(),
                }
            }
        }
        with_beats(&mut heartbeat, &mut mb, step, |waiting| {
            world.step(&moves, waiting)
        })?
        .map_err(|what| RuntimeError::Ground { node: me, what })?;
        world.record(&mut recorder);
        positions.push(world.positions());
        // The caller may take its time here (a pace): the robots hear the world meanwhile.
        let next = with_beats(&mut heartbeat, &mut mb, step, |waiting| {
            on_step(&world, waiting)
        })?;
        if next.is_break() {
            break;
        }
    }
    let step = world.t() as u64;
    if let Some(show) = show.as_mut() {
        // The last picture's exchanges: the radio's for a timestep that will not be played.
        send_contacts(&mut mb, &mut world, &present, step)?;
        let pairs = exchanges(&mut mb, &mut heartbeat, step)?;
        show(&world, &shown, &pairs);
    }
    // The last timestep's outcome, for what the robots show (their ROS 2 topics), then stop.
    for i in 0..n {
        let last = Body::Final(world.observation(i));
        mb.send(&Envelope::new(step, me, Node::Robot(i), last))?;
    }
    for to in (0..n).map(Node::Robot).chain([Node::Radio]) {
        mb.send(&Envelope::new(step, me, to, Body::Stop))?;
    }
    let trial_s = started.elapsed().as_secs_f64();
    let (mut decisions, mut decision_s) = (0, 0.0);
    let mut latency = Latency::default();
    let mut latency_s = 0.0;
    for i in (0..n).filter(|&i| present[i]) {
        let e = mb.try_take(timeouts.node, |e| {
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
        absent_robot_steps: absent_steps,
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
