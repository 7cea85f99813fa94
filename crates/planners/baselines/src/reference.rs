//! The known-map reference: what a team that knows the true map can do, as a yardstick for
//! every exploration method (issue 29). Two numbers per trial:
//!
//! * [`lower_bound`] — no team, however coordinated, explores the map in fewer timesteps:
//!   the largest, over the cells left to observe after t = 0, of the fewest moves any robot
//!   needs to reach a cell that sees it (a move covers one cell, slips included, so noise
//!   never helps; sensing misses only add time).
//! * [`run`] — a clairvoyant team executed in the trial's own world (the same motion noise
//!   and sensing misses as every method sees for that seed). Its plan, a documented min–max
//!   heuristic and not an optimum: viewpoints that see every cell to observe (greedy set
//!   cover, redundant ones dropped), routed from the robots' cells by the insertion that
//!   keeps the longest route shortest, then improved by 2-opt within routes and relocations
//!   out of the longest. The robots walk true shortest paths (recomputed after slips), skip a
//!   viewpoint once the team has observed all it was for, and re-plan from where they are
//!   when a route runs out while cells are missing (misses leave cells unknown) or a robot
//!   was blocked three steps; a robot without a viewpoint steps out of a teammate's way.
//!
//! A method's gap to the reference says how much room coordination and map knowledge leave;
//! the reference's own gap to the bound says how far the heuristic is from any possible team.

use madenet_map::{Movement, OccGrid, Occupancy, Pos};
use madenet_metrics::{MetricsRecorder, Timing};
use madenet_sim::{record_step, SimError, TrialResult, TrialSpec};
use madenet_world::geometry::step_allowed;
use madenet_world::{Move, World};
use std::collections::{HashMap, VecDeque};
use std::sync::Arc;

const FAR: u32 = u32::MAX;

/// What the reference planned for a trial at t = 0 (execution re-plans as it goes).
#[derive(Clone, Debug, PartialEq)]
pub struct ReferencePlan {
    /// Each robot's viewpoints, in visiting order.
    pub routes: Vec<Vec<Pos>>,
    /// Each robot's planned moves along its route (noiseless).
    pub route_steps: Vec<u32>,
    /// The plan's makespan: the longest route, in moves (noiseless).
    pub planned_steps: u32,
    /// [`lower_bound`] of the trial.
    pub lower_bound: u32,
}

/// The map as the reference sees it: passable cells, what each cell sees, and which cells the
/// team still has to observe after t = 0.
struct Known {
    truth: OccGrid,
    movement: Movement,
    visibility: Arc<madenet_world::Visibility>,
    /// Cells to observe: explorable and unknown to the team after the first sensing.
    target: Vec<bool>,
    /// For every cell c: the passable cells that see c.
    seers: Vec<Vec<u32>>,
}

impl Known {
    fn new(world: &mut World) -> Self {
        let truth = world.truth().clone();
        let movement = world.config().movement;
        let visibility = world.visibility();
        let target: Vec<bool> = world
            .explorable()
            .iter()
            .zip(world.team_map())
            .map(|(&e, &m)| e && m == Occupancy::Unknown)
            .collect();
        let mut known = Known {
            truth,
            movement,
            visibility,
            target,
            seers: Vec::new(),
        };
        // Viewpoints: the cells some robot can reach (a free pocket no robot reaches sees the
        // walls it shares with the rest, but is no viewpoint).
        let mut reachable = vec![false; known.truth.len()];
        let mut dist = Vec::new();
        for &s in world.positions() {
            known.distances(s, &mut dist);
            for (r, &d) in reachable.iter_mut().zip(&dist) {
                *r |= d != FAR;
            }
        }
        let mut seers = vec![Vec::new(); known.truth.len()];
        for p in (0..known.truth.len()).filter(|&p| reachable[p]) {
            for c in known.visibility.visible_from(p) {
                seers[c].push(p as u32);
            }
        }
        known.seers = seers;
        known
    }

    fn passable(&self, p: Pos) -> bool {
        self.truth.in_bounds(p) && self.truth.get(p) == Occupancy::Free
    }

    /// Moves from `from` to every cell (FAR where unreachable), into `dist`. By hand: time is
    /// moves, a diagonal one step, where `madenet_nav::Dijkstra` weighs diagonals by length.
    fn distances(&self, from: Pos, dist: &mut Vec<u32>) {
        dist.clear();
        dist.resize(self.truth.len(), FAR);
        let mut queue = VecDeque::new();
        dist[self.truth.index(from)] = 0;
        queue.push_back(from);
        while let Some(p) = queue.pop_front() {
            let d = dist[self.truth.index(p)];
            for &m in &Move::ALL[1..] {
                if step_allowed(|q| self.passable(q), p, m, self.movement) {
                    let qi = self.truth.index(m.apply(p));
                    if dist[qi] == FAR {
                        dist[qi] = d + 1;
                        queue.push_back(m.apply(p));
                    }
                }
            }
        }
    }
}

