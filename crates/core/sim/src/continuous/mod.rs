//! A trial in the continuous world (`madenet_continuous`): the same agents and policies as the
//! grid [`crate::Trial`], in continuous time, each robot on its own clock.
//!
//! Every control period, in order:
//! 1. **Radio** (at `radio_rate_hz`): pairs within d_s with line of sight try to exchange
//!    (CSP, dropouts: [`madenet_world::Radio`]); β goes both ways along each success.
//! 2. **Agents**: a robot asks its agent for a move when it enters its target cell (a tenth
//!    of a cell past its edge, or at the local path's end: [`LocalPlanner::entered`]; cells a
//!    detour passes through do not count), when its agent said "stay" `stay_period` seconds ago,
//!    when its local planner found the target cell impassable, or when teammates have held it
//!    up for `wait_time` seconds. A scan after a robot reached its goal, the neighbours of that
//!    cell its map still cannot read are written off as obstacles to it (seen from the frontier
//!    they border, they never will be). The agent observes (its map's newly read cells, the
//!    teammates in view, whom it exchanged with), decides if its macro action ended, plans, and
//!    names the next cell. When no robot's agent has a reachable frontier left though the
//!    world is incomplete, the trial ends `no_frontier_time` later and says so.
//! 3. **Local planning**: each robot's planner drives toward its target cell. The stuck rule:
//!    a target not entered `stuck_time` seconds after it was named is impassable to the robot.
//! 4. **World**: motion, contacts, scans ([`ContinuousWorld::step`]).

use crate::registry::PolicyRegistry;
use crate::stepping::{Present, RobotShown, Stepping};
use crate::trial::{build_agent, TrialSpec};
use crate::SimError;
use madenet_agent::{Agent, Beta, Decision};
use madenet_continuous::{
    Collisions, Command, ContinuousConfig, ContinuousWorld, LocalPlanner, Scene,
};
use madenet_map::{Occupancy, Pos};
use madenet_world::{Observation, Radio, ScenarioConfig};
use serde::{Deserialize, Serialize};
use spare::Spare;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

/// Everything that defines a continuous trial.
#[derive(Clone, Debug)]
pub struct ContinuousSpec {
    /// The true geometry.
    pub scene: Arc<Scene>,
    /// Start cells (of `config.cell_size` metres): robot i starts at the centre of `starts[i]`.
    pub starts: Vec<Pos>,
    /// The scenario (team size, d_s, CSP, dropout, the discretization rule, |G|).
    pub config: ScenarioConfig,
    /// The continuous world's parameters.
    pub continuous: ContinuousConfig,
    /// Every robot's policy, by registry name.
    pub policy: String,
    /// Seed of the sensors, the radio and the policies.
    pub seed: u64,
}

impl ContinuousSpec {
    /// The world this spec names: its robots at their starts, no agents (a
    /// [`ContinuousTrial`] adds them; the nav2 sim drives the robots from outside).
    pub fn world(&self) -> Result<ContinuousWorld, SimError> {
        ContinuousWorld::new(
            self.scene.clone(),
            &self.starts,
            self.config.clone(),
            self.continuous,
            self.seed,
        )
        .map_err(|e| SimError::Continuous(e.to_string()))
    }
}

