//! The true geometry of a continuous world: obstacle shapes in metres, and the same geometry as
//! a fine raster (for the ground-truth coarse map, completion and pictures).
//!
//! Coordinates: `x` to the right and `y` downward, in metres from the top-left corner of the
//! map, as the rows and columns of [`OccGrid`]s run (pixel `(row, col)` covers
//! `[col·res, (col+1)·res) × [row·res, (row+1)·res)`). Headings are `atan2(dy, dx)` in that frame.

use madenet_map::discretize::{discretize_area, DiscretizeParams};
use madenet_map::{OccGrid, Occupancy, Pos};
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// One obstacle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    /// A rectangle centred at (`x`, `y`), half extents `hx` × `hy`, turned by `angle` radians.
    Rect {
        /// Centre x (m).
        x: f64,
        /// Centre y (m).
        y: f64,
        /// Half width along its own x axis (m).
        hx: f64,
        /// Half height along its own y axis (m).
        hy: f64,
        /// Rotation (rad).
        angle: f64,
    },
    /// A disc centred at (`x`, `y`) of radius `r`.
    Circle {
        /// Centre x (m).
        x: f64,
        /// Centre y (m).
        y: f64,
        /// Radius (m).
        r: f64,
    },
}

impl Shape {
    /// How far outside the point (`px`, `py`) lies along each of the shape's own axes
    /// (rectangle: beyond each half extent; disc: beyond the radius, and 0); ≤ 0 both: inside.
    fn outside(&self, px: f64, py: f64) -> (f64, f64) {
        match *self {
            Shape::Rect {
                x,
                y,
                hx,
                hy,
                angle,
            } => {
                let (s, c) = angle.sin_cos();
                let (dx, dy) = (px - x, py - y);
                let (lx, ly) = (c * dx + s * dy, -s * dx + c * dy);
                (lx.abs() - hx, ly.abs() - hy)
            }
            Shape::Circle { x, y, r } => ((px - x).hypot(py - y) - r, 0.0),
        }
    }

    /// Whether the point (`px`, `py`) lies inside.
    pub fn contains(&self, px: f64, py: f64) -> bool {
        let (a, b) = self.outside(px, py);
        a <= 0.0 && b <= 0.0
    }

    /// Metres from the point (`px`, `py`) to the shape (0 inside).
    pub fn distance(&self, px: f64, py: f64) -> f64 {
        let (a, b) = self.outside(px, py);
        a.max(0.0).hypot(b.max(0.0))
    }

    /// Axis-aligned bounds `(x0, y0, x1, y1)`.
    pub fn bounds(&self) -> (f64, f64, f64, f64) {
        match *self {
            Shape::Rect {
                x,
                y,
                hx,
                hy,
                angle,
            } => {
                let (s, c) = angle.sin_cos();
                let ex = (c * hx).abs() + (s * hy).abs();
                let ey = (s * hx).abs() + (c * hy).abs();
                (x - ex, y - ey, x + ex, y + ey)
            }
            Shape::Circle { x, y, r } => (x - r, y - r, x + r, y + r),
        }
    }
}

/// The edge of a `width_m` × `height_m` map as four walls half a metre thick just outside it:
/// nothing leaves the map, and no pixel inside it is taken.
fn edge_walls(width_m: f64, height_m: f64) -> [Shape; 4] {
    let (w2, h2) = (width_m / 2.0, height_m / 2.0);
    [
        (w2, -0.25, w2 + 0.5, 0.25),
        (w2, height_m + 0.25, w2 + 0.5, 0.25),
        (-0.25, h2, 0.25, h2 + 0.5),
        (width_m + 0.25, h2, 0.25, h2 + 0.5),
    ]
    .map(|(x, y, hx, hy)| Shape::Rect {
        x,
        y,
        hx,
        hy,
        angle: 0.0,
    })
}

/// Metres a picked start keeps beyond the footprint (the world's own check runs in `f32`).
pub const START_MARGIN: f64 = 0.02;

/// A world's true geometry.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Obstacles (the map's border included).
    pub shapes: Vec<Shape>,
    /// The same geometry, one pixel per `fine.resolution` metres: obstacle or free.
    pub fine: OccGrid,
    /// Where it came from, for messages (`generated:30:7`, a file path).
    pub name: String,
}

impl Scene {
    /// Width in metres.
    pub fn width_m(&self) -> f64 {
        self.fine.width() as f64 * self.fine.resolution
    }
    /// Height in metres.
    pub fn height_m(&self) -> f64 {
        self.fine.height() as f64 * self.fine.resolution
    }

