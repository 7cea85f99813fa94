//! [`Agent`]: one robot, self-contained. It sees the world only through [`Observation`]s,
//! hears teammates only through [`Beta`] and [`PlanMessage`]s, and acts only through a
//! [`Move`].

use crate::belief::Belief;
use crate::goals::{extract_goals_with, GoalCandidates};
use crate::messages::{Beta, PlanMessage, TeammateRecord};
use crate::policy::{Decision, DecisionMode, Policy};
use crate::view::{search_from, AgentView};
use madenet_map::Pos;
use madenet_nav::{astar, one_step, Dijkstra, Reservations, SpaceTimePlanner};
use madenet_world::{Move, Observation, ScenarioConfig};
use std::time::{Duration, Instant};

/// The per-robot parameters an agent needs, derived from the [`ScenarioConfig`].
#[derive(Clone, Debug, PartialEq)]
pub struct AgentConfig {
    /// Robot index i (0-based); also its planning priority: lower indices plan first.
    pub id: usize,
    /// Team size |I|.
    pub num_robots: usize,
    /// Map height in cells (rows).
    pub height: usize,
    /// Map width in cells (columns).
    pub width: usize,
    /// |G| (Eq. 3 unless configured).
    pub goal_count: usize,
    /// Plan among communicating robots with prioritized space-time A* (Sec. III.C.5); when
    /// false, teammates' [`PlanMessage`]s are ignored.
    pub prioritized_planning: bool,
    /// Space-time A* horizon in timesteps; reservations beyond it are ignored.
    pub plan_horizon: usize,
    /// The rule for diagonal steps past obstacle corners, for navigation and the frontier.
    pub movement: madenet_map::Movement,
    /// How 𝒢 is chosen ([`madenet_world::CandidateRule`]).
    pub candidate_rule: madenet_world::CandidateRule,
    /// d_s, the sensing range in cells (Sec. V.A.1): the policies read it from the view.
    pub sensing_range: i32,
}

impl AgentConfig {
    /// The config of robot `id` on a `height` × `width` map (cells) under `cfg`; |G| is
    /// [`ScenarioConfig::goal_count_for`] the map's cells (Eq. 3 unless configured).
    pub fn from_scenario(cfg: &ScenarioConfig, id: usize, height: usize, width: usize) -> Self {
        AgentConfig {
            id,
            num_robots: cfg.num_robots,
            height,
            width,
            goal_count: cfg.goal_count_for(height * width),
            prioritized_planning: cfg.prioritized_planning,
            plan_horizon: cfg.plan_horizon,
            movement: cfg.movement,
            candidate_rule: cfg.candidate_rule,
            sensing_range: cfg.sensing_range,
        }
    }
}

/// Why the current macro action ended (Sec. III.C.2: β^m), for logs and learning.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// The robot had no goal (start of an episode, or its last decision idled).
    NoGoal,
    /// The robot stands on its goal.
    Reached,
    /// A teammate was newly detected within d_s (not detected the timestep before).
    TeammateDetected,
    /// The goal is no longer a frontier cell of the robot's belief m_i.
    NotFrontier,
    /// A* through the robot's known free cells finds no path to the goal.
    Unreachable,
    /// The robot had a goal elsewhere and stayed put (blocked or waiting) for
    /// [`BLOCKED_STEPS`] timesteps in a row: it re-decides rather than deadlock.
    Blocked,
    /// Primitive-level policies re-decide every timestep.
    EveryStep,
}

/// Consecutive timesteps without moving, despite a goal elsewhere, that end a macro action.
pub const BLOCKED_STEPS: usize = 3;