/// The outcome of a continuous trial.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContinuousResult {
    /// The scene's name.
    pub map: String,
    /// The policy's registry name.
    pub policy: String,
    /// The trial's seed.
    pub seed: u64,
    /// CSP.
    pub comm_success_prob: f64,
    /// Whether the team explored every explorable cell before the time cap.
    pub complete: bool,
    /// When no robot's agent had a reachable frontier left though the world was incomplete
    /// (the team then stopped exploring: the trial ended `no_frontier_time` later).
    pub no_frontier_at: Option<f64>,
    /// ET: simulated seconds until exploration ended — complete, the team out of frontiers
    /// (`no_frontier_at`), or the time cap.
    pub exploration_time_s: f64,
    /// TTD: metres driven by the whole team.
    pub team_distance_m: f64,
    /// Robot–obstacle collisions.
    pub obstacle_collisions: u64,
    /// Robot–robot collisions.
    pub robot_collisions: u64,
    /// Local interactions: pairs in contact summed over radio rounds.
    pub local_interactions: u64,
    /// Cells a local planner found impassable (read free on the coarse map, blocked in truth).
    pub impassable_cells: u64,
    /// Stuck events: a target cell not entered `planner.stuck_time` seconds after it was named.
    pub stuck: u64,
    /// Cells written off: unknown neighbours of a reached goal its robot could not see from it.
    pub written_off_cells: u64,
    /// Explorable cells counted as explored though no robot's map read them (written off or
    /// found impassable before anyone saw them).
    pub unread_cells: u64,
    /// Explorable cells (free in truth, reachable, enterable by a robot's footprint).
    pub explorable_cells: u64,
    /// Times a robot was held up by teammates for `wait_time` seconds and asked its agent again.
    pub held_up: u64,
    /// Decisions taken by the agents.
    pub decisions: usize,
    /// Explored fraction at every whole simulated second (index = second).
    pub explored: Vec<f64>,
    /// Metres the team has driven at every whole simulated second, aligned with `explored`.
    pub distance: Vec<f64>,
    /// Wall-clock seconds the trial took.
    pub wall_s: f64,
}

impl ContinuousResult {
    /// The grid world's metrics of this trial, with the simulated second as the timestep:
    /// TNS is ET rounded up to whole seconds, `steps_to` in whole seconds, OFV over the
    /// per-second curves, NOLI (both counts) the local interactions of the radio rounds.
    pub fn metrics(&self) -> madenet_metrics::TrialMetrics {
        let mut rec = madenet_metrics::MetricsRecorder::new(self.explored[0]);
        for (&e, &d) in self.explored.iter().zip(&self.distance).skip(1) {
            rec.record(e, d, 0, 0);
        }
        let mut m = rec.finish(self.complete);
        m.noli = self.local_interactions as usize;
        m.noli_authors = self.local_interactions as usize;
        m
    }

    /// Simulated seconds per wall-clock second.
    pub fn real_time_factor(&self) -> f64 {
        if self.wall_s > 0.0 {
            self.exploration_time_s / self.wall_s
        } else {
            f64::INFINITY
        }
    }
}

/// Why robot i must ask its agent now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ask {
    No,
    Yes,
}

/// The stuck rule's clock of one robot: since when its current target has been named, and
/// the cell it stood in then.
#[derive(Clone, Copy, Debug, PartialEq)]
struct StuckClock {
    since: f64,
    from: Pos,
}

impl Default for StuckClock {
    fn default() -> Self {
        StuckClock {
            since: 0.0,
            from: Pos::new(-1, -1),
        }
    }
}

impl StuckClock {
    /// A new target named at `now` from cell `here` (`had_target`: the robot was driving to
    /// another). The clock restarts, but runs on while the robot has not left the cell it was
    /// in when the clock started: a robot held in place whose agent names one first step, then
    /// another (two ways round to one goal), would otherwise restart it with every new name
    /// and never be found stuck (measured: a 40 m trial held 500 s in one cell until the time
    /// cap).
    fn named(&mut self, had_target: bool, here: Pos, now: f64) {
        if !had_target || self.from != here {
            *self = StuckClock {
                since: now,
                from: here,
            };
        }
    }
}