    /// A scene from a fine grid (a map file loaded at its native resolution): every obstacle or
    /// unknown pixel is solid (unknown space of a map file lies outside what was mapped), merged
    /// into as few axis-aligned rectangles as runs allow (row runs extended downward while the
    /// pixels below are solid too); the map's edge is a wall just outside it.
    pub fn from_grid(grid: &OccGrid, name: &str) -> Scene {
        let (h, w, res) = (grid.height(), grid.width(), grid.resolution);
        let solid = |r: usize, c: usize| grid.cells()[r * w + c] != Occupancy::Free;
        let mut fine = OccGrid::from_cells(
            h,
            w,
            grid.cells()
                .iter()
                .map(|&c| {
                    if c == Occupancy::Free {
                        Occupancy::Free
                    } else {
                        Occupancy::Obstacle
                    }
                })
                .collect(),
        );
        fine.resolution = res;
        fine.origin = grid.origin;
        // Row runs, merged downward into rectangles.
        let mut used = vec![false; h * w];
        let mut shapes = Vec::new();
        for r in 0..h {
            let mut c = 0;
            while c < w {
                if !solid(r, c) || used[r * w + c] {
                    c += 1;
                    continue;
                }
                let c0 = c;
                while c < w && solid(r, c) && !used[r * w + c] {
                    c += 1;
                }
                let c1 = c;
                let mut r1 = r + 1;
                while r1 < h && (c0..c1).all(|k| solid(r1, k) && !used[r1 * w + k]) {
                    r1 += 1;
                }
                for rr in r..r1 {
                    used[rr * w..][c0..c1].fill(true);
                }
                shapes.push(Shape::Rect {
                    x: (c0 + c1) as f64 * res / 2.0,
                    y: (r + r1) as f64 * res / 2.0,
                    hx: (c1 - c0) as f64 * res / 2.0,
                    hy: (r1 - r) as f64 * res / 2.0,
                    angle: 0.0,
                });
            }
        }
        shapes.extend(edge_walls(w as f64 * res, h as f64 * res));
        Scene {
            shapes,
            fine,
            name: name.into(),
        }
    }

    /// A scene from shapes inside a `width_m` × `height_m` box, rasterized at `resolution`
    /// (a pixel is an obstacle when its centre lies in a shape); the box's edge is a wall just
    /// outside it.
    pub fn from_shapes(
        mut shapes: Vec<Shape>,
        width_m: f64,
        height_m: f64,
        resolution: f64,
        name: &str,
    ) -> Scene {
        shapes.extend(edge_walls(width_m, height_m));
        let w = (width_m / resolution).round().max(1.0) as usize;
        let h = (height_m / resolution).round().max(1.0) as usize;
        let mut cells = vec![Occupancy::Free; w * h];
        for s in &shapes {
            let (x0, y0, x1, y1) = s.bounds();
            let c0 = ((x0 / resolution).floor().max(0.0)) as usize;
            let r0 = ((y0 / resolution).floor().max(0.0)) as usize;
            let c1 = ((x1 / resolution).ceil() as usize).min(w);
            let r1 = ((y1 / resolution).ceil() as usize).min(h);
            for r in r0..r1 {
                for c in c0..c1 {
                    let (px, py) = ((c as f64 + 0.5) * resolution, (r as f64 + 0.5) * resolution);
                    if s.contains(px, py) {
                        cells[r * w + c] = Occupancy::Obstacle;
                    }
                }
            }
        }
        let mut fine = OccGrid::from_cells(h, w, cells);
        fine.resolution = resolution;
        Scene {
            shapes,
            fine,
            name: name.into(),
        }
    }

    /// The true map in the agent's cells of `cell_size` metres, by the paper's rule: what the
    /// team would know at the end, and what "explored" is measured against.
    pub fn coarse_truth(&self, cell_size: f64, params: &DiscretizeParams) -> OccGrid {
        let probs: Vec<f64> = self
            .fine
            .cells()
            .iter()
            .map(|&c| if c == Occupancy::Free { 0.0 } else { 1.0 })
            .collect();
        let cell_px = (cell_size / self.fine.resolution).max(1.0);
        let mut g = discretize_area(
            &probs,
            self.fine.height(),
            self.fine.width(),
            cell_px,
            params,
        );
        g.resolution = cell_size;
        // The same place in the map frame as the scene (a map file's origin and yaw).
        g.origin = self.fine.origin;
        g
    }