/// Timesteps of the oscillation test: a robot with a goal that learned nothing new over this
/// many steps while shuttling between at most [`OSCILLATION_CELLS`] cells, with a teammate of
/// lower index in view, is in a livelock with it (two robots that cannot talk swapping places
/// or goals back and forth); it yields.
pub const OSCILLATION_STEPS: usize = 8;
/// Distinct cells a shuttling robot visits within [`OSCILLATION_STEPS`].
pub const OSCILLATION_CELLS: usize = 3;
/// Timesteps a robot in a livelock stays put so that the teammate of lower index can get by.
/// The robot of lowest index in view never yields, which breaks the symmetry.
pub const YIELD_STEPS: usize = 4;

/// Per-agent timing and counters.
#[derive(Clone, Debug, Default)]
pub struct AgentStats {
    /// Decisions applied ([`Agent::apply_decision`]: the own policy's or a joint policy's).
    pub decisions: usize,
    /// Wall-clock time spent in [`Agent::decide`] (view, goal extraction and the policy).
    pub decision_time: Duration,
    /// Space-time searches run, and how many found no plan.
    pub space_time_plans: usize,
    /// Space-time searches that found no plan (the robot kept its A* path).
    pub space_time_failures: usize,
}

/// Scratch space for [`Agent::peek_view`].
pub struct ViewScratch {
    dijkstra: Dijkstra,
    candidates: GoalCandidates,
    fresh: bool,
}

impl ViewScratch {
    /// Scratch for a `height` × `width` map (cells).
    pub fn new(height: usize, width: usize) -> Self {
        ViewScratch {
            dijkstra: Dijkstra::new(height, width),
            candidates: GoalCandidates {
                slots: 0,
                cells: Vec::new(),
            },
            fresh: false,
        }
    }
}

/// The parts of an [`Agent`] that hold allocations, carried from one episode to the next by
/// [`Agent::restarted`].
struct Buffers {
    belief: Belief,
    teammates: Vec<TeammateRecord>,
    exchanged: Vec<usize>,
    candidates: GoalCandidates,
    dijkstra: Dijkstra,
    reservations: Reservations,
    space_time: SpaceTimePlanner,
    scratch: Vec<Pos>,
    path: Vec<Pos>,
}

/// One robot.
pub struct Agent {
    cfg: AgentConfig,
    t: usize,
    pos: Pos,
    belief: Belief,
    teammates: Vec<TeammateRecord>,
    teammate_detected: bool,
    newly_detected: bool,
    exchanged: Vec<usize>,
    goal: Option<Pos>,
    prev_goal: Option<Pos>,
    candidates: GoalCandidates,
    dijkstra: Dijkstra,
    dijkstra_fresh: bool,
    reservations: Reservations,
    space_time: SpaceTimePlanner,
    scratch: Vec<Pos>,
    path: Vec<Pos>,
    path_ready: bool,
    policy: Box<dyn Policy>,
    termination: Option<Termination>,
    /// Timesteps in a row the robot intended to move and did not.
    blocked_for: usize,
    /// The last positions and known-cell counts (ring of [`OSCILLATION_STEPS`] + 1, newest at
    /// `history_len - 1` modulo), for the livelock test.
    history: [(Pos, usize); OSCILLATION_STEPS + 1],
    history_len: usize,
    /// Timesteps left to stay put, yielding to a teammate in a livelock.
    yield_for: usize,
    /// The macro action (candidate index) in force, if the last decision chose one.
    action: Option<usize>,
    stats: AgentStats,
}

impl Agent {
    /// Robot `cfg.id` at `start` at the beginning of an episode: it knows no cell, has no goal
    /// and decides with `policy`.
    pub fn new(cfg: AgentConfig, start: Pos, policy: Box<dyn Policy>) -> Self {
        let (h, w) = (cfg.height, cfg.width);
        let buffers = Buffers {
            belief: Belief::new(h, w, cfg.movement),
            teammates: vec![TeammateRecord::default(); cfg.num_robots],
            exchanged: Vec::new(),
            candidates: GoalCandidates {
                slots: cfg.goal_count,
                cells: Vec::new(),
            },
            dijkstra: Dijkstra::new(h, w),
            reservations: Reservations::new(h, w, cfg.plan_horizon),
            space_time: SpaceTimePlanner::new(h, w, cfg.plan_horizon),
            scratch: Vec::new(),
            path: Vec::new(),
        };
        Self::assemble(cfg, start, policy, buffers)
    }

