//! Seeded random map generator for training and tests, plus the free-space connectivity
//! helpers the simulator reuses.
//!
//! The generated maps mimic the paper's evaluation maps (see [`crate::paper`]): thin,
//! irregular obstacles made of straight and diagonal wall strokes (often branching off
//! each other, sometimes bending by 45°) and a few small ragged blobs, with all free space in
//! one connected component.
//!
//! # Movement and connectivity
//!
//! Robots move to any of the 8 neighbouring cells. By default ([`Movement::CornerCutting`],
//! the rule of the paper's evaluation code) any free neighbour can be entered, so
//! connectivity is plain 8-connectivity. Under [`Movement::NoCornerCutting`] a diagonal step
//! also needs both orthogonal cells free, so the cells reachable from a start are exactly its
//! 4-connected free component. The functions without a suffix use the default rule; the
//! `_with` / `_with_movement` variants take it as a parameter. Unknown cells are not
//! traversable.
//!
//! Note: the paper's 10 maps are each one 8-connected component, but under
//! [`Movement::NoCornerCutting`] most of them fall apart into several components (their thin
//! diagonal walls close off pockets), e.g. `test_9`'s four corners lie in four different ones.

use crate::paper::Corner;
use crate::{MapError, Movement, OccGrid, Occupancy, Pos};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// The obstacle-fraction range of the "wide" generated maps (`generate-wide:SEED`, the learned
/// policy's training, validation and held-out sets): the paper's training maps are 40–60 %
/// obstacles, its evaluation maps 18–36 %, real buildings span both.
pub const WIDE_DENSITY: (f64, f64) = (0.15, 0.60);

/// `team` start cells around a free cell of `map` drawn with `seed`: the free cells nearest to it
/// by moves (breadth-first under `movement`), or `None` if fewer than `team` are connected to it.
pub fn random_starts(
    map: &OccGrid,
    team: usize,
    movement: Movement,
    seed: u64,
) -> Option<Vec<Pos>> {
    let free: Vec<usize> = (0..map.len())
        .filter(|&i| map.cells()[i] == Occupancy::Free)
        .collect();
    if free.len() < team || free.is_empty() {
        return None;
    }
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let anchor = map.pos(free[rng.random_range(0..free.len())]);
    starts_from(map, anchor, team, movement)
}

/// `team` start cells around `near`: breadth-first (under `movement`) from the free cell
/// nearest to `near` (Euclidean; ties to the lower row-major index), or `None` if fewer than
/// `team` free cells are connected to it.
pub fn starts_near(map: &OccGrid, near: Pos, team: usize, movement: Movement) -> Option<Vec<Pos>> {
    let anchor = (0..map.len())
        .filter(|&i| map.cells()[i] == Occupancy::Free)
        .map(|i| map.pos(i))
        .min_by(|a, b| a.euclid(near).total_cmp(&b.euclid(near)))?;
    starts_from(map, anchor, team, movement)
}

/// The first `team` cells of a breadth-first search from the free cell `anchor`.
fn starts_from(map: &OccGrid, anchor: Pos, team: usize, movement: Movement) -> Option<Vec<Pos>> {
    if team == 0 {
        return Some(Vec::new());
    }
    let mut seen = vec![false; map.len()];
    let mut queue = VecDeque::from([anchor]);
    seen[map.index(anchor)] = true;
    let mut starts = Vec::with_capacity(team);
    while let Some(p) = queue.pop_front() {
        starts.push(p);
        if starts.len() == team {
            return Some(starts);
        }
        for (dr, dc) in [
            (-1, 0),
            (0, 1),
            (1, 0),
            (0, -1),
            (-1, -1),
            (-1, 1),
            (1, 1),
            (1, -1),
        ] {
            let q = Pos::new(p.row + dr, p.col + dc);
            if map.in_bounds(q) && !seen[map.index(q)] && map.can_step_with(p, q, movement) {
                seen[map.index(q)] = true;
                queue.push_back(q);
            }
        }
    }
    None
}

/// Parameters of [`generate`].
///
/// With serde, missing fields take their [`Default`] values; note that the default
/// `keep_free` is the 12 corner start cells *of a 20×20 grid*, so a configuration that changes
/// `height`/`width` should also list `keep_free` (or be built with [`GeneratorConfig::for_size`]),
/// otherwise [`GeneratorConfig::validate`] reports the out-of-bounds cells.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GeneratorConfig {
    /// Rows (default 20, at least 3).
    pub height: usize,
    /// Columns (default 20, at least 3).
    pub width: usize,
    /// Lower bound of the target obstacle density (default 0.15).
    pub density_min: f64,
    /// Upper bound of the target obstacle density (default 0.40, below 0.9).
    pub density_max: f64,
    /// Cells that must stay free, e.g. the robots' start cells (default: the three start cells
    /// of each of the four corners, [`Corner::start_cells`], of a 20×20 grid).
    pub keep_free: Vec<Pos>,
}