    /// Which pixels of [`Scene::fine`] the centre of a disc of `radius` metres can reach from
    /// the points `from` (metres) without the disc touching an obstacle pixel: where a robot
    /// of that footprint can drive (8-connected without cutting corners; a start is a seed even
    /// where the raster's rounding blocks it).
    pub fn drivable(&self, from: &[(f64, f64)], radius: f64) -> Vec<bool> {
        let (h, w, res) = (self.fine.height(), self.fine.width(), self.fine.resolution);
        let cells = self.fine.cells();
        let kernel = crate::mapping::disc_kernel(radius, res);
        // The edge walls lie outside the raster: within `radius` of the edge is blocked too.
        let edge = |k: usize, n: usize| {
            let d = (k as f64 + 0.5).min(n as f64 - k as f64 - 0.5) * res;
            d < radius
        };
        let mut blocked: Vec<bool> = (0..h * w)
            .map(|k| edge(k / w, h) || edge(k % w, w))
            .collect();
        for (k, _) in cells
            .iter()
            .enumerate()
            .filter(|(_, &c)| c != Occupancy::Free)
        {
            let (r, c) = ((k / w) as i64, (k % w) as i64);
            for &(dr, dc) in &kernel {
                let (nr, nc) = (r + dr, c + dc);
                if nr >= 0 && nc >= 0 && (nr as usize) < h && (nc as usize) < w {
                    blocked[nr as usize * w + nc as usize] = true;
                }
            }
        }
        let mut seen = vec![false; h * w];
        let mut queue = std::collections::VecDeque::new();
        for &(x, y) in from {
            let (r, c) = ((y / res).floor() as i64, (x / res).floor() as i64);
            if r >= 0 && c >= 0 && (r as usize) < h && (c as usize) < w {
                let k = r as usize * w + c as usize;
                if !seen[k] {
                    seen[k] = true;
                    queue.push_back(k);
                }
            }
        }
        while let Some(k) = queue.pop_front() {
            let (r, c) = ((k / w) as i64, (k % w) as i64);
            // The grid world's moves but staying: the 8 neighbours.
            for (dr, dc) in madenet_world::geometry::Move::ALL.map(|m| m.delta()) {
                if (dr, dc) == (0, 0) {
                    continue;
                }
                let (nr, nc) = (r + dr as i64, c + dc as i64);
                if nr < 0 || nc < 0 || nr as usize >= h || nc as usize >= w {
                    continue;
                }
                let j = nr as usize * w + nc as usize;
                // No corner cutting: a diagonal step needs both side pixels open (two walls
                // that meet at a corner leave no gap).
                let diagonal_open = dr == 0
                    || dc == 0
                    || (!blocked[r as usize * w + nc as usize]
                        && !blocked[nr as usize * w + c as usize]);
                if !seen[j] && !blocked[j] && diagonal_open {
                    seen[j] = true;
                    queue.push_back(j);
                }
            }
        }
        seen
    }

    /// Whether a disc of `radius` metres centred at (`x`, `y`) keeps [`START_MARGIN`] clear of
    /// every shape (the map's edge included): a robot's footprint fits there.
    pub fn footprint_fits(&self, x: f64, y: f64, radius: f64) -> bool {
        self.shapes
            .iter()
            .all(|s| s.distance(x, y) > radius + START_MARGIN)
    }

    /// The cells where a robot may start: [`Scene::coarse_truth`] with every free cell at whose
    /// centre a footprint of `radius` metres does not fit ([`Scene::footprint_fits`]) marked
    /// occupied. The program's own start pickers (`--start random`, the scalability study's
    /// start areas) draw from it, so the world never refuses what they pick.
    pub fn start_cells(&self, cell_size: f64, params: &DiscretizeParams, radius: f64) -> OccGrid {
        let mut g = self.coarse_truth(cell_size, params);
        for k in 0..g.len() {
            let p = g.pos(k);
            if g.get(p) == Occupancy::Free {
                let (x, y) = Scene::cell_centre(p, cell_size);
                if !self.footprint_fits(x, y, radius) {
                    g.set(p, Occupancy::Obstacle);
                }
            }
        }
        g
    }

    /// The centre of cell `p` of `cell_size` metres, in metres.
    pub fn cell_centre(p: Pos, cell_size: f64) -> (f64, f64) {
        (
            (p.col as f64 + 0.5) * cell_size,
            (p.row as f64 + 0.5) * cell_size,
        )
    }
}

