//! The robot node: one [`Agent`] that sees the world only through the observations it is sent,
//! hears teammates only through the β and plans the radio forwards, and acts only by sending a
//! move. A teammate (or the radio) that stays silent past [`Timeouts::peer`] is done without
//! for that timestep; a β that arrives late is merged when it arrives.

use crate::mailbox::{Mailbox, Traffic};
use crate::transport::Transport;
use crate::wire::{BetaMessage, Body, Envelope, Node, Shown};
use crate::{RuntimeError, Timeouts};
use madenet_agent::{Agent, Beta};
use madenet_map::Occupancy;
use std::collections::{HashMap, HashSet};
use std::time::Duration;

/// What a robot node remembers of its map exchanges, to send each teammate only the changes.
#[derive(Default)]
struct MapExchanges {
    /// Per teammate: the timestep and map of the last β sent to it.
    sent_to: HashMap<usize, (usize, Vec<Occupancy>)>,
    /// Per teammate: the timestep of the last map taken in whole (full, or changes that fitted).
    heard_from: HashMap<usize, usize>,
    /// Teammates whose last changes did not fit: ask them for their whole map.
    want_full: HashSet<usize>,
    /// Malformed β dropped so far.
    dropped: usize,
}

impl MapExchanges {
    fn outgoing(&mut self, beta: &Beta, to: usize) -> BetaMessage {
        let base = self.sent_to.get(&to).map(|(t, m)| (*t, m.as_slice()));
        let msg = BetaMessage::new(beta, base, self.want_full.remove(&to));
        self.sent_to.insert(to, (beta.t, beta.map.clone()));
        msg
    }

    /// The β to merge from `msg`, or `None` when it is malformed — from a teammate that does
    /// not exist, a map of another size, cells outside the map: such a β is dropped and counted
    /// (a teammate started on another map must not end this robot).
    fn incoming(
        &mut self,
        me: Node,
        msg: &BetaMessage,
        cfg: &madenet_agent::AgentConfig,
    ) -> Option<Beta> {
        let j = msg.from;
        let inside = |p: madenet_map::Pos| {
            p.row >= 0
                && p.col >= 0
                && (p.row as usize) < cfg.height
                && (p.col as usize) < cfg.width
        };
        let positions_inside =
            inside(msg.pos) && msg.goal.is_none_or(inside) && msg.prev_goal.is_none_or(inside);
        let malformed = if j >= cfg.num_robots || j == cfg.id {
            Some("from a teammate that does not exist".to_string())
        } else if !positions_inside {
            Some("with a position or goal outside this map".to_string())
        } else {
            None
        };
        let converted = match malformed {
            Some(why) => Err(why),
            None => msg
                .to_beta(self.heard_from.get(&j).copied(), cfg.height * cfg.width)
                .map_err(|e| e.to_string()),
        };
        let (beta, fitted) = match converted {
            Ok(b) => b,
            Err(why) => {
                self.dropped += 1;
                tracing::warn!(
                    "{me}: dropped a β of robot {j} for timestep {} ({why}); {} dropped so far — are all nodes started with the same map and config?",
                    msg.t,
                    self.dropped
                );
                return None;
            }
        };
        if msg.want_full {
            self.sent_to.remove(&j);
        }
        if fitted {
            self.heard_from.insert(j, msg.t);
        } else {
            tracing::warn!(
                "{me}: the map changes from robot {j} at timestep {} build on a map not received here: merged what came, asking for its whole map",
                msg.t
            );
            self.want_full.insert(j);
        }
        Some(beta)
    }
}

/// Checks what arrived before the agent takes it in: an observation for this robot, of cells and
/// teammates that exist, so a malformed message ends the node with an error rather than a panic.
fn check_observation(
    me: Node,
    step: u64,
    cfg: &madenet_agent::AgentConfig,
    obs: &madenet_world::Observation,
) -> Result<(), RuntimeError> {
    let inside = |p: madenet_map::Pos| {
        p.row >= 0 && p.col >= 0 && (p.row as usize) < cfg.height && (p.col as usize) < cfg.width
    };
    let teammate = |j: usize| j < cfg.num_robots && j != cfg.id;
    let what = if obs.robot != cfg.id {
        "an observation of another robot"
    } else if !inside(obs.pos) || obs.seen.iter().any(|&(p, _)| !inside(p)) {
        "an observation of cells outside the map"
    } else if obs
        .teammates
        .iter()
        .any(|&(j, p)| !teammate(j) || !inside(p))
    {
        "an observation of a teammate that does not exist"
    } else {
        return Ok(());
    };
    Err(RuntimeError::Unexpected {
        node: me,
        from: Node::World,
        step,
        what,
    })
}

/// How often a robot says hello until the world answers.
const HELLO_EVERY: Duration = Duration::from_millis(500);