impl Default for GeneratorConfig {
    fn default() -> Self {
        GeneratorConfig::for_size(20, 20)
    }
}

impl GeneratorConfig {
    /// The default densities for a `height × width` grid, keeping the 12 corner start cells
    /// of that size free.
    pub fn for_size(height: usize, width: usize) -> Self {
        GeneratorConfig {
            height,
            width,
            density_min: 0.15,
            density_max: 0.40,
            keep_free: Corner::all_start_cells(height, width),
        }
    }

    /// Checks the configuration: `height, width >= 3`, `0 <= density_min <= density_max < 0.9`,
    /// every `keep_free` cell inside the grid. Errors are [`MapError::Invalid`] naming the field.
    pub fn validate(&self) -> Result<(), MapError> {
        let bad = |field: &str, msg: String| invalid_field("generator config", field, msg);
        if self.height < 3 {
            return bad("height", format!("must be at least 3, got {}", self.height));
        }
        if self.width < 3 {
            return bad("width", format!("must be at least 3, got {}", self.width));
        }
        if self
            .height
            .checked_mul(self.width)
            .is_none_or(|n| n > i32::MAX as usize)
        {
            return bad(
                "height",
                format!("{}×{} cells is too large", self.height, self.width),
            );
        }
        if !(self.density_min >= 0.0 && self.density_min < 0.9) {
            return bad(
                "density_min",
                format!("must lie in [0, 0.9), got {}", self.density_min),
            );
        }
        if self.density_max.is_nan() || self.density_max >= 0.9 {
            return bad(
                "density_max",
                format!("must be below 0.9, got {}", self.density_max),
            );
        }
        if self.density_min > self.density_max {
            return bad(
                "density_min",
                format!(
                    "must not exceed density_max ({}), got {}",
                    self.density_max, self.density_min
                ),
            );
        }
        if let Some(p) = cell_outside(&self.keep_free, self.height, self.width) {
            return bad(
                "keep_free",
                format!(
                    "cell {p} is outside the {}×{} grid (when changing height/width, list keep_free too \
                     or use GeneratorConfig::for_size)",
                    self.height, self.width
                ),
            );
        }
        Ok(())
    }
}

/// A configuration error naming the field: `what: field `field`: msg`.
pub(crate) fn invalid_field(what: &str, field: &str, msg: String) -> Result<(), MapError> {
    Err(MapError::Invalid(format!("{what}: field `{field}`: {msg}")))
}

/// The first of `cells` outside a `height × width` grid, if any.
pub(crate) fn cell_outside(cells: &[Pos], height: usize, width: usize) -> Option<&Pos> {
    let probe = OccGrid::new(height, width, Occupancy::Free);
    cells.iter().find(|p| !probe.in_bounds(**p))
}

/// The 8 unit steps, orthogonal first.
const DIRS: [(i32, i32); 8] = [
    (-1, 0),
    (0, 1),
    (1, 0),
    (0, -1),
    (-1, 1),
    (1, 1),
    (1, -1),
    (-1, -1),
];

/// Consecutive rejected additions after which shapes shrink to one or two cells.
const SHRINK_AFTER: usize = 30;
/// Probability of keeping a shape that touches an existing obstacle (8-neighbourhood).
const TOUCH_ACCEPT: f64 = 0.35;
/// Consecutive rejected additions after which touching shapes are always considered.
const TOUCH_RELAX_AFTER: usize = 20;
/// Consecutive rejected additions after which the generator gives up.
const GIVE_UP_AFTER: usize = 150;

/// Generates a random map from `cfg` and `seed` (same inputs ⇒ identical map).
///
/// A target density is drawn uniformly from `[density_min, density_max]`; random wall
/// strokes (length 2–6 in one of 8 directions, thickness 1, sometimes bending by 45° or
/// branching off an existing obstacle) and ragged 2×2 to 3×3 blobs are added until the target
/// is reached. An addition is rejected when it would cover a `keep_free` cell or split the free
/// space (see the [module docs](self) for the movement rule), so the result's free cells form
/// one connected component containing every `keep_free` cell. The last addition is truncated
/// so the density never overshoots the target (the target is rounded to whole cells, so the
/// density is at most `density_max + 0.5 / cells`). After a bounded number of consecutive
/// rejections the generator stops with the densest map reached, which can then fall short of
/// the target (rarely, for dense targets on small grids). Each addition's connectivity check
/// searches outward from the free cells around the new ones only until they are known to be
/// joined (or one part is found closed off), so it costs about the area of the detour or of the
/// smaller part rather than of the whole grid.
///
/// The grid has 1 m cells and a zero origin. Errors come from [`GeneratorConfig::validate`].
pub fn generate(cfg: &GeneratorConfig, seed: u64) -> Result<OccGrid, MapError> {
    generate_with_movement(cfg, seed, Movement::default())
}