/// A trial in the continuous world.
pub struct ContinuousTrial {
    world: ContinuousWorld,
    agents: Vec<Agent>,
    planners: Vec<LocalPlanner>,
    radio: Radio,
    targets: Vec<Option<Pos>>,
    cells: Vec<Pos>,
    ask_at: Vec<f64>,
    asks: Vec<Ask>,
    agent_t: Vec<usize>,
    held_since: Vec<Option<f64>>,
    replan: Vec<bool>,
    commands: Vec<Command>,
    /// The goal cell a robot reached, and when: its unknown neighbours are written off a scan
    /// later if it could not see them.
    reached: Vec<Option<(Pos, f64)>>,
    written_off: u64,
    /// The cells each robot has stood in (row-major masks of the coarse grid).
    visited: Vec<Vec<bool>>,
    /// The cells spared from robot i's write-off (a teammate may hide it, or it is a corner
    /// cell with a side cell not yet stood in), and since when.
    spared: BTreeMap<(usize, Pos), Spare>,
    /// When each robot's current target was named (the stuck rule), and the cell the robot
    /// was in then.
    clocks: Vec<StuckClock>,
    stuck: u64,
    /// Since when no robot's agent has had a reachable frontier.
    no_frontier_since: Option<f64>,
    exchanged: Vec<Vec<usize>>,
    /// The last radio round's pairs in contact, and of those the ones that exchanged β.
    radio_contacts: Vec<(usize, usize)>,
    radio_exchanges: Vec<(usize, usize)>,
    radio_every: u64,
    ticks: u64,
    seen: Vec<(Pos, Occupancy)>,
    outbox: Vec<Beta>,
    spec_map: String,
    policy: String,
    seed: u64,
    local_interactions: u64,
    impassable: u64,
    held_up: u64,
    explored: Vec<f64>,
    distance: Vec<f64>,
    /// Per robot, where it was every [`TRAIL_EVERY`] control periods (pictures).
    trails: Vec<Vec<(f32, f32)>>,
    started: Instant,
    /// Decisions come from outside ([`ContinuousTrial::with_external_decisions`]).
    external: bool,
    /// Robots waiting for an outside decision.
    deciding: Vec<bool>,
    /// A control period is half done: its agents were asked, its motion is still to come.
    resuming: bool,
}

/// Control periods between two points of a robot's trail ([`ContinuousTrial::trail`]).
const TRAIL_EVERY: u64 = 4;

impl ContinuousTrial {
    /// Builds the world and the agents (policies from `registry`).
    pub fn new(spec: ContinuousSpec, registry: &PolicyRegistry) -> Result<Self, SimError> {
        let world = spec.world()?;
        let n = world.robots();
        // The agents see only the map's size (their cells).
        let grid_spec = TrialSpec {
            map: world.coarse_truth().clone(),
            map_name: spec.scene.name.clone(),
            starts: spec.starts.clone(),
            config: spec.config.clone(),
            policy: spec.policy.clone(),
            seed: spec.seed,
        };
        let agents = (0..n)
            .map(|i| build_agent(&grid_spec, registry, i))
            .collect::<Result<Vec<_>, _>>()?;
        let radio_every = (1.0 / (spec.continuous.radio_rate_hz * spec.continuous.control_period))
            .round()
            .max(1.0) as u64;
        let cells: Vec<Pos> = (0..n).map(|i| world.cell_of(i)).collect();
        let (h, w) = world.map(0).coarse_size();
        let visited = cells
            .iter()
            .map(|c| {
                let mut v = vec![false; h * w];
                v[c.row as usize * w + c.col as usize] = true;
                v
            })
            .collect();
        let outbox = agents.iter().map(|a| a.beta()).collect();
        Ok(ContinuousTrial {
            radio: Radio::new(&spec.config, n, spec.seed),
            planners: vec![LocalPlanner::default(); n],
            targets: vec![None; n],
            cells,
            ask_at: vec![0.0; n],
            asks: vec![Ask::Yes; n],
            agent_t: vec![0; n],
            held_since: vec![None; n],
            replan: vec![false; n],
            commands: vec![Command::Drive(0.0, 0.0); n],
            reached: vec![None; n],
            written_off: 0,
            visited,
            spared: BTreeMap::new(),
            clocks: vec![StuckClock::default(); n],
            stuck: 0,
            no_frontier_since: None,
            exchanged: vec![Vec::new(); n],
            radio_contacts: Vec::new(),
            radio_exchanges: Vec::new(),
            radio_every,
            ticks: 0,
            seen: Vec::new(),
            outbox,
            spec_map: spec.scene.name.clone(),
            policy: spec.policy,
            seed: spec.seed,
            local_interactions: 0,
            impassable: 0,
            held_up: 0,
            explored: vec![world.explored_fraction()],
            distance: vec![0.0],
            trails: (0..n)
                .map(|i| {
                    let p = world.pose(i);
                    vec![(p.x as f32, p.y as f32)]
                })
                .collect(),
            started: Instant::now(),
            external: false,
            deciding: vec![false; n],
            resuming: false,
            agents,
            world,
        })
    }

