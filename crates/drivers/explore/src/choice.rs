//! Any madenet policy in the node (`policy: spread`, `made-net-any`, `nf`, …): the paper's
//! agent ([`madenet_agent::Agent`]) on the robot's map read into its 1 m cells
//! ([`crate::cells`]), as the continuous world's robots read theirs.
//!
//! At each plan the agent observes the cells its map newly reads, hears each teammate as the
//! paper's β (Sec. III.C.1: the teammate's shared map read into cells, its position, its goal
//! and its previous goal, from [`crate::team`]) while it was heard in the last
//! [`SILENT_AGE`] seconds, counts as detected the teammates within d_s
//! cells heard in the last [`DETECTION_AGE`] seconds, and decides when its macro action ends
//! (goal reached, no longer a frontier, unreachable, a teammate newly detected) or when a
//! teammate's intent changes onto its goal (the teammate's new goal within a cell of its
//! own). Its goal cell's centre goes to nav2.
//!
//! Cells the robot cannot resolve are written off, as in the continuous trial: the unknown
//! neighbours of a goal it reached, a second after (it cannot see them from there: for good if
//! its map saw part of them, a wall's face; else until the blacklist expires, as they may be
//! round a corner or behind a teammate), and a goal nav2 aborted or that made no progress for `progress_timeout` (on the expiring
//! [`Blacklist`]: when it expires the agent's belief is read afresh from the maps, so the cell
//! is tried again).

use crate::cells::{CellReader, Geometry};
use crate::node::{Blacklist, Choice, Chooser, ExploreError, PlanInput, Progress, Shown};
use crate::params::ExploreParams;
use madenet_agent::{Agent, AgentConfig, Beta};
use madenet_map::{Occupancy, Pos};
use madenet_ros2::actions::status;
use madenet_sim::{PolicyContext, PolicyRegistry};
use madenet_world::{Observation, ScenarioConfig};

/// Seconds since a teammate's position was heard within which it counts as detected.
pub const DETECTION_AGE: f64 = 2.0;

/// Seconds since a teammate was last heard after which it is not exchanged with (its β is
/// not taken again): a teammate whose node has died is not heard as if it were still there.
pub const SILENT_AGE: f64 = 5.0;

/// Seconds without a goal or a reachable frontier before exploration is complete (the maps
/// the node reads may lag what the robot saw).
pub const NO_FRONTIER_TIME: f64 = 5.0;

/// The continuous world's `mapping.known_fraction`: a cell is known free once this fraction
/// of its pixels are observed.
const KNOWN_FRACTION: f64 = 0.5;

/// The agent and what it reads.
struct Reading {
    agent: Agent,
    own: CellReader,
    /// Per teammate (in [`crate::team::Team::mates`] order), its shared map's cells.
    mates: Vec<Option<CellReader>>,
}

/// A madenet policy's chooser.
pub(crate) struct AgentChoice {
    name: String,
    registry: PolicyRegistry,
    scenario: ScenarioConfig,
    reading: Option<Reading>,
    /// Observations so far (the agent's timestep).
    t: usize,
    blacklist: Blacklist,
    /// Cells written off (goals that failed, unresolvable neighbours of reached goals).
    written: Vec<Pos>,
    /// The goal cell sent to nav2, if any.
    goal: Option<Pos>,
    /// The nearest distance to the goal, and when it was reached.
    progress: Progress,
    /// A goal cell reached, and when.
    reached: Option<(Pos, f64)>,
    /// The time of the last plan.
    last_plan: f64,
    /// Since when the agent has had no goal and no frontier.
    idle_since: Option<f64>,
    /// Each teammate's goal cell at the last plan (to see its intent change).
    mate_goals: Vec<Option<Pos>>,
}

impl AgentChoice {
    /// The chooser of policy `name` (of madenet's catalogue).
    pub(crate) fn new(name: &str, p: &ExploreParams, ns: &str) -> Result<Self, ExploreError> {
        let registry = madenet_catalogue::shipped().map_err(|e| ExploreError::Policy {
            name: name.into(),
            why: e.to_string(),
        })?;
        if !registry.names().iter().any(|n| n == name) {
            return Err(ExploreError::Policy {
                name: name.into(),
                why: format!(
                    "unknown (explore-lite, or one of madenet's: {})",
                    registry.names().join(", ")
                ),
            });
        }
        tracing::info!("{ns}: goals chosen by {name} on 1 m cells");
        Ok(AgentChoice {
            name: name.into(),
            registry,
            scenario: ScenarioConfig::default(),
            reading: None,
            t: 0,
            blacklist: Blacklist::default(),
            written: Vec::new(),
            goal: None,
            progress: Progress::new(p.progress_timeout),
            reached: None,
            last_plan: 0.0,
            idle_since: None,
            mate_goals: Vec::new(),
        })
    }