/// [`generate`] with free-space connectivity judged under `movement` instead of the default
/// rule. With [`Movement::CornerCutting`] thin diagonal walls may close off pockets, as in the
/// paper's maps.
pub fn generate_with_movement(
    cfg: &GeneratorConfig,
    seed: u64,
    movement: Movement,
) -> Result<OccGrid, MapError> {
    let mut cut = CutCheck::default();
    generate_checked(cfg, seed, |grid, seen, _placed| {
        cut.still_connected(grid, seen, movement)
    })
}

/// The generator's loop, with the connectivity check of a tentative addition left to
/// `still_connected(grid, seen, placed)`: `grid` already holds the new cells `seen` as
/// obstacles, `placed` counts the obstacles accepted before them. [`generate_with_movement`]
/// checks locally; the tests pass a full breadth-first count to show the maps are the same.
fn generate_checked(
    cfg: &GeneratorConfig,
    seed: u64,
    mut still_connected: impl FnMut(&OccGrid, &[Pos], usize) -> bool,
) -> Result<OccGrid, MapError> {
    cfg.validate()?;
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let (h, w) = (cfg.height, cfg.width);
    let n = h * w;
    let density = if cfg.density_min < cfg.density_max {
        rng.random_range(cfg.density_min..=cfg.density_max)
    } else {
        cfg.density_min
    };
    let target = ((density * n as f64).round() as usize).min(n);

    let mut grid = OccGrid::new(h, w, Occupancy::Free);
    let mut protected = vec![false; n];
    for p in &cfg.keep_free {
        protected[grid.index(*p)] = true;
    }
    let mut obstacles: Vec<Pos> = Vec::with_capacity(target);
    let mut shape = Vec::with_capacity(16);
    let mut seen = Vec::with_capacity(16);
    let mut failures = 0;

    while obstacles.len() < target && failures < GIVE_UP_AFTER {
        random_shape(
            &mut rng,
            &grid,
            &obstacles,
            failures >= SHRINK_AFTER,
            &mut shape,
        );
        // Keep the new cells, in shape order, up to the target.
        let remaining = target - obstacles.len();
        seen.clear();
        for &p in &shape {
            if grid.is_free(p) && !seen.contains(&p) && seen.len() < remaining {
                seen.push(p);
            }
        }
        // Shapes touching existing walls are mostly turned down (while additions succeed), so
        // obstacles stay thin and scattered instead of growing into clumps.
        let touches = || {
            seen.iter().any(|p| {
                DIRS.iter().any(|(dr, dc)| {
                    grid.get(Pos::new(p.row + dr, p.col + dc)) == Occupancy::Obstacle
                        && grid.in_bounds(Pos::new(p.row + dr, p.col + dc))
                })
            })
        };
        let accepted = !seen.is_empty()
            && !seen.iter().any(|&p| protected[grid.index(p)])
            && (failures >= TOUCH_RELAX_AFTER || !touches() || rng.random_bool(TOUCH_ACCEPT))
            && {
                for &p in &seen {
                    grid.set(p, Occupancy::Obstacle);
                }
                // The free space was one component before this addition (it starts whole and
                // every accepted addition keeps it so), so only the new cells' surroundings
                // need checking rather than the whole grid.
                let ok = still_connected(&grid, &seen, obstacles.len());
                if !ok {
                    for &p in &seen {
                        grid.set(p, Occupancy::Free);
                    }
                }
                ok
            };
        if accepted {
            obstacles.extend_from_slice(&seen);
            failures = 0;
        } else {
            failures += 1;
        }
    }
    Ok(grid)
}