/// The paper's kind of cluttered world (Sec. V.B, Fig. 6: bookshelves, bins, cylinders),
/// seeded: `side` metres square, pixels of `resolution` metres. Bookshelf-like boxes stand in
/// rows with gaps (narrow passages and dead ends between them), bins and cylinders are
/// scattered; the area near the three start positions the paper uses (bottom-left, top-right,
/// middle) is kept clear.
pub fn generate_cluttered(side: f64, resolution: f64, seed: u64) -> Scene {
    let mut rng = madenet_world::rng::stream(seed, "continuous-generator", 0);
    let mut shapes = Vec::new();
    let clear = [
        (2.0, side - 2.0),
        (side - 2.0, 2.0),
        (side / 2.0, side / 2.0),
    ];
    let keep_clear = |s: &Shape| {
        let (x0, y0, x1, y1) = s.bounds();
        clear.iter().all(|&(cx, cy)| {
            let dx = (cx - cx.clamp(x0, x1)).abs();
            let dy = (cy - cy.clamp(y0, y1)).abs();
            dx * dx + dy * dy > 2.5 * 2.5
        })
    };
    // About one obstacle per 9 m²: bookshelves 40 %, bins 30 %, cylinders 30 %.
    let count = (side * side / 9.0).round() as usize;
    let mut tries = 0;
    while shapes.len() < count && tries < count * 20 {
        tries += 1;
        let x = rng.random_range(1.0..side - 1.0);
        let y = rng.random_range(1.0..side - 1.0);
        let kind: f64 = rng.random();
        let s = if kind < 0.4 {
            // A bookshelf: 0.4 m deep, 1.2–3 m long, along one of the axes (as furniture
            // stands), sometimes turned.
            let long = rng.random_range(0.6..1.5);
            let turned = rng.random::<f64>() < 0.2;
            let angle = if turned {
                rng.random_range(0.0..std::f64::consts::PI)
            } else if rng.random::<bool>() {
                0.0
            } else {
                std::f64::consts::FRAC_PI_2
            };
            Shape::Rect {
                x,
                y,
                hx: long,
                hy: 0.2,
                angle,
            }
        } else if kind < 0.7 {
            // A bin: 0.5–0.9 m square.
            let half = rng.random_range(0.25..0.45);
            Shape::Rect {
                x,
                y,
                hx: half,
                hy: half,
                angle: 0.0,
            }
        } else {
            Shape::Circle {
                x,
                y,
                r: rng.random_range(0.1..0.4),
            }
        };
        if keep_clear(&s) {
            shapes.push(s);
        }
    }
    Scene::from_shapes(
        shapes,
        side,
        side,
        resolution,
        &format!("generated:{side}:{seed}"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_edge_takes_no_pixel_and_a_gap_narrower_than_the_footprint_stops_the_drive() {
        let wall = |y: f64, hy: f64| Shape::Rect {
            x: 3.0,
            y,
            hx: 0.1,
            hy,
            angle: 0.0,
        };
        // A wall across a 6 m × 4 m box at x = 3 m, open between y = 1.8 and y = 1.8 + gap.
        let scene = |gap: f64| {
            let low = 1.8;
            Scene::from_shapes(
                vec![
                    wall(low / 2.0, low / 2.0),
                    wall((low + gap + 4.0) / 2.0, (4.0 - low - gap) / 2.0),
                ],
                6.0,
                4.0,
                0.1,
                "gap",
            )
        };
        let empty = Scene::from_shapes(Vec::new(), 6.0, 4.0, 0.1, "empty");
        assert!(empty.fine.cells().iter().all(|&c| c == Occupancy::Free));
        assert_eq!(empty.shapes.len(), 4, "the edge walls, outside");
        // From the left half: the right half only through a gap wider than the disc.
        let right = |d: &[bool], s: &Scene| (0..d.len()).any(|k| d[k] && k % s.fine.width() > 35);
        let narrow = scene(0.4);
        assert!(!right(&narrow.drivable(&[(1.0, 2.0)], 0.227), &narrow));
        let wide = scene(0.7);
        let d = wide.drivable(&[(1.0, 2.0)], 0.227);
        assert!(right(&d, &wide));
        // Nothing within the footprint of a wall or the edge is drivable.
        let w = wide.fine.width();
        assert!((0..d.len()).all(|k| !d[k] || (k % w >= 2 && k / w >= 2)));
    }

    #[test]
    fn walls_that_meet_at_a_corner_leave_no_way_through() {
        // The right half is joined to the left only diagonally, between the walls at (1, 2) and
        // (2, 1), whose squares touch at one point (issue 59: a floor plan counted 114 such
        // cells as explorable).
        let text = "..#..\n..#..\n.#...\n.#...\n.#...\n";
        let g = madenet_map::io::parse_text(text, std::path::Path::new("t.txt")).unwrap();
        let s = Scene::from_grid(&g, "t");
        let d = s.drivable(&[(0.5, 4.5)], 0.227);
        let w = s.fine.width();
        assert!(d[w + 1], "the left side is drivable");
        assert!(
            !d[2 * w + 2] && !d[4 * w + 4],
            "nothing right of the corner"
        );
        // With the corner open (one wall gone), the diagonal step is taken.
        let open = "..#..\n.....\n.#...\n.#...\n.#...\n";
        let g = madenet_map::io::parse_text(open, std::path::Path::new("t.txt")).unwrap();
        let s = Scene::from_grid(&g, "t");
        assert!(s.drivable(&[(0.5, 4.5)], 0.227)[4 * w + 4]);
    }

    #[test]
    fn a_start_cell_is_one_where_the_footprint_fits() {
        // A pole of radius 0.1 m at (1.5, 0.75) m: cell (0, 1)'s centre is 0.15 m from its
        // edge, free on the cells (it covers too little of the cell) but no place for a robot.
        let pole = Shape::Circle {
            x: 1.5,
            y: 0.75,
            r: 0.1,
        };
        let s = Scene::from_shapes(vec![pole], 4.0, 2.0, 0.1, "pole");
        let params = DiscretizeParams::default();
        let coarse = s.coarse_truth(1.0, &params);
        let starts = s.start_cells(1.0, &params, 0.177);
        assert_eq!(coarse.get(Pos::new(0, 1)), Occupancy::Free);
        assert_eq!(starts.get(Pos::new(0, 1)), Occupancy::Obstacle);
        assert!(!s.footprint_fits(1.5, 0.5, 0.177) && s.footprint_fits(2.5, 0.5, 0.177));
        // Every other free cell stays a start (the edge is 0.5 m from each centre).
        for k in 0..coarse.len() {
            let p = coarse.pos(k);
            if p != Pos::new(0, 1) {
                assert_eq!(starts.get(p), coarse.get(p), "cell {p}");
            }
        }
        assert!(
            (Shape::Circle {
                x: 0.0,
                y: 0.0,
                r: 1.0
            }
            .distance(3.0, 4.0)
                - 4.0)
                .abs()
                < 1e-12
        );
        let rect = Shape::Rect {
            x: 0.0,
            y: 0.0,
            hx: 1.0,
            hy: 2.0,
            angle: std::f64::consts::FRAC_PI_2,
        };
        // Turned a quarter: 2 m half extent along x.
        assert!((rect.distance(3.0, 0.0) - 1.0).abs() < 1e-9 && rect.distance(1.5, 0.0) == 0.0);
    }

    #[test]
    fn a_grid_becomes_rectangles_covering_exactly_its_solid_pixels() {
        let text = "#####\n#..##\n#...#\n##..#\n#####\n";
        let mut g = madenet_map::io::parse_text(text, std::path::Path::new("t.txt")).unwrap();
        g.resolution = 0.5;
        let s = Scene::from_grid(&g, "t");
        for r in 0..5 {
            for c in 0..5 {
                let (px, py) = ((c as f64 + 0.5) * 0.5, (r as f64 + 0.5) * 0.5);
                let inside = s.shapes.iter().filter(|sh| sh.contains(px, py)).count();
                let solid = g.get(Pos::new(r, c)) != Occupancy::Free;
                assert_eq!(inside, usize::from(solid), "pixel ({r}, {c})");
            }
        }
    }

    #[test]
    fn generated_worlds_are_seeded_and_keep_the_starts_clear() {
        let a = generate_cluttered(20.0, 0.1, 3);
        let b = generate_cluttered(20.0, 0.1, 3);
        assert_eq!(a.shapes, b.shapes);
        assert_ne!(a.shapes, generate_cluttered(20.0, 0.1, 4).shapes);
        assert_eq!((a.fine.height(), a.fine.width()), (200, 200));
        for (x, y) in [(2.0, 18.0), (18.0, 2.0), (10.0, 10.0)] {
            assert!(a.shapes[..a.shapes.len() - 4]
                .iter()
                .all(|s| !s.contains(x, y)));
        }
        let coarse = a.coarse_truth(1.0, &DiscretizeParams::default());
        assert_eq!((coarse.height(), coarse.width()), (20, 20));
        let obstacles = coarse
            .cells()
            .iter()
            .filter(|&&c| c == Occupancy::Obstacle)
            .count();
        assert!((20..200).contains(&obstacles), "{obstacles} obstacle cells");
    }
}