/// The trial's world as every method meets it (same map, starts, scenario and noise streams).
fn world_of(spec: &TrialSpec) -> Result<World, SimError> {
    Ok(World::new(
        spec.map.clone(),
        &spec.starts,
        spec.config.clone(),
        spec.seed,
    )?)
}

/// The fewest timesteps in which any team could observe every cell of `spec` left unknown
/// after t = 0 (see the module docs); 0 if none is left.
pub fn lower_bound(spec: &TrialSpec) -> Result<u32, SimError> {
    let mut world = world_of(spec)?;
    let known = Known::new(&mut world);
    Ok(bound_of(&known, world.positions()))
}

fn bound_of(known: &Known, starts: &[Pos]) -> u32 {
    // nearest[p]: the fewest moves any robot needs to reach p.
    let mut nearest = vec![FAR; known.truth.len()];
    let mut dist = Vec::new();
    for &s in starts {
        known.distances(s, &mut dist);
        for (n, &d) in nearest.iter_mut().zip(&dist) {
            *n = (*n).min(d);
        }
    }
    (0..known.truth.len())
        .filter(|&c| known.target[c])
        .map(|c| {
            known.seers[c]
                .iter()
                .map(|&p| nearest[p as usize])
                .min()
                .unwrap_or(FAR)
        })
        .filter(|&d| d != FAR)
        .max()
        .unwrap_or(0)
}

/// Viewpoints that see every uncovered cell: greedy set cover (the cell seeing the most
/// uncovered cells first; ties to the lower index), then each viewpoint dropped whose cells
/// the others see too (latest first).
fn cover(known: &Known, initially: &[bool]) -> Vec<usize> {
    let cells = known.truth.len();
    let mut covered = initially.to_vec();
    let mut gain = vec![0u32; cells];
    for c in (0..cells).filter(|&c| !covered[c]) {
        for &p in &known.seers[c] {
            gain[p as usize] += 1;
        }
    }
    let mut chosen = Vec::new();
    while let Some(p) = (0..cells)
        .filter(|&p| gain[p] > 0)
        .max_by_key(|&p| (gain[p], std::cmp::Reverse(p)))
    {
        chosen.push(p);
        for c in known.visibility.visible_from(p) {
            if !covered[c] {
                covered[c] = true;
                for &q in &known.seers[c] {
                    gain[q as usize] -= 1;
                }
            }
        }
    }
    // Redundant viewpoints: every cell one sees that needed seeing is seen by another.
    let mut count = vec![0u32; cells];
    for &p in &chosen {
        for c in known.visibility.visible_from(p) {
            count[c] += 1;
        }
    }
    let mut k = chosen.len();
    while k > 0 {
        k -= 1;
        let p = chosen[k];
        if known
            .visibility
            .visible_from(p)
            .all(|c| count[c] > 1 || initially[c])
        {
            for c in known.visibility.visible_from(p) {
                count[c] -= 1;
            }
            chosen.remove(k);
        }
    }
    chosen
}

