//! Spatial-temporal A* with a reservation table, for prioritized planning.

use crate::{move_cost, octile};
use madenet_map::{Movement, Pos};
use madenet_world::{step_allowed, Move};

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
    count: usize,
}

impl Reservations {
    pub fn new(height: usize, width: usize, horizon: usize) -> Self {
        Reservations { width, height, horizon, stamp: vec![0; width * height * (horizon + 1)], generation: 1, count: 0 }
    }

    pub fn horizon(&self) -> usize {
        self.horizon
    }

    /// Forget every reservation (O(1)).
    pub fn clear(&mut self) {
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.stamp.fill(0);
            self.generation = 1;
        }
        self.count = 0;
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    #[inline]
    fn slot(&self, p: Pos, t: usize) -> Option<usize> {
        let inb = p.row >= 0 && p.col >= 0 && (p.row as usize) < self.height && (p.col as usize) < self.width;
        (inb && t <= self.horizon).then(|| t * self.width * self.height + p.row as usize * self.width + p.col as usize)
    }

    pub fn reserve(&mut self, p: Pos, t: usize) {
        if let Some(s) = self.slot(p, t) {
            if self.stamp[s] != self.generation {
                self.stamp[s] = self.generation;
                self.count += 1;
            }
        }
    }

    #[inline]
    pub fn is_reserved(&self, p: Pos, t: usize) -> bool {
        self.slot(p, t).is_some_and(|s| self.stamp[s] == self.generation)
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
        for t in path.len() + 1..=self.horizon {
            self.reserve(last, t);
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
/// (repeated cells are waits), or `None` when no plan exists.
pub fn space_time_astar(
    start: Pos,
    goal: Pos,
    passable: impl Fn(Pos) -> bool + Copy,
    movement: Movement,
    res: &Reservations,
) -> Option<Vec<Pos>> {
    if start == goal {
        return Some(Vec::new());
    }
    let h = res.horizon();
    let (states, _cost) = pathfinding::directed::astar::astar(
        &(start, 0usize),
        |&(p, t)| {
            let nt = (t + 1).min(h);
            Move::ALL.iter().filter_map(move |&m| {
                if !step_allowed(passable, p, m, movement) {
                    return None;
                }
                let q = m.apply(p);
                if !res.step_free(p, q, t) {
                    return None;
                }
                // At the horizon a wait would loop onto the same state: useless.
                if m == Move::Stay && t >= h {
                    return None;
                }
                let c = if m == Move::Stay { WAIT_COST } else { move_cost(m) };
                Some(((q, nt), c))
            })
        },
        |&(p, _)| octile(p, goal),
        |&(p, _)| p == goal,
    )?;
    Some(states.into_iter().skip(1).map(|(p, _)| p).collect())
}
