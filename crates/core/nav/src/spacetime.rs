//! Spatial-temporal A* with a reservation table, for prioritized planning.

use crate::{move_cost, next_generation, Dijkstra};
use madenet_map::{Movement, Pos};
use madenet_world::{step_allowed, Move};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Cost of waiting one timestep in place (a quarter of a straight step): waiting is cheaper
/// than a detour, so robots give way rather than wander, but never free.
pub const WAIT_COST: u32 = 2_500;

/// Cells reserved by higher-priority robots over time: `(cell, t)` for t in `0..=horizon`,
/// t = 0 being now. Beyond the horizon reservations are ignored.
#[derive(Clone, Debug)]
pub struct Reservations {
    width: usize,
    height: usize,
    horizon: usize,
    stamp: Vec<u32>,
    generation: u32,
    /// Reservations made since the last clear (repeats counted): zero means none.
    count: usize,
}

impl Reservations {
    /// An empty table for a `height × width` grid (cells) reserving timesteps `0..=horizon`;
    /// the table itself is allocated on the first reservation.
    pub fn new(height: usize, width: usize, horizon: usize) -> Self {
        // The table is allocated on the first reservation.
        Reservations {
            width,
            height,
            horizon,
            stamp: Vec::new(),
            generation: 1,
            count: 0,
        }
    }

    /// The last timestep (from now) that reservations cover.
    pub fn horizon(&self) -> usize {
        self.horizon
    }

    /// Forget every reservation (O(1)).
    pub fn clear(&mut self) {
        next_generation(&mut self.generation, [&mut self.stamp]);
        self.count = 0;
    }

