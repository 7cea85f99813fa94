//! The world: ground truth, robot poses, and the per-timestep pipeline
//! motion → sensing → contact & communication.

use crate::config::{ConfigError, ScenarioConfig};
use crate::geometry::{line_of_sight, step_allowed, Move, ViewPattern};
use crate::radio::Radio;
use crate::rng::{stream, Rng};
use madenet_map::{OccGrid, Occupancy, Pos};
use rand::{Rng as _, RngExt};
use std::sync::Arc;

/// Why a scenario cannot start.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The [`ScenarioConfig`] fails [`ScenarioConfig::validate`].
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A robot's start cell cannot be used.
    #[error("start cell {pos} of robot {robot} is {what}")]
    BadStart {
        /// Index of the robot whose start it is.
        robot: usize,
        /// The offending start cell.
        pos: Pos,
        /// Why: `outside the map`, `not free` or `shared with another robot`.
        what: &'static str,
    },
    /// Fewer start cells than robots (extra start cells are ignored, not an error).
    #[error("{robots} robots but {starts} start cells (config field `num_robots`)")]
    StartCount {
        /// Team size |I| (`num_robots`).
        robots: usize,
        /// Number of start cells given.
        starts: usize,
    },
}

/// What one robot perceives in one timestep (its primitive observation o_i).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Observation {
    /// Index i of the observing robot.
    pub robot: usize,
    /// Timestep of the observation.
    pub t: usize,
    /// The robot's own position (localization).
    pub pos: Pos,
    /// Cells observed this step (own cell included), with their true occupancy.
    pub seen: Vec<(Pos, Occupancy)>,
    /// Teammates detected: within d_s (Chebyshev) and in line of sight.
    pub teammates: Vec<(usize, Pos)>,
    /// Teammates this robot exchanged β with this step (comm succeeded).
    pub exchanged_with: Vec<usize>,
}

/// The world of one trial.
#[derive(Clone, Debug)]
pub struct World {
    cfg: ScenarioConfig,
    truth: OccGrid,
    blocked: Vec<bool>,
    view: ViewPattern,
    positions: Vec<Pos>,
    starts: Vec<Pos>,
    t: usize,
    rng_motion: Vec<Rng>,
    rng_sensor: Vec<Rng>,
    /// The communication model; `None` once [`World::detach_radio`] handed it to a radio node.
    radio: Option<Radio>,
    team_map: Vec<Occupancy>,
    known: usize,
    explorable: Vec<bool>,
    explorable_count: usize,
    obs: Vec<Observation>,
    contacts: Vec<(usize, usize)>,
    exchanges: Vec<(usize, usize)>,
    executed: Vec<Move>,
    distance: Vec<f64>,
    targets: Vec<Pos>,
    /// Per cell, the range of `visible` holding the cells visible from it (ignoring misses),
    /// cast on first use: robots revisit cells, and rays are the costly part of sensing.
    visible_range: Vec<(u32, u32)>,
    visible: Vec<(Pos, Occupancy, u32)>,
    /// A complete cache of cast rays shared with other worlds on the same map and scenario
    /// ([`World::visibility`]); when set, `visible_range`/`visible` are unused.
    shared_visible: Option<Arc<Visibility>>,
    /// Cells observed by the team in the current step (stamped with `sense_round`), and how
    /// many were new to the team: the C_t and C_t ∩ U_t of Eq. (8).
    seen_round: Vec<u32>,
    sense_round: u32,
    team_seen: usize,
    team_new: usize,
}

const NOT_CAST: (u32, u32) = (u32::MAX, 0);

/// Every cell's cast rays (the cells visible from it, ignoring misses), for one map and one
/// sensing range and movement rule: shared by the worlds of a batch of environments, whose own
/// lazily filled caches would otherwise each take ≈ 0.5 MB on a 20 × 20 map.
#[derive(Debug)]
pub struct Visibility {
    range: Vec<(u32, u32)>,
    cells: Vec<(Pos, Occupancy, u32)>,
}

impl Visibility {
    /// The cells (row-major indices) visible from cell `from` (a row-major index), misses
    /// ignored; none from a blocked cell.
    pub fn visible_from(&self, from: usize) -> impl Iterator<Item = usize> + '_ {
        let (start, end) = self.range[from];
        let cells = if (start, end) == NOT_CAST {
            &[][..]
        } else {
            &self.cells[start as usize..end as usize]
        };
        cells.iter().map(|&(_, _, i)| i as usize)
    }
}