    /// This trial taking its decisions from outside (an environment's caller): a robot whose
    /// macro action ended waits, in the middle of its control period, until
    /// [`ContinuousTrial::apply_decisions`] gives it one; [`ContinuousTrial::step`] then
    /// finishes the period.
    pub fn with_external_decisions(mut self, on: bool) -> Self {
        self.external = on;
        self
    }

    /// Which robots wait for an outside decision ([`ContinuousTrial::with_external_decisions`]).
    pub fn deciding(&self) -> &[bool] {
        &self.deciding
    }

    /// Robot `i`'s agent (an environment observes it, and reads its goal candidates).
    pub fn agent_mut(&mut self, i: usize) -> &mut Agent {
        &mut self.agents[i]
    }

    /// Gives each robot waiting for a decision its own: `Some(d)` from outside (a candidate
    /// index — the agent's candidates extracted first, by [`Agent::view`]`(true)` or
    /// [`Agent::adopt_candidates`] —, a goal cell, or idling), `None` from its own policy.
    /// Robots not waiting are skipped. The robots then plan and name their next cells, and the next
    /// [`ContinuousTrial::step`] finishes the control period they were asked in.
    pub fn apply_decisions(&mut self, decisions: &[Option<Decision>]) {
        for i in 0..self.agents.len() {
            if !std::mem::take(&mut self.deciding[i]) {
                continue;
            }
            let a = &mut self.agents[i];
            match decisions.get(i).copied().flatten() {
                Some(d) => a.apply_decision(d),
                None => a.decide(),
            }
            self.act(i);
        }
    }

    /// The world.
    pub fn world(&self) -> &ContinuousWorld {
        &self.world
    }
    /// The agents, robot i at index i.
    pub fn agents(&self) -> &[Agent] {
        &self.agents
    }
    /// Where robot `i` has been (metres, every fifth of a second at the default control period,
    /// the start first): the trail pictures draw.
    pub fn trail(&self, i: usize) -> &[(f32, f32)] {
        &self.trails[i]
    }
    /// Robot `i`'s local planner (its local path, for pictures).
    pub fn planner(&self, i: usize) -> &LocalPlanner {
        &self.planners[i]
    }
    /// Robot `i`'s target cell.
    pub fn target(&self, i: usize) -> Option<Pos> {
        self.targets[i]
    }
    /// Robot `i`'s last local-planner command.
    pub fn command(&self, i: usize) -> Command {
        self.commands[i]
    }
    /// Complete, at the time cap, or `no_frontier_time` after the team ran out of frontiers.
    pub fn is_done(&self) -> bool {
        let (now, cfg) = (self.world.time(), self.world.config());
        self.world.is_complete()
            || now >= cfg.time_cap
            || self
                .no_frontier_since
                .is_some_and(|t| now - t >= cfg.no_frontier_time - 1e-9)
    }

