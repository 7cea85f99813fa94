//! explore_lite's frontier search (`m-explore-ros2`, `frontier_search.cpp`), so that madenet's
//! `explore-lite` policy and its exploration node choose as explore_lite does.
//!
//! On a costmap (nav2's cell values: [`FREE_SPACE`] 0, inflated costs 1–253, [`LETHAL`] 254,
//! [`NO_INFORMATION`] 255; cell (mx, my) at `origin + (m + ½)·resolution`, y up), from the
//! robot's position:
//! 1. a breadth-first search over the 4-neighbourhood (or the 8-neighbourhood,
//!    [`Connectivity`]) from the nearest free cell, entering a
//!    neighbour whose value is not above the current cell's (a "descending" search, so a robot
//!    standing on an inflated cell still gets out);
//! 2. an unknown cell next to (same neighbourhood) a free one that the search meets is a new
//!    frontier, grown over the 8-neighbourhood through such cells;
//! 3. a frontier of `size · resolution < min_frontier_size` metres is dropped; the others are
//!    sorted by cost `potential_scale · min_distance · resolution − gain_scale · size ·
//!    resolution` (lower first; ties keep the search's order).
//!
//! Faithful to explore_lite, quirks included, because its users' results come from them: the
//! distance term is metres × resolution; a frontier's first cell counts in `size` but not in
//! its centroid's sum, nor in `points` or `min_distance` (so the centroid of a short frontier
//! is pulled toward the map origin); distances are from the centre of the robot's cell.
//! Neighbours are visited in explore_lite's order (−x, +x, −y, +y, then the diagonals).

use std::collections::VecDeque;

/// nav2's free cell.
pub const FREE_SPACE: u8 = 0;
/// nav2's lethal obstacle.
pub const LETHAL: u8 = 254;
/// nav2's unknown cell.
pub const NO_INFORMATION: u8 = 255;

/// An `OccupancyGrid` value as explore_lite's costmap client reads it: −1 unknown (255), 0 free,
/// 100 lethal (254), 99 inscribed (253), 1–98 scaled linearly to 1–251; anything else read
/// through the same table as its byte (explore_lite's `cost_translation_table`).
pub fn occupancy_to_cost(v: i8) -> u8 {
    match v as u8 {
        0 => FREE_SPACE,
        99 => 253,
        100 => LETHAL,
        255 => NO_INFORMATION,
        // explore_lite's `1 + (251 · (i − 1)) / 97` in unsigned char arithmetic.
        i => (1 + (251 * (i as usize).wrapping_sub(1)) / 97) as u8,
    }
}

/// A costmap to search: row-major from the origin's row, `cost[my · width + mx]`.
#[derive(Clone, Copy, Debug)]
pub struct CostGrid<'a> {
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// Metres per cell.
    pub resolution: f64,
    /// The corner of cell (0, 0), metres.
    pub origin: (f64, f64),
    /// The cells' values.
    pub cost: &'a [u8],
    /// How the search moves and what touches a free cell.
    pub connectivity: Connectivity,
}

/// The neighbourhood of the search through free cells and of a frontier cell's free
/// neighbour. A frontier itself grows over the 8-neighbourhood either way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Connectivity {
    /// explore_lite's: the 4-neighbourhood (on a fine costmap, walls are thick enough).
    #[default]
    Four,
    /// The 8-neighbourhood: for coarse grids whose robots step diagonally between two
    /// obstacles (madenet's `Movement::CornerCutting`), where a diagonal line of obstacles is
    /// no wall.
    Eight,
}