impl World {
    /// Builds the world and performs the initial sensing and contact stage (t = 0). Unknown
    /// cells of `truth` (a map's unmapped area) are obstacles: nobody can enter or explore them.
    pub fn new(
        mut truth: OccGrid,
        starts: &[Pos],
        cfg: ScenarioConfig,
        seed: u64,
    ) -> Result<Self, ScenarioError> {
        cfg.validate()?;
        for c in truth.cells_mut() {
            if *c == Occupancy::Unknown {
                *c = Occupancy::Obstacle;
            }
        }
        let n = cfg.num_robots;
        if starts.len() < n {
            return Err(ScenarioError::StartCount {
                robots: n,
                starts: starts.len(),
            });
        }
        let starts = &starts[..n];
        for (i, &p) in starts.iter().enumerate() {
            if !truth.in_bounds(p) {
                return Err(ScenarioError::BadStart {
                    robot: i,
                    pos: p,
                    what: "outside the map",
                });
            }
            if truth.get(p) != Occupancy::Free {
                return Err(ScenarioError::BadStart {
                    robot: i,
                    pos: p,
                    what: "not free",
                });
            }
            if starts[..i].contains(&p) {
                return Err(ScenarioError::BadStart {
                    robot: i,
                    pos: p,
                    what: "shared with another robot",
                });
            }
        }
        let blocked: Vec<bool> = truth
            .cells()
            .iter()
            .map(|&c| c != Occupancy::Free)
            .collect();
        let view = ViewPattern::new(cfg.sensing_range, cfg.movement);
        let cells = truth.len();
        let mut w = World {
            rng_motion: (0..n).map(|i| stream(seed, "motion", i as u64)).collect(),
            rng_sensor: (0..n).map(|i| stream(seed, "sensor", i as u64)).collect(),
            radio: Some(Radio::new(&cfg, n, seed)),
            team_map: vec![Occupancy::Unknown; cells],
            known: 0,
            explorable: vec![false; cells],
            explorable_count: 0,
            obs: (0..n)
                .map(|i| Observation {
                    robot: i,
                    ..Default::default()
                })
                .collect(),
            contacts: Vec::new(),
            exchanges: Vec::new(),
            executed: vec![Move::Stay; n],
            distance: vec![0.0; n],
            targets: Vec::with_capacity(n),
            visible_range: vec![NOT_CAST; cells],
            visible: Vec::new(),
            shared_visible: None,
            seen_round: vec![0; cells],
            sense_round: 0,
            team_seen: 0,
            team_new: 0,
            positions: starts.to_vec(),
            starts: starts.to_vec(),
            t: 0,
            view,
            blocked,
            truth,
            cfg,
        };
        w.compute_explorable();
        w.sense();
        w.contact_and_communicate();
        Ok(w)
    }

    /// From now on, no sensor misses and no slips (communication stays as configured): the
    /// certainty-equivalent future a rollout can score a decision in without luck.
    pub fn set_noiseless(&mut self) {
        self.cfg.sensor_miss_prob = 0.0;
        self.cfg.motion_success_prob = 1.0;
    }

    /// Replaces every noise stream (motion, sensor, communication) by fresh ones derived from
    /// the world's seed and `salt` (streams `fork/motion`, `fork/sensor`, `fork/comm`): a
    /// clone of this world then lives a different future from the same present. How the
    /// rollout teacher and oracle average over the future's noise.
    pub fn reseed_noise(&mut self, seed: u64, salt: u64) {
        let n = self.positions.len();
        let k = |i: usize| salt.wrapping_mul(1 << 16).wrapping_add(i as u64);
        self.rng_motion = (0..n).map(|i| stream(seed, "fork/motion", k(i))).collect();
        self.rng_sensor = (0..n).map(|i| stream(seed, "fork/sensor", k(i))).collect();
        if let Some(radio) = &mut self.radio {
            radio.reseed(stream(seed, "fork/comm", k(0)));
        }
    }