    /// One control period (the stages of the module docs). Returns false once done.
    ///
    /// With [`ContinuousTrial::with_external_decisions`], a period whose agents wait for
    /// decisions stops after stage 2b ([`ContinuousTrial::deciding`]); after
    /// [`ContinuousTrial::apply_decisions`] the next call finishes it. Called while decisions
    /// are still awaited, it does nothing.
    pub fn step(&mut self) -> bool {
        if self.deciding.contains(&true) {
            return true;
        }
        // A period half done is finished even if its first half completed the world (a
        // write-off counts as explored), as it is without outside decisions.
        if !std::mem::take(&mut self.resuming) {
            if self.is_done() {
                return false;
            }
            self.ask_agents();
            if self.deciding.contains(&true) {
                self.resuming = true;
                return true;
            }
        }
        self.move_robots();
        true
    }

    /// Stages 1 to 2b of a control period: the radio, write-offs, and the agents that ask.
    fn ask_agents(&mut self) {
        let n = self.agents.len();
        let now = self.world.time();
        // 1. radio
        if self.ticks.is_multiple_of(self.radio_every) {
            self.radio_contacts = self.world.contacts();
            self.local_interactions += self.radio_contacts.len() as u64;
            let mut exchanges = std::mem::take(&mut self.radio_exchanges);
            exchanges.clear();
            self.radio.exchange(&self.radio_contacts, &mut exchanges);
            for &(i, j) in &exchanges {
                for k in [i, j] {
                    self.agents[k].beta_into(&mut self.outbox[k]);
                }
                let (bi, bj) = (self.outbox[i].clone(), self.outbox[j].clone());
                self.agents[j].receive_beta(&bi);
                self.agents[i].receive_beta(&bj);
                self.exchanged[i].push(j);
                self.exchanged[j].push(i);
            }
            self.radio_exchanges = exchanges;
        }
        // 2a. cells a robot could not see from the goal it reached: written off (module docs)
        let scan_period = 1.0 / self.world.config().lidar.rate_hz;
        for i in 0..n {
            if let Some((cell, at)) = self.reached[i] {
                if now >= at + scan_period + 1e-9 {
                    self.reached[i] = None;
                    self.write_off_around(i, cell);
                }
            }
        }
        // 2b. agents
        let cell_size = self.world.scenario().cell_size;
        for i in 0..n {
            let cell = self.world.cell_of(i);
            let pose = self.world.pose(i);
            // Only the target counts: cells the local path passes through on a detour do not.
            let entered = cell != self.cells[i]
                && self.targets[i] == Some(cell)
                && self.planners[i].entered(pose, cell, cell_size);
            let due = self.targets[i].is_none() && now >= self.ask_at[i];
            if entered || due || self.asks[i] == Ask::Yes {
                self.cells[i] = cell;
                self.ask(i);
            }
        }
    }