impl CostGrid<'_> {
    fn world(&self, idx: usize) -> (f64, f64) {
        let (mx, my) = (idx % self.width, idx / self.width);
        (
            self.origin.0 + (mx as f64 + 0.5) * self.resolution,
            self.origin.1 + (my as f64 + 0.5) * self.resolution,
        )
    }

    fn cell_at(&self, (x, y): (f64, f64)) -> Option<usize> {
        let mx = ((x - self.origin.0) / self.resolution).floor();
        let my = ((y - self.origin.1) / self.resolution).floor();
        (mx >= 0.0 && my >= 0.0 && (mx as usize) < self.width && (my as usize) < self.height)
            .then(|| my as usize * self.width + mx as usize)
    }

    /// The search's neighbourhood ([`Connectivity`]).
    fn nhood(&self, idx: usize, out: &mut Vec<usize>) {
        match self.connectivity {
            Connectivity::Four => self.nhood4(idx, out),
            Connectivity::Eight => self.nhood8(idx, out),
        }
    }

    /// explore_lite's `nhood4`: −x, +x, −y, +y within the grid.
    fn nhood4(&self, idx: usize, out: &mut Vec<usize>) {
        let w = self.width;
        out.clear();
        if !idx.is_multiple_of(w) {
            out.push(idx - 1);
        }
        if idx % w < w - 1 {
            out.push(idx + 1);
        }
        if idx >= w {
            out.push(idx - w);
        }
        if idx < w * (self.height - 1) {
            out.push(idx + w);
        }
    }

    /// explore_lite's `nhood8`: `nhood4`, then (−x, −y), (−x, +y), (+x, −y), (+x, +y).
    fn nhood8(&self, idx: usize, out: &mut Vec<usize>) {
        self.nhood4(idx, out);
        let (w, last_row) = (self.width, self.width * (self.height - 1));
        let (left, right) = (!idx.is_multiple_of(w), idx % w < w - 1);
        let (down, up) = (idx >= w, idx < last_row);
        if left && down {
            out.push(idx - 1 - w);
        }
        if left && up {
            out.push(idx - 1 + w);
        }
        if right && down {
            out.push(idx + 1 - w);
        }
        if right && up {
            out.push(idx + 1 + w);
        }
    }
}

/// explore_lite's weights ([module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontierParams {
    /// Weight of a frontier's distance (explore_lite's `potential_scale`).
    pub potential_scale: f64,
    /// Weight of its size (`gain_scale`).
    pub gain_scale: f64,
    /// Metres; shorter frontiers are dropped (`min_frontier_size`).
    pub min_frontier_size: f64,
}

/// One frontier ([module docs](self)); points in metres.
#[derive(Clone, Debug, PartialEq)]
pub struct Frontier {
    /// Cells, its first included.
    pub size: u32,
    /// Metres from the robot's cell to its nearest point.
    pub min_distance: f64,
    /// Its cost (lower is better).
    pub cost: f64,
    /// The cell that started it.
    pub initial: (f64, f64),
    /// Where explore_lite sends the robot.
    pub centroid: (f64, f64),
    /// Its point nearest the robot.
    pub middle: (f64, f64),
    /// Its cells but the first.
    pub points: Vec<(f64, f64)>,
}

/// explore_lite's `searchFrom`: the frontiers seen from `position` on `grid`, best first.
/// None when the position is off the grid (explore_lite logs an error and finds none).
pub fn search_from(grid: &CostGrid<'_>, position: (f64, f64), p: &FrontierParams) -> Vec<Frontier> {
    let n = grid.width * grid.height;
    assert_eq!(grid.cost.len(), n, "a cost grid of width × height cells");
    let Some(pos) = grid.cell_at(position) else {
        return Vec::new();
    };
    let map = grid.cost;
    let mut frontier_flag = vec![false; n];
    let mut visited = vec![false; n];
    let mut nbrs = Vec::with_capacity(8);
    let start = nearest_cell(grid, pos, FREE_SPACE).unwrap_or(pos);
    let mut bfs = VecDeque::from([start]);
    visited[start] = true;
    let mut out = Vec::new();
    while let Some(idx) = bfs.pop_front() {
        grid.nhood(idx, &mut nbrs);
        for &nbr in &nbrs {
            if map[nbr] <= map[idx] && !visited[nbr] {
                visited[nbr] = true;
                bfs.push_back(nbr);
            } else if is_new_frontier_cell(grid, nbr, &frontier_flag) {
                frontier_flag[nbr] = true;
                let f = build_frontier(grid, nbr, pos, &mut frontier_flag);
                if f.size as f64 * grid.resolution >= p.min_frontier_size {
                    out.push(f);
                }
            }
        }
    }
    for f in &mut out {
        f.cost = p.potential_scale * f.min_distance * grid.resolution
            - p.gain_scale * f.size as f64 * grid.resolution;
    }
    out.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    out
}