/// Routes over `points` from `starts` keeping the longest short: cheapest insertion (the
/// insertion that keeps the makespan lowest, then adds least), then relocations out of the
/// longest route and 2-opt within routes while the makespan falls.
fn route(known: &Known, starts: &[Pos], points: &[usize]) -> (Vec<Vec<usize>>, Vec<u32>) {
    let n = starts.len();
    let v = points.len();
    // d[a][b] over nodes: robots' starts 0..n, then the points.
    let nodes: Vec<usize> = starts
        .iter()
        .map(|&s| known.truth.index(s))
        .chain(points.iter().copied())
        .collect();
    let mut dist = Vec::new();
    let d: Vec<Vec<u32>> = nodes
        .iter()
        .map(|&a| {
            known.distances(known.truth.pos(a), &mut dist);
            nodes.iter().map(|&b| dist[b]).collect()
        })
        .collect();
    let len = |r: usize, route: &[usize]| -> u64 {
        let mut at = r;
        let mut total = 0u64;
        for &k in route {
            total += d[at][n + k] as u64;
            at = n + k;
        }
        total
    };
    let mut routes: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut lens = vec![0u64; n];
    let mut left: Vec<usize> = (0..v)
        .filter(|&k| (0..n).any(|r| d[r][n + k] != FAR))
        .collect();
    while !left.is_empty() {
        let makespan = lens.iter().copied().max().unwrap_or(0);
        let mut best: Option<((u64, u64), usize, usize, usize)> = None;
        for (li, &k) in left.iter().enumerate() {
            for r in 0..n {
                if d[r][n + k] == FAR {
                    continue;
                }
                for pos in 0..=routes[r].len() {
                    let prev = if pos == 0 { r } else { n + routes[r][pos - 1] };
                    let delta = if pos == routes[r].len() {
                        d[prev][n + k] as u64
                    } else {
                        let next = n + routes[r][pos];
                        (d[prev][n + k] as u64 + d[n + k][next] as u64)
                            .saturating_sub(d[prev][next] as u64)
                    };
                    let key = (makespan.max(lens[r] + delta), delta);
                    if best.is_none_or(|b| key < b.0) {
                        best = Some((key, li, r, pos));
                    }
                }
            }
        }
        let Some((_, li, r, pos)) = best else { break };
        let k = left.swap_remove(li);
        routes[r].insert(pos, k);
        lens[r] = len(r, &routes[r]);
    }
    // Local search.
    for _ in 0..200 {
        let mut improved = false;
        // 2-opt within each route (open path).
        for r in 0..n {
            let m = routes[r].len();
            for a in 0..m {
                for b in a + 1..m {
                    let mut t = routes[r].clone();
                    t[a..=b].reverse();
                    let l = len(r, &t);
                    if l < lens[r] {
                        routes[r] = t;
                        lens[r] = l;
                        improved = true;
                    }
                }
            }
        }
        // Relocate a point out of the longest route where it lowers the makespan.
        let longest = (0..n)
            .max_by_key(|&r| (lens[r], std::cmp::Reverse(r)))
            .unwrap_or(0);
        let makespan = lens[longest];
        'relocate: for a in 0..routes[longest].len() {
            let mut from = routes[longest].clone();
            let k = from.remove(a);
            let lf = len(longest, &from);
            for r in (0..n).filter(|&r| r != longest && d[r][n + k] != FAR) {
                for pos in 0..=routes[r].len() {
                    let mut to = routes[r].clone();
                    to.insert(pos, k);
                    let lt = len(r, &to);
                    let others = (0..n)
                        .filter(|&q| q != longest && q != r)
                        .map(|q| lens[q])
                        .max()
                        .unwrap_or(0);
                    if lf.max(lt).max(others) < makespan {
                        routes[longest] = from;
                        lens[longest] = lf;
                        routes[r] = to;
                        lens[r] = lt;
                        improved = true;
                        break 'relocate;
                    }
                }
            }
        }
        if !improved {
            break;
        }
    }
    (routes, lens.iter().map(|&l| l as u32).collect())
}

fn plan_of(known: &Known, starts: &[Pos]) -> ReferencePlan {
    let covered: Vec<bool> = known.target.iter().map(|&t| !t).collect();
    let routes = plan_routes(known, starts, &covered);
    ReferencePlan {
        planned_steps: routes.1.iter().copied().max().unwrap_or(0),
        lower_bound: bound_of(known, starts),
        routes: routes.0,
        route_steps: routes.1,
    }
}

/// The reference's team plan over `world` as it stands — its truth, its team's knowledge, its
/// robots' cells (a fork whose unseen cells were redrawn, for the plan-redrawn oracle): for each
/// robot, the moves from every cell to its first viewpoint (`u32::MAX` where unreachable), or
/// `None` when the plan gives it none.
pub(crate) fn first_viewpoint_moves(world: &mut World) -> Vec<Option<Vec<u32>>> {
    let known = Known::new(world);
    let covered: Vec<bool> = known.target.iter().map(|&t| !t).collect();
    let (routes, _) = plan_routes(&known, world.positions(), &covered);
    routes
        .iter()
        .map(|r| {
            r.first().map(|&v| {
                let mut d = Vec::new();
                known.distances(v, &mut d);
                d
            })
        })
        .collect()
}