    /// Stages 2c to 4 of a control period: the team's frontier check, local planning, motion.
    fn move_robots(&mut self) {
        let n = self.agents.len();
        let now = self.world.time();
        let cell_size = self.world.scenario().cell_size;
        // 2c. the team's belief: no robot has a reachable frontier left (ends the trial later)
        // Spared cells are retried when a goal is reached; an idle team reaches none, so
        // here they are written off once their time is up, and the clock waits for them.
        if self.targets.iter().all(Option::is_none)
            && self.agents.iter().all(|a| !a.frontier_reachable())
        {
            if self.write_off_expired_spares() {
                self.no_frontier_since = None;
            } else {
                self.no_frontier_since.get_or_insert(now);
            }
        } else {
            self.no_frontier_since = None;
        }
        // 3. local planning
        let cfg = *self.world.config();
        let mut commands = vec![(0.0, 0.0); n];
        #[allow(clippy::needless_range_loop)] // i indexes the world, the planners and commands
        for i in 0..n {
            let Some(target) = self.targets[i] else {
                continue;
            };
            if now - self.clocks[i].since >= cfg.planner.stuck_time {
                // The stuck rule (`planner.stuck_time`).
                self.stuck += 1;
                self.world.block(i, target);
                self.planners[i].reset();
                self.targets[i] = None;
                self.asks[i] = Ask::Yes;
                continue;
            }
            let neighbours = self.world.neighbours(i);
            let replan = std::mem::take(&mut self.replan[i]);
            let c = self.planners[i].command(
                &cfg,
                cell_size,
                self.world.map(i),
                self.world.pose(i),
                self.world.velocity(i),
                target,
                &neighbours,
                replan,
            );
            self.commands[i] = c;
            match c {
                Command::Drive(v, w) => {
                    self.held_since[i] = None;
                    commands[i] = (v, w);
                }
                Command::Held(v, w) => {
                    commands[i] = (v, w);
                    let since = *self.held_since[i].get_or_insert(now);
                    if now - since >= cfg.planner.wait_time {
                        self.held_since[i] = None;
                        self.held_up += 1;
                        self.asks[i] = Ask::Yes;
                    }
                }
                Command::Impassable => {
                    self.impassable += 1;
                    self.world.block(i, target);
                    self.planners[i].reset();
                    self.targets[i] = None;
                    self.asks[i] = Ask::Yes;
                }
            }
        }
        // Local paths are re-planned at every scan (the map has changed).
        // 4. world
        self.world.step(&commands);
        self.ticks += 1;
        let w = self.world.map(0).coarse_size().1;
        for (i, v) in self.visited.iter_mut().enumerate() {
            let c = self.world.cell_of(i);
            v[c.row as usize * w + c.col as usize] = true;
        }
        for r in &mut self.replan {
            *r = self.ticks.is_multiple_of(4);
        }
        if self.ticks.is_multiple_of(TRAIL_EVERY) {
            for (i, t) in self.trails.iter_mut().enumerate() {
                let p = self.world.pose(i);
                t.push((p.x as f32, p.y as f32));
            }
        }
        let second = self.world.time().floor() as usize;
        if second >= self.explored.len() {
            self.explored.push(self.world.explored_fraction());
            self.distance.push(self.team_distance());
        }
    }

    /// Robot `i` asks its agent: observe, decide if the macro action ended, plan, move.
    fn ask(&mut self, i: usize) {
        self.asks[i] = Ask::No;
        self.seen.clear();
        self.world.take_observed(i, &mut self.seen);
        let n = self.agents.len();
        let teammates = (0..n)
            .filter(|&j| j != i && self.world.in_view(i, j))
            .map(|j| (j, self.world.cell_of(j)))
            .collect();
        let mut exchanged = std::mem::take(&mut self.exchanged[i]);
        exchanged.sort_unstable();
        exchanged.dedup();
        let obs = Observation {
            robot: i,
            t: self.agent_t[i],
            pos: self.cells[i],
            seen: std::mem::take(&mut self.seen),
            teammates,
            exchanged_with: exchanged,
        };
        self.agent_t[i] += 1;
        let a = &mut self.agents[i];
        a.observe(&obs);
        self.seen = obs.seen;
        if a.goal() == Some(self.cells[i]) {
            self.reached[i] = Some((self.cells[i], self.world.time()));
        }
        if a.needs_decision() {
            if self.external {
                // Waits for [`ContinuousTrial::apply_decisions`], which then acts.
                self.deciding[i] = true;
                return;
            }
            a.decide();
        }
        self.act(i);
    }

    /// Robot `i`'s agent plans and names its next cell: the robot's target.
    fn act(&mut self, i: usize) {
        let a = &mut self.agents[i];
        a.plan();
        let (dr, dc) = a.next_move().delta();
        let here = self.cells[i];
        let next = Pos::new(here.row + dr, here.col + dc);
        if next == here {
            self.targets[i] = None;
            self.ask_at[i] = self.world.time() + self.world.config().planner.stay_period;
        } else {
            if self.targets[i] != Some(next) {
                self.planners[i].reset();
                let had_target = self.targets[i].is_some();
                self.clocks[i].named(had_target, here, self.world.time());
            }
            self.targets[i] = Some(next);
        }
        self.held_since[i] = None;
    }

