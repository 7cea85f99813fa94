//! Grid geometry shared by the world and the agents: the nine primitive moves, the movement
//! rule, Bresenham rays, line of sight and the sensor's view pattern.

use madenet_map::{Movement, Pos};
use serde::{Deserialize, Serialize};

/// A primitive action: one of the 8 neighbour moves or staying (paper Sec. III.B).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Move {
    /// Stay in the current cell (Δ = (0, 0)).
    Stay,
    /// North: one row up (Δ = (−1, 0)).
    N,
    /// North-east, diagonal (Δ = (−1, +1)).
    NE,
    /// East: one column right (Δ = (0, +1)).
    E,
    /// South-east, diagonal (Δ = (+1, +1)).
    SE,
    /// South: one row down (Δ = (+1, 0)).
    S,
    /// South-west, diagonal (Δ = (+1, −1)).
    SW,
    /// West: one column left (Δ = (0, −1)).
    W,
    /// North-west, diagonal (Δ = (−1, −1)).
    NW,
}

impl Move {
    /// All nine moves, `Stay` first; the order is the index used by primitive-action APIs.
    pub const ALL: [Move; 9] = [
        Move::Stay,
        Move::N,
        Move::NE,
        Move::E,
        Move::SE,
        Move::S,
        Move::SW,
        Move::W,
        Move::NW,
    ];

    /// (Δrow, Δcol); north is up (row − 1).
    pub const fn delta(self) -> (i32, i32) {
        match self {
            Move::Stay => (0, 0),
            Move::N => (-1, 0),
            Move::NE => (-1, 1),
            Move::E => (0, 1),
            Move::SE => (1, 1),
            Move::S => (1, 0),
            Move::SW => (1, -1),
            Move::W => (0, -1),
            Move::NW => (-1, -1),
        }
    }

    /// The move from `from` to an 8-neighbour (or the same cell) `to`.
    pub fn between(from: Pos, to: Pos) -> Option<Move> {
        let d = (to.row - from.row, to.col - from.col);
        Move::ALL.into_iter().find(|m| m.delta() == d)
    }

    /// True for the four diagonal moves (NE, SE, SW, NW).
    pub const fn is_diagonal(self) -> bool {
        let (r, c) = self.delta();
        r != 0 && c != 0
    }

    /// Distance travelled in cells: 1 straight, √2 diagonal, 0 staying.
    pub fn length(self) -> f64 {
        match self {
            Move::Stay => 0.0,
            m if m.is_diagonal() => std::f64::consts::SQRT_2,
            _ => 1.0,
        }
    }

    /// The cell this move leads to from `p` (not checked against any map).
    pub fn apply(self, p: Pos) -> Pos {
        let (dr, dc) = self.delta();
        Pos::new(p.row + dr, p.col + dc)
    }

    /// The move's position in [`Move::ALL`] (`Stay` = 0, `N` = 1, …, `NW` = 8).
    pub fn index(self) -> usize {
        self as usize
    }
}

/// The movement rule: the target must be passable; under [`Movement::NoCornerCutting`] a
/// diagonal step also needs both orthogonal neighbours passable. `Stay` is always allowed.
#[inline]
pub fn step_allowed(
    passable: impl Fn(Pos) -> bool,
    from: Pos,
    m: Move,
    movement: Movement,
) -> bool {
    let to = m.apply(from);
    if m == Move::Stay {
        return true;
    }
    if !passable(to) {
        return false;
    }
    if m.is_diagonal() && movement == Movement::NoCornerCutting {
        let (dr, dc) = m.delta();
        passable(Pos::new(from.row + dr, from.col)) && passable(Pos::new(from.row, from.col + dc))
    } else {
        true
    }
}

/// The cells of the Bresenham line from `from` to `to`, excluding `from`, including `to`.
///
/// The line is traced in the first octant and mapped back by sign and axis swap, with ties
/// never stepping the minor axis, so the pattern is exactly symmetric under mirroring and
/// transposition of the grid.
pub fn bresenham(from: Pos, to: Pos, out: &mut Vec<Pos>) {
    out.clear();
    out.extend(bresenham_cells(from, to));
}