/// Runs robot `agent`'s node until the world says stop; returns what it sent (all of it, and
/// the part that went to teammates).
pub fn run_robot<T: Transport>(
    agent: Agent,
    transport: T,
    timeouts: Timeouts,
) -> Result<(Traffic, Traffic), RuntimeError> {
    run_robot_with(agent, transport, timeouts, None, |_, _, _| {})
}

/// [`run_robot`], its hello carrying `scenario` (the [`scenario_digest`](crate::wire::scenario_digest)
/// of what it was started with; a world started with others refuses it), calling
/// `on_step(timestep, agent, false)` after each move it sends (progress), and
/// `on_step(timestep, agent, true)` once the trial is over, after the agent observed where it
/// ended ([`Body::Final`]).
pub fn run_robot_with<T: Transport>(
    mut agent: Agent,
    transport: T,
    timeouts: Timeouts,
    scenario: Option<u64>,
    mut on_step: impl FnMut(u64, &Agent, bool),
) -> Result<(Traffic, Traffic), RuntimeError> {
    let i = agent.id();
    let me = Node::Robot(i);
    let mut mb = Mailbox::new(transport, me);
    mb.connect(&[Node::World, Node::Radio], timeouts.node)?;
    // Say hello until the world answers: a world that has given up on this robot (it was
    // killed and is now restarted) waits for its moves again.
    let started = std::time::Instant::now();
    loop {
        mb.send(&Envelope::new(0, me, Node::World, Body::Hello { scenario }))?;
        if mb
            .try_take(HELLO_EVERY, |e| e.from == Node::World)?
            .is_some_and(|first| {
                mb.pending.insert(0, first);
                true
            })
        {
            break;
        }
        if started.elapsed() > timeouts.world_start() {
            return Err(RuntimeError::Timeout {
                node: me,
                waiting_for: "the world's first message after hello".into(),
                timeout: timeouts.world_start(),
            });
        }
    }
    let mut to_world = mb.sent;
    let mut maps = MapExchanges::default();
    // Whether the world asked for what this robot shows (pictures).
    let mut show = false;
    // Observation to move: timesteps acted, total and longest latency.
    let (mut acted, mut latency, mut latency_max) = (0, Duration::ZERO, Duration::ZERO);
    loop {
        let e = mb.take(
            "an observation from the world",
            timeouts.world_silence(),
            |e| e.from == Node::World,
        )?;
        let step = e.step;
        let observed = std::time::Instant::now();
        let mut obs = match e.body {
            Body::Observation(o) => o,
            Body::Show => {
                show = true;
                continue;
            }
            // The world is waiting (for an absent teammate, a slow ground): wait on.
            Body::Waiting => continue,
            // The trial is over: observe where it ended (for what this robot shows); the
            // world's stop follows.
            Body::Final(o) => {
                check_observation(me, step, agent.config(), &o)?;
                agent.observe(&o);
                on_step(step, &agent, true);
                continue;
            }
            Body::Stop => {
                let between = Traffic {
                    messages: mb.sent.messages - to_world.messages,
                    bytes: mb.sent.bytes - to_world.bytes,
                };
                let stats = agent.stats();
                let done = Body::Done {
                    decisions: stats.decisions,
                    decision_s: stats.decision_time.as_secs_f64(),
                    acted,
                    latency_s: latency.as_secs_f64(),
                    latency_max_s: latency_max.as_secs_f64(),
                };
                mb.send(&Envelope::new(step, me, Node::World, done))?;
                return Ok((mb.sent, between));
            }
            _ => {
                return Err(RuntimeError::Unexpected {
                    node: me,
                    from: e.from,
                    step,
                    what: "the world sends observations, show, waiting, final and stop only",
                })
            }
        };
        check_observation(me, step, agent.config(), &obs)?;
        // Behind (restarted, or slowed by silent teammates)? Skip to the newest observation.
        mb.drain()?;
        if mb.pending.iter().any(|p| {
            p.from == Node::World && p.step > step && matches!(p.body, Body::Observation(_))
        }) {
            continue;
        }
        // β that arrived after their timestep are merged now (a delaying radio, a slow
        // teammate); everything else of past timesteps is over.
        let mut late: Vec<Beta> = Vec::new();
        for e in mb.forget_before(step, |e| matches!(e.body, Body::Beta(_))) {
            if let Body::Beta(m) = &e.body {
                late.extend(maps.incoming(me, m, agent.config()));
            }
        }
        // 1–2. observe, with this timestep's links from the radio.
        let links = mb.try_take(timeouts.peer, |e| {
            e.step == step && e.from == Node::Radio && matches!(e.body, Body::Links { .. })
        })?;
        let n = agent.config().num_robots;
        let (now, delayed) = match links.map(|e| e.body) {
            Some(Body::Links { now, late }) => {
                if now.iter().chain(&late).any(|&j| j >= n || j == i) {
                    return Err(RuntimeError::Unexpected {
                        node: me,
                        from: Node::Radio,
                        step,
                        what: "links to a teammate that does not exist",
                    });
                }
                (now, late)
            }
            _ => {
                tracing::warn!(
                    "{me}: no links from the radio for timestep {step} within {:?}: exchanging with nobody",
                    timeouts.peer
                );
                (Vec::new(), Vec::new())
            }
        };
        obs.exchanged_with = now;
        agent.observe(&obs);
        // 3. β along this timestep's exchanges (and the delayed ones), merged in sender order.
        let partners = agent.exchanged_with().to_vec();
        if !partners.is_empty() || !delayed.is_empty() {
            let beta = agent.beta();
            for &j in partners.iter().chain(&delayed) {
                let msg = Body::Beta(maps.outgoing(&beta, j));
                mb.send(&Envelope::new(step, me, Node::Robot(j), msg))?;
            }
        }
        for &j in &partners {
            let e = mb.try_take(timeouts.peer, |e| {
                e.step == step && e.from == Node::Robot(j) && matches!(e.body, Body::Beta(_))
            })?;
            match e.map(|e| e.body) {
                Some(Body::Beta(m)) => late.extend(maps.incoming(me, &m, agent.config())),
                _ => tracing::warn!(
                    "{me}: no β from robot {j} for timestep {step} within {:?}",
                    timeouts.peer
                ),
            }
        }
        late.sort_by_key(|b| b.from);
        for b in &late {
            agent.receive_beta(b);
        }
        // 4. decide (own policy) when the macro action ended
        if agent.needs_decision() {
            agent.decide();
        }
        // 5. plan in priority order: the plans of higher-priority partners first.
        let mut higher: Vec<usize> = partners.iter().copied().filter(|&j| j < i).collect();
        higher.sort_unstable();
        for j in higher {
            let e = mb.try_take(timeouts.peer, |e| {
                e.step == step && e.from == Node::Robot(j) && matches!(e.body, Body::Plan(_))
            })?;
            match e.map(|e| e.body) {
                Some(Body::Plan(p)) => agent.receive_plan(&p),
                _ => tracing::warn!(
                    "{me}: no plan from robot {j} for timestep {step} within {:?}",
                    timeouts.peer
                ),
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
        let took = observed.elapsed();
        acted += 1;
        latency += took;
        latency_max = latency_max.max(took);
        if show {
            let shown = Body::Shown(Shown {
                goal: agent.goal(),
                path: agent.path().to_vec(),
                candidates: agent.candidates().cells.clone(),
                exchanged_with: agent.exchanged_with().to_vec(),
                scores: agent.policy_scores().map_or_else(Vec::new, <[f32]>::to_vec),
                decisions: agent.stats().decisions as u64,
            });
            mb.send(&Envelope::new(step, me, Node::World, shown))?;
        }
        to_world.messages += mb.sent.messages - before.messages;
        to_world.bytes += mb.sent.bytes - before.bytes;
        on_step(step, &agent, false);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use madenet_map::Pos;

    fn message(from: usize, cells: usize, pos: Pos) -> BetaMessage {
        let beta = Beta {
            from,
            t: 4,
            prev_goal: None,
            pos,
            goal: Some(Pos::new(2, 3)),
            map: vec![Occupancy::Free; cells],
            explored: cells,
        };
        BetaMessage::new(&beta, None, false)
    }

    /// A β of another map size, of a robot that does not exist or of cells outside the map is
    /// dropped and counted; the next good one is merged as ever.
    #[test]
    fn a_malformed_beta_is_dropped_and_counted_not_fatal() {
        let cfg = madenet_agent::AgentConfig::from_scenario(&Default::default(), 0, 20, 20);
        let me = Node::Robot(0);
        let mut maps = MapExchanges::default();
        assert!(maps
            .incoming(me, &message(1, 30 * 30, Pos::new(1, 1)), &cfg)
            .is_none());
        assert!(maps
            .incoming(me, &message(7, 400, Pos::new(1, 1)), &cfg)
            .is_none());
        assert!(maps
            .incoming(me, &message(0, 400, Pos::new(1, 1)), &cfg)
            .is_none());
        assert!(maps
            .incoming(me, &message(1, 400, Pos::new(25, 1)), &cfg)
            .is_none());
        assert_eq!(maps.dropped, 4);
        let beta = maps.incoming(me, &message(1, 400, Pos::new(1, 1)), &cfg);
        assert_eq!(beta.map(|b| (b.from, b.map.len())), Some((1, 400)));
        assert_eq!(maps.dropped, 4);
    }
}