    /// The 8-neighbours of `cell` that robot `i`'s map still cannot read after it stood in
    /// `cell` for a scan become obstacles to it: it cannot see them from there (something
    /// thinner than the rule's fraction stands between), and a frontier it cannot resolve by
    /// going there would draw it back for ever. Spared are a corner (diagonal) neighbour with
    /// a side neighbour the robot knows free, can reach and has not stood in — from there it
    /// may see round the corner that hid it, and written off it could seal a corridor's far
    /// end off from every frontier — and a cell a teammate may hide: one whose footprint lies
    /// within half a cell diagonal of the line from the robot to the cell's centre (lidar
    /// beams stop at teammates). A spared cell is tried again the next time a goal is
    /// reached, and written off all the same once `planner.stuck_time` has passed since it was
    /// first spared (by the idle team's check, stage 2c, when no goal is reached any more); a
    /// spare not renewed within `planner.stuck_time` has lapsed, and the next one starts
    /// afresh (once per cell, [`Spare::renew`]). Written-off cells count as explored (resolved
    /// as far as the team can) and are reported (`written_off_cells`).
    fn write_off_around(&mut self, i: usize, cell: Pos) {
        let now = self.world.time();
        let cell_size = self.world.scenario().cell_size;
        let here = self.world.pose(i);
        let reach = spare::hide_reach(self.world.config().robot.radius, cell_size);
        let mates: Vec<(f64, f64)> = (0..self.agents.len())
            .filter(|&j| j != i)
            .map(|j| {
                let p = self.world.pose(j);
                (p.x, p.y)
            })
            .collect();
        let hidden = |q: Pos| {
            let c = (
                (q.col as f64 + 0.5) * cell_size,
                (q.row as f64 + 0.5) * cell_size,
            );
            spare::hidden_by_teammate((here.x, here.y), c, &mates, reach)
        };
        let (h, w) = self.world.map(i).coarse_size();
        // Searched only when a corner cell needs it (most reached goals have none unknown).
        let reachable = std::cell::OnceCell::new();
        let agent = &self.agents[i];
        let belief = agent.belief();
        let visited = &self.visited[i];
        let open_unvisited = |s: Pos| {
            let reachable = reachable.get_or_init(|| agent.reachable());
            belief.is_free(s) && reachable[belief.index(s)] && !visited[belief.index(s)]
        };
        let mut write_off = Vec::new();
        for dr in -1..=1 {
            for dc in -1..=1 {
                let q = Pos::new(cell.row + dr, cell.col + dc);
                if (dr, dc) == (0, 0)
                    || q.row < 0
                    || q.col < 0
                    || q.row as usize >= h
                    || q.col as usize >= w
                {
                    continue;
                }
                if self.world.map(i).coarse()[q.row as usize * w + q.col as usize]
                    != Occupancy::Unknown
                {
                    continue;
                }
                // A corner cell seen past a side cell not yet stood in, or a cell a teammate
                // may hide: spared, but not for longer than the stuck rule's time (two robots
                // hiding each other's cells, or one going back and forth, would wait for ever).
                let corner = spare::corner_with_open_side(cell, q, open_unvisited);
                if corner || hidden(q) {
                    let stuck_time = self.world.config().planner.stuck_time;
                    let spared = self.spared.entry((i, q)).or_insert(Spare::at(now));
                    if spared.renew(now, stuck_time) {
                        continue;
                    }
                }
                self.spared.remove(&(i, q));
                write_off.push(q);
            }
        }
        for q in write_off {
            self.world.block(i, q);
            self.written_off += 1;
            self.asks[i] = Ask::Yes;
        }
    }