    /// The agent [`Agent::new`] would build with this agent's config, `start` and `policy`,
    /// reusing this one's buffers (map, search scratch, reservation table): how a trial starts
    /// its next episode without allocating.
    pub fn restarted(self, start: Pos, policy: Box<dyn Policy>) -> Self {
        let Agent {
            cfg,
            mut belief,
            mut teammates,
            mut exchanged,
            mut candidates,
            dijkstra,
            mut reservations,
            mut space_time,
            mut scratch,
            mut path,
            ..
        } = self;
        belief.reset();
        teammates.fill(TeammateRecord::default());
        exchanged.clear();
        candidates.cells.clear();
        candidates.slots = cfg.goal_count;
        reservations.clear();
        space_time.expanded = 0;
        scratch.clear();
        path.clear();
        // The search scratch is only read after a search from the robot's position
        // (`dijkstra_fresh`), so it need not be cleared.
        let buffers = Buffers {
            belief,
            teammates,
            exchanged,
            candidates,
            dijkstra,
            reservations,
            space_time,
            scratch,
            path,
        };
        Self::assemble(cfg, start, policy, buffers)
    }

    /// A copy of this agent in its current state (map, teammate records, goal, macro action,
    /// navigator state) driven from now on by `policy`: how a rollout continues a trial from
    /// its present under another policy. Counters start from zero.
    pub fn fork(&self, policy: Box<dyn Policy>) -> Self {
        Agent {
            cfg: self.cfg.clone(),
            t: self.t,
            pos: self.pos,
            belief: self.belief.clone(),
            teammates: self.teammates.clone(),
            teammate_detected: self.teammate_detected,
            newly_detected: self.newly_detected,
            exchanged: self.exchanged.clone(),
            goal: self.goal,
            prev_goal: self.prev_goal,
            candidates: self.candidates.clone(),
            dijkstra: self.dijkstra.clone(),
            dijkstra_fresh: self.dijkstra_fresh,
            reservations: self.reservations.clone(),
            space_time: self.space_time.clone(),
            scratch: Vec::new(),
            path: self.path.clone(),
            path_ready: self.path_ready,
            policy,
            termination: self.termination,
            blocked_for: self.blocked_for,
            history: self.history,
            history_len: self.history_len,
            yield_for: self.yield_for,
            action: self.action,
            stats: AgentStats::default(),
        }
    }

    /// An agent at the start of an episode, holding `buffers` (in their initial state).
    fn assemble(cfg: AgentConfig, start: Pos, policy: Box<dyn Policy>, buffers: Buffers) -> Self {
        let Buffers {
            belief,
            teammates,
            exchanged,
            candidates,
            dijkstra,
            reservations,
            space_time,
            scratch,
            path,
        } = buffers;
        Agent {
            t: 0,
            pos: start,
            belief,
            teammates,
            teammate_detected: false,
            newly_detected: false,
            exchanged,
            goal: None,
            prev_goal: None,
            candidates,
            dijkstra,
            dijkstra_fresh: false,
            reservations,
            space_time,
            scratch,
            path,
            path_ready: false,
            policy,
            termination: None,
            blocked_for: 0,
            history: [(start, 0); OSCILLATION_STEPS + 1],
            history_len: 0,
            yield_for: 0,
            action: None,
            stats: AgentStats::default(),
            cfg,
        }
    }