/// The world the reference plans on for what one robot knows: `belief` (the robot's map m_i)
/// with its unknown cells taken from `fill` (a map the generator drew, its unknown cells
/// obstacles: one belief-consistent future, as the plan-redrawn teacher's) or, without one, as
/// free (optimistic: nothing unseen blocks a route or a ray), its known cells known to the team,
/// noiseless, with a robot at each cell of `team` that the belief does not hold blocked (kept
/// free; duplicates dropped). Also returns, for each member of `team`, its robot's index in that
/// world (`None`: dropped). `None` when no member is left or the world cannot be built.
///
/// # Panics
/// If `fill` is not the belief's size.
fn belief_world(
    belief: &OccGrid,
    fill: Option<&OccGrid>,
    team: &[Pos],
    sensing_range: i32,
    movement: Movement,
) -> Option<(World, Vec<Option<usize>>)> {
    let mut truth = belief.clone();
    if let Some(f) = fill {
        assert_eq!((f.height(), f.width()), (belief.height(), belief.width()));
    }
    for (i, c) in truth.cells_mut().iter_mut().enumerate() {
        if *c == Occupancy::Unknown {
            *c = match fill.map(|f| f.cells()[i]) {
                None | Some(Occupancy::Free) => Occupancy::Free,
                Some(_) => Occupancy::Obstacle,
            };
        }
    }
    let mut starts: Vec<Pos> = Vec::with_capacity(team.len());
    let mut index = Vec::with_capacity(team.len());
    for &p in team {
        let usable = belief.in_bounds(p) && belief.get(p) != Occupancy::Obstacle;
        index.push(if !usable || starts.contains(&p) {
            None
        } else {
            truth.set(p, Occupancy::Free);
            starts.push(p);
            Some(starts.len() - 1)
        });
    }
    if starts.is_empty() {
        return None;
    }
    let cfg = madenet_world::ScenarioConfig {
        num_robots: starts.len(),
        sensing_range,
        movement,
        sensor_miss_prob: 0.0,
        motion_success_prob: 1.0,
        ..Default::default()
    };
    let mut world = World::new(truth, &starts, cfg, 0).ok()?;
    world.assume_known(belief.cells());
    Some((world, index))
}

/// The reference's team plan on what one robot knows — the decentralized counterpart of
/// `first_viewpoint_moves`, which knows the team's cells and every robot's position. It plans
/// on `belief_world`'s world: `belief` with its unknown cells from `fill` (or free), `team[0]`
/// the robot itself and the rest the teammates at their last known cells. Returns the moves on
/// that world from every cell to the robot's first viewpoint (`u32::MAX` where unreachable), or
/// `None` when the plan gives it none (nothing left to see, every viewpoint is a teammate's, or
/// the robot's own cell is not known free); `sensing_range` is d_s, the belief's movement rule
/// the world's.
///
/// # Panics
/// If `fill` is not the belief's size.
pub fn belief_first_viewpoint_moves(
    belief: &OccGrid,
    fill: Option<&OccGrid>,
    team: &[Pos],
    sensing_range: i32,
    movement: Movement,
) -> Option<Vec<u32>> {
    let own = *team.first()?;
    if !(belief.in_bounds(own) && belief.get(own) == Occupancy::Free) {
        return None;
    }
    let (mut world, _) = belief_world(belief, fill, team, sensing_range, movement)?;
    first_viewpoint_moves(&mut world)
        .into_iter()
        .next()
        .flatten()
}

/// The reference's team plan on `belief_world`'s world (`belief`, its unknown cells from
/// `fill` or free; a robot at each cell of `team`): each member's viewpoints in visiting order,
/// empty for a member the plan gives none or that was dropped (its cell blocked, or a teammate's
/// duplicate). `None` when no member is left. What the `convention` policy splits the map by.
///
/// # Panics
/// If `fill` is not the belief's size.
pub fn belief_team_routes(
    belief: &OccGrid,
    fill: Option<&OccGrid>,
    team: &[Pos],
    sensing_range: i32,
    movement: Movement,
) -> Option<Vec<Vec<Pos>>> {
    let (mut world, index) = belief_world(belief, fill, team, sensing_range, movement)?;
    let known = Known::new(&mut world);
    let covered: Vec<bool> = known.target.iter().map(|&t| !t).collect();
    let (routes, _) = plan_routes(&known, world.positions(), &covered);
    Some(
        index
            .iter()
            .map(|k| k.map_or_else(Vec::new, |k| routes[k].clone()))
            .collect(),
    )
}

/// The mean, per cell of `cells`, of its moves in each field of `fields` (`None`: a plan that
/// gave the robot no viewpoint, skipped), capped at `far`; `None` when no field is given. How
/// the plan teachers and `belief-plan` value candidates by their moves to a first viewpoint.
pub(crate) fn mean_plan_moves(
    grid: &OccGrid,
    cells: &[Pos],
    far: u32,
    fields: impl IntoIterator<Item = Option<Vec<u32>>>,
) -> Option<Vec<f64>> {
    let mut sum = vec![0.0; cells.len()];
    let mut planned = 0usize;
    for to_first in fields.into_iter().flatten() {
        planned += 1;
        for (v, &c) in sum.iter_mut().zip(cells) {
            *v += f64::from(to_first[grid.index(c)].min(far));
        }
    }
    (planned > 0).then(|| sum.into_iter().map(|v| v / planned as f64).collect())
}