    /// Writes off the spared cells (still unknown to their robot) whose `planner.stuck_time`
    /// has passed; true while any is written off now or still waiting for its time.
    fn write_off_expired_spares(&mut self) -> bool {
        let now = self.world.time();
        let wait = self.world.config().planner.stuck_time;
        let mut pending = false;
        let mut expired = Vec::new();
        // Spares of cells their robot has read since are done with.
        let world = &self.world;
        self.spared.retain(|&(i, q), _| {
            let (_, w) = world.map(i).coarse_size();
            world.map(i).coarse()[q.row as usize * w + q.col as usize] == Occupancy::Unknown
        });
        for (&(i, q), s) in &self.spared {
            if s.expired(now, wait) {
                expired.push((i, q));
            } else {
                pending = true;
            }
        }
        for &(i, q) in &expired {
            self.spared.remove(&(i, q));
            self.world.block(i, q);
            self.written_off += 1;
            self.asks[i] = Ask::Yes;
        }
        pending || !expired.is_empty()
    }

    /// Runs to completion or the time cap (robots waiting for outside decisions take their
    /// own policy's).
    pub fn run(mut self) -> ContinuousResult {
        crate::stepping::run_to_end(&mut self);
        self.finish()
    }

    /// Metres the team has driven so far.
    fn team_distance(&self) -> f64 {
        (0..self.agents.len()).map(|i| self.world.distance(i)).sum()
    }

    /// The result so far.
    pub fn finish(mut self) -> ContinuousResult {
        // The curves end with the state at the end, as the sample of the second it falls in.
        if self.world.time() > (self.explored.len() - 1) as f64 + 1e-9 {
            self.explored.push(self.world.explored_fraction());
            self.distance.push(self.team_distance());
        }
        let complete = self.world.is_complete();
        // Only when that rule ended the trial (not a cap inside its window, not a mid-run look).
        let (now, wait) = (self.world.time(), self.world.config().no_frontier_time);
        let no_frontier_at = self
            .no_frontier_since
            .filter(|&t| !complete && now - t >= wait - 1e-9);
        let Collisions { obstacle, robot } = self.world.collisions();
        let team_distance_m = self.team_distance();
        ContinuousResult {
            map: self.spec_map,
            policy: self.policy,
            seed: self.seed,
            comm_success_prob: self.world.scenario().comm_success_prob,
            complete,
            no_frontier_at,
            exploration_time_s: self.world.time(),
            team_distance_m,
            obstacle_collisions: obstacle,
            robot_collisions: robot,
            local_interactions: self.local_interactions,
            impassable_cells: self.impassable,
            written_off_cells: self.written_off,
            unread_cells: self.world.unread() as u64,
            explorable_cells: self.world.explorable_count() as u64,
            stuck: self.stuck,
            held_up: self.held_up,
            decisions: self.agents.iter().map(|a| a.stats().decisions).sum(),
            explored: self.explored,
            distance: self.distance,
            wall_s: self.started.elapsed().as_secs_f64(),
        }
    }
}

impl Present for ContinuousTrial {
    crate::present_continuous_world!();
    fn robot(&self, i: usize) -> RobotShown<'_> {
        RobotShown::of(&self.agents[i])
    }
    fn contacts(&self) -> Cow<'_, [(usize, usize)]> {
        Cow::Borrowed(&self.radio_contacts)
    }
    fn exchanges(&self) -> &[(usize, usize)] {
        &self.radio_exchanges
    }
}

impl Stepping for ContinuousTrial {
    type Outcome = ContinuousResult;

    fn step(&mut self) -> bool {
        ContinuousTrial::step(self)
    }
    fn is_done(&self) -> bool {
        ContinuousTrial::is_done(self)
    }
    fn is_complete(&self) -> bool {
        self.world.is_complete()
    }
    fn deciding(&self) -> &[bool] {
        ContinuousTrial::deciding(self)
    }
    fn apply_decisions(&mut self, decisions: &[Option<Decision>]) {
        ContinuousTrial::apply_decisions(self, decisions)
    }
    fn agents(&self) -> &[Agent] {
        &self.agents
    }
    fn agent_mut(&mut self, i: usize) -> &mut Agent {
        &mut self.agents[i]
    }
    fn finish(self) -> ContinuousResult {
        ContinuousTrial::finish(self)
    }
}

pub mod spare;
#[cfg(test)]
mod tests;