    /// Robot index i.
    pub fn id(&self) -> usize {
        self.cfg.id
    }
    /// The per-robot parameters this agent was built with.
    pub fn config(&self) -> &AgentConfig {
        &self.cfg
    }
    /// x_i: the robot's position as of its last observation.
    pub fn pos(&self) -> Pos {
        self.pos
    }
    /// m_i: the robot's local map with its frontier.
    pub fn belief(&self) -> &Belief {
        &self.belief
    }
    /// What the robot remembers of each teammate, indexed by robot (its own index holds an
    /// empty record).
    pub fn teammates(&self) -> &[TeammateRecord] {
        &self.teammates
    }
    /// g_i: the current goal (None: the robot has none and stays).
    pub fn goal(&self) -> Option<Pos> {
        self.goal
    }
    /// 𝒢_i as last extracted for a view of this robot (empty when that view was taken without
    /// candidates).
    pub fn candidates(&self) -> &GoalCandidates {
        &self.candidates
    }
    /// The planned cells, first = next cell.
    pub fn path(&self) -> &[Pos] {
        &self.path
    }
    /// The registry name of this robot's policy (e.g. `"nf"`).
    pub fn policy_name(&self) -> &str {
        self.policy.name()
    }
    /// The values its policy weighed at its last decision, per candidate slot
    /// ([`Policy::last_scores`]; learned policies only).
    pub fn policy_scores(&self) -> Option<&[f32]> {
        self.policy.last_scores()
    }
    /// When this robot's policy decides.
    pub fn policy_mode(&self) -> DecisionMode {
        self.policy.mode()
    }
    /// Timing and counters since the agent was built, restarted or forked.
    pub fn stats(&self) -> &AgentStats {
        &self.stats
    }
    /// States expanded by this agent's space-time searches so far.
    pub fn space_time_expanded(&self) -> u64 {
        self.space_time.expanded
    }
    /// Why the macro action ended this timestep (None: it goes on).
    pub fn termination(&self) -> Option<Termination> {
        self.termination
    }
    /// The cells this robot can reach from where it stands over cells its belief holds free
    /// (a row-major mask; its own cell included whatever the belief says of it, as the path
    /// searches start there).
    pub fn reachable(&self) -> Vec<bool> {
        self.reachable_avoiding(&[])
    }

    /// The cells teammates in view stand on: goal extraction neither passes through nor offers
    /// them.
    fn held_cells(&self) -> Vec<Pos> {
        self.teammates
            .iter()
            .filter(|r| r.detected)
            .filter_map(|r| r.seen_pos)
            .collect()
    }

    /// [`Agent::reachable`] without passing through `held` cells.
    fn reachable_avoiding(&self, held: &[Pos]) -> Vec<bool> {
        let b = &self.belief;
        let (mut seen, mut stack) = (vec![false; b.map().len()], vec![self.pos]);
        seen[b.index(self.pos)] = true;
        let open = |q: Pos| b.is_free(q) && !held.contains(&q);
        while let Some(p) = stack.pop() {
            for (q, _) in madenet_nav::neighbours(p, open, b.movement()) {
                if !std::mem::replace(&mut seen[b.index(q)], true) {
                    stack.push(q);
                }
            }
        }
        seen
    }

    /// Whether a frontier cell other than its own is reachable as goal extraction counts them
    /// (not through, nor onto, a cell a teammate in view stands on): false once, as far as this
    /// robot knows, it will be offered no goal.
    pub fn frontier_reachable(&self) -> bool {
        let held = self.held_cells();
        let here = self.belief.index(self.pos);
        self.reachable_avoiding(&held)
            .iter()
            .enumerate()
            .any(|(i, &r)| r && i != here && self.belief.is_frontier_index(i))
    }

