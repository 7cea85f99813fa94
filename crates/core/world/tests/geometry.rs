//! Ray casting: symmetry of the sensor's view pattern under mirroring and transposition,
//! agreement of `ViewPattern::for_each_visible` with `ray_clear`, symmetry of line of sight,
//! and hand-checked blocking cases for both movement rules.

use madenet_map::{Movement, Pos};
use madenet_world::{bresenham, line_of_sight, ray_clear, step_allowed, Move, ViewPattern};
use proptest::prelude::*;
use std::collections::BTreeSet;

const RULES: [Movement; 2] = [Movement::CornerCutting, Movement::NoCornerCutting];

/// A square `n × n` grid of blocked flags.
#[derive(Clone, Debug)]
struct Grid {
    n: usize,
    blocked: Vec<bool>,
}

impl Grid {
    fn in_bounds(&self, p: Pos) -> bool {
        p.row >= 0 && p.col >= 0 && (p.row as usize) < self.n && (p.col as usize) < self.n
    }
    /// Out-of-bounds cells read as blocked (they are never queried by a correct caster).
    fn is_blocked(&self, p: Pos) -> bool {
        !self.in_bounds(p) || self.blocked[p.row as usize * self.n + p.col as usize]
    }
    fn transformed(&self, f: impl Fn(Pos) -> Pos) -> Grid {
        let mut blocked = vec![false; self.n * self.n];
        for r in 0..self.n as i32 {
            for c in 0..self.n as i32 {
                let q = f(Pos::new(r, c));
                blocked[q.row as usize * self.n + q.col as usize] = self.is_blocked(Pos::new(r, c));
            }
        }
        Grid { n: self.n, blocked }
    }
    fn visible(&self, view: &ViewPattern, at: Pos) -> BTreeSet<Pos> {
        let mut out = BTreeSet::new();
        view.for_each_visible(
            at,
            |q| self.in_bounds(q),
            |q| self.is_blocked(q),
            |q| {
                assert!(out.insert(q), "cell {q} visited twice");
            },
        );
        out
    }
}

fn from_rows(rows: &[&str]) -> Grid {
    let n = rows.len();
    assert!(rows.iter().all(|r| r.len() == n), "square grids only");
    let blocked = rows
        .iter()
        .flat_map(|r| r.chars().map(|c| c == '#'))
        .collect();
    Grid { n, blocked }
}

/// A 9×9 grid, free but for the `walls` cells (row, column).
fn open_9x9(walls: &[(usize, usize)]) -> Grid {
    let n = 9;
    let mut blocked = vec![false; n * n];
    for &(r, c) in walls {
        blocked[r * n + c] = true;
    }
    Grid { n, blocked }
}