    /// Gives every cell the team has not seen yet (unknown in the team map) the occupancy it has
    /// in `other` (unknown there: an obstacle) — another world that agrees with everything the
    /// team knows: the belief-consistent future of a rollout, where `other` is a draw of the map
    /// generator (madenet-sim's `Future::Redrawn`). Robots stand on cells they have seen, so
    /// they keep their places; what is explorable is recomputed from where they stand, and
    /// every cell the team has seen stays explorable (a cell seen past a missed one could
    /// otherwise fall out of the count the team's progress is measured against).
    ///
    /// # Panics
    /// When `other` is not the size of this world's map.
    pub fn redraw_unseen(&mut self, other: &OccGrid) {
        assert_eq!(
            (other.height(), other.width()),
            (self.truth.height(), self.truth.width()),
            "the redrawn map must be the world's size"
        );
        for (i, cell) in self.truth.cells_mut().iter_mut().enumerate() {
            if self.team_map[i] == Occupancy::Unknown {
                *cell = match other.cells()[i] {
                    Occupancy::Unknown => Occupancy::Obstacle,
                    c => c,
                };
            }
            self.blocked[i] = *cell != Occupancy::Free;
        }
        // The cast rays were cast on the old map.
        self.shared_visible = None;
        self.visible_range.clear();
        self.visible_range.resize(self.truth.len(), NOT_CAST);
        self.visible.clear();
        self.compute_explorable();
        for (e, &k) in self.explorable.iter_mut().zip(&self.team_map) {
            *e |= k != Occupancy::Unknown;
        }
        self.explorable_count = self.explorable.iter().filter(|&&e| e).count();
    }

    /// Marks every cell `known` does not leave unknown as known to the team, with `known`'s
    /// occupancy (a planner's world built from one robot's belief starts from what that robot
    /// knows, not from a blank team map). Cells the world cannot explore stay so.
    ///
    /// # Panics
    /// If `known` is not one value per cell.
    pub fn assume_known(&mut self, known: &[Occupancy]) {
        assert_eq!(
            known.len(),
            self.team_map.len(),
            "a known map of another size"
        );
        for (m, &k) in self.team_map.iter_mut().zip(known) {
            if k != Occupancy::Unknown && *m == Occupancy::Unknown {
                *m = k;
                self.known += 1;
            }
        }
        for (e, &k) in self.explorable.iter_mut().zip(&self.team_map) {
            *e |= k != Occupancy::Unknown;
        }
        self.explorable_count = self.explorable.iter().filter(|&&e| e).count();
    }

    /// The world of `World::new(truth, starts, cfg, seed)` for the same map, starts and
    /// scenario, reusing this one's allocations and its cache of cast rays (the costly part of
    /// building and sensing): an episode restarts without casting again what earlier episodes
    /// cast. Identical to a new world in every observable respect.
    pub fn restart(&mut self, seed: u64) {
        let n = self.positions.len();
        self.rng_motion = (0..n).map(|i| stream(seed, "motion", i as u64)).collect();
        self.rng_sensor = (0..n).map(|i| stream(seed, "sensor", i as u64)).collect();
        if let Some(radio) = &mut self.radio {
            radio.restart(seed);
        }
        self.team_map.fill(Occupancy::Unknown);
        self.known = 0;
        for (i, o) in self.obs.iter_mut().enumerate() {
            *o = Observation {
                robot: i,
                ..Default::default()
            };
        }
        self.contacts.clear();
        self.exchanges.clear();
        self.executed.fill(Move::Stay);
        self.distance.fill(0.0);
        self.targets.clear();
        self.seen_round.fill(0);
        self.sense_round = 0;
        self.team_seen = 0;
        self.team_new = 0;
        self.positions.clone_from(&self.starts);
        self.t = 0;
        self.sense();
        self.contact_and_communicate();
    }

    /// Cells visible (ignoring misses) from any free cell reachable from a start.
    fn compute_explorable(&mut self) {
        let cells = self.truth.len();
        let mut reach = vec![false; cells];
        let mut stack: Vec<Pos> = self.positions.clone();
        for &p in &stack {
            reach[self.truth.index(p)] = true;
        }
        while let Some(p) = stack.pop() {
            for m in &Move::ALL[1..] {
                if step_allowed(|q| self.passable(q), p, *m, self.cfg.movement) {
                    let q = m.apply(p);
                    let qi = self.truth.index(q);
                    if !reach[qi] {
                        reach[qi] = true;
                        stack.push(q);
                    }
                }
            }
        }
        // A cell visible from a reachable cell is adjacent to a reachable cell: every cell a
        // ray passes before its target is free and, under the movement rule, reachable from
        // the previous one (a squeeze that blocks robots blocks rays too). And an adjacent
        // cell is visible unless the step to it is such a squeeze. So the union of the view
        // sets is the reachable cells plus their unsqueezed 8-neighbours — O(cells), where
        // casting every ray from every reachable cell cost 80 rays per cell.
        let mut explorable = reach.clone();
        let strict = self.cfg.movement == madenet_map::Movement::NoCornerCutting;
        for (i, &r) in reach.iter().enumerate() {
            if !r {
                continue;
            }
            let p = self.truth.pos(i);
            for m in &Move::ALL[1..] {
                let q = m.apply(p);
                if self.truth.in_bounds(q)
                    && !(strict && crate::geometry::squeezed(|c| self.is_blocked(c), p, q))
                {
                    explorable[self.truth.index(q)] = true;
                }
            }
        }
        self.explorable_count = explorable.iter().filter(|&&e| e).count();
        self.explorable = explorable;
    }