    /// Stage 1: take in this timestep's primitive observation o_i.
    pub fn observe(&mut self, obs: &Observation) {
        debug_assert_eq!(obs.robot, self.cfg.id);
        let trying = self.goal.is_some_and(|g| g != self.pos);
        if obs.t > 0 && trying && obs.pos == self.pos {
            self.blocked_for += 1;
        } else {
            self.blocked_for = 0;
        }
        self.t = obs.t;
        self.pos = obs.pos;
        for &(p, occ) in &obs.seen {
            self.belief.observe(p, occ);
        }
        let mut newly = false;
        for rec in &mut self.teammates {
            rec.detected = false;
        }
        for &(j, p) in &obs.teammates {
            let rec = &mut self.teammates[j];
            rec.detected = true;
            rec.seen_pos = Some(p);
            newly |= rec.seen_at != Some(obs.t.wrapping_sub(1)) || obs.t == 0;
            rec.seen_at = Some(obs.t);
        }
        self.newly_detected = newly;
        self.teammate_detected = !obs.teammates.is_empty();
        self.check_livelock();
        self.exchanged.clear();
        self.exchanged.extend_from_slice(&obs.exchanged_with);
        self.reservations.clear();
        self.dijkstra_fresh = false;
        self.path_ready = false;
        self.termination = None;
    }

    /// The livelock test (after taking in an observation): remembers the position and the
    /// known-cell count, and starts yielding for [`YIELD_STEPS`] when the robot has a goal, has
    /// learned nothing over [`OSCILLATION_STEPS`] steps while visiting at most
    /// [`OSCILLATION_CELLS`] cells, and sees a teammate of lower index.
    fn check_livelock(&mut self) {
        let ring = self.history.len();
        self.history[self.history_len % ring] = (self.pos, self.belief.known_count());
        self.history_len += 1;
        if self.history_len < ring || self.yield_for > 0 || self.goal.is_none_or(|g| g == self.pos)
        {
            return;
        }
        let oldest = self.history[self.history_len % ring];
        if oldest.1 != self.belief.known_count() {
            return;
        }
        let mut cells: [Option<Pos>; OSCILLATION_CELLS + 1] = [None; OSCILLATION_CELLS + 1];
        let mut distinct = 0;
        for &(p, _) in &self.history {
            if !cells[..distinct].contains(&Some(p)) {
                if distinct == cells.len() {
                    return;
                }
                cells[distinct] = Some(p);
                distinct += 1;
            }
        }
        if distinct > OSCILLATION_CELLS {
            return;
        }
        let id = self.cfg.id;
        if self
            .teammates
            .iter()
            .enumerate()
            .any(|(j, r)| j < id && r.detected)
        {
            self.yield_for = YIELD_STEPS;
            self.history_len = 0;
        }
    }

    /// β_i to send to a teammate this timestep.
    pub fn beta(&self) -> Beta {
        let mut b = Beta {
            from: 0,
            t: 0,
            prev_goal: None,
            pos: self.pos,
            goal: None,
            map: Vec::new(),
            explored: 0,
        };
        self.beta_into(&mut b);
        b
    }

    /// [`Agent::beta`] written over `b`, reusing its map's allocation.
    pub fn beta_into(&self, b: &mut Beta) {
        b.from = self.cfg.id;
        b.t = self.t;
        b.prev_goal = self.prev_goal;
        b.pos = self.pos;
        b.goal = self.goal;
        b.map.clear();
        b.map.extend_from_slice(self.belief.map());
        b.explored = self.belief.known_count();
    }

    /// Stage 2: take in a teammate's β: merge its map, remember its goals and position.
    pub fn receive_beta(&mut self, b: &Beta) {
        self.belief.merge(&b.map);
        let rec = &mut self.teammates[b.from];
        rec.heard_at = Some(b.t);
        rec.prev_goal = b.prev_goal;
        rec.goal = b.goal;
        rec.beta_pos = Some(b.pos);
        rec.explored = b.explored;
        self.dijkstra_fresh = false;
    }

    /// Stage 3: does this robot decide now? Every timestep for primitive-level policies;
    /// otherwise when its macro action terminated: no goal, goal reached, a teammate newly
    /// detected, or the goal is no longer a frontier or no longer reachable.
    pub fn needs_decision(&mut self) -> bool {
        self.termination = self.check_termination();
        self.termination.is_some()
    }