    /// A fresh agent for a map of `geometry`, robot `me` of `size`, at `here`.
    fn read_afresh(
        &mut self,
        geometry: Geometry,
        me: usize,
        size: usize,
        here: (f64, f64),
        mates: usize,
    ) -> Result<Option<Reading>, ExploreError> {
        let s = &mut self.scenario;
        let own = CellReader::new(geometry, s.cell_size, &s.discretize, KNOWN_FRACTION);
        let (rows, cols) = own.size();
        let Some(start) = own.cell_at(here.0, here.1) else {
            return Ok(None);
        };
        s.num_robots = size;
        let ctx = PolicyContext {
            seed: 0,
            robot: me,
            config: s,
            height: rows,
            width: cols,
        };
        let policy = self
            .registry
            .make(&self.name, &ctx)
            .map_err(|e| ExploreError::Policy {
                name: self.name.clone(),
                why: e.to_string(),
            })?;
        self.t = 0;
        Ok(Some(Reading {
            agent: Agent::new(AgentConfig::from_scenario(s, me, rows, cols), start, policy),
            own,
            mates: (0..mates).map(|_| None).collect(),
        }))
    }
}

impl Chooser for AgentChoice {
    fn ended(&mut self, st: i8, now: f64) {
        let Some(g) = self.goal.take() else {
            return;
        };
        match st {
            status::SUCCEEDED => {
                self.reached.get_or_insert((g, now));
            }
            status::CANCELED | status::UNKNOWN => {}
            _ => self.write_off(g, now, false),
        }
    }

    fn blacklisted(&self) -> usize {
        self.blacklist.len()
    }

    fn shown(&self) -> Shown {
        let Some(r) = &self.reading else {
            return Shown::default();
        };
        Shown {
            options: (r.agent.candidates().cells.iter())
                .map(|&c| r.own.centre(c))
                .collect(),
            blacklisted: self.blacklist.points(self.last_plan),
        }
    }