    /// True if nothing has been reserved since the last [`clear`](Self::clear).
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Index of (`p`, `t`) in `stamp`, cell-major (a cell's timesteps are adjacent, so parking
    /// a robot until the horizon writes one run of memory).
    #[inline]
    fn slot(&self, p: Pos, t: usize) -> Option<usize> {
        let inb = p.row >= 0
            && p.col >= 0
            && (p.row as usize) < self.height
            && (p.col as usize) < self.width;
        (inb && t <= self.horizon)
            .then(|| (p.row as usize * self.width + p.col as usize) * (self.horizon + 1) + t)
    }

    fn allocate(&mut self) {
        if self.stamp.is_empty() {
            self.stamp = vec![0; self.width * self.height * (self.horizon + 1)];
        }
    }

    /// Reserves cell `p` at timestep `t`; off-grid cells and t beyond the horizon are ignored.
    pub fn reserve(&mut self, p: Pos, t: usize) {
        self.allocate();
        if let Some(s) = self.slot(p, t) {
            self.stamp[s] = self.generation;
            self.count += 1;
        }
    }

    /// Reserves `p` for every t in `from..=self.horizon`.
    fn reserve_until_horizon(&mut self, p: Pos, from: usize) {
        self.allocate();
        if let Some(s) = self.slot(p, from) {
            let end = s + (self.horizon - from) + 1;
            self.stamp[s..end].fill(self.generation);
            self.count += end - s;
        }
    }

    /// True if cell `p` is reserved at timestep `t` (never off the grid or beyond the horizon).
    #[inline]
    pub fn is_reserved(&self, p: Pos, t: usize) -> bool {
        self.count > 0
            && self
                .slot(p, t)
                .is_some_and(|s| self.stamp[s] == self.generation)
    }

    /// Reserve a robot's plan: `start` at t = 0, `path[k]` at t = k + 1, and the last cell
    /// until the horizon (the robot parks at its goal). A cell entered at t is also reserved
    /// at t − 1: the world lets no robot enter a cell held at the start of the step, so
    /// whoever is there must have left one step earlier.
    pub fn reserve_path(&mut self, start: Pos, path: &[Pos]) {
        self.reserve(start, 0);
        for (k, &p) in path.iter().enumerate() {
            self.reserve(p, k + 1);
            self.reserve(p, k);
        }
        let last = path.last().copied().unwrap_or(start);
        if path.len() < self.horizon {
            self.reserve_until_horizon(last, path.len() + 1);
        }
    }

    /// True if stepping from `from` (held at `t`) to `to` at `t + 1` is allowed: `to` is free
    /// at `t + 1`, and — when moving — not held at `t` either (the world forbids entering a
    /// cell another robot holds at the start of a step, which also rules out swaps).
    #[inline]
    pub fn step_free(&self, from: Pos, to: Pos, t: usize) -> bool {
        if t >= self.horizon {
            return true;
        }
        !self.is_reserved(to, t + 1) && (from == to || !self.is_reserved(to, t))
    }

    /// Whether following `path` from `start` (t = 0) violates a reservation.
    pub fn conflicts(&self, start: Pos, path: &[Pos]) -> bool {
        let mut prev = start;
        for (k, &p) in path.iter().enumerate() {
            if k >= self.horizon {
                break;
            }
            if !self.step_free(prev, p, k) {
                return true;
            }
            prev = p;
        }
        false
    }
}

/// Spatial-temporal A* from `start` (at t = 0) to `goal` over `passable` cells avoiding
/// `res`. States are (cell, t) with t saturating at the horizon; waiting costs
/// [`WAIT_COST`]. Returns the cells occupied at t = 1, 2, … up to the arrival at `goal`
/// (repeated cells are waits), or `None` when no plan exists. Allocates a fresh
/// [`SpaceTimePlanner`]; keep one around to plan without allocating.
pub fn space_time_astar(
    start: Pos,
    goal: Pos,
    passable: impl Fn(Pos) -> bool + Copy,
    movement: Movement,
    res: &Reservations,
) -> Option<Vec<Pos>> {
    let mut planner = SpaceTimePlanner::new(res.height, res.width, res.horizon);
    let mut out = Vec::new();
    planner
        .plan(start, goal, passable, movement, res, &mut out)
        .then_some(out)
}

/// Reusable buffers for [`space_time_astar`] over a fixed grid and horizon.
///
/// A robot moves at most one cell (Chebyshev) per step, so before the horizon the states at
/// time t lie within t cells of the start: the buffers hold a (2t + 1)² window per t < horizon
/// and the whole grid only for t = horizon — about cells + 4·horizon³/3 entries instead of
/// cells × (horizon + 1) (≈ 23× less on a 500 × 500 map at horizon 24). States keep their
/// whole-grid numbers in the heap, so the search order is exactly the unwindowed one.
///
/// Hand-written on flat arrays rather than on the `pathfinding` crate's A*: the states are
/// dense integers, and the crate's hash-map bookkeeping made this search 80 % of an NF
/// trial's time (callgrind, test_5).
#[derive(Clone, Debug)]
pub struct SpaceTimePlanner {
    width: usize,
    height: usize,
    horizon: usize,
    g: Vec<u32>,
    parent: Vec<u32>,
    seen: Vec<u32>,
    closed: Vec<u32>,
    /// `layer[t]`: where time t's entries start in the buffers (t = 0..=horizon).
    layer: Vec<usize>,
    generation: u32,
    heap: BinaryHeap<Reverse<(u32, u32, u32)>>,
    /// Exact distances to the goal ignoring reservations: the A* heuristic.
    to_goal: Dijkstra,
    /// `goal_free_from[t]`: the goal is unreserved from t to the horizon.
    goal_free_from: Vec<bool>,
    /// States expanded over all searches so far (a cost counter for benchmarks).
    pub expanded: u64,
}

impl SpaceTimePlanner {
    /// A planner for a `height × width` grid (cells) and a planning horizon in timesteps,
    /// matching the [`Reservations`] it will plan against; buffers are allocated on first use.
    pub fn new(height: usize, width: usize, horizon: usize) -> Self {
        // Buffers are allocated on the first search: most robots rarely need one.
        SpaceTimePlanner {
            width,
            height,
            horizon,
            g: Vec::new(),
            parent: Vec::new(),
            seen: Vec::new(),
            closed: Vec::new(),
            layer: (0..=horizon)
                .scan(0, |at, t| {
                    let start = *at;
                    *at += (2 * t + 1) * (2 * t + 1);
                    Some(start)
                })
                .collect(),
            generation: 0,
            heap: BinaryHeap::new(),
            to_goal: Dijkstra::new(height, width),
            goal_free_from: Vec::new(),
            expanded: 0,
        }
    }