    fn check_termination(&mut self) -> Option<Termination> {
        if self.policy.mode() == DecisionMode::EveryStep {
            return Some(Termination::EveryStep);
        }
        let Some(goal) = self.goal else {
            return Some(Termination::NoGoal);
        };
        if goal == self.pos {
            return Some(Termination::Reached);
        }
        if self.newly_detected {
            return Some(Termination::TeammateDetected);
        }
        if self.blocked_for >= BLOCKED_STEPS {
            self.blocked_for = 0;
            return Some(Termination::Blocked);
        }
        if !self.belief.is_frontier(goal) {
            return Some(Termination::NotFrontier);
        }
        let belief = &self.belief;
        match astar(self.pos, goal, |p| belief.is_free(p), belief.movement()) {
            Some((path, _)) => {
                self.path = path;
                self.path_ready = true;
                None
            }
            None => Some(Termination::Unreachable),
        }
    }

    /// The robot's view for a policy; candidates are extracted first when `with_candidates`.
    pub fn view(&mut self, with_candidates: bool) -> AgentView<'_> {
        if with_candidates {
            let held = self.held_cells();
            self.candidates = extract_goals_with(
                &self.belief,
                self.pos,
                self.cfg.goal_count,
                &mut self.dijkstra,
                &held,
                self.cfg.candidate_rule,
            );
            self.dijkstra_fresh = true;
        } else {
            self.candidates.cells.clear();
        }
        AgentView {
            id: self.cfg.id,
            t: self.t,
            pos: self.pos,
            teammate_detected: self.teammate_detected,
            belief: &self.belief,
            teammates: &self.teammates,
            goal: self.goal,
            prev_goal: self.prev_goal,
            sensing_range: self.cfg.sensing_range,
            candidates: &self.candidates,
            dijkstra: &mut self.dijkstra,
            dijkstra_fresh: &mut self.dijkstra_fresh,
        }
    }

    /// Takes the goal candidates, and the search that found them, from `scratch` after an
    /// observer's [`Agent::peek_view`]`(true, scratch)` of this agent in its current state:
    /// exactly what [`Agent::view`]`(true)` would compute (same inputs, same search), without
    /// searching again. The scratch is left holding the agent's old buffers.
    pub fn adopt_candidates(&mut self, scratch: &mut ViewScratch) {
        std::mem::swap(&mut self.candidates, &mut scratch.candidates);
        std::mem::swap(&mut self.dijkstra, &mut scratch.dijkstra);
        self.dijkstra_fresh = true;
        scratch.fresh = false;
    }

    /// The robot's view without touching its own navigator state: candidates and searches use
    /// `scratch`. For observers (e.g. an environment building observations of robots that do
    /// not decide now); the trajectory is the same whether or not this is called.
    pub fn peek_view<'a>(
        &'a self,
        with_candidates: bool,
        scratch: &'a mut ViewScratch,
    ) -> AgentView<'a> {
        let ViewScratch {
            dijkstra,
            candidates,
            fresh,
        } = scratch;
        if with_candidates {
            let held = self.held_cells();
            *candidates = extract_goals_with(
                &self.belief,
                self.pos,
                self.cfg.goal_count,
                dijkstra,
                &held,
                self.cfg.candidate_rule,
            );
            *fresh = true;
        } else {
            candidates.slots = self.cfg.goal_count;
            candidates.cells.clear();
            *fresh = false;
        }
        AgentView {
            id: self.cfg.id,
            t: self.t,
            pos: self.pos,
            teammate_detected: self.teammate_detected,
            belief: &self.belief,
            teammates: &self.teammates,
            goal: self.goal,
            prev_goal: self.prev_goal,
            sensing_range: self.cfg.sensing_range,
            candidates,
            dijkstra,
            dijkstra_fresh: fresh,
        }
    }

    /// Stage 4: ask the robot's own policy (call when [`Agent::needs_decision`] is true).
    pub fn decide(&mut self) {
        let start = Instant::now();
        let needs = self.policy.needs_candidates();
        // Temporarily take the policy out so the view can borrow the rest of the agent.
        let mut policy =
            std::mem::replace(&mut self.policy, Box::new(crate::policy::NearestFrontier));
        let decision = {
            let mut view = self.view(needs);
            policy.decide(&mut view)
        };
        self.policy = policy;
        self.apply_decision(decision);
        self.stats.decision_time += start.elapsed();
    }

    /// The macro action in force: the goal candidate index chosen at the last decision (None
    /// for decisions that named a cell or idled).
    pub fn action(&self) -> Option<usize> {
        self.action
    }

    /// Sets the goal from a decision (own policy or a joint policy).
    pub fn apply_decision(&mut self, d: Decision) {
        self.stats.decisions += 1;
        self.action = match d {
            Decision::Candidate(k) if self.candidates.is_valid(k) => Some(k),
            _ => None,
        };
        let new_goal = match d {
            Decision::Candidate(k) => self.candidates.get(k),
            Decision::Goal(p) => Some(p),
            Decision::Idle => None,
        };
        if new_goal != self.goal {
            self.prev_goal = self.goal;
            self.goal = new_goal;
            self.path_ready = false;
        }
    }

    /// Stage 5: a teammate of higher priority announced its plan.
    pub fn receive_plan(&mut self, m: &PlanMessage) {
        if self.cfg.prioritized_planning {
            self.reservations.reserve_path(m.start, &m.path);
        }
    }

    /// Stage 6: plan the path to the goal. Plain A* on known free cells; when the plan
    /// collides with a reservation of a higher-priority communicating teammate, or with a
    /// detected teammate this robot cannot talk to (a static obstacle to it), space-time A*
    /// plans around them, waiting where needed.
    pub fn plan(&mut self) {
        if self.yield_for > 0 {
            // Yielding in a livelock: stay put (the path is planned afresh afterwards).
            self.yield_for -= 1;
            self.path.clear();
            self.path_ready = false;
            return;
        }
        let Some(goal) = self.goal else {
            self.path.clear();
            return;
        };
        if goal == self.pos {
            self.path.clear();
            return;
        }
        if !self.path_ready {
            // The path is the robot's one search's path to the goal (`view::search_from`),
            // whatever the policy queried before: from the tree at hand if it settled the goal
            // (a stopped search settles exactly what the full one does), else searched on.
            let ok = self.dijkstra_fresh
                && self.dijkstra.source() == Some(self.pos)
                && self.dijkstra.path_to(goal, &mut self.path);
            if !ok {
                let (belief, teammates) = (&self.belief, &self.teammates);
                let held = |q: Pos| {
                    teammates
                        .iter()
                        .any(|r| r.detected && r.seen_pos == Some(q))
                };
                if one_step(
                    self.pos,
                    goal,
                    |p| belief.is_free(p) && !held(p),
                    belief.movement(),
                )
                .is_some()
                {
                    // The search's path, without a search (a one-step path is the unique shortest).
                    self.path.clear();
                    self.path.push(goal);
                } else {
                    let g = belief.index(goal);
                    let found =
                        search_from(&mut self.dijkstra, belief, teammates, self.pos, |i, _| {
                            i == g
                        })
                        .is_some();
                    self.dijkstra_fresh = true;
                    if !(found && self.dijkstra.path_to(goal, &mut self.path)) {
                        // Not reachable around the teammates in view: through them (they may move).
                        self.path = astar(self.pos, goal, |p| belief.is_free(p), belief.movement())
                            .map(|(p, _)| p)
                            .unwrap_or_default();
                    }
                }
            }
            self.path_ready = true;
        }
        // Detected teammates this robot cannot talk to are obstacles to it; the cells of
        // those it talks to cannot be entered in the first step (the world's rule), and
        // their announced plans are already reserved.
        let mut obstacles = [Pos::new(-1, -1); 8];
        let mut n_obs = 0;
        for (j, rec) in self.teammates.iter().enumerate() {
            if let (true, Some(p)) = (rec.detected, rec.seen_pos) {
                if self.exchanged.contains(&j) {
                    self.reservations.reserve(p, 0);
                } else if n_obs < obstacles.len() {
                    obstacles[n_obs] = p;
                    n_obs += 1;
                }
            }
        }
        let obstacles = &obstacles[..n_obs];
        let belief = &self.belief;
        let passable = |q: Pos| belief.is_free(q) && !obstacles.contains(&q);
        if self.path.iter().any(|p| obstacles.contains(p)) {
            if let Some((p, _)) = astar(self.pos, goal, passable, belief.movement()) {
                self.path = p;
            }
        }
        if !self.path.is_empty()
            && !self.reservations.is_empty()
            && self.reservations.conflicts(self.pos, &self.path)
        {
            if self.space_time.plan(
                self.pos,
                goal,
                passable,
                belief.movement(),
                &self.reservations,
                &mut self.scratch,
            ) {
                std::mem::swap(&mut self.path, &mut self.scratch);
            } else {
                self.stats.space_time_failures += 1;
            }
            self.stats.space_time_plans += 1;
        }
    }

    /// This robot's plan, for lower-priority teammates it communicates with.
    pub fn plan_message(&self) -> PlanMessage {
        let mut m = PlanMessage {
            from: 0,
            t: 0,
            start: self.pos,
            path: Vec::new(),
        };
        self.plan_message_into(&mut m);
        m
    }

    /// [`Agent::plan_message`] written over `m`, reusing its path's allocation.
    pub fn plan_message_into(&self, m: &mut PlanMessage) {
        m.from = self.cfg.id;
        m.t = self.t;
        m.start = self.pos;
        m.path.clear();
        m.path.extend_from_slice(&self.path);
    }

    /// Teammates this robot exchanged with this timestep.
    pub fn exchanged_with(&self) -> &[usize] {
        &self.exchanged
    }

    /// Stage 7: the primitive action a_i.
    pub fn next_move(&self) -> Move {
        self.path
            .first()
            .and_then(|&n| Move::between(self.pos, n))
            .unwrap_or(Move::Stay)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policy::External;
    use madenet_map::Occupancy;

    /// A corridor along row 0 of a 1 × 5 map, cells 0–3 known free, cell 4 unknown: the only
    /// frontier is cell 3. Robot 0 at cell 0 reaches it, unless teammate 1 stands on it (goal
    /// extraction offers no goal then, so the robot must not count it) or in between.
    #[test]
    fn a_frontier_a_teammate_in_view_holds_does_not_count() {
        let scenario = madenet_world::ScenarioConfig::default();
        let cfg = AgentConfig::from_scenario(&scenario, 0, 12, 12);
        let frontier_reachable = |mate: Option<Pos>| {
            let mut agent = Agent::new(cfg.clone(), Pos::new(0, 0), Box::new(External));
            let mut seen: Vec<(Pos, Occupancy)> = (0..12)
                .flat_map(|r| (0..12).map(move |c| Pos::new(r, c)))
                .filter(|p| !(p.row == 0 && p.col >= 4))
                .map(|p| {
                    let free = p.row == 0;
                    (
                        p,
                        if free {
                            Occupancy::Free
                        } else {
                            Occupancy::Obstacle
                        },
                    )
                })
                .collect();
            seen.sort_by_key(|(p, _)| (p.row, p.col));
            agent.observe(&Observation {
                robot: 0,
                t: 0,
                pos: Pos::new(0, 0),
                seen,
                teammates: mate.map(|p| (1, p)).into_iter().collect(),
                exchanged_with: Vec::new(),
            });
            agent.frontier_reachable()
        };
        assert!(frontier_reachable(None));
        assert!(!frontier_reachable(Some(Pos::new(0, 3))), "held frontier");
        assert!(!frontier_reachable(Some(Pos::new(0, 2))), "held corridor");
        assert!(
            frontier_reachable(Some(Pos::new(5, 5))),
            "a teammate elsewhere"
        );
    }
}