/// The maps a belief plan fills the unknown cells from: each of `fills`, or, with none, the one
/// optimistic plan (`None`: unknown cells free).
pub fn plan_fills(fills: &[OccGrid]) -> Vec<Option<&OccGrid>> {
    if fills.is_empty() {
        vec![None]
    } else {
        fills.iter().map(Some).collect()
    }
}

/// The team as robot `id` at `pos` knows it from its records β_i (`teammates`, its own
/// included): itself first, then every teammate it has heard of or seen, at the goal it last
/// announced or else at its last known cell, however old.
pub fn known_team(id: usize, pos: Pos, teammates: &[madenet_agent::TeammateRecord]) -> Vec<Pos> {
    std::iter::once(pos)
        .chain(
            teammates
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != id)
                .filter_map(|(_, r)| r.goal.or_else(|| r.last_pos())),
        )
        .collect()
}

/// [`belief_first_viewpoint_moves`] for the robot of `view`, over each map of `fills` (none:
/// once, optimistic): the team is the robot and every teammate it has heard of or seen, placed
/// at the goal it last announced or else at its last known cell, however old (a teammate is
/// predicted where it was heading, not forgotten after a few steps: with the 10 steps `spread`
/// remembers, robots out of touch planned the same regions; models/README, stop 53); each goal
/// candidate's moves to the robot's first viewpoint, in slot order, the mean over the plans
/// that give it one (an unreachable viewpoint counts twice the map's height + width), `None`
/// when none does. What the `belief-plan` policy decides by and the agnostic DEP's plan inputs
/// read.
pub fn candidate_plan_moves(
    view: &madenet_agent::AgentView<'_>,
    fills: &[OccGrid],
) -> Option<Vec<f64>> {
    let sensing_range = view.sensing_range;
    let team = known_team(view.id, view.pos, view.teammates);
    let grid = view.belief.grid();
    let far = 2 * (grid.height() + grid.width()) as u32;
    let movement = view.belief.movement();
    let fields = plan_fills(fills)
        .into_iter()
        .map(|fill| belief_first_viewpoint_moves(grid, fill, &team, sensing_range, movement));
    mean_plan_moves(grid, &view.candidates().cells, far, fields)
}

/// The viewpoints covering what `covered` leaves ([`cover`]), routed from `starts`
/// ([`route`]): each robot's viewpoints in order and its route's moves.
fn plan_routes(known: &Known, starts: &[Pos], covered: &[bool]) -> (Vec<Vec<Pos>>, Vec<u32>) {
    let points = cover(known, covered);
    let (order, steps) = route(known, starts, &points);
    let routes = order
        .iter()
        .map(|r| r.iter().map(|&k| known.truth.pos(points[k])).collect())
        .collect();
    (routes, steps)
}

/// Shortest-path fields towards goals, computed once per goal.
struct Fields<'a> {
    known: &'a Known,
    to: HashMap<usize, Vec<u32>>,
}

impl Fields<'_> {
    fn field(&mut self, goal: Pos) -> &[u32] {
        let known = self.known;
        self.to.entry(known.truth.index(goal)).or_insert_with(|| {
            let mut d = Vec::new();
            known.distances(goal, &mut d);
            d
        })
    }
}

