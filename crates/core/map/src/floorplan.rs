//! A seeded floor-plan generator: rooms and corridors, as in office and lab buildings — the
//! structure that [`crate::generate`]'s clutter lacks (issue 29: train where coordination
//! matters; the paper's building floor stays held out).
//!
//! Recursive division: the whole grid is a room; a room larger than twice `min_room` along
//! its longer side is split across that side by a one-cell wall with a door `door_width`
//! cells wide, or — with probability `corridor_prob`, when there is room — by a corridor
//! `corridor_width` cells wide between two walls, each with a door into the corridor. The
//! halves are divided again. Then the `keep_free` cells are cleared and any pocket a door did
//! not reach (where a wall ends in front of an earlier door) is joined to the rest by opening
//! the wall cell between them. Last, furniture: single obstacle cells inside rooms up to a
//! `clutter` fraction of the area, each kept only if the free space stays connected — so the
//! free cells always form one connected component under the movement rule.
//!
//! ```
//! use madenet_map::floorplan::{floor_plan, FloorPlanConfig};
//! let cfg = FloorPlanConfig::for_size(30, 40);
//! let map = floor_plan(&cfg, 7).unwrap();
//! assert_eq!((map.height(), map.width()), (30, 40));
//! assert!(madenet_map::generate::is_connected(&map));
//! assert_eq!(map, floor_plan(&cfg, 7).unwrap()); // same seed, same plan
//! ```

use crate::generate::{cell_outside, invalid_field, reachable_from_with};
use crate::paper::Corner;
use crate::{MapError, Movement, OccGrid, Occupancy, Pos};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

/// The floor-plan generator's parameters, with documented defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FloorPlanConfig {
    /// Rows (default 20, 8 to 256).
    pub height: usize,
    /// Columns (default 20, 8 to 256).
    pub width: usize,
    /// The smallest room side, cells (default 4, at least 2); a room is split only if both
    /// halves keep at least this much.
    pub min_room: usize,
    /// Width of a door, cells (default 2, at least 1).
    pub door_width: usize,
    /// Width of a corridor between two walls, cells (default 2, at least 1).
    pub corridor_width: usize,
    /// Probability that a split is a corridor rather than a single wall (default 0.3).
    pub corridor_prob: f64,
    /// Furniture: the fraction of all cells made single obstacles inside rooms (default 0.05,
    /// below 0.3).
    pub clutter: f64,
    /// Cells that must stay free, e.g. the robots' start cells (default: the paper's corner
    /// start cells of a grid this size).
    pub keep_free: Vec<Pos>,
}

impl Default for FloorPlanConfig {
    fn default() -> Self {
        FloorPlanConfig::for_size(20, 20)
    }
}

impl FloorPlanConfig {
    /// The defaults for a `height × width` grid, keeping its 12 corner start cells free.
    pub fn for_size(height: usize, width: usize) -> Self {
        FloorPlanConfig {
            height,
            width,
            min_room: 4,
            door_width: 2,
            corridor_width: 2,
            corridor_prob: 0.3,
            clutter: 0.05,
            keep_free: Corner::all_start_cells(height, width),
        }
    }

    /// Checks every field; errors are [`MapError::Invalid`] naming the field.
    pub fn validate(&self) -> Result<(), MapError> {
        let bad = |field: &str, msg: String| invalid_field("floor plan config", field, msg);
        for (name, v) in [("height", self.height), ("width", self.width)] {
            // Each piece of furniture checks connectivity over the whole grid: 256 keeps a
            // plan under a second.
            if !(8..=256).contains(&v) {
                return bad(name, format!("must lie in 8..=256, got {v}"));
            }
        }
        if self.min_room < 2 {
            return bad(
                "min_room",
                format!("must be at least 2, got {}", self.min_room),
            );
        }
        if self.door_width < 1 || self.door_width > self.min_room {
            return bad(
                "door_width",
                format!(
                    "must lie in 1..=min_room ({}), got {}",
                    self.min_room, self.door_width
                ),
            );
        }
        if self.corridor_width < 1 || self.corridor_width > 10 {
            return bad(
                "corridor_width",
                format!("must lie in 1..=10, got {}", self.corridor_width),
            );
        }
        if !(0.0..=1.0).contains(&self.corridor_prob) {
            return bad(
                "corridor_prob",
                format!("must lie in [0, 1], got {}", self.corridor_prob),
            );
        }
        if !(0.0..0.3).contains(&self.clutter) {
            return bad(
                "clutter",
                format!("must lie in [0, 0.3), got {}", self.clutter),
            );
        }
        if let Some(p) = cell_outside(&self.keep_free, self.height, self.width) {
            return bad(
                "keep_free",
                format!(
                    "cell {p} is outside the {}×{} grid (use FloorPlanConfig::for_size)",
                    self.height, self.width
                ),
            );
        }
        Ok(())
    }
}