/// Fills `out` with the cells of one random shape, in drawing order, clipped to the grid.
fn random_shape(
    rng: &mut Pcg64Mcg,
    grid: &OccGrid,
    obstacles: &[Pos],
    small: bool,
    out: &mut Vec<Pos>,
) {
    out.clear();
    let (h, w) = (grid.height() as i32, grid.width() as i32);
    // Start next to an existing obstacle (branching walls) or anywhere.
    let start = if !obstacles.is_empty() && rng.random_bool(0.35) {
        let base = obstacles[rng.random_range(0..obstacles.len())];
        let (dr, dc) = DIRS[rng.random_range(0..8)];
        Pos::new(base.row + dr, base.col + dc)
    } else {
        Pos::new(rng.random_range(0..h), rng.random_range(0..w))
    };
    let kind = rng.random_range(0..100);
    if small || kind < 85 {
        // A stroke: 45 % diagonal, 40 % straight (of all shapes).
        let diagonal = if small {
            rng.random_bool(0.5)
        } else {
            kind < 45
        };
        let mut dir = (if diagonal { 1 } else { 0 }) + 2 * rng.random_range(0..4usize);
        let len = if small {
            rng.random_range(1..=2)
        } else {
            rng.random_range(2..=6)
        };
        let bend_at = if !small && rng.random_bool(0.25) {
            rng.random_range(1..len)
        } else {
            len
        };
        let mut p = start;
        for k in 0..len {
            if k == bend_at {
                dir = if rng.random_bool(0.5) {
                    (dir + 1) % 8
                } else {
                    (dir + 7) % 8
                };
            }
            if !grid.in_bounds(p) {
                break;
            }
            out.push(p);
            let (dr, dc) = crate::RING8[dir];
            p = Pos::new(p.row + dr, p.col + dc);
        }
    } else {
        // A ragged blob of 2×2 to 3×3: corners often missing, the middle always present.
        let bh = rng.random_range(2..=3);
        let bw = rng.random_range(2..=3);
        for r in 0..bh {
            for c in 0..bw {
                let edge_r = r == 0 || r == bh - 1;
                let edge_c = c == 0 || c == bw - 1;
                let keep = match (edge_r, edge_c) {
                    (true, true) => rng.random_bool(0.45),
                    (true, false) | (false, true) => rng.random_bool(0.85),
                    (false, false) => true,
                };
                let p = Pos::new(start.row + r, start.col + c);
                if keep && grid.in_bounds(p) {
                    out.push(p);
                }
            }
        }
    }
}

/// Decides whether blocking a few cells split a free space that was one connected component,
/// without searching the whole grid.
///
/// Hand-written for the generator: every part the free space could fall into must contain a
/// free cell bordering the blocked ones (a path from any free cell to a blocked one enters it
/// from such a border cell), so the free space is still one component exactly when all the
/// border cells are still connected to one another. One search per border cell grows in turn,
/// one cell at a time; searches that meet are merged (union-find). The answer is yes once a
/// single merged search is left and no once some merged search runs out of cells (it has
/// enclosed a part without the others). Either way the work is about the size of the detour
/// around the blocked cells, or of the smallest enclosed part, times the few searches.
#[derive(Default)]
struct CutCheck {
    /// Per cell (row-major): the label of the search that reached it. Labels only grow, so
    /// those below the current search's first label are stale and the array never needs
    /// clearing.
    label: Vec<u32>,
    /// The first label not yet handed out.
    next: u32,
    /// The free cells bordering the blocked ones; search `g` starts from `border[g]`.
    border: Vec<Pos>,
    /// Cells reached by search `g` and not yet expanded.
    queues: Vec<VecDeque<Pos>>,
    /// Union-find forest over the searches.
    parent: Vec<usize>,
    /// Per root search: cells of its merged search not yet expanded.
    pending: Vec<usize>,
}