/// [`bresenham`]'s cells as an iterator (no buffer: line-of-sight checks run every step).
pub fn bresenham_cells(from: Pos, to: Pos) -> impl ExactSizeIterator<Item = Pos> {
    let dr = to.row - from.row;
    let dc = to.col - from.col;
    let (sr, sc) = (dr.signum(), dc.signum());
    let (ar, ac) = (dr.abs(), dc.abs());
    let swap = ar > ac; // major axis is rows
    let (major, minor) = if swap { (ar, ac) } else { (ac, ar) };
    let mut err = 2 * minor - major;
    let mut m = 0;
    (1..major as usize + 1).map(move |k| {
        let k = k as i32;
        if err > 0 {
            m += 1;
            err -= 2 * major;
        }
        err += 2 * minor;
        let (r, c) = if swap {
            (k * sr, m * sc)
        } else {
            (m * sr, k * sc)
        };
        Pos::new(from.row + r, from.col + c)
    })
}

/// True when the Bresenham ray from `from` reaches `to`: no cell strictly between them is
/// blocked and, under [`Movement::NoCornerCutting`], no diagonal step of the ray (the last
/// one included) squeezes between two blocked cells touching at a corner — a corner closed
/// to robots is closed to light, so everything visible can be approached.
pub fn ray_clear(blocked: impl Fn(Pos) -> bool, from: Pos, to: Pos, movement: Movement) -> bool {
    let squeeze_blocks = movement == Movement::NoCornerCutting;
    let cells = bresenham_cells(from, to);
    let len = cells.len();
    let mut prev = from;
    for (k, p) in cells.enumerate() {
        if k + 1 < len && blocked(p) {
            return false;
        }
        if squeeze_blocks && squeezed(&blocked, prev, p) {
            return false;
        }
        prev = p;
    }
    true
}

/// A diagonal step from `a` to `b` passes between two blocked cells touching at a corner.
#[inline]
pub fn squeezed(blocked: impl Fn(Pos) -> bool, a: Pos, b: Pos) -> bool {
    a.row != b.row
        && a.col != b.col
        && blocked(Pos::new(a.row, b.col))
        && blocked(Pos::new(b.row, a.col))
}

/// Line of sight between two cells: the ray from either end reaches the other (symmetric by
/// construction; the two rays differ only on exact ties).
pub fn line_of_sight(
    blocked: impl Fn(Pos) -> bool + Copy,
    a: Pos,
    b: Pos,
    movement: Movement,
) -> bool {
    ray_clear(blocked, a, b, movement) || ray_clear(blocked, b, a, movement)
}

/// One step of a sensor ray: the cell entered, and for a diagonal step the two orthogonal
/// cells whose corners it passes between.
#[derive(Clone, Copy, Debug)]
struct RayStep {
    cell: (i32, i32),
    corners: Option<((i32, i32), (i32, i32))>,
}

/// The sensor's rays for a square window of radius d_s: for each offset in the window
/// (origin excluded), the steps of its Bresenham line (see [`ray_clear`] for the rule).
#[derive(Clone, Debug)]
pub struct ViewPattern {
    radius: i32,
    targets: Vec<(i32, i32)>,
    /// `steps[start[k]..start[k+1]]` are the steps of ray `k`, its target last.
    start: Vec<u32>,
    steps: Vec<RayStep>,
}

impl ViewPattern {
    /// Traces the rays of the (2·`radius`+1)² window, `radius` being d_s in cells, nearest
    /// ring first; under [`Movement::NoCornerCutting`] a ray squeezing between two obstacles
    /// touching at a corner is blocked there.
    pub fn new(radius: i32, movement: Movement) -> Self {
        let squeeze_blocks = movement == Movement::NoCornerCutting;
        let mut targets = Vec::new();
        let mut start = vec![0u32];
        let mut steps = Vec::new();
        let mut line = Vec::new();
        // Visit targets by ring so a caller may rely on near cells coming first.
        for ring in 1..=radius {
            for dr in -ring..=ring {
                for dc in -ring..=ring {
                    if dr.abs().max(dc.abs()) != ring {
                        continue;
                    }
                    bresenham(Pos::new(0, 0), Pos::new(dr, dc), &mut line);
                    let mut prev = Pos::new(0, 0);
                    for &p in &line {
                        let corners = (squeeze_blocks && prev.row != p.row && prev.col != p.col)
                            .then_some(((prev.row, p.col), (p.row, prev.col)));
                        steps.push(RayStep {
                            cell: (p.row, p.col),
                            corners,
                        });
                        prev = p;
                    }
                    targets.push((dr, dc));
                    start.push(steps.len() as u32);
                }
            }
        }
        ViewPattern {
            radius,
            targets,
            start,
            steps,
        }
    }