    /// Plans like [`space_time_astar`], writing the cells into `out`; false if no plan.
    pub fn plan(
        &mut self,
        start: Pos,
        goal: Pos,
        passable: impl Fn(Pos) -> bool + Copy,
        movement: Movement,
        res: &Reservations,
        out: &mut Vec<Pos>,
    ) -> bool {
        assert!(
            res.width == self.width && res.height == self.height && res.horizon == self.horizon,
            "planner and reservations differ in size"
        );
        out.clear();
        if start == goal {
            return true;
        }
        // A goal held until the horizon by a robot of higher priority cannot be reached.
        if res.is_reserved(goal, self.horizon) {
            return false;
        }
        // The heuristic is the exact static distance to the goal (moves are symmetric), so
        // without conflicts the search walks straight down the optimal path, and cells that
        // cannot reach the goal are never entered.
        self.to_goal.run(goal, passable, movement, |_| false);
        if self.to_goal.settled_cost(start).is_none() {
            return false;
        }
        let cells = self.width * self.height;
        let h = self.horizon;
        if self.g.is_empty() {
            let n = self.layer[h] + cells;
            self.g = vec![0; n];
            self.parent = vec![u32::MAX; n];
            self.seen = vec![0; n];
            self.closed = vec![0; n];
        }
        let gen = next_generation(&mut self.generation, [&mut self.seen, &mut self.closed]);
        let w = self.width;
        // A state's number (heap order, parents): t · cells + cell, as without windows.
        let state = |p: Pos, t: usize| (t * cells + p.row as usize * w + p.col as usize) as u32;
        // Its place in the buffers: in time t's window around the start, or the whole grid at
        // the horizon.
        let layer = &self.layer;
        let slot = |p: Pos, t: usize| {
            if t < h {
                let side = 2 * t + 1;
                let (dr, dc) = (p.row - start.row + t as i32, p.col - start.col + t as i32);
                debug_assert!(dr >= 0 && dc >= 0 && (dr as usize) < side && (dc as usize) < side);
                layer[t] + dr as usize * side + dc as usize
            } else {
                layer[h] + p.row as usize * w + p.col as usize
            }
        };
        let s0 = state(start, 0);
        let i0 = slot(start, 0);
        self.g[i0] = 0;
        self.parent[i0] = u32::MAX;
        self.seen[i0] = gen;
        self.heap.clear();
        self.goal_free_from.clear();
        self.goal_free_from.resize(h + 1, true);
        let mut free = true;
        for t in (0..=h).rev() {
            free &= !res.is_reserved(goal, t);
            self.goal_free_from[t] = free;
        }
        let h0 = self.to_goal.settled_cost(start).unwrap_or(0);
        self.heap.push(Reverse((h0, h0, s0)));
        let mut found = None;
        while let Some(Reverse((_, _, s))) = self.heap.pop() {
            let (t, c) = (s as usize / cells, s as usize % cells);
            let p = Pos::new((c / w) as i32, (c % w) as i32);
            let si = slot(p, t);
            if self.closed[si] == gen {
                continue;
            }
            self.closed[si] = gen;
            self.expanded += 1;
            // The robot parks at its goal: arriving counts only if nobody of higher priority
            // passes through the goal afterwards, up to the horizon.
            if p == goal && self.goal_free_from[t] {
                found = Some(s);
                break;
            }
            let g = self.g[si];
            let nt = (t + 1).min(h);
            for m in Move::ALL {
                // At the horizon a wait would loop onto the same state: useless.
                if m == Move::Stay && t >= h {
                    continue;
                }
                if !step_allowed(passable, p, m, movement) {
                    continue;
                }
                let q = m.apply(p);
                if !res.step_free(p, q, t) {
                    continue;
                }
                let Some(hq) = self.to_goal.settled_cost(q) else {
                    continue;
                };
                let ns = state(q, nt);
                let ni = slot(q, nt);
                let ng = g + if m == Move::Stay {
                    WAIT_COST
                } else {
                    move_cost(m)
                };
                if self.closed[ni] != gen && (self.seen[ni] != gen || ng < self.g[ni]) {
                    self.seen[ni] = gen;
                    self.g[ni] = ng;
                    self.parent[ni] = s;
                    // Ties on f go to the state nearer the goal: fewer expansions.
                    self.heap.push(Reverse((ng + hq, hq, ns)));
                }
            }
        }
        let Some(mut s) = found else { return false };
        loop {
            let (t, c) = (s as usize / cells, s as usize % cells);
            let p = Pos::new((c / w) as i32, (c % w) as i32);
            let parent = self.parent[slot(p, t)];
            if parent == u32::MAX {
                break;
            }
            out.push(p);
            s = parent;
        }
        out.reverse();
        true
    }
}
