//! Navigation: A* optimality against Dijkstra, path validity and costs, the octile
//! heuristic, and prioritized space-time planning (no collisions under the world's rules).

use madenet_map::{Movement, Pos};
use madenet_nav::{
    astar, astar_search, move_cost, octile, path_length, space_time_astar, Dijkstra, Reservations,
    DIAGONAL, STRAIGHT, WAIT_COST,
};
use madenet_world::{step_allowed, Move};
use proptest::prelude::*;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

const RULES: [Movement; 2] = [Movement::CornerCutting, Movement::NoCornerCutting];

#[derive(Clone, Debug)]
struct Grid {
    h: usize,
    w: usize,
    free: Vec<bool>,
}

impl Grid {
    fn from_rows(rows: &[&str]) -> Grid {
        let h = rows.len();
        let w = rows[0].len();
        let free = rows
            .iter()
            .flat_map(|r| r.chars().map(|c| c != '#'))
            .collect();
        Grid { h, w, free }
    }
    fn in_bounds(&self, p: Pos) -> bool {
        p.row >= 0 && p.col >= 0 && (p.row as usize) < self.h && (p.col as usize) < self.w
    }
    fn passable(&self, p: Pos) -> bool {
        self.in_bounds(p) && self.free[p.row as usize * self.w + p.col as usize]
    }
    fn pos(&self, i: usize) -> Pos {
        Pos::new((i / self.w) as i32, (i % self.w) as i32)
    }
    /// [`astar`] over this grid's free cells.
    fn astar(&self, start: Pos, goal: Pos, movement: Movement) -> Option<(Vec<Pos>, u32)> {
        astar(start, goal, |p| self.passable(p), movement)
    }
    /// [`space_time_astar`] over this grid's free cells.
    fn space_time(
        &self,
        start: Pos,
        goal: Pos,
        movement: Movement,
        res: &Reservations,
    ) -> Option<Vec<Pos>> {
        space_time_astar(start, goal, |p| self.passable(p), movement, res)
    }
    /// Frees the cell `s` picks and returns it.
    fn free_cell(&mut self, s: prop::sample::Index) -> Pos {
        let i = s.index(self.h * self.w);
        self.free[i] = true;
        self.pos(i)
    }
    fn free_cells(&self) -> Vec<Pos> {
        (0..self.h * self.w)
            .map(|i| self.pos(i))
            .filter(|&p| self.passable(p))
            .collect()
    }
}

/// Checks that `path` is a sequence of legal single steps from `start` ending at `goal` and
/// returns its integer cost. Waits (repeated cells) are allowed only when `allow_wait`.
fn check_path(
    grid: &Grid,
    start: Pos,
    goal: Pos,
    path: &[Pos],
    movement: Movement,
    allow_wait: bool,
) -> Result<u32, String> {
    let mut prev = start;
    let mut cost = 0;
    for (k, &p) in path.iter().enumerate() {
        let m = Move::between(prev, p)
            .ok_or_else(|| format!("step {k}: {prev} -> {p} is not a king move"))?;
        if m == Move::Stay && !allow_wait {
            return Err(format!("step {k}: wait at {p} in a spatial path"));
        }
        if !step_allowed(|q| grid.passable(q), prev, m, movement) {
            return Err(format!(
                "step {k}: {prev} -> {p} ({m:?}) not allowed under {movement:?}"
            ));
        }
        cost += move_cost(m);
        prev = p;
    }
    if prev != goal {
        return Err(format!("path ends at {prev}, not at the goal {goal}"));
    }
    Ok(cost)
}