fn grid_strategy() -> impl Strategy<Value = (Grid, Pos, i32)> {
    (9usize..=13, 0.0f64..0.5, 1i32..=5).prop_flat_map(|(n, density, radius)| {
        (
            prop::collection::vec(0.0f64..1.0, n * n),
            0..n as i32,
            0..n as i32,
        )
            .prop_map(move |(u, r, c)| {
                let blocked = u.iter().map(|&x| x < density).collect();
                (Grid { n, blocked }, Pos::new(r, c), radius)
            })
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 192, ..ProptestConfig::default() })]

    #[test]
    fn visible_set_is_symmetric_under_mirrors_and_transpose((grid, at, radius) in grid_strategy()) {
        let n = grid.n as i32;
        type Symmetry = (&'static str, fn(Pos, i32) -> Pos);
        let maps: [Symmetry; 5] = [
            ("left-right", |p, n| Pos::new(p.row, n - 1 - p.col)),
            ("top-bottom", |p, n| Pos::new(n - 1 - p.row, p.col)),
            ("transpose", |p, _| Pos::new(p.col, p.row)),
            ("anti-transpose", |p, n| Pos::new(n - 1 - p.col, n - 1 - p.row)),
            ("rotate-180", |p, n| Pos::new(n - 1 - p.row, n - 1 - p.col)),
        ];
        for movement in RULES {
            let view = ViewPattern::new(radius, movement);
            let original = grid.visible(&view, at);
            for (name, f) in maps {
                let g2 = grid.transformed(|p| f(p, n));
                let seen = g2.visible(&view, f(at, n));
                let want: BTreeSet<Pos> = original.iter().map(|&p| f(p, n)).collect();
                prop_assert_eq!(&seen, &want, "{} under {:?} radius {} at {}", name, movement, radius, at);
            }
        }
    }

    #[test]
    fn for_each_visible_agrees_with_ray_clear((grid, at, radius) in grid_strategy()) {
        for movement in RULES {
            let view = ViewPattern::new(radius, movement);
            let seen = grid.visible(&view, at);
            let mut window = 0;
            for dr in -radius..=radius {
                for dc in -radius..=radius {
                    let q = Pos::new(at.row + dr, at.col + dc);
                    if q == at || !grid.in_bounds(q) {
                        continue;
                    }
                    window += 1;
                    let clear = ray_clear(|p| grid.is_blocked(p), at, q, movement);
                    prop_assert_eq!(seen.contains(&q), clear, "target {} from {} under {:?}", q, at, movement);
                }
            }
            // Nothing outside the window or the grid is reported, nor the robot's own cell.
            prop_assert!(seen.len() <= window);
            prop_assert!(seen.iter().all(|p| p.chebyshev(at) <= radius && *p != at && grid.in_bounds(*p)));
        }
    }

    #[test]
    fn line_of_sight_is_symmetric_and_mirror_invariant(
        (grid, a, _r) in grid_strategy(),
        br in 0i32..13, bc in 0i32..13,
    ) {
        let n = grid.n as i32;
        let b = Pos::new(br % n, bc % n);
        let lr = grid.transformed(|p| Pos::new(p.row, n - 1 - p.col));
        let tr = grid.transformed(|p| Pos::new(p.col, p.row));
        for movement in RULES {
            let blocked = |p: Pos| grid.is_blocked(p);
            let ab = line_of_sight(blocked, a, b, movement);
            prop_assert_eq!(ab, line_of_sight(blocked, b, a, movement));
            // Line of sight is the union of the two rays.
            prop_assert_eq!(ab, ray_clear(blocked, a, b, movement) || ray_clear(blocked, b, a, movement));
            let m = |p: Pos| Pos::new(p.row, n - 1 - p.col);
            prop_assert_eq!(ab, line_of_sight(|p| lr.is_blocked(p), m(a), m(b), movement));
            let t = |p: Pos| Pos::new(p.col, p.row);
            prop_assert_eq!(ab, line_of_sight(|p| tr.is_blocked(p), t(a), t(b), movement));
            // Under NoCornerCutting a clear ray is also a clear ray under CornerCutting.
            if movement == Movement::NoCornerCutting && ab {
                prop_assert!(line_of_sight(blocked, a, b, Movement::CornerCutting));
            }
        }
    }

    #[test]
    fn bresenham_is_a_king_path(fr in -6i32..6, fc in -6i32..6, tr in -6i32..6, tc in -6i32..6) {
        let (from, to) = (Pos::new(fr, fc), Pos::new(tr, tc));
        let mut line = Vec::new();
        bresenham(from, to, &mut line);
        prop_assert_eq!(line.len() as i32, from.chebyshev(to));
        let mut prev = from;
        for &p in &line {
            prop_assert_eq!(prev.chebyshev(p), 1);
            prev = p;
        }
        if from != to {
            prop_assert_eq!(*line.last().unwrap(), to);
        }
    }
}

/// Cells visible from the centre of a 9×9 grid, as a picture: `V` visible, `.` not.
fn picture(grid: &Grid, at: Pos, movement: Movement) -> Vec<String> {
    let view = ViewPattern::new(4, movement);
    let seen = grid.visible(&view, at);
    (0..grid.n as i32)
        .map(|r| {
            (0..grid.n as i32)
                .map(|c| {
                    if seen.contains(&Pos::new(r, c)) {
                        'V'
                    } else {
                        '.'
                    }
                })
                .collect()
        })
        .collect()
}