/// A room: rows `r0..r1`, columns `c0..c1`.
#[derive(Clone, Copy)]
struct Room {
    r0: usize,
    r1: usize,
    c0: usize,
    c1: usize,
}

/// Draws a wall across `room` at row `at` (`across_rows`) or column `at`, with a door of `door`
/// cells at a random place along it.
fn wall(
    grid: &mut OccGrid,
    room: Room,
    across_rows: bool,
    at: usize,
    door: usize,
    rng: &mut Pcg64Mcg,
) {
    let (lo, hi) = if across_rows {
        (room.c0, room.c1)
    } else {
        (room.r0, room.r1)
    };
    let len = hi - lo;
    let d0 = lo + rng.random_range(0..=len.saturating_sub(door));
    for k in lo..hi {
        if (d0..d0 + door).contains(&k) {
            continue;
        }
        let p = if across_rows {
            Pos::new(at as i32, k as i32)
        } else {
            Pos::new(k as i32, at as i32)
        };
        grid.set(p, Occupancy::Obstacle);
    }
}

/// Generates a floor plan from `cfg` and `seed` (same inputs ⇒ identical map); see the module
/// docs. Connectivity is judged under `movement`.
pub fn floor_plan_with_movement(
    cfg: &FloorPlanConfig,
    seed: u64,
    movement: Movement,
) -> Result<OccGrid, MapError> {
    cfg.validate()?;
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut grid = OccGrid::new(cfg.height, cfg.width, Occupancy::Free);
    let m = cfg.min_room;
    let mut rooms = vec![Room {
        r0: 0,
        r1: cfg.height,
        c0: 0,
        c1: cfg.width,
    }];
    let mut done = Vec::new();
    while let Some(room) = rooms.pop() {
        let (h, w) = (room.r1 - room.r0, room.c1 - room.c0);
        // Split across the longer side (rows when the room is taller).
        let across_rows = if h == w { rng.random_bool(0.5) } else { h > w };
        let (lo, span) = if across_rows {
            (room.r0, h)
        } else {
            (room.c0, w)
        };
        let corridor = cfg.corridor_width + 2;
        let use_corridor = span >= 2 * m + corridor && rng.random_bool(cfg.corridor_prob);
        let gap = if use_corridor { corridor } else { 1 };
        if span < 2 * m + gap {
            done.push(room);
            continue;
        }
        // The wall (or the corridor's first wall) at lo + m ..= lo + span − m − gap.
        let at = lo + rng.random_range(m..=span - m - gap);
        wall(&mut grid, room, across_rows, at, cfg.door_width, &mut rng);
        let last = at + gap - 1;
        if use_corridor {
            wall(&mut grid, room, across_rows, last, cfg.door_width, &mut rng);
        }
        let (a, b) = if across_rows {
            (
                Room { r1: at, ..room },
                Room {
                    r0: last + 1,
                    ..room
                },
            )
        } else {
            (
                Room { c1: at, ..room },
                Room {
                    c0: last + 1,
                    ..room
                },
            )
        };
        rooms.push(b);
        rooms.push(a);
    }
    for &p in &cfg.keep_free {
        grid.set(p, Occupancy::Free);
    }
    if !connect(&mut grid, movement) {
        return Err(MapError::Invalid(format!(
            "floor plan (seed {seed}): its rooms could not be joined (please report this seed and config)"
        )));
    }
    // Furniture inside the rooms, each piece kept only if the free space stays connected.
    let target = (cfg.clutter * grid.len() as f64).round() as usize;
    let mut placed = 0;
    let mut tries = 0;
    while placed < target && tries < 20 * target.max(1) {
        tries += 1;
        let room = done[rng.random_range(0..done.len())];
        let p = Pos::new(
            rng.random_range(room.r0..room.r1) as i32,
            rng.random_range(room.c0..room.c1) as i32,
        );
        if grid.get(p) != Occupancy::Free || cfg.keep_free.contains(&p) {
            continue;
        }
        grid.set(p, Occupancy::Obstacle);
        if crate::generate::is_connected_with(&grid, movement) {
            placed += 1;
        } else {
            grid.set(p, Occupancy::Free);
        }
    }
    Ok(grid)
}