impl CutCheck {
    /// Whether the free cells of `grid` are one component (under `movement`, see the module
    /// docs), given that they were before the cells `blocked` became obstacles.
    fn still_connected(&mut self, grid: &OccGrid, blocked: &[Pos], movement: Movement) -> bool {
        // Without corner cutting, reachability is exactly 4-connectivity (see module docs).
        let dirs = match movement {
            Movement::NoCornerCutting => &DIRS[..4],
            Movement::CornerCutting => &DIRS[..],
        };
        self.border.clear();
        for p in blocked {
            for (dr, dc) in dirs {
                let q = Pos::new(p.row + dr, p.col + dc);
                if grid.is_free(q) && !self.border.contains(&q) {
                    self.border.push(q);
                }
            }
        }
        // No border cell: nothing is left free. One: everything left is connected to it.
        let k = self.border.len();
        if k <= 1 {
            return true;
        }

        if self.label.len() != grid.len() {
            self.label = vec![0; grid.len()];
            self.next = 1;
        }
        if self.next.checked_add(k as u32).is_none() {
            self.label.fill(0);
            self.next = 1;
        }
        let base = self.next;
        self.next += k as u32;
        self.parent.clear();
        self.parent.extend(0..k);
        self.pending.clear();
        self.pending.resize(k, 1);
        if self.queues.len() < k {
            self.queues.resize_with(k, VecDeque::new);
        }
        for (g, &p) in self.border.iter().enumerate() {
            self.label[grid.index(p)] = base + g as u32;
            self.queues[g].clear();
            self.queues[g].push_back(p);
        }

        let mut searches = k;
        // Border cells next to each other are connected without searching.
        for a in 0..k {
            for b in a + 1..k {
                let (pa, pb) = (self.border[a], self.border[b]);
                let (dr, dc) = ((pa.row - pb.row).abs(), (pa.col - pb.col).abs());
                let adjacent = match movement {
                    Movement::NoCornerCutting => dr + dc == 1,
                    Movement::CornerCutting => dr.max(dc) == 1,
                };
                if adjacent && self.union(a, b) {
                    searches -= 1;
                }
            }
        }
        if searches == 1 {
            return true;
        }

        loop {
            for g in 0..k {
                let Some(p) = self.queues[g].pop_front() else {
                    continue;
                };
                let root = self.find(g);
                self.pending[root] -= 1;
                for (dr, dc) in dirs {
                    let q = Pos::new(p.row + dr, p.col + dc);
                    if !grid.is_free(q) {
                        continue;
                    }
                    let i = grid.index(q);
                    let l = self.label[i];
                    if l < base {
                        self.label[i] = base + g as u32;
                        self.queues[g].push_back(q);
                        let root = self.find(g);
                        self.pending[root] += 1;
                    } else if self.union(g, (l - base) as usize) {
                        searches -= 1;
                        if searches == 1 {
                            return true;
                        }
                    }
                }
                let root = self.find(g);
                if self.pending[root] == 0 {
                    return false;
                }
            }
        }
    }

    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }

    /// Merges the searches of `a` and `b`; false if they were already one.
    fn union(&mut self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        self.parent[rb] = ra;
        self.pending[ra] += self.pending[rb];
        true
    }
}

/// Reusable breadth-first search buffers.
#[derive(Default)]
struct Bfs {
    seen: Vec<bool>,
    queue: VecDeque<Pos>,
}

impl Bfs {
    /// Marks (in `self.seen`) the free cells reachable from `start`; returns how many.
    fn reach_count(&mut self, grid: &OccGrid, start: Pos, movement: Movement) -> usize {
        // Without corner cutting, reachability is exactly 4-connectivity (see module docs).
        let dirs = match movement {
            Movement::NoCornerCutting => &DIRS[..4],
            Movement::CornerCutting => &DIRS[..],
        };
        self.seen.clear();
        self.seen.resize(grid.len(), false);
        self.queue.clear();
        if !grid.is_free(start) {
            return 0;
        }
        self.seen[grid.index(start)] = true;
        self.queue.push_back(start);
        let mut count = 0;
        while let Some(p) = self.queue.pop_front() {
            count += 1;
            for (dr, dc) in dirs {
                let q = Pos::new(p.row + dr, p.col + dc);
                if grid.is_free(q) {
                    let i = grid.index(q);
                    if !self.seen[i] {
                        self.seen[i] = true;
                        self.queue.push_back(q);
                    }
                }
            }
        }
        count
    }
}

/// Which cells a robot starting at `start` can reach (a flat mask in the grid's row-major
/// order), moving by king steps under the default [`Movement`] (see the module docs).
/// Only free cells are traversable; if `start` is not a free cell the mask is all `false`.
pub fn reachable_from(grid: &OccGrid, start: Pos) -> Vec<bool> {
    reachable_from_with(grid, start, Movement::default())
}

/// [`reachable_from`] under the given movement rule.
pub fn reachable_from_with(grid: &OccGrid, start: Pos, movement: Movement) -> Vec<bool> {
    let mut bfs = Bfs::default();
    bfs.reach_count(grid, start, movement);
    bfs.seen
}

/// Whether all free cells of `grid` form one connected component under the default movement
/// rule (true for a grid without free cells).
pub fn is_connected(grid: &OccGrid) -> bool {
    is_connected_with(grid, Movement::default())
}

/// [`is_connected`] under the given movement rule.
pub fn is_connected_with(grid: &OccGrid, movement: Movement) -> bool {
    match grid.cells().iter().position(|&c| c == Occupancy::Free) {
        None => true,
        Some(i) => {
            Bfs::default().reach_count(grid, grid.pos(i), movement) == grid.count(Occupancy::Free)
        }
    }
}

#[cfg(test)]
mod tests;