/// Runs the reference plan of `spec` in the trial's own world (its noise streams from
/// `spec.seed`) to completion or the step cap. The result's policy is `reference`.
pub fn run(spec: &TrialSpec) -> Result<(TrialResult, ReferencePlan), SimError> {
    let started = std::time::Instant::now();
    let mut world = world_of(spec)?;
    let known = Known::new(&mut world);
    let plan = plan_of(&known, world.positions());
    let n = world.positions().len();
    let mut recorder = MetricsRecorder::new(world.explored_fraction());
    let mut fields = Fields {
        known: &known,
        to: HashMap::new(),
    };
    let mut routes: Vec<VecDeque<Pos>> = plan
        .routes
        .iter()
        .map(|r| r.iter().copied().collect())
        .collect();
    let mut idle: Vec<bool> = routes.iter().map(|r| r.is_empty()).collect();
    // Steps without getting closer to the viewpoint (after two, a robot steps around).
    let mut stalled = vec![0u32; n];
    let mut moves = vec![Move::Stay; n];
    // A viewpoint is still useful while a cell to observe that it sees is unknown to the team.
    let useful = |world: &World, p: Pos| {
        let map = world.team_map();
        known
            .visibility
            .visible_from(known.truth.index(p))
            .any(|c| known.target[c] && map[c] == Occupancy::Unknown)
    };
    while !world.is_done() {
        // Follow the routes, skipping viewpoints reached or no longer needed; re-plan from here
        // when a robot's route ran out while cells are missing, or a robot made no progress
        // towards its viewpoint for four steps (teammates in a passage, slips).
        for (i, r) in routes.iter_mut().enumerate() {
            while r
                .front()
                .is_some_and(|&g| g == world.positions()[i] || !useful(&world, g))
            {
                r.pop_front();
            }
        }
        if (0..n).any(|i| (routes[i].is_empty() && !idle[i]) || stalled[i] >= 4) {
            let map = world.team_map();
            let covered: Vec<bool> = (0..known.truth.len())
                .map(|c| !known.target[c] || map[c] != Occupancy::Unknown)
                .collect();
            let (r, _) = plan_routes(&known, world.positions(), &covered);
            routes = r.into_iter().map(VecDeque::from).collect();
            for i in 0..n {
                idle[i] = routes[i].is_empty();
                stalled[i] = 0;
            }
        }
        let goals: Vec<Option<Pos>> = routes.iter().map(|r| r.front().copied()).collect();
        for i in 0..n {
            let at = world.positions()[i];
            moves[i] = match goals[i] {
                Some(g) if g != at => {
                    let field = fields.field(g);
                    let occupied = |q: Pos| world.positions().contains(&q);
                    let d = |q: Pos| field[known.truth.index(q)];
                    let options: Vec<Move> = Move::ALL[1..]
                        .iter()
                        .copied()
                        .filter(|&m| step_allowed(|q| known.passable(q), at, m, known.movement))
                        .collect();
                    let here = d(at);
                    // Down the field; around a teammate in the way after a blocked step.
                    let down = options
                        .iter()
                        .copied()
                        .filter(|&m| d(m.apply(at)) < here)
                        .min_by_key(|&m| (occupied(m.apply(at)), d(m.apply(at))));
                    match down {
                        Some(m) if !occupied(m.apply(at)) => m,
                        _ if stalled[i] >= 2 => options
                            .iter()
                            .copied()
                            .filter(|&m| !occupied(m.apply(at)))
                            .min_by_key(|&m| d(m.apply(at)))
                            .unwrap_or(Move::Stay),
                        Some(m) => m,
                        None => Move::Stay,
                    }
                }
                _ => Move::Stay,
            };
        }
        // A robot without a viewpoint steps out of a teammate's way.
        for i in 0..n {
            if goals[i].is_some() {
                continue;
            }
            let at = world.positions()[i];
            let wanted = |q: Pos| {
                (0..n).any(|j| {
                    j != i && moves[j].apply(world.positions()[j]) == q && moves[j] != Move::Stay
                })
            };
            if wanted(at) {
                moves[i] = Move::ALL[1..]
                    .iter()
                    .copied()
                    .filter(|&m| step_allowed(|q| known.passable(q), at, m, known.movement))
                    .find(|&m| {
                        let q = m.apply(at);
                        !wanted(q) && !world.positions().contains(&q)
                    })
                    .unwrap_or(Move::Stay);
            }
        }
        let before = world.positions().to_vec();
        world.step(&moves);
        for i in 0..n {
            stalled[i] = match goals[i] {
                Some(g) if g != before[i] => {
                    let field = fields.field(g);
                    let d = |p: Pos| field[known.truth.index(p)];
                    if d(world.positions()[i]) < d(before[i]) {
                        0
                    } else {
                        stalled[i] + 1
                    }
                }
                _ => 0,
            };
        }
        record_step(&mut recorder, &world);
    }
    let result = TrialResult {
        map: spec.map_name.clone(),
        policy: "reference".into(),
        seed: spec.seed,
        comm_success_prob: spec.config.comm_success_prob,
        starts: spec.starts.iter().take(n).copied().collect(),
        metrics: recorder.finish(world.is_complete()),
        trajectory: Vec::new(),
        timing: Timing {
            trial_s: started.elapsed().as_secs_f64(),
            decisions: 0,
            per_decision_s: 0.0,
        },
    };
    Ok((result, plan))
}

#[cfg(test)]
mod tests {
    use super::*;
    use madenet_map::paper::{paper_map, Corner};
    use madenet_world::ScenarioConfig;

    /// A free 1 × `len` corridor, and `robots` robots sensing 2 cells, exactly, and moving
    /// exactly.
    fn corridor(len: usize, robots: usize) -> (OccGrid, ScenarioConfig) {
        let text = format!("{}\n", ".".repeat(len));
        let map = madenet_map::io::parse_text(&text, std::path::Path::new("corridor")).unwrap();
        let cfg = ScenarioConfig {
            num_robots: robots,
            sensing_range: 2,
            sensor_miss_prob: 0.0,
            motion_success_prob: 1.0,
            ..ScenarioConfig::default()
        };
        (map, cfg)
    }