    #[inline]
    fn is_blocked(&self, p: Pos) -> bool {
        self.blocked[self.truth.index(p)]
    }

    #[inline]
    fn passable(&self, p: Pos) -> bool {
        self.truth.in_bounds(p) && !self.is_blocked(p)
    }

    /// Whether a robot may stand on `p`: on the map and not an obstacle (nor unmapped).
    pub fn is_passable(&self, p: Pos) -> bool {
        self.passable(p)
    }

    /// Advances one timestep: every robot executes its move simultaneously, then all sense,
    /// then contacts and exchanges are resolved. `intents[i]` is robot i's desired move.
    pub fn step(&mut self, intents: &[Move]) {
        assert_eq!(intents.len(), self.positions.len(), "one move per robot");
        self.apply_motion(intents);
        self.t += 1;
        self.sense();
        self.contact_and_communicate();
    }

    /// Motion stage. A move is legal when [`step_allowed`] holds on the obstacles and its
    /// target is not held by another robot at the start of the step (so swaps and trains
    /// cannot happen; robots are not corners); an illegal intent becomes `Stay`. With probability 1 − `motion_success_prob`
    /// a uniformly random other legal move (staying included) is executed instead. Two robots
    /// heading for the same cell: the lower index moves, the other stays.
    fn apply_motion(&mut self, intents: &[Move]) {
        let n = self.positions.len();
        let mut targets = std::mem::take(&mut self.targets);
        targets.clear();
        targets.extend_from_slice(&self.positions);
        for i in 0..n {
            let at = self.positions[i];
            let (positions, blocked, truth, movement) = (
                &self.positions,
                &self.blocked,
                &self.truth,
                self.cfg.movement,
            );
            // Obstacles make corners; robots only block the cell they hold.
            let legal = |m: Move| {
                let to = m.apply(at);
                step_allowed(
                    |q| truth.in_bounds(q) && !blocked[truth.index(q)],
                    at,
                    m,
                    movement,
                ) && (m == Move::Stay
                    || !positions
                        .iter()
                        .enumerate()
                        .any(|(j, &pj)| j != i && pj == to))
            };
            let intent = if legal(intents[i]) {
                intents[i]
            } else {
                Move::Stay
            };
            // Always two draws per robot and step, so streams stay aligned across policies.
            let slip = self.rng_motion[i].random::<f64>() >= self.cfg.motion_success_prob;
            let pick = self.rng_motion[i].random::<f64>();
            let mut executed = intent;
            if slip && (intent != Move::Stay || self.cfg.slip_when_staying) {
                let mut options = [Move::Stay; 9];
                let mut k = 0;
                for m in Move::ALL {
                    if m != intent && legal(m) {
                        options[k] = m;
                        k += 1;
                    }
                }
                if k > 0 {
                    executed = options[((pick * k as f64) as usize).min(k - 1)];
                }
            }
            targets[i] = executed.apply(at);
            self.executed[i] = executed;
        }
        for i in 0..n {
            if self.executed[i] != Move::Stay && targets[..i].contains(&targets[i]) {
                self.executed[i] = Move::Stay;
                targets[i] = self.positions[i];
            }
        }
        for (d, m) in self.distance.iter_mut().zip(&self.executed) {
            *d += m.length() * self.cfg.cell_size;
        }
        self.positions[..n].copy_from_slice(&targets[..n]);
        self.targets = targets;
    }