fn grid_strategy(max: usize, max_density: f64) -> impl Strategy<Value = Grid> {
    (1usize..=max, 1usize..=max, 0.0f64..max_density).prop_flat_map(|(h, w, density)| {
        prop::collection::vec(0.0f64..1.0, h * w).prop_map(move |u| Grid {
            h,
            w,
            free: u.iter().map(|&x| x >= density).collect(),
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn astar_is_optimal_and_agrees_with_dijkstra(
        mut grid in grid_strategy(16, 0.45),
        s in any::<prop::sample::Index>(),
        g in any::<prop::sample::Index>(),
    ) {
        let (start, goal) = (grid.free_cell(s), grid.free_cell(g));
        // One Dijkstra reused for all runs, so stale buffers from an earlier run would show.
        let mut dij = Dijkstra::new(grid.h, grid.w);
        for movement in RULES {
            let pass = |p: Pos| grid.passable(p);
            // A run from elsewhere first (reuse), then the one under test.
            dij.run(goal, pass, movement, |_| false);
            let stopped = dij.run(start, pass, movement, |p| p == goal);
            prop_assert_eq!(dij.source(), Some(start));
            let want = dij.settled_cost(goal);
            prop_assert_eq!(stopped.is_some(), want.is_some());
            let got = astar(start, goal, pass, movement);
            prop_assert_eq!(got.as_ref().map(|(_, c)| *c), want, "{:?} from {} to {}", movement, start, goal);
            if let Some((path, cost)) = got {
                let walked = check_path(&grid, start, goal, &path, movement, false).map_err(TestCaseError::fail)?;
                prop_assert_eq!(walked, cost);
                let metres = path_length(start, &path);
                // DIAGONAL is √2·STRAIGHT rounded down: ≤ 0.14 per diagonal step.
                prop_assert!((metres * STRAIGHT as f64 - cost as f64).abs() <= 0.5 * path.len() as f64 + 1e-6,
                    "length {} vs cost {}", metres, cost);
                prop_assert!(octile(start, goal) <= cost);
                let mut dpath = Vec::new();
                prop_assert!(dij.path_to(goal, &mut dpath));
                let dcost = check_path(&grid, start, goal, &dpath, movement, false).map_err(TestCaseError::fail)?;
                prop_assert_eq!(dcost, cost);
                if start == goal {
                    prop_assert!(path.is_empty() && dpath.is_empty());
                }
            } else {
                let mut dpath = vec![Pos::new(99, 99)];
                prop_assert!(!dij.path_to(goal, &mut dpath));
                prop_assert!(dpath.is_empty());
            }
        }
    }

    #[test]
    fn one_step_shortcut_gives_the_searchs_own_path(
        mut grid in grid_strategy(6, 0.5),
        s in any::<prop::sample::Index>(),
    ) {
        let start = grid.free_cell(s);
        for movement in RULES {
            for m in Move::ALL {
                let goal = m.apply(start);
                let pass = |p: Pos| grid.passable(p);
                prop_assert_eq!(astar(start, goal, pass, movement), astar_search(start, goal, pass, movement), "{:?} {:?} from {}", movement, m, start);
            }
        }
    }

    #[test]
    fn octile_never_exceeds_the_true_cost_and_full_dijkstra_paths_are_valid(
        mut grid in grid_strategy(14, 0.45),
        s in any::<prop::sample::Index>(),
    ) {
        let n = grid.h * grid.w;
        let start = grid.free_cell(s);
        let mut dij = Dijkstra::new(grid.h, grid.w);
        for movement in RULES {
            prop_assert_eq!(dij.run(start, |p| grid.passable(p), movement, |_| false), None);
            let mut path = Vec::new();
            for goal in grid.free_cells() {
                let Some(cost) = dij.settled_cost(goal) else {
                    prop_assert!(astar(start, goal, |p| grid.passable(p), movement).is_none());
                    continue;
                };
                prop_assert!(octile(start, goal) <= cost, "octile {} > cost {} to {}", octile(start, goal), cost, goal);
                prop_assert!(dij.path_to(goal, &mut path));
                let c = check_path(&grid, start, goal, &path, movement, false).map_err(TestCaseError::fail)?;
                prop_assert_eq!(c, cost);
            }
            // Obstacles and out-of-bounds cells are never settled.
            for i in 0..n {
                if !grid.free[i] {
                    prop_assert_eq!(dij.settled_cost(grid.pos(i)), None);
                }
            }
            prop_assert_eq!(dij.settled_cost(Pos::new(-1, 0)), None);
            prop_assert_eq!(dij.settled_cost(Pos::new(0, grid.w as i32)), None);
        }
    }
}

#[test]
fn octile_values() {
    assert_eq!(octile(Pos::new(0, 0), Pos::new(0, 0)), 0);
    assert_eq!(octile(Pos::new(0, 0), Pos::new(3, 0)), 3 * STRAIGHT);
    assert_eq!(octile(Pos::new(0, 0), Pos::new(2, 2)), 2 * DIAGONAL);
    assert_eq!(
        octile(Pos::new(5, 1), Pos::new(2, 8)),
        3 * DIAGONAL + 4 * STRAIGHT
    );
    assert_eq!(
        octile(Pos::new(2, 8), Pos::new(5, 1)),
        3 * DIAGONAL + 4 * STRAIGHT
    );
    assert_eq!(
        DIAGONAL,
        (std::f64::consts::SQRT_2 * STRAIGHT as f64).floor() as u32
    );
}

#[test]
fn astar_hand_cases() {
    // A wall with one gap: the path must go through (2,3) for both rules.
    let grid = Grid::from_rows(&[
        "...#...", //
        "...#...", ".......", "...#...", "...#...",
    ]);
    for movement in RULES {
        let (path, cost) = grid
            .astar(Pos::new(0, 0), Pos::new(0, 6), movement)
            .unwrap();
        assert!(path.contains(&Pos::new(2, 3)), "{path:?}");
        assert_eq!(
            check_path(
                &grid,
                Pos::new(0, 0),
                Pos::new(0, 6),
                &path,
                movement,
                false
            )
            .unwrap(),
            cost
        );
        // (0,0) -> (2,3) -> (0,6): corner cutting: 2 diag + 1 straight each side.
        if movement == Movement::CornerCutting {
            assert_eq!(cost, 4 * DIAGONAL + 2 * STRAIGHT);
        }
    }
    // A diagonal squeeze: passable only with corner cutting.
    let squeeze = Grid::from_rows(&[".#", "#."]);
    let cut = squeeze.astar(Pos::new(0, 0), Pos::new(1, 1), Movement::CornerCutting);
    assert_eq!(cut, Some((vec![Pos::new(1, 1)], DIAGONAL)));
    assert_eq!(
        squeeze.astar(Pos::new(0, 0), Pos::new(1, 1), Movement::NoCornerCutting),
        None
    );
    // Start equals goal.
    assert_eq!(
        squeeze.astar(Pos::new(0, 0), Pos::new(0, 0), Movement::CornerCutting),
        Some((vec![], 0))
    );
    // path_length in cells.
    let len = path_length(
        Pos::new(0, 0),
        &[Pos::new(1, 1), Pos::new(1, 2), Pos::new(1, 2)],
    );
    assert!((len - (1.0 + std::f64::consts::SQRT_2)).abs() < 1e-12);
}

// ---------------------------------------------------------------------------------------
// Space-time planning
// ---------------------------------------------------------------------------------------

/// The cell of robot with plan `path` from `start` at time `t`: parked at its last cell
/// once the path ends.
fn at(start: Pos, path: &[Pos], t: usize) -> Pos {
    if t == 0 {
        start
    } else {
        path.get(t - 1)
            .copied()
            .unwrap_or_else(|| path.last().copied().unwrap_or(start))
    }
}

/// A conflict between robots' plans, simulated until `until` with parking.
#[derive(Debug, PartialEq)]
enum Conflict {
    /// Two robots in one cell at time t.
    Vertex {
        t: usize,
        a: usize,
        b: usize,
        cell: Pos,
    },
    /// Robot `a` entered at t a cell robot `b` held at t − 1 (the world forbids it).
    Follow {
        t: usize,
        a: usize,
        b: usize,
        cell: Pos,
    },
}

fn conflicts(starts: &[Pos], plans: &[Vec<Pos>], until: usize) -> Vec<Conflict> {
    let mut out = Vec::new();
    for t in 0..=until {
        for a in 0..starts.len() {
            let pa = at(starts[a], &plans[a], t);
            for b in 0..starts.len() {
                if a == b {
                    continue;
                }
                if a < b && pa == at(starts[b], &plans[b], t) {
                    out.push(Conflict::Vertex { t, a, b, cell: pa });
                }
                if t > 0
                    && pa != at(starts[a], &plans[a], t - 1)
                    && pa == at(starts[b], &plans[b], t - 1)
                {
                    out.push(Conflict::Follow { t, a, b, cell: pa });
                }
            }
        }
    }
    out
}

fn plan_team(
    grid: &Grid,
    starts: &[Pos],
    goals: &[Pos],
    movement: Movement,
    horizon: usize,
) -> Option<Vec<Vec<Pos>>> {
    let mut res = Reservations::new(grid.h, grid.w, horizon);
    // Every robot holds its cell now (as the agents reserve detected teammates at t = 0).
    for &s in starts {
        res.reserve(s, 0);
    }
    let mut plans = Vec::new();
    for (k, (&s, &g)) in starts.iter().zip(goals).enumerate() {
        let path = space_time_astar(s, g, |p| grid.passable(p), movement, &res)?;
        if let Err(e) = check_path(grid, s, g, &path, movement, true) {
            panic!("robot {k}: {e}");
        }
        // A plan never violates the reservations it was planned against.
        assert!(
            !res.conflicts(s, &path),
            "robot {k}'s plan conflicts with the reservations it avoided"
        );
        res.reserve_path(s, &path);
        plans.push(path);
    }
    Some(plans)
}

fn team_strategy() -> impl Strategy<Value = (Grid, Vec<Pos>, Vec<Pos>, Movement, usize)> {
    (
        grid_strategy(9, 0.3),
        2usize..=4,
        any::<bool>(),
        6usize..=20,
        prop::collection::vec(any::<prop::sample::Index>(), 8),
    )
        .prop_filter_map(
            "not enough free cells",
            |(grid, k, strict, horizon, picks)| {
                let mut free = grid.free_cells();
                if free.len() < 2 * k {
                    return None;
                }
                let mut cells = Vec::new();
                for ix in picks.iter().take(2 * k) {
                    cells.push(free.remove(ix.index(free.len())));
                }
                let movement = if strict {
                    Movement::NoCornerCutting
                } else {
                    Movement::CornerCutting
                };
                Some((
                    grid,
                    cells[..k].to_vec(),
                    cells[k..].to_vec(),
                    movement,
                    horizon,
                ))
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn prioritized_plans_never_collide_including_parking((grid, starts, goals, movement, horizon) in team_strategy()) {
        let plans = plan_team(&grid, &starts, &goals, movement, horizon);
        prop_assume!(plans.is_some(), "no plan");
        let plans = plans.unwrap();
        let c = conflicts(&starts, &plans, horizon);
        prop_assert!(c.is_empty(), "conflicts {:?} (plans {:?}, starts {:?}, goals {:?}, {:?}, horizon {})",
            c, plans, starts, goals, movement, horizon);
    }
}

/// The minimal case of the parking bug: robot 1 sits in a side pocket next to its goal
/// (0,4) in robot 0's corridor; it steps onto the goal at t = 1 and parks, and robot 0, which
/// planned first, drives through (0,4) at t = 4.
#[test]
fn parked_robot_is_not_run_over() {
    let grid = corridor_with_pocket();
    let starts = [Pos::new(0, 0), Pos::new(1, 4)];
    let goals = [Pos::new(0, 6), Pos::new(0, 4)];
    for movement in RULES {
        let plans = plan_team(&grid, &starts, &goals, movement, 10).expect("both plans exist");
        let c = conflicts(&starts, &plans, 10);
        assert!(
            c.is_empty(),
            "{movement:?}: plans {plans:?} give conflicts {c:?}"
        );
    }
}

fn corridor_with_pocket() -> Grid {
    // A 1-wide corridor (row 0) with a one-cell side pocket at (1,4).
    Grid::from_rows(&[
        ".......", //
        "####.##",
    ])
}

#[test]
fn corridor_head_on_plain_astar_collides_space_time_resolves() {
    let grid = corridor_with_pocket();
    let starts = [Pos::new(0, 0), Pos::new(0, 6)];
    let goals = [Pos::new(0, 6), Pos::new(0, 0)];
    for movement in RULES {
        let pass = |p: Pos| grid.passable(p);
        let plain: Vec<Vec<Pos>> = (0..2)
            .map(|k| astar(starts[k], goals[k], pass, movement).unwrap().0)
            .collect();
        assert_eq!(plain[0].len(), 6);
        assert!(!plain[0].contains(&Pos::new(1, 4)) && !plain[1].contains(&Pos::new(1, 4)));
        assert!(
            !conflicts(&starts, &plain, 12).is_empty(),
            "plain A* head-on paths must collide"
        );

        let horizon = 16;
        let mut res = Reservations::new(grid.h, grid.w, horizon);
        res.reserve(starts[1], 0);
        let p0 = space_time_astar(starts[0], goals[0], pass, movement, &res).unwrap();
        assert_eq!(p0, plain[0], "robot 0 meets no reservation on its way");
        res.reserve_path(starts[0], &p0);
        assert!(
            res.conflicts(starts[1], &plain[1]),
            "robot 1's plain path crosses robot 0's reservations"
        );
        let p1 = space_time_astar(starts[1], goals[1], pass, movement, &res)
            .expect("robot 1 can dodge into the pocket");
        assert!(!res.conflicts(starts[1], &p1));
        check_path(&grid, starts[1], goals[1], &p1, movement, true).unwrap();
        assert!(
            p1.contains(&Pos::new(1, 4)),
            "robot 1 must use the pocket: {p1:?}"
        );
        let plans = vec![p0, p1.clone()];
        assert_eq!(
            conflicts(&starts, &plans, horizon),
            vec![],
            "{movement:?}: {plans:?}"
        );
        // Robot 1 waits in the pocket while robot 0 passes (a repeated cell is a wait) or
        // otherwise takes longer than the 6 free-corridor steps.
        assert!(p1.len() > 6, "{p1:?}");
        assert_eq!(*p1.last().unwrap(), goals[1]);
    }
}

/// The cost of a space-time plan: moves at their cost, waits at [`WAIT_COST`].
fn st_cost(start: Pos, path: &[Pos]) -> u32 {
    let mut prev = start;
    let mut cost = 0;
    for &p in path {
        let m = Move::between(prev, p).expect("king move");
        cost += if m == Move::Stay {
            WAIT_COST
        } else {
            move_cost(m)
        };
        prev = p;
    }
    cost
}

/// Reference space-time search: plain Dijkstra over (cell, t) states, t saturating at the
/// horizon, the transitions of `space_time_astar`'s documentation. Returns the optimal cost.
fn reference_space_time(
    grid: &Grid,
    start: Pos,
    goal: Pos,
    movement: Movement,
    res: &Reservations,
) -> Option<u32> {
    let h = res.horizon();
    let cells = grid.h * grid.w;
    let idx = |p: Pos, t: usize| t * cells + p.row as usize * grid.w + p.col as usize;
    let mut dist = vec![u32::MAX; cells * (h + 1)];
    let mut heap = BinaryHeap::new();
    dist[idx(start, 0)] = 0;
    heap.push(Reverse((0u32, start.row, start.col, 0usize)));
    while let Some(Reverse((d, r, c, t))) = heap.pop() {
        let p = Pos::new(r, c);
        if d > dist[idx(p, t)] {
            continue;
        }
        if p == goal {
            return Some(d);
        }
        for m in Move::ALL {
            if m == Move::Stay && t >= h {
                continue;
            }
            if !step_allowed(|q| grid.passable(q), p, m, movement) {
                continue;
            }
            let q = m.apply(p);
            if !res.step_free(p, q, t) {
                continue;
            }
            let nt = (t + 1).min(h);
            let nd = d + if m == Move::Stay {
                WAIT_COST
            } else {
                move_cost(m)
            };
            if nd < dist[idx(q, nt)] {
                dist[idx(q, nt)] = nd;
                heap.push(Reverse((nd, q.row, q.col, nt)));
            }
        }
    }
    None
}

/// A space-time case: grid, start, goal, other robots' (start, path), movement, horizon.
type SpaceTimeCase = (Grid, Pos, Pos, Vec<(Pos, Vec<Pos>)>, Movement, usize);

fn space_time_case() -> impl Strategy<Value = SpaceTimeCase> {
    (
        grid_strategy(9, 0.3),
        any::<bool>(),
        3usize..=14,
        prop::collection::vec(any::<prop::sample::Index>(), 2),
        prop::collection::vec(
            (
                any::<prop::sample::Index>(),
                prop::collection::vec(0usize..9, 0..16),
            ),
            1..=3,
        ),
    )
        .prop_filter_map(
            "too few free cells",
            |(grid, strict, horizon, ends, others)| {
                let free = grid.free_cells();
                if free.len() < 2 {
                    return None;
                }
                let movement = if strict {
                    Movement::NoCornerCutting
                } else {
                    Movement::CornerCutting
                };
                // Other robots: random walks of legal moves and waits.
                let mut walks = Vec::new();
                for (ix, moves) in others {
                    let s = free[ix.index(free.len())];
                    let mut at = s;
                    let mut path = Vec::new();
                    for m in moves {
                        let m = Move::ALL[m];
                        if step_allowed(|q| grid.passable(q), at, m, movement) {
                            at = m.apply(at);
                        }
                        path.push(at);
                    }
                    walks.push((s, path));
                }
                let start = free[ends[0].index(free.len())];
                let goal = free[ends[1].index(free.len())];
                Some((grid, start, goal, walks, movement, horizon))
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// With the goal never reserved, space-time A* finds a plan exactly when the reference
    /// search does, of the same (optimal) cost, legal and free of reservation conflicts.
    #[test]
    fn space_time_astar_is_optimal((grid, start, goal, walks, movement, horizon) in space_time_case()) {
        let mut res = Reservations::new(grid.h, grid.w, horizon);
        for (s, path) in &walks {
            res.reserve_path(*s, path);
        }
        prop_assume!((0..=horizon).all(|t| !res.is_reserved(goal, t)));
        let want = reference_space_time(&grid, start, goal, movement, &res);
        let got = space_time_astar(start, goal, |p| grid.passable(p), movement, &res);
        prop_assert_eq!(got.is_some(), want.is_some(), "plan {:?} vs reference cost {:?}", got, want);
        if let Some(path) = got {
            check_path(&grid, start, goal, &path, movement, true).map_err(TestCaseError::fail)?;
            prop_assert!(!res.conflicts(start, &path), "plan {:?} violates the reservations", path);
            prop_assert_eq!(Some(st_cost(start, &path)), want, "plan {:?}", path);
            // Without reservations it costs what plain A* does.
            let empty = Reservations::new(grid.h, grid.w, horizon);
            let free_plan = space_time_astar(start, goal, |p| grid.passable(p), movement, &empty).unwrap();
            let (_, a_cost) = astar(start, goal, |p| grid.passable(p), movement).unwrap();
            prop_assert_eq!(st_cost(start, &free_plan), a_cost);
            prop_assert!(st_cost(start, &path) >= a_cost);
        } else {
            prop_assert!(astar(start, goal, |p| grid.passable(p), movement).is_none() || !res.is_empty());
        }
    }
}

#[test]
fn space_time_with_no_reservations_matches_astar_cost() {
    let grid = Grid::from_rows(&[
        "........", //
        ".####...", "....#.#.", "..#.#...", "........",
    ]);
    let res = Reservations::new(grid.h, grid.w, 20);
    for movement in RULES {
        let (a, cost) = grid
            .astar(Pos::new(0, 0), Pos::new(3, 5), movement)
            .unwrap();
        let st = grid
            .space_time(Pos::new(0, 0), Pos::new(3, 5), movement, &res)
            .unwrap();
        let st_cost =
            check_path(&grid, Pos::new(0, 0), Pos::new(3, 5), &st, movement, false).unwrap();
        assert_eq!(st_cost, cost, "{movement:?}: {st:?} vs {a:?}");
    }
    // Unreachable goal: no plan.
    let walled = Grid::from_rows(&["..#..", "..#..", "..#.."]);
    let res = Reservations::new(3, 5, 8);
    assert_eq!(
        walled.space_time(
            Pos::new(0, 0),
            Pos::new(0, 4),
            Movement::CornerCutting,
            &res
        ),
        None
    );
    // start == goal: empty plan.
    assert_eq!(
        walled.space_time(
            Pos::new(0, 0),
            Pos::new(0, 0),
            Movement::CornerCutting,
            &res
        ),
        Some(vec![])
    );
}

#[test]
fn space_time_waits_for_a_crossing_robot() {
    // Open 3×3: a reservation sweeps through the middle column at t = 1..3; a robot going
    // (1,0) -> (1,2) must not be in (1,1) at t = 2 nor enter it at t = 3 (held at 2).
    let grid = Grid::from_rows(&["...", "...", "..."]);
    let mut res = Reservations::new(3, 3, 10);
    res.reserve_path(Pos::new(0, 1), &[Pos::new(1, 1), Pos::new(2, 1)]);
    // Robot 0 parks at (2,1) from t = 2 on, (1,1) is reserved at t = 0, 1 (entered at 1).
    assert!(res.is_reserved(Pos::new(1, 1), 0) && res.is_reserved(Pos::new(1, 1), 1));
    assert!(!res.is_reserved(Pos::new(1, 1), 2));
    assert!(res.is_reserved(Pos::new(2, 1), 1) && res.is_reserved(Pos::new(2, 1), 10));
    assert!(
        !res.is_reserved(Pos::new(2, 1), 11),
        "beyond the horizon nothing is reserved"
    );
    for movement in RULES {
        let path = grid
            .space_time(Pos::new(1, 0), Pos::new(1, 2), movement, &res)
            .unwrap();
        check_path(&grid, Pos::new(1, 0), Pos::new(1, 2), &path, movement, true).unwrap();
        assert!(!res.conflicts(Pos::new(1, 0), &path));
        let plans = vec![vec![Pos::new(1, 1), Pos::new(2, 1)], path.clone()];
        assert_eq!(
            conflicts(&[Pos::new(0, 1), Pos::new(1, 0)], &plans, 10),
            vec![],
            "{path:?}"
        );
        // (1,1) is held at t = 1, so it can be neither occupied at t = 1 nor entered at t = 2.
        assert_ne!(path.first(), Some(&Pos::new(1, 1)));
        assert_ne!(path.get(1), Some(&Pos::new(1, 1)));
    }
}

/// The cells of row `r` at columns `cols`, in order: a path along the row.
fn row(r: i32, cols: &[i32]) -> Vec<Pos> {
    cols.iter().map(|&c| Pos::new(r, c)).collect()
}

#[test]
fn reservations_conflicts_detects_reserved_cells() {
    let mut res = Reservations::new(5, 5, 6);
    assert!(res.is_empty());
    res.reserve(Pos::new(2, 2), 3);
    assert!(!res.is_empty());
    // Path in (2,2) at t = 3: conflict.
    let path_at_3 = row(2, &[1, 1, 2, 3]);
    assert!(
        res.conflicts(Pos::new(2, 0), &path_at_3),
        "in (2,2) at t = 3"
    );
    // Entering (2,2) at t = 4 means entering a cell held at t = 3: conflict as well.
    let path_at_4 = row(2, &[1, 1, 1, 2]);
    assert!(
        res.conflicts(Pos::new(2, 0), &path_at_4),
        "entering (2,2) at t = 4"
    );
    // In (2,2) at t = 2 and gone at t = 3: fine.
    let path_at_2 = row(2, &[1, 2, 3]);
    assert!(!res.conflicts(Pos::new(2, 0), &path_at_2));
    // Entering at t = 5: fine.
    let path_at_5 = row(2, &[1, 1, 1, 1, 2]);
    assert!(!res.conflicts(Pos::new(2, 0), &path_at_5));
    // Never touching it: fine.
    assert!(!res.conflicts(Pos::new(0, 0), &row(0, &[1, 2, 3, 4])));
    // Reservations beyond the horizon are ignored; clear() forgets everything.
    res.reserve(Pos::new(0, 0), 7);
    assert!(!res.is_reserved(Pos::new(0, 0), 7));
    res.clear();
    assert!(res.is_empty());
    assert!(!res.conflicts(Pos::new(2, 0), &path_at_3));
    // reserve_path: a robot's path reserves each cell at its time and one step before.
    let mut res = Reservations::new(5, 5, 6);
    res.reserve_path(Pos::new(0, 0), &[Pos::new(0, 1), Pos::new(0, 2)]);
    let reserved: Vec<(Pos, usize)> = (0..=6)
        .flat_map(|t| (0..25).map(move |i| (Pos::new(i / 5, i % 5), t)))
        .filter(|&(p, t)| res.is_reserved(p, t))
        .collect();
    let mut want = vec![
        (Pos::new(0, 0), 0),
        (Pos::new(0, 1), 0),
        (Pos::new(0, 1), 1),
        (Pos::new(0, 2), 1),
    ];
    want.extend((2..=6).map(|t| (Pos::new(0, 2), t)));
    want.sort_by_key(|&(p, t)| (t, p));
    assert_eq!(reserved, want);
    // A head-on path down the same row conflicts; a path that stays below does not.
    assert!(res.conflicts(Pos::new(0, 4), &[Pos::new(0, 3), Pos::new(0, 2)]));
    assert!(!res.conflicts(
        Pos::new(1, 4),
        &[Pos::new(1, 3), Pos::new(1, 2), Pos::new(1, 1)]
    ));
}