    fn spec(map: usize, corner: Corner, seed: u64, cfg: ScenarioConfig) -> TrialSpec {
        let map = paper_map(map).unwrap();
        TrialSpec {
            starts: corner.start_cells(map.height(), map.width()).to_vec(),
            map,
            map_name: "paper".into(),
            config: cfg,
            policy: "reference".into(),
            seed,
        }
    }

    #[test]
    fn first_viewpoints_split_a_corridor_between_its_ends() {
        // A 1 × 24 corridor with a robot at each end, d_s = 2: the min–max plan sends each
        // robot to its own half, so each one's first viewpoint lies nearer itself than the other.
        let (map, cfg) = corridor(24, 2);
        let starts = [Pos::new(0, 0), Pos::new(0, 23)];
        let mut world = World::new(map, &starts, cfg, 1).unwrap();
        let moves = first_viewpoint_moves(&mut world);
        assert_eq!(moves.len(), 2);
        for (i, m) in moves.iter().enumerate() {
            let m = m.as_ref().expect("each robot has a viewpoint");
            let (own, other) = (starts[i], starts[1 - i]);
            assert!(
                m[own.col as usize] < m[other.col as usize],
                "robot {i}: {m:?}"
            );
            // Its first viewpoint sees an unknown cell (column 3 onwards, d_s = 2: one move at
            // least) and lies in its own half's first stretch.
            assert!(
                m[own.col as usize] >= 1 && m[own.col as usize] <= 9,
                "robot {i}: {m:?}"
            );
            assert!(m.contains(&0));
        }
    }

    /// The belief plan by hand on a 1 × 24 corridor (d_s = 2) whose middle the robot knows:
    /// alone, it is sent to its nearer unknown end; with a teammate last known at the left end
    /// it takes the right half (and the plan's moves are on the optimistic map: unknown cells
    /// are free); cells the belief knows are not observed again (a known left half sends it
    /// right even when alone); nothing left to see or a robot in a wall gives no plan.
    #[test]
    fn belief_plans_split_a_corridor_by_hand() {
        let m = Movement::default();
        let first = |rows: &str, team: &[Pos]| {
            let b = madenet_agent::Belief::from_rows(&[rows], m);
            belief_first_viewpoint_moves(b.grid(), None, team, 2, m).map(|d| {
                (0..24)
                    .min_by_key(|&c| (d[c], c))
                    .map(|c| (c, d[c]))
                    .unwrap()
            })
        };
        // Known: columns 8..=14; the robot at 10 sees 8..=12 again. Alone, the left end (0..=7,
        // 8 cells) is nearer than the right (15..=23, 9 cells), so its first viewpoint is left.
        let middle = "????????.......?????????";
        let (v, d) = first(middle, &[Pos::new(0, 10)]).unwrap();
        assert_eq!(d, 0);
        assert!(v < 10, "alone, first viewpoint at {v}");
        // A teammate last known at column 2 (in the unknown left part): the robot goes right.
        let (v, _) = first(middle, &[Pos::new(0, 10), Pos::new(0, 2)]).unwrap();
        assert!(
            v > 10,
            "with a teammate on the left, first viewpoint at {v}"
        );
        // The left half known: alone, it goes right.
        let (v, _) = first("...............?????????", &[Pos::new(0, 10)]).unwrap();
        assert!(v > 10, "left half known, first viewpoint at {v}");
        // Everything known: nothing to plan; the robot in a known wall: no plan.
        assert_eq!(first(&".".repeat(24), &[Pos::new(0, 10)]), None);
        assert_eq!(first("????????...#...?????????", &[Pos::new(0, 11)]), None);
    }

    #[test]
    fn team_routes_split_a_corridor_by_hand() {
        let m = Movement::default();
        let routes = |rows: &str, team: &[Pos]| {
            let b = madenet_agent::Belief::from_rows(&[rows], m);
            belief_team_routes(b.grid(), None, team, 2, m)
        };
        // Known: columns 8..=14; robots at 9 and 13: the left one takes the left end, the
        // right one the right end (min–max: neither crosses the other).
        let middle = "????????.......?????????";
        let r = routes(middle, &[Pos::new(0, 9), Pos::new(0, 13)]).unwrap();
        assert_eq!(r.len(), 2);
        assert!(!r[0].is_empty() && r[0].iter().all(|v| v.col < 9), "{r:?}");
        assert!(!r[1].is_empty() && r[1].iter().all(|v| v.col > 13), "{r:?}");
        // A member on a known wall and a second robot on a cell get no route; the plan is the
        // one robot's (both ends).
        let walled = "????????...#...?????????";
        let r = routes(walled, &[Pos::new(0, 9), Pos::new(0, 11), Pos::new(0, 9)]).unwrap();
        assert!(r[1].is_empty() && r[2].is_empty(), "{r:?}");
        assert!(r[0].iter().any(|v| v.col < 8), "{r:?}");
        // Everything known: nothing to route; nobody usable: no plan.
        let known = routes(&".".repeat(24), &[Pos::new(0, 3), Pos::new(0, 20)]).unwrap();
        assert!(known.iter().all(Vec::is_empty), "{known:?}");
        assert_eq!(routes(walled, &[Pos::new(0, 11)]), None);
    }