/// explore_lite's `nearestCell`: breadth-first over the 8-neighbourhood from `start` to the
/// first cell of value `value`.
fn nearest_cell(grid: &CostGrid<'_>, start: usize, value: u8) -> Option<usize> {
    let mut visited = vec![false; grid.cost.len()];
    let mut bfs = VecDeque::from([start]);
    visited[start] = true;
    let mut nbrs = Vec::with_capacity(8);
    while let Some(idx) = bfs.pop_front() {
        if grid.cost[idx] == value {
            return Some(idx);
        }
        grid.nhood8(idx, &mut nbrs);
        for &nbr in &nbrs {
            if !visited[nbr] {
                visited[nbr] = true;
                bfs.push_back(nbr);
            }
        }
    }
    None
}

/// Unknown, not yet in a frontier, and next to a free cell (in the search's neighbourhood).
fn is_new_frontier_cell(grid: &CostGrid<'_>, idx: usize, frontier_flag: &[bool]) -> bool {
    if grid.cost[idx] != NO_INFORMATION || frontier_flag[idx] {
        return false;
    }
    let mut nbrs = Vec::with_capacity(8);
    grid.nhood(idx, &mut nbrs);
    nbrs.iter().any(|&n| grid.cost[n] == FREE_SPACE)
}

/// explore_lite's `buildNewFrontier` from `initial`, distances from cell `reference`.
fn build_frontier(
    grid: &CostGrid<'_>,
    initial: usize,
    reference: usize,
    frontier_flag: &mut [bool],
) -> Frontier {
    let mut f = Frontier {
        size: 1,
        min_distance: f64::INFINITY,
        cost: 0.0,
        initial: grid.world(initial),
        centroid: (0.0, 0.0),
        middle: (0.0, 0.0),
        points: Vec::new(),
    };
    let (rx, ry) = grid.world(reference);
    let mut bfs = VecDeque::from([initial]);
    let mut nbrs = Vec::with_capacity(8);
    while let Some(idx) = bfs.pop_front() {
        grid.nhood8(idx, &mut nbrs);
        for &nbr in &nbrs {
            if is_new_frontier_cell(grid, nbr, frontier_flag) {
                frontier_flag[nbr] = true;
                let (wx, wy) = grid.world(nbr);
                f.points.push((wx, wy));
                f.size += 1;
                f.centroid.0 += wx;
                f.centroid.1 += wy;
                let d = (rx - wx).hypot(ry - wy);
                if d < f.min_distance {
                    f.min_distance = d;
                    f.middle = (wx, wy);
                }
                bfs.push_back(nbr);
            }
        }
    }
    f.centroid.0 /= f.size as f64;
    f.centroid.1 /= f.size as f64;
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid from rows written top (highest y) first: `.` free, `#` lethal, `?` unknown.
    fn grid(rows: &[&str]) -> (usize, usize, Vec<u8>) {
        let (h, w) = (rows.len(), rows[0].len());
        let mut cost = vec![0; w * h];
        for (k, row) in rows.iter().enumerate() {
            let my = h - 1 - k;
            for (mx, c) in row.chars().enumerate() {
                cost[my * w + mx] = match c {
                    '.' => FREE_SPACE,
                    '#' => LETHAL,
                    _ => NO_INFORMATION,
                };
            }
        }
        (w, h, cost)
    }

    /// `cost` as a 1 m grid at the origin, searched as explore_lite does (4-connected).
    fn on(cost: &[u8], w: usize, h: usize) -> CostGrid<'_> {
        CostGrid {
            width: w,
            height: h,
            resolution: 1.0,
            origin: (0.0, 0.0),
            cost,
            connectivity: Connectivity::Four,
        }
    }

    const P: FrontierParams = FrontierParams {
        potential_scale: 3.0,
        gain_scale: 1.0,
        min_frontier_size: 0.75,
    };

    #[test]
    fn a_wall_of_unknown_is_one_frontier_with_explore_lites_centroid() {
        // Free columns 0–2, unknown columns 3–4; robot in cell (0, 0).
        let (w, h, cost) = grid(&["...??", "...??", "...??"]);
        let g = on(&cost, w, h);
        let fs = search_from(&g, (0.5, 0.5), &P);
        assert_eq!(fs.len(), 1, "{fs:?}");
        let f = &fs[0];
        // The unknown cells next to a free one: column 3, rows 0–2.
        assert_eq!(f.size, 3);
        // The first cell met is (3, 0): its coordinates are not in the centroid's sum.
        assert_eq!(f.initial, (3.5, 0.5));
        assert_eq!(f.points, [(3.5, 1.5), (3.5, 2.5)]);
        assert_eq!(f.centroid, (7.0 / 3.0, 4.0 / 3.0));
        // Nearest point (of `points`): (3.5, 1.5), √(9 + 1) from the robot's cell centre.
        assert!((f.min_distance - 10f64.sqrt()).abs() < 1e-12);
        assert!((f.cost - (3.0 * 10f64.sqrt() - 3.0)).abs() < 1e-12);
    }

    #[test]
    fn walls_split_frontiers_and_short_ones_are_dropped() {
        // Two openings into unknown space: one cell wide at the top right (kept at 1 m, dropped
        // at 1.5 m), three wide at the bottom.
        let rows = ["####?#", "#....#", "#....#", "#....#", "#???##"];
        let (w, h, cost) = grid(&rows);
        let g = on(&cost, w, h);
        let all = search_from(&g, (1.5, 2.5), &P);
        assert_eq!(all.len(), 2, "{all:?}");
        let sizes: Vec<u32> = all.iter().map(|f| f.size).collect();
        assert!(sizes.contains(&1) && sizes.contains(&3), "{sizes:?}");
        // Sorted by cost.
        assert!(all[0].cost <= all[1].cost);
        let big = FrontierParams {
            min_frontier_size: 1.5,
            ..P
        };
        let kept = search_from(&g, (1.5, 2.5), &big);
        assert_eq!(kept.len(), 1);
        assert_eq!(kept[0].size, 3);
        // Off the grid: none.
        assert!(search_from(&g, (-3.0, 1.0), &P).is_empty());
    }

    #[test]
    fn a_diagonal_line_of_obstacles_walls_in_four_connected_searches_only() {
        // The robot's corner is closed by a diagonal line: 8-connected robots pass it.
        let rows = ["..#???", ".#.???", "#..???"];
        let (w, h, cost) = grid(&rows);
        let mut g = on(&cost, w, h);
        assert!(search_from(&g, (0.5, 2.5), &P).is_empty());
        g.connectivity = Connectivity::Eight;
        let fs = search_from(&g, (0.5, 2.5), &P);
        assert_eq!(fs.len(), 1, "{fs:?}");
        assert_eq!(fs[0].size, 3);
    }

    #[test]
    fn occupancy_values_translate_as_explore_lite_reads_them() {
        assert_eq!(occupancy_to_cost(-1), NO_INFORMATION);
        assert_eq!(occupancy_to_cost(0), FREE_SPACE);
        assert_eq!(occupancy_to_cost(100), LETHAL);
        assert_eq!(occupancy_to_cost(99), 253);
        assert_eq!(occupancy_to_cost(1), 1);
        assert_eq!(occupancy_to_cost(50), (1 + (251 * 49) / 97) as u8);
        assert_eq!(occupancy_to_cost(98), 252);
    }
}