    /// Sensing stage: every visible cell of the (2·d_s+1)² window is observed unless missed
    /// (probability `sensor_miss_prob`, independently per cell and step). The robot's own
    /// cell is always observed.
    fn sense(&mut self) {
        // A cell is missed when a uniform u64 falls below miss · 2^64 (integer compare; a
        // probability of 1 misses everything).
        let miss = self.cfg.sensor_miss_prob;
        let always_miss = miss >= 1.0;
        let threshold = (miss * 18_446_744_073_709_551_616.0) as u64;
        let known_before = self.known;
        self.sense_round += 1;
        let round = self.sense_round;
        self.team_seen = 0;
        // Taken out for the loop (no reference-count traffic per robot), put back after.
        let shared = self.shared_visible.take();
        for i in 0..self.positions.len() {
            let at = self.positions[i];
            let (start, end) = match &shared {
                Some(v) => v.range[self.truth.index(at)],
                None => self.visible_from(at),
            };
            let visible = match &shared {
                Some(v) => &v.cells[start as usize..end as usize],
                None => &self.visible[start as usize..end as usize],
            };
            let obs = &mut self.obs[i];
            obs.t = self.t;
            obs.pos = at;
            let own = self.truth.index(at);
            let (team_map, seen_round) = (&mut self.team_map[..], &mut self.seen_round[..]);
            let (mut known, mut team_seen) = (self.known, self.team_seen);
            if team_map[own] == Occupancy::Unknown {
                team_map[own] = Occupancy::Free;
                known += 1;
            }
            if seen_round[own] != round {
                seen_round[own] = round;
                team_seen += 1;
            }
            // Branch-free: every visible cell is written to the next slot of `seen` and the slot
            // kept only when the cell is not missed (a miss, 1 in 10 at random, mispredicted a
            // branch per robot and step many times over). No draws when everything is missed.
            let seen = &mut obs.seen;
            seen.resize(visible.len() + 1, (at, Occupancy::Free));
            seen[0] = (at, Occupancy::Free);
            let mut n = 1;
            if !always_miss {
                let rng = &mut self.rng_sensor[i];
                for &(q, occ, k) in visible {
                    let hit = rng.next_u64() >= threshold;
                    seen[n] = (q, occ);
                    n += hit as usize;
                    let k = k as usize;
                    // A known team-map cell already holds `occ` (sensing is exact).
                    let new = hit & (team_map[k] == Occupancy::Unknown);
                    known += new as usize;
                    team_map[k] = if new { occ } else { team_map[k] };
                    let first = hit & (seen_round[k] != round);
                    team_seen += first as usize;
                    seen_round[k] = if first { round } else { seen_round[k] };
                }
            }
            seen.truncate(n);
            self.known = known;
            self.team_seen = team_seen;
        }
        self.shared_visible = shared;
        self.team_new = self.known - known_before;
    }

    /// This world's rays cast from every free cell, to share with other worlds on the same map
    /// and scenario ([`World::use_visibility`]); this world uses the shared copy from now on.
    pub fn visibility(&mut self) -> Arc<Visibility> {
        if let Some(v) = &self.shared_visible {
            return v.clone();
        }
        for i in 0..self.truth.len() {
            if !self.blocked[i] {
                self.visible_from(self.truth.pos(i));
            }
        }
        let v = Arc::new(Visibility {
            range: std::mem::take(&mut self.visible_range),
            cells: std::mem::take(&mut self.visible),
        });
        self.shared_visible = Some(v.clone());
        v
    }

    /// Uses `v` ([`World::visibility`] of a world on the same map and scenario) instead of
    /// this world's own cache. Sensing is unchanged: the rays are the same.
    ///
    /// # Panics
    /// If `v` was cast on a map of another size.
    pub fn use_visibility(&mut self, v: Arc<Visibility>) {
        assert_eq!(v.range.len(), self.truth.len(), "visibility of another map");
        self.visible_range = Vec::new();
        self.visible = Vec::new();
        self.shared_visible = Some(v);
    }

    /// The range of `self.visible` listing the cells visible from `at`, cast on first use.
    fn visible_from(&mut self, at: Pos) -> (u32, u32) {
        let i = self.truth.index(at);
        if self.visible_range[i] == NOT_CAST {
            let start = self.visible.len() as u32;
            let (truth, blocked, visible) = (&self.truth, &self.blocked, &mut self.visible);
            self.view.for_each_visible(
                at,
                |q| truth.in_bounds(q),
                |q| blocked[truth.index(q)],
                |q| visible.push((q, truth.get(q), truth.index(q) as u32)),
            );
            self.visible_range[i] = (start, self.visible.len() as u32);
        }
        self.visible_range[i]
    }