    #[test]
    fn a_corridor_bound_by_hand() {
        // A 1 × 12 corridor, one robot at the left end, d_s = 2: it sees cells 0..=2 at t = 0,
        // and the last cell (11) from cell 9 at the earliest: 9 moves.
        let (map, cfg) = corridor(12, 1);
        let s = TrialSpec {
            map,
            map_name: "corridor".into(),
            starts: vec![Pos::new(0, 0)],
            config: cfg,
            policy: "reference".into(),
            seed: 1,
        };
        assert_eq!(lower_bound(&s).unwrap(), 9);
        let (r, plan) = run(&s).unwrap();
        assert_eq!(plan.lower_bound, 9);
        assert_eq!(plan.planned_steps, 9, "{plan:?}");
        assert!(r.metrics.completed);
        assert_eq!(r.metrics.tns, 9);
    }

    #[test]
    fn noiseless_runs_match_their_plan_and_never_beat_the_bound() {
        let cfg = ScenarioConfig {
            sensor_miss_prob: 0.0,
            motion_success_prob: 1.0,
            ..ScenarioConfig::default()
        };
        for map in [1, 4, 7] {
            let s = spec(map, Corner::TopLeft, 3, cfg.clone());
            let (r, plan) = run(&s).unwrap();
            assert!(r.metrics.completed, "map {map}");
            // The plan's viewpoints see every cell left to observe.
            let mut world = World::new(s.map.clone(), &s.starts, s.config.clone(), 3).unwrap();
            let known = Known::new(&mut world);
            let mut seen = vec![false; known.truth.len()];
            for p in plan.routes.iter().flatten() {
                for c in known.visibility.visible_from(known.truth.index(*p)) {
                    seen[c] = true;
                }
            }
            assert!(
                (0..seen.len()).all(|c| seen[c] || !known.target[c]),
                "map {map}"
            );
            let tns = r.metrics.tns as u32;
            assert!(
                tns >= plan.lower_bound,
                "map {map}: {tns} < {}",
                plan.lower_bound
            );
            // En-route sightings can only shorten the plan; teammates in the way add a little.
            assert!(
                tns <= plan.planned_steps + 10,
                "map {map}: {tns} vs {plan:?}"
            );
        }
    }

    #[test]
    fn it_completes_in_rooms_and_passages_without_livelock() {
        // Floor plans (doors and corridors one or two cells wide) and the paper's maps under
        // the strict movement rule (which splits test_9 into pockets no robot reaches): every
        // run completes, never faster than its bound.
        let strict = ScenarioConfig {
            movement: Movement::NoCornerCutting,
            ..ScenarioConfig::default()
        };
        let mut specs = Vec::new();
        for seed in 1..=12 {
            let map = madenet_sim::MapSource::FloorPlan(seed)
                .load(&strict)
                .unwrap();
            let starts = madenet_sim::StartSpec::Random.cells(&map, 3, strict.movement);
            specs.push(TrialSpec {
                map,
                map_name: format!("floorplan:{seed}"),
                starts,
                config: strict.clone(),
                policy: "reference".into(),
                seed,
            });
        }
        for map in 1..=10 {
            specs.push(spec(map, Corner::TopRight, 2, strict.clone()));
        }
        for s in &specs {
            let (r, plan) = run(s).unwrap();
            assert!(
                r.metrics.completed,
                "{}: {} steps",
                s.map_name, r.metrics.tns
            );
            assert!(r.metrics.tns as u32 >= plan.lower_bound, "{}", s.map_name);
        }
    }

    #[test]
    fn same_seed_same_run_and_noise_costs_time() {
        let s = spec(3, Corner::BottomRight, 5, ScenarioConfig::default());
        let (a, pa) = run(&s).unwrap();
        let (b, pb) = run(&s).unwrap();
        assert_eq!(
            (a.metrics.tns, a.metrics.ttd),
            (b.metrics.tns, b.metrics.ttd)
        );
        assert_eq!(pa, pb);
        assert!(a.metrics.completed);
        assert!(a.metrics.tns as u32 >= pa.lower_bound);
    }
}