    fn plan(&mut self, at: PlanInput<'_>) -> Result<Choice, ExploreError> {
        let PlanInput {
            ns,
            map,
            here,
            now,
            team,
            nav_progress_at,
        } = at;
        let (me, size, mates) = team
            .as_ref()
            .map_or((0, 1, 0), |t| (t.me, t.size, t.mates().len()));
        let geometry = Geometry::of(map);
        let stale = self
            .reading
            .as_ref()
            .is_none_or(|r| r.own.geometry() != geometry);
        if stale || self.blacklist.expired_since(self.last_plan, now) {
            self.reading = self.read_afresh(geometry, me, size, here, mates)?;
        }
        self.last_plan = now;
        let cell_size = self.scenario.cell_size;
        let d_s = self.scenario.sensing_range;
        let tol = 0.5 * cell_size;
        let Some(r) = self.reading.as_mut() else {
            tracing::warn!("{ns}: the robot is off its map: no goal");
            return Ok(Choice::Keep);
        };
        let Some(pos) = r.own.cell_at(here.0, here.1) else {
            tracing::warn!("{ns}: the robot is off its map: no goal");
            return Ok(Choice::Keep);
        };
        let mut seen = Vec::new();
        r.own.read(map, &mut seen);
        // Unknown neighbours of a goal reached a second ago: it cannot see them from there.
        if let Some((g, at)) = self.reached {
            if now >= at + 1.0 {
                self.reached = None;
                for (dr, dc) in madenet_agent::belief::NEIGHBOURS {
                    let q = Pos::new(g.row + dr, g.col + dc);
                    let (rows, cols) = r.own.size();
                    if q.row >= 0
                        && q.col >= 0
                        && (q.row as usize) < rows
                        && (q.col as usize) < cols
                        && r.agent.belief().get(q) == Occupancy::Unknown
                    {
                        // Seen in part (a wall's face): for good; not seen at all (round a
                        // corner, behind a teammate): until the blacklist expires.
                        let seen_part = r.own.observed(q) > 0;
                        tracing::debug!(
                            "{ns} at {now:.1} s: wrote off {q:?} (seen in part: {seen_part})"
                        );
                        self.blacklist.list(r.own.centre(q), now, tol, seen_part);
                        if !self.written.contains(&q) {
                            self.written.push(q);
                        }
                    }
                }
            }
        }
        for &q in &self.written {
            if self.blacklist.listed(r.own.centre(q), now, tol) {
                r.own.write_off(q, &mut seen);
            }
        }
        // Teammates: β from what they shared; detected within d_s when heard lately.
        let (mut detected, mut exchanged) = (Vec::new(), Vec::new());
        let mut clash = false;
        if let Some(team) = team {
            for k in 0..mates {
                let fresh = team.mates()[k].fresh_map || r.mates[k].is_none();
                if fresh {
                    if let Some(m) = team.map_of(k).filter(|m| Geometry::of(m) == geometry) {
                        let reader = r.mates[k].get_or_insert_with(|| {
                            let s = &self.scenario;
                            CellReader::new(geometry, s.cell_size, &s.discretize, KNOWN_FRACTION)
                        });
                        reader.read(m, &mut Vec::new());
                    }
                }
                let mate = &team.mates()[k];
                let cell = |p: Option<(f64, f64)>| p.and_then(|(x, y)| r.own.cell_at(x, y));
                let Some(((x, y), heard)) = mate.pos else {
                    continue;
                };
                let Some(their) = r.own.cell_at(x, y) else {
                    continue;
                };
                let map = match &r.mates[k] {
                    Some(m) => m.cells().to_vec(),
                    None => vec![Occupancy::Unknown; r.own.cells().len()],
                };
                let explored = map.iter().filter(|&&c| c != Occupancy::Unknown).count();
                let their_goal = cell(mate.goal);
                // A teammate's intent changed onto (or next to) this robot's goal.
                if self.mate_goals.get(k).copied().flatten() != their_goal {
                    let mine = r.agent.goal();
                    clash |= their_goal
                        .zip(mine)
                        .is_some_and(|(t, g)| t.chebyshev(g) <= 1);
                }
                if self.mate_goals.len() <= k {
                    self.mate_goals.resize(k + 1, None);
                }
                self.mate_goals[k] = their_goal;
                // A teammate not heard lately (its node gone, or out of reach) is not
                // exchanged with: what it said last stays with the agent, as in the paper.
                if now - heard > SILENT_AGE {
                    continue;
                }
                r.agent.receive_beta(&Beta {
                    from: mate.index,
                    t: self.t,
                    prev_goal: cell(mate.prev_goal),
                    pos: their,
                    goal: their_goal,
                    map,
                    explored,
                });
                exchanged.push(mate.index);
                if now - heard <= DETECTION_AGE && pos.chebyshev(their) <= d_s {
                    detected.push((mate.index, their));
                }
            }
        }
        let obs = Observation {
            robot: me,
            t: self.t,
            pos,
            seen,
            teammates: detected,
            exchanged_with: exchanged,
        };
        self.t += 1;
        let a = &mut r.agent;
        a.observe(&obs);
        if a.goal() == Some(pos) && self.reached.is_none() {
            self.reached = Some((pos, now));
        }
        if a.needs_decision() {
            let why = a.termination();
            a.decide();
            tracing::debug!(
                "{ns} at {now:.1} s in {pos:?}: {why:?} → goal {:?}",
                a.goal()
            );
        } else if clash {
            a.decide();
            tracing::debug!(
                "{ns} at {now:.1} s: a teammate's goal moved onto its own → {:?}",
                a.goal()
            );
        }
        let Some(g) = a.goal() else {
            // Done when no frontier is reachable, teammates or not in the way, with nothing
            // waiting out the blacklist, for NO_FRONTIER_TIME (the maps may lag).
            let b = a.belief();
            let reach = a.reachable();
            let open = (0..b.map().len()).any(|k| reach[k] && b.is_frontier_index(k));
            if open || self.blacklist.pending(now) {
                self.idle_since = None;
                return Ok(Choice::Keep);
            }
            let since = *self.idle_since.get_or_insert(now);
            return Ok(match now - since >= NO_FRONTIER_TIME {
                true => Choice::Complete,
                false => Choice::Keep,
            });
        };
        self.idle_since = None;
        let target = r.own.centre(g);
        let d = (here.0 - target.0).hypot(here.1 - target.1);
        if self.goal != Some(g) {
            self.goal = Some(g);
            self.progress.restart(d, now);
            return Ok(Choice::Send(target));
        }
        // Progress: nearer by half a cell.
        self.progress.update(d, now, 0.5 * cell_size);
        if let Some(waited) = self.progress.stalled(now, nav_progress_at) {
            tracing::info!(
                "{ns}: gave up the goal {g:?} at ({:.2}, {:.2}), {d:.1} m away: no progress for {waited:.0} s",
                target.0,
                target.1,
            );
            self.goal = None;
            self.write_off(g, now, false);
            return Ok(Choice::GiveUp);
        }
        Ok(Choice::Keep)
    }
}

impl AgentChoice {
    /// Writes cell `g` off: on the blacklist (for good, or until it expires) and, from the next
    /// plan, an obstacle to the agent.
    fn write_off(&mut self, g: Pos, now: f64, for_good: bool) {
        let Some(r) = &self.reading else {
            return;
        };
        let tol = 0.5 * self.scenario.cell_size;
        self.blacklist.list(r.own.centre(g), now, tol, for_good);
        if !self.written.contains(&g) {
            self.written.push(g);
        }
    }
}