#[test]
fn wall_in_front_blocks_cells_behind_but_is_itself_visible() {
    let grid = open_9x9(&[(4, 5)]);
    let at = Pos::new(4, 4);
    for movement in RULES {
        let view = ViewPattern::new(4, movement);
        let seen = grid.visible(&view, at);
        assert!(
            seen.contains(&Pos::new(4, 5)),
            "the wall cell itself is seen ({movement:?})"
        );
        for c in 6..=8 {
            assert!(
                !seen.contains(&Pos::new(4, c)),
                "(4,{c}) is behind the wall ({movement:?})"
            );
            assert!(!ray_clear(
                |p| grid.is_blocked(p),
                at,
                Pos::new(4, c),
                movement
            ));
        }
        // The exact shadow. Bresenham ties never step the minor axis, so rays to (±1, +2),
        // (±1, +3), (±1, +4) and (±2, +4) (offsets from the robot) all pass the wall first.
        let hidden: BTreeSet<Pos> = [
            (0, 2),
            (0, 3),
            (0, 4),
            (1, 2),
            (1, 3),
            (1, 4),
            (-1, 2),
            (-1, 3),
            (-1, 4),
            (2, 4),
            (-2, 4),
        ]
        .iter()
        .map(|&(dr, dc)| Pos::new(at.row + dr, at.col + dc))
        .collect();
        let mut want = BTreeSet::new();
        for r in 0..9 {
            for c in 0..9 {
                let p = Pos::new(r, c);
                if p != at && !hidden.contains(&p) {
                    want.insert(p);
                }
            }
        }
        assert_eq!(seen, want, "{:#?}", picture(&grid, at, movement));
        // A cell beside the wall on a steeper ray is not shadowed.
        assert!(seen.contains(&Pos::new(3, 5)) && seen.contains(&Pos::new(2, 7)));
    }
}

#[test]
fn full_wall_hides_the_far_side() {
    let grid = from_rows(&[
        "......#..",
        "......#..",
        "......#..",
        "......#..",
        "......#..",
        "......#..",
        "......#..",
        "......#..",
        "......#..",
    ]);
    let at = Pos::new(4, 4);
    for movement in RULES {
        let seen = grid.visible(&ViewPattern::new(4, movement), at);
        for r in 0..9 {
            assert!(
                seen.contains(&Pos::new(r, 6)),
                "wall cell ({r},6) seen ({movement:?})"
            );
            assert!(!seen.contains(&Pos::new(r, 7)) && !seen.contains(&Pos::new(r, 8)));
        }
        // 9 rows × 7 columns (0..=6) minus the robot's own cell.
        assert_eq!(seen.len(), 9 * 7 - 1);
    }
}

#[test]
fn diagonal_squeeze_blocks_only_without_corner_cutting() {
    // Two obstacles touching at a corner on the robot's NE diagonal: (3,4) and (4,5).
    let grid = open_9x9(&[(3, 4), (4, 5)]);
    let at = Pos::new(4, 4);
    let blocked = |p: Pos| grid.is_blocked(p);
    let ne: Vec<Pos> = (1..=4).map(|k| Pos::new(4 - k, 4 + k)).collect();

    let strict = grid.visible(&ViewPattern::new(4, Movement::NoCornerCutting), at);
    let cutting = grid.visible(&ViewPattern::new(4, Movement::CornerCutting), at);
    for &p in &ne {
        assert!(
            !strict.contains(&p),
            "{p} must be hidden behind the squeeze"
        );
        assert!(
            cutting.contains(&p),
            "{p} must be visible through the squeeze with corner cutting"
        );
        assert!(!ray_clear(blocked, at, p, Movement::NoCornerCutting));
        assert!(ray_clear(blocked, at, p, Movement::CornerCutting));
        assert!(!line_of_sight(blocked, at, p, Movement::NoCornerCutting));
        assert!(line_of_sight(blocked, at, p, Movement::CornerCutting));
    }
    // The two obstacles themselves are seen under both rules.
    for p in [Pos::new(3, 4), Pos::new(4, 5)] {
        assert!(strict.contains(&p) && cutting.contains(&p));
    }
    // The robot can step through the squeeze only with corner cutting, like the light.
    let passable = |p: Pos| grid.in_bounds(p) && !grid.is_blocked(p);
    assert!(!step_allowed(
        passable,
        at,
        Move::NE,
        Movement::NoCornerCutting
    ));
    assert!(step_allowed(
        passable,
        at,
        Move::NE,
        Movement::CornerCutting
    ));
    // A single obstacle at a corner (no squeeze) does not block the diagonal under either rule.
    let single = open_9x9(&[(3, 4)]);
    for movement in RULES {
        let seen = single.visible(&ViewPattern::new(4, movement), at);
        assert!(ne.iter().all(|p| seen.contains(p)), "{movement:?}");
    }
}

#[test]
fn window_is_clipped_at_the_grid_edge() {
    let grid = open_9x9(&[]);
    for movement in RULES {
        let view = ViewPattern::new(4, movement);
        // Corner: 5×5 minus itself; edge middle: 9×5 minus itself.
        assert_eq!(grid.visible(&view, Pos::new(0, 0)).len(), 24);
        assert_eq!(grid.visible(&view, Pos::new(0, 4)).len(), 44);
        assert_eq!(grid.visible(&view, Pos::new(8, 8)).len(), 24);
    }
}