/// [`floor_plan_with_movement`] under the default movement rule.
pub fn floor_plan(cfg: &FloorPlanConfig, seed: u64) -> Result<OccGrid, MapError> {
    floor_plan_with_movement(cfg, seed, Movement::default())
}

/// Opens wall cells until the free cells form one component: each time, the obstacle cell
/// (lowest index) with free neighbours both inside and outside the component of the first free
/// cell. False if no such cell is left (walls are one cell thick, so this does not happen).
fn connect(grid: &mut OccGrid, movement: Movement) -> bool {
    loop {
        let Some(first) = grid.cells().iter().position(|&c| c == Occupancy::Free) else {
            return true;
        };
        let reach = reachable_from_with(grid, grid.pos(first), movement);
        let free = grid.count(Occupancy::Free);
        if reach.iter().filter(|&&r| r).count() == free {
            return true;
        }
        let near = |p: Pos, inside: bool| {
            crate::RING8.iter().any(|&(dr, dc)| {
                let q = Pos::new(p.row + dr, p.col + dc);
                grid.in_bounds(q)
                    && grid.get(q) == Occupancy::Free
                    && reach[grid.index(q)] == inside
                    && (dr == 0 || dc == 0)
            })
        };
        let opening = (0..grid.len())
            .map(|i| grid.pos(i))
            .find(|&p| grid.get(p) == Occupancy::Obstacle && near(p, true) && near(p, false));
        match opening {
            Some(p) => grid.set(p, Occupancy::Free),
            None => return false,
        }
    }
}

/// `seed`'s own draw of a floor plan's look (the generator's knobs vary per map): door and
/// corridor widths, corridor probability and clutter, for a `height × width` grid.
pub fn varied(height: usize, width: usize, seed: u64) -> FloorPlanConfig {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
    let base = FloorPlanConfig::for_size(height, width);
    FloorPlanConfig {
        min_room: rng.random_range(4..=7usize),
        door_width: rng.random_range(1..=2usize),
        corridor_width: rng.random_range(2..=3usize),
        corridor_prob: rng.random_range(0.2..0.5),
        clutter: rng.random_range(0.0..0.06),
        ..base
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plans_are_connected_keep_their_cells_free_and_repeat() {
        for (h, w) in [(20, 20), (30, 45), (60, 60)] {
            for seed in 0..20 {
                let cfg = varied(h, w, seed);
                let g = floor_plan(&cfg, seed).unwrap();
                assert!(crate::generate::is_connected(&g), "{h}×{w} seed {seed}");
                assert!(cfg.keep_free.iter().all(|&p| g.get(p) == Occupancy::Free));
                let d = g.obstacle_density();
                assert!(
                    (0.03..0.45).contains(&d),
                    "{h}×{w} seed {seed}: density {d}"
                );
                assert_eq!(g, floor_plan(&cfg, seed).unwrap());
            }
        }
    }

    #[test]
    fn rooms_have_walls_with_doors() {
        // No clutter: every obstacle belongs to a wall; a 40 × 40 plan has several rooms, so
        // some full rows or columns of a room are walls broken only by doors.
        let cfg = FloorPlanConfig {
            clutter: 0.0,
            corridor_prob: 0.0,
            ..FloorPlanConfig::for_size(40, 40)
        };
        let g = floor_plan(&cfg, 3).unwrap();
        let walls = g.count(Occupancy::Obstacle);
        assert!(walls >= 40, "{walls} wall cells");
        // Lines (rows or columns, `cell(line, k)` the k-th cell of one) with 8+ wall cells.
        let walled = |cell: fn(i32, i32) -> Pos| {
            (0..40)
                .filter(|&l| {
                    (0..40)
                        .filter(|&k| g.get(cell(l, k)) == Occupancy::Obstacle)
                        .count()
                        >= 8
                })
                .count()
        };
        let row_walls = walled(Pos::new);
        let col_walls = walled(|c, r| Pos::new(r, c));
        assert!(row_walls + col_walls >= 2, "{row_walls} + {col_walls}");
        assert!(crate::generate::is_connected(&g));
    }

    #[test]
    fn bad_fields_are_named() {
        let bad = [
            (
                FloorPlanConfig {
                    door_width: 9,
                    ..FloorPlanConfig::default()
                },
                "`door_width`",
            ),
            (
                FloorPlanConfig {
                    height: 3,
                    ..FloorPlanConfig::default()
                },
                "`height`",
            ),
        ];
        for (cfg, field) in bad {
            let e = floor_plan(&cfg, 1).unwrap_err();
            assert!(e.to_string().contains(field), "{e}");
        }
    }
}