    /// Contact and communication stage. Robots within Chebyshev distance d_s and in line of
    /// sight are in contact and detect each other. A pair in contact and not in dropout
    /// exchanges β with probability CSP; a failure starts a dropout of `dropout_steps`
    /// timesteps for that pair. Dropout timers count down every step, in contact or not.
    fn contact_and_communicate(&mut self) {
        let n = self.positions.len();
        self.contacts.clear();
        self.exchanges.clear();
        for o in &mut self.obs {
            o.teammates.clear();
            o.exchanged_with.clear();
        }
        let ds = self.cfg.sensing_range;
        for i in 0..n {
            for j in i + 1..n {
                let (a, b) = (self.positions[i], self.positions[j]);
                if a.chebyshev(b) > ds
                    || !line_of_sight(|q| self.is_blocked(q), a, b, self.cfg.movement)
                {
                    continue;
                }
                self.contacts.push((i, j));
                self.obs[i].teammates.push((j, b));
                self.obs[j].teammates.push((i, a));
            }
        }
        if let Some(radio) = &mut self.radio {
            radio.exchange(&self.contacts, &mut self.exchanges);
            for &(i, j) in &self.exchanges {
                self.obs[i].exchanged_with.push(j);
                self.obs[j].exchanged_with.push(i);
            }
        }
    }

    /// Hands communication to someone else (the runtime's radio node): from now on this world
    /// decides contacts only, [`World::exchanges`] stays empty and no observation lists
    /// exchanges. The radio node runs its own [`Radio::new`] with the trial's seed, which decides
    /// every timestep from 0 exactly as this world's radio would have.
    pub fn detach_radio(&mut self) {
        for o in &mut self.obs {
            o.exchanged_with.clear();
        }
        self.exchanges.clear();
        self.radio = None;
    }

    /// The scenario's parameters (with noise switched off after [`World::set_noiseless`]).
    pub fn config(&self) -> &ScenarioConfig {
        &self.cfg
    }
    /// The ground-truth grid, which no robot may read directly.
    pub fn truth(&self) -> &OccGrid {
        &self.truth
    }
    /// Current timestep (0 before the first move).
    pub fn t(&self) -> usize {
        self.t
    }
    /// Every robot's true cell, indexed by robot.
    pub fn positions(&self) -> &[Pos] {
        &self.positions
    }
    /// Robot i's observation of the current timestep.
    pub fn observation(&self, i: usize) -> &Observation {
        &self.obs[i]
    }
    /// Pairs (i < j) in contact this step: within d_s and in line of sight (for NOLI).
    pub fn contacts(&self) -> &[(usize, usize)] {
        &self.contacts
    }
    /// Pairs (i < j) that exchanged β this step.
    pub fn exchanges(&self) -> &[(usize, usize)] {
        &self.exchanges
    }
    /// The moves executed in the last step.
    pub fn executed_moves(&self) -> &[Move] {
        &self.executed
    }
    /// Distance each robot has travelled, metres.
    pub fn distances(&self) -> &[f64] {
        &self.distance
    }
    /// The team's merged map 𝓜 (union of everything any robot observed).
    pub fn team_map(&self) -> &[Occupancy] {
        &self.team_map
    }
    /// Cells the team knows (obstacles included).
    pub fn known_count(&self) -> usize {
        self.known
    }
    /// Cells visible from some reachable free cell: what "fully explored" means.
    pub fn explorable_count(&self) -> usize {
        self.explorable_count
    }
    /// Per cell (row-major, as [`OccGrid::index`]): whether it is explorable, i.e. visible
    /// from a free cell reachable from the starts; [`World::explorable_count`] counts them.
    pub fn explorable(&self) -> &[bool] {
        &self.explorable
    }
    /// Known cells over explorable cells, 0..=1.
    pub fn explored_fraction(&self) -> f64 {
        self.known as f64 / self.explorable_count.max(1) as f64
    }
    /// Distinct cells the team observed in the last sensing stage (|C_t| of Eq. 8).
    pub fn team_observed(&self) -> usize {
        self.team_seen
    }
    /// Of those, the cells the team had not known before (|C_t ∩ U_t| of Eq. 8).
    pub fn team_newly_observed(&self) -> usize {
        self.team_new
    }
    /// The team knows every explorable cell.
    pub fn is_complete(&self) -> bool {
        self.known >= self.explorable_count
    }
    /// Complete or at the step cap.
    pub fn is_done(&self) -> bool {
        self.is_complete() || self.t >= self.cfg.step_cap
    }
    /// Remaining dropout steps of pair (i, j) (0 once the radio is detached).
    pub fn dropout_remaining(&self, i: usize, j: usize) -> u32 {
        self.radio.as_ref().map_or(0, |r| r.dropout_remaining(i, j))
    }
}
