//! The navigation controller of MADE-Net (paper Sec. III.C.5): turns a goal cell into moves.
//!
//! * [`Dijkstra`] — a flat-array, allocation-free Dijkstra over an 8-connected grid that can
//!   stop as soon as a condition holds (the nearest frontier) and hand back the path. Written
//!   by hand because the `pathfinding` crate's variants allocate hash maps on every call, and
//!   this runs for every robot at every timestep in the classical baselines.
//! * [`astar`] — A* on a robot's known-free cells with the admissible octile heuristic, on the
//!   `pathfinding` crate's generic A*.
//! * [`Reservations`] and [`space_time_astar`] / [`SpaceTimePlanner`] — spatial-temporal A*
//!   (on flat arrays, see [`SpaceTimePlanner`] for why) for prioritized planning:
//!   higher-priority robots' plans are reserved as (cell, time) and a later robot plans around
//!   them, waiting being an action. This resolves the corridor and head-on deadlocks that
//!   plain A* leaves.
//! * [`frontiers`] — explore_lite's frontier search and cost, for the `explore-lite` policy
//!   and the exploration node of a nav2 robot.
//!
//! Costs are integers: a straight step costs [`STRAIGHT`], a diagonal [`DIAGONAL`]
//! (≈ √2·STRAIGHT), so path lengths in metres are `cost / STRAIGHT` times the cell size.
//! The movement rule is the world's ([`madenet_world::step_allowed`] under a [`Movement`]).

#![deny(missing_docs)]

mod dijkstra;
pub mod frontiers;
mod spacetime;

pub use dijkstra::Dijkstra;
pub use spacetime::{space_time_astar, Reservations, SpaceTimePlanner, WAIT_COST};

pub use madenet_map::Movement;
use madenet_map::Pos;
use madenet_world::{step_allowed, Move};

/// Cost of a straight step.
pub const STRAIGHT: u32 = 10_000;
/// Cost of a diagonal step, √2 · [`STRAIGHT`] rounded down.
pub const DIAGONAL: u32 = 14_142;

/// Advances the generation counter of buffers reused across runs (an entry of `marks` is
/// current when it equals the counter) and returns it; when the counter wraps, the marks are
/// zeroed and it restarts at 1.
#[inline]
fn next_generation<const N: usize>(generation: &mut u32, marks: [&mut Vec<u32>; N]) -> u32 {
    *generation = generation.wrapping_add(1);
    if *generation == 0 {
        for m in marks {
            m.fill(0);
        }
        *generation = 1;
    }
    *generation
}

/// Integer cost of a move.
#[inline]
pub fn move_cost(m: Move) -> u32 {
    match m {
        Move::Stay => 0,
        m if m.is_diagonal() => DIAGONAL,
        _ => STRAIGHT,
    }
}

/// The octile distance: the exact cost between two cells on an obstacle-free grid, hence an
/// admissible and consistent A* heuristic.
#[inline]
pub fn octile(a: Pos, b: Pos) -> u32 {
    let dr = (a.row - b.row).unsigned_abs();
    let dc = (a.col - b.col).unsigned_abs();
    let (lo, hi) = if dr < dc { (dr, dc) } else { (dc, dr) };
    lo * DIAGONAL + (hi - lo) * STRAIGHT
}

/// Convert an integer path cost to cells of distance.
pub fn cost_to_cells(cost: u32) -> f64 {
    cost as f64 / STRAIGHT as f64
}

/// Moves allowed from `p` under the world's movement rule on `passable` cells (no `Stay`).
#[inline]
pub fn neighbours(
    p: Pos,
    passable: impl Fn(Pos) -> bool + Copy,
    movement: Movement,
) -> impl Iterator<Item = (Pos, u32)> {
    Move::ALL[1..]
        .iter()
        .filter(move |&&m| step_allowed(passable, p, m, movement))
        .map(move |&m| (m.apply(p), move_cost(m)))
}

/// A* from `start` to `goal` over `passable` cells (8-connected under `movement`, octile
/// heuristic). Returns the cells after `start` up to and including `goal`, and the cost.
pub fn astar(
    start: Pos,
    goal: Pos,
    passable: impl Fn(Pos) -> bool + Copy,
    movement: Movement,
) -> Option<(Vec<Pos>, u32)> {
    // A goal one allowed step away: that step is the unique shortest path (any other takes two
    // steps, ≥ 2·STRAIGHT > DIAGONAL), so skip the search and its hash map — the common case of
    // primitive moves and of PB's one-cell goals. (`start == goal` is no step: the search
    // answers it at once with the empty path.)
    if let Some(cost) = one_step(start, goal, passable, movement) {
        return Some((vec![goal], cost));
    }
    astar_search(start, goal, passable, movement)
}

/// The cost of reaching `goal` from `start` in one allowed step (`None` if it takes more or
/// cannot be done): then `[goal]` is [`astar`]'s path, found without a search.
#[inline]
pub fn one_step(
    start: Pos,
    goal: Pos,
    passable: impl Fn(Pos) -> bool + Copy,
    movement: Movement,
) -> Option<u32> {
    Move::between(start, goal)
        .filter(|&m| m != Move::Stay && step_allowed(passable, start, m, movement))
        .map(move_cost)
}

/// [`astar`] without its one-step shortcut: the `pathfinding` crate's A* (for tests).
pub fn astar_search(
    start: Pos,
    goal: Pos,
    passable: impl Fn(Pos) -> bool + Copy,
    movement: Movement,
) -> Option<(Vec<Pos>, u32)> {
    if start == goal {
        return Some((Vec::new(), 0));
    }
    let (mut path, cost) = pathfinding::directed::astar::astar(
        &start,
        |&p| neighbours(p, passable, movement),
        |&p| octile(p, goal),
        |&p| p == goal,
    )?;
    path.remove(0);
    Some((path, cost))
}

/// The path's length in cells (1 per straight step, √2 per diagonal).
pub fn path_length(start: Pos, path: &[Pos]) -> f64 {
    let mut prev = start;
    let mut len = 0.0;
    for &p in path {
        len += Move::between(prev, p)
            .map(|m| m.length())
            .unwrap_or(f64::NAN);
        prev = p;
    }
    len
}