    /// The window radius d_s in cells this pattern was built for.
    pub fn radius(&self) -> i32 {
        self.radius
    }

    /// Calls `visit(cell)` for every in-bounds cell visible from `at` (the robot's own cell
    /// excluded) under the rule of [`ray_clear`]. A blocking cell is itself visible.
    #[inline]
    pub fn for_each_visible(
        &self,
        at: Pos,
        in_bounds: impl Fn(Pos) -> bool,
        blocked: impl Fn(Pos) -> bool,
        mut visit: impl FnMut(Pos),
    ) {
        let off = |(r, c): (i32, i32)| Pos::new(at.row + r, at.col + c);
        for (k, &target) in self.targets.iter().enumerate() {
            if !in_bounds(off(target)) {
                continue;
            }
            let ray = &self.steps[self.start[k] as usize..self.start[k + 1] as usize];
            let last = ray.len() - 1;
            let clear = ray.iter().enumerate().all(|(s, step)| {
                let p = off(step.cell);
                if s < last && (!in_bounds(p) || blocked(p)) {
                    return false;
                }
                match step.corners {
                    Some((a, b)) => !(blocked(off(a)) && blocked(off(b))),
                    None => true,
                }
            });
            if clear {
                visit(off(target));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bresenham_basic_lines() {
        let mut v = Vec::new();
        bresenham(Pos::new(0, 0), Pos::new(0, 3), &mut v);
        assert_eq!(v, vec![Pos::new(0, 1), Pos::new(0, 2), Pos::new(0, 3)]);
        bresenham(Pos::new(0, 0), Pos::new(2, 2), &mut v);
        assert_eq!(v, vec![Pos::new(1, 1), Pos::new(2, 2)]);
        bresenham(Pos::new(0, 0), Pos::new(0, 0), &mut v);
        assert!(v.is_empty());
        // A knight-like offset: one minor step, taken after the tie (err == 0 does not step).
        bresenham(Pos::new(0, 0), Pos::new(1, 2), &mut v);
        assert_eq!(v, vec![Pos::new(0, 1), Pos::new(1, 2)]);
    }

    #[test]
    fn moves_and_corner_rule() {
        for m in Move::ALL {
            assert_eq!(
                Move::between(Pos::new(5, 5), m.apply(Pos::new(5, 5))),
                Some(m)
            );
        }
        // Obstacle at (0,1): the diagonal (0,0) -> (1,1) cuts its corner.
        let passable = |p: Pos| p != Pos::new(0, 1) && p.row >= 0 && p.col >= 0;
        let strict = Movement::NoCornerCutting;
        assert!(!step_allowed(passable, Pos::new(0, 0), Move::SE, strict));
        assert!(step_allowed(
            passable,
            Pos::new(0, 0),
            Move::SE,
            Movement::CornerCutting
        ));
        assert!(step_allowed(passable, Pos::new(0, 0), Move::S, strict));
        assert!(!step_allowed(passable, Pos::new(0, 0), Move::E, strict));
    }

    #[test]
    fn view_pattern_size() {
        let v = ViewPattern::new(4, Movement::default());
        let mut n = 0;
        v.for_each_visible(Pos::new(10, 10), |_| true, |_| false, |_| n += 1);
        assert_eq!(n, 80); // 9×9 window minus the robot's own cell
        let mut corner = 0;
        v.for_each_visible(
            Pos::new(0, 0),
            |p| p.row >= 0 && p.col >= 0,
            |_| false,
            |_| corner += 1,
        );
        assert_eq!(corner, 24);
    }
}
