//! The paper's discretization rule (Sec. V.B.1).
//!
//! A fine occupancy image (one occupancy probability per pixel) is turned into robot-sized
//! cells: each output cell covers a `factor × factor` block of pixels and is an obstacle when
//! *more than* [`DiscretizeParams::obstacle_fraction`] of its pixels have an occupancy
//! probability *above* [`DiscretizeParams::occupied_prob`] ("a cell is considered occupied when
//! more than 25 % of its pixels have an occupancy probability > 65 %"). Every other cell is
//! free: the output of [`discretize`] never contains [`Occupancy::Unknown`].

use crate::{OccGrid, Occupancy};
use serde::{Deserialize, Serialize};

/// Parameters of the discretization rule. The defaults are the paper's values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DiscretizeParams {
    /// A pixel counts as occupied when its occupancy probability is strictly above this
    /// (default 0.65).
    pub occupied_prob: f64,
    /// A cell is an obstacle when strictly more than this fraction of its pixels are occupied
    /// (default 0.25).
    pub obstacle_fraction: f64,
}

impl Default for DiscretizeParams {
    fn default() -> Self {
        DiscretizeParams {
            occupied_prob: 0.65,
            obstacle_fraction: 0.25,
        }
    }
}

/// Which cell each pixel of a `height` × `width` image of `resolution` metres belongs to, at
/// cells of `cell_size` metres (a pixel belongs to the cell its centre falls in), and how many
/// pixels each cell has: the tables a map still being built is read through
/// ([`read_partial_cell`]), by the continuous world's robots and by a node reading a
/// published map.
#[derive(Clone, Debug, PartialEq)]
pub struct CellTables {
    /// The cell row of each pixel row.
    pub row_cell: Vec<u32>,
    /// The cell column of each pixel column.
    pub col_cell: Vec<u32>,
    /// Cells: rows and columns.
    pub rows: usize,
    /// See `rows`.
    pub cols: usize,
    /// Pixels per cell, row-major.
    pub pixels: Vec<u32>,
}

impl CellTables {
    /// The tables of an image of `height` × `width` pixels of `resolution` metres, read in
    /// cells of `cell_size` metres (at least a pixel).
    pub fn new(height: usize, width: usize, resolution: f64, cell_size: f64) -> Self {
        let cell_px = (cell_size / resolution).max(1.0);
        let cell_of = |k: usize| ((k as f64 + 0.5) / cell_px).floor() as u32;
        let row_cell: Vec<u32> = (0..height).map(cell_of).collect();
        let col_cell: Vec<u32> = (0..width).map(cell_of).collect();
        let rows = row_cell.last().map_or(0, |&c| c as usize + 1);
        let cols = col_cell.last().map_or(0, |&c| c as usize + 1);
        let mut pixels = vec![0u32; rows * cols];
        for &r in &row_cell {
            for &c in &col_cell {
                pixels[r as usize * cols + c as usize] += 1;
            }
        }
        CellTables {
            row_cell,
            col_cell,
            rows,
            cols,
            pixels,
        }
    }
}

/// A cell's next value when it was `now` and reads `read`: write-once, but for the upgrade to
/// an obstacle (a cell known free turns obstacle when more of it is seen occupied; never back).
pub fn write_once(now: Occupancy, read: Occupancy) -> Occupancy {
    match (now, read) {
        (_, Occupancy::Obstacle) => Occupancy::Obstacle,
        (Occupancy::Unknown, Occupancy::Free) => Occupancy::Free,
        _ => now,
    }
}

/// A cell of a map still being built, read from counts of its pixels by the paper's rule: an
/// obstacle when its `occupied` pixels are more than `obstacle_fraction` of its `observed`
/// ones, or of half its `pixels` while fewer are observed (a sensor sees an obstacle's surface,
/// never its inside: under the rule over all pixels a cell mostly covered by an obstacle would
/// stay unknown, a frontier, for ever; and a glimpse of a few pixels by a wall, some of them
/// occupied by range noise, is not enough to call it one); else free once `known_fraction` of
/// its pixels are observed; else unknown. A robot's own map in the continuous world and a real
/// robot's published grid are both read so.
pub fn read_partial_cell(
    pixels: u32,
    observed: u32,
    occupied: u32,
    obstacle_fraction: f64,
    known_fraction: f64,
) -> Occupancy {
    let (n, seen) = (f64::from(pixels), f64::from(observed));
    if f64::from(occupied) > obstacle_fraction * seen.max(0.5 * n) {
        Occupancy::Obstacle
    } else if pixels > 0 && seen >= known_fraction * n {
        Occupancy::Free
    } else {
        Occupancy::Unknown
    }
}

/// A built-in grid (the paper's maps and generated maps: cells of `grid.resolution` metres,
/// 1 m) at robot cell size `cell_size` metres: each cell is read as a pixel (obstacle: occupancy
/// probability 1; free and unknown: 0) and blocks are merged with [`discretize`], exactly as a
/// map file at that resolution would be. `cell_size` must be a whole multiple of the grid's
/// cells; the same grid comes back when they are equal.
/// Errors name `name` (e.g. `paper:3`) and the field `cell_size`.
pub fn coarsen(
    grid: &OccGrid,
    cell_size: f64,
    params: &DiscretizeParams,
    name: &str,
) -> Result<OccGrid, crate::MapError> {
    let ratio = cell_size / grid.resolution;
    let factor = ratio.round();
    if !(factor >= 1.0 && (ratio - factor).abs() <= 1e-6 && factor <= u32::MAX as f64) {
        return Err(crate::MapError::Field {
            path: name.into(),
            field: "cell_size".into(),
            message: format!(
                "built-in maps have cells of {} m; the robot cell size must be a whole multiple of that, got {cell_size} m",
                grid.resolution
            ),
        });
    }
    if factor == 1.0 {
        return Ok(grid.clone());
    }
    let probs: Vec<f64> = grid
        .cells()
        .iter()
        .map(|&c| if c == Occupancy::Obstacle { 1.0 } else { 0.0 })
        .collect();
    let mut out = discretize(&probs, grid.height(), grid.width(), factor as usize, params);
    out.resolution = cell_size;
    out.origin = grid.origin;
    Ok(out)
}

/// Discretizes a row-major image of per-pixel occupancy probabilities (`px_height` rows of
/// `px_width` pixels, row 0 at the top) into cells of `factor × factor` pixels.
///
/// The output has `ceil(px_height / factor)` rows and `ceil(px_width / factor)` columns; the
/// partial blocks at the right and bottom edges use the pixels they have (the fraction is taken
/// over the pixels actually present). A cell is [`Occupancy::Obstacle`] when strictly more than
/// `params.obstacle_fraction` of its pixels have probability strictly above
/// `params.occupied_prob`, otherwise [`Occupancy::Free`]. `NaN` probabilities count as not
/// occupied.
///
/// The returned grid has resolution 1.0 and a zero origin; callers that know the pixel size set
/// them (e.g. [`crate::io::load`] sets the resolution to `factor × pixel resolution`).
///
/// # Panics
///
/// Panics if `factor == 0` or `probs.len() != px_height * px_width` (programming errors, not
/// input errors: the loaders in [`crate::io`] check both before calling).
pub fn discretize(
    probs: &[f64],
    px_height: usize,
    px_width: usize,
    factor: usize,
    params: &DiscretizeParams,
) -> OccGrid {
    assert!(factor > 0, "discretize: factor must be at least 1");
    discretize_area(probs, px_height, px_width, factor as f64, params)
}

/// [`discretize`] for cells of any size `cell_px ≥ 1` pixels (a robot cell that is not a whole
/// number of pixels, e.g. 1 m cells on a 0.15 m/pixel map: `cell_px` = 6.67): each cell merges
/// the pixels whose centres fall in the area it covers, by the same rule. Cell `k` along an axis
/// covers `[k·cell_px, (k+1)·cell_px)` pixel units from the top-left corner; there are as many
/// cells as hold at least one pixel centre (`ceil(px / cell_px)` for a whole `cell_px`, so a
/// whole `cell_px` gives exactly [`discretize`]).
///
/// # Panics
///
/// Panics if `cell_px` is not a finite number ≥ 1 or `probs.len() != px_height * px_width`
/// (programming errors: the loaders check both).
pub fn discretize_area(
    probs: &[f64],
    px_height: usize,
    px_width: usize,
    cell_px: f64,
    params: &DiscretizeParams,
) -> OccGrid {
    assert!(
        cell_px.is_finite() && cell_px >= 1.0,
        "discretize: a cell must be at least one pixel"
    );
    assert_eq!(
        probs.len(),
        px_height * px_width,
        "discretize: probs.len() must be px_height * px_width"
    );
    // The cell of pixel k along an axis: the one its centre k + 0.5 falls in.
    let cell_of = |k: usize| ((k as f64 + 0.5) / cell_px).floor() as usize;
    let cells = |px: usize| if px == 0 { 0 } else { cell_of(px - 1) + 1 };
    let (height, width) = (cells(px_height), cells(px_width));
    let col_cell: Vec<usize> = (0..px_width).map(cell_of).collect();
    // Occupied-pixel and total-pixel counts per output cell.
    let mut occupied = vec![0usize; height * width];
    let mut total = vec![0usize; height * width];
    for (r, row) in probs.chunks(px_width.max(1)).enumerate().take(px_height) {
        let cell_row = cell_of(r) * width;
        for (c, &p) in row.iter().enumerate() {
            let i = cell_row + col_cell[c];
            total[i] += 1;
            if p > params.occupied_prob {
                occupied[i] += 1;
            }
        }
    }
    let cells = occupied
        .iter()
        .zip(&total)
        .map(|(&occ, &n)| {
            if occ as f64 > params.obstacle_fraction * n as f64 {
                Occupancy::Obstacle
            } else {
                Occupancy::Free
            }
        })
        .collect();
    OccGrid::from_cells(height, width, cells)
}

/// What a discretization kept of a fine map's obstacles ([`erasure`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Erasure {
    /// Obstacle pixels of the fine map.
    pub obstacle_pixels: usize,
    /// Of those, the ones whose cell came out free.
    pub erased_pixels: usize,
    /// Obstacle cells of the coarse map.
    pub obstacle_cells: usize,
    /// Free cells through which the coarse map opens a passage the fine map does not have
    /// ([`opened_passages`]).
    pub opened_cells: usize,
    /// The first of them (row-major), if any.
    pub first_opened: Option<crate::Pos>,
}

impl Erasure {
    /// The fraction of obstacle pixels in free cells (0 when there are none).
    pub fn erased_fraction(&self) -> f64 {
        if self.obstacle_pixels == 0 {
            0.0
        } else {
            self.erased_pixels as f64 / self.obstacle_pixels as f64
        }
    }

    /// A warning when the discretization erased most of the obstacles (more than half their
    /// pixels lie in free cells) or all of them, naming the setting that keeps walls; `None`
    /// when it kept them.
    ///
    /// Short of that, a warning when it opened passages through walls the fine map has
    /// ([`opened_passages`]), naming the first such cell and the same setting.
    pub fn warning(&self, name: &str, params: &DiscretizeParams) -> Option<String> {
        let most = self.erased_fraction() > 0.5;
        let all = self.obstacle_cells == 0 && self.obstacle_pixels > 0;
        if most || all {
            return Some(format!(
                "{name}: the discretization into cells left {:.0} % of the map's obstacle pixels in free cells ({} obstacle cells): walls thinner than {:.0} % of a cell vanish, and a robot on the cells plans through them; a lower `discretize.obstacle_fraction` (now {}) keeps them",
                100.0 * self.erased_fraction(),
                self.obstacle_cells,
                100.0 * params.obstacle_fraction,
                params.obstacle_fraction
            ));
        }
        let first = self.first_opened?;
        Some(format!(
            "{name}: the discretization into cells opens passages the map does not have at {} free cells (the first at row {}, column {}): a wall thinner than {:.0} % of a cell runs through or beside them, and a robot on the cells plans through it; a lower `discretize.obstacle_fraction` (now {}) keeps such walls",
            self.opened_cells,
            first.row,
            first.col,
            100.0 * params.obstacle_fraction,
            params.obstacle_fraction
        ))
    }
}

/// Compares a fine map (`fine`, e.g. a map file at its native resolution) with its
/// discretization `coarse` (the same area in cells of `coarse.resolution` metres, cells
/// holding the pixels whose centres they cover, as [`discretize_area`] merges them): how many
/// of the fine map's obstacle pixels ended up in free cells.
pub fn erasure(fine: &OccGrid, coarse: &OccGrid) -> Erasure {
    let cell_px = (coarse.resolution / fine.resolution).max(1.0);
    let cell_of = |k: usize| ((k as f64 + 0.5) / cell_px).floor() as i32;
    let opened = opened_passages(fine, coarse);
    let mut e = Erasure {
        obstacle_pixels: 0,
        erased_pixels: 0,
        obstacle_cells: coarse.count(Occupancy::Obstacle),
        opened_cells: opened.len(),
        first_opened: opened.first().copied(),
    };
    for r in 0..fine.height() {
        for c in 0..fine.width() {
            if fine.get(crate::Pos::new(r as i32, c as i32)) != Occupancy::Obstacle {
                continue;
            }
            e.obstacle_pixels += 1;
            if coarse.get(crate::Pos::new(cell_of(r), cell_of(c))) == Occupancy::Free {
                e.erased_pixels += 1;
            }
        }
    }
    e
}

/// The free cells of `coarse` (the discretization of `fine`, as in [`erasure`]) through which
/// it opens a passage that `fine` does not have, row-major. Pixels are passable unless they
/// are obstacles; parts of a cell are its passable pixels joined by passable paths inside the
/// 3 × 3 cells around it (a detour that stays near is no new passage), counted when they
/// hold at least a tenth of the cell's pixels (slivers and speckle are not places a robot
/// stands). A cell opens a passage when it holds two or more parts (a wall runs through it),
/// or when it shares no part with a free side neighbour (a wall runs between them).
pub fn opened_passages(fine: &OccGrid, coarse: &OccGrid) -> Vec<crate::Pos> {
    use crate::Pos;
    let cell_px = (coarse.resolution / fine.resolution).max(1.0);
    let cell_of = |k: usize| ((k as f64 + 0.5) / cell_px).floor() as usize;
    let (fh, fw) = (fine.height(), fine.width());
    let (ch, cw) = (coarse.height(), coarse.width());
    // The pixel range of each coarse row and column.
    let ranges = |px: usize, cells: usize| {
        let mut r = vec![(usize::MAX, 0usize); cells];
        for k in 0..px {
            let c = cell_of(k);
            if c < cells {
                r[c].0 = r[c].0.min(k);
                r[c].1 = r[c].1.max(k + 1);
            }
        }
        r
    };
    let (rows, cols) = (ranges(fh, ch), ranges(fw, cw));
    let free = |p: Pos| coarse.get(p) == Occupancy::Free;
    // Passable pixels, and obstacle pixels per cell: a cell whose 3 × 3 neighbourhood holds
    // none is one part shared with its neighbours (most cells of a map), skipped unsearched.
    let passable_px: Vec<bool> = fine
        .cells()
        .iter()
        .map(|&o| o != Occupancy::Obstacle)
        .collect();
    let mut obstacles_in = vec![0u32; ch * cw];
    for r in 0..fh {
        for c in 0..fw {
            let (cr, cc) = (cell_of(r), cell_of(c));
            if !passable_px[r * fw + c] && cr < ch && cc < cw {
                obstacles_in[cr * cw + cc] += 1;
            }
        }
    }
    let mut opened = Vec::new();
    // Component labels of one window (reused), and a stack for the flood fill.
    let mut label = Vec::new();
    let mut stack = Vec::new();
    for cr in 0..ch {
        for cc in 0..cw {
            let a = Pos::new(cr as i32, cc as i32);
            if !free(a) || rows[cr].0 >= rows[cr].1 || cols[cc].0 >= cols[cc].1 {
                continue;
            }
            let near = |lo: usize, n: usize| lo.saturating_sub(1)..(lo + 2).min(n);
            if near(cr, ch).all(|r| near(cc, cw).all(|c| obstacles_in[r * cw + c] == 0)) {
                continue;
            }
            let r0 = rows[cr.saturating_sub(1)].0.min(rows[cr].0);
            let r1 = rows[(cr + 1).min(ch - 1)].1.max(rows[cr].1);
            let c0 = cols[cc.saturating_sub(1)].0.min(cols[cc].0);
            let c1 = cols[(cc + 1).min(cw - 1)].1.max(cols[cc].1);
            let ww = c1 - c0;
            label.clear();
            label.resize((r1 - r0) * ww, u32::MAX);
            let passable = |r: usize, c: usize| passable_px[r * fw + c];
            let mut parts = 0u32;
            for r in r0..r1 {
                for c in c0..c1 {
                    if label[(r - r0) * ww + c - c0] != u32::MAX || !passable(r, c) {
                        continue;
                    }
                    label[(r - r0) * ww + c - c0] = parts;
                    stack.push((r, c));
                    while let Some((r, c)) = stack.pop() {
                        let next = [
                            (r.wrapping_sub(1), c),
                            (r + 1, c),
                            (r, c.wrapping_sub(1)),
                            (r, c + 1),
                        ];
                        for (nr, nc) in next {
                            if (r0..r1).contains(&nr) && (c0..c1).contains(&nc) {
                                let l = &mut label[(nr - r0) * ww + nc - c0];
                                if *l == u32::MAX && passable(nr, nc) {
                                    *l = parts;
                                    stack.push((nr, nc));
                                }
                            }
                        }
                    }
                    parts += 1;
                }
            }
            // The parts of a cell of the window: components holding a tenth of its pixels.
            let parts_of = |p: Pos| -> Vec<u32> {
                let (pr, pc) = (rows[p.row as usize], cols[p.col as usize]);
                if pr.0 >= pr.1 || pc.0 >= pc.1 {
                    return Vec::new();
                }
                let mut count = vec![0usize; parts as usize];
                for r in pr.0..pr.1 {
                    for c in pc.0..pc.1 {
                        let l = label[(r - r0) * ww + c - c0];
                        if l != u32::MAX {
                            count[l as usize] += 1;
                        }
                    }
                }
                let min = ((pr.1 - pr.0) * (pc.1 - pc.0)).div_ceil(10);
                (0..parts).filter(|&l| count[l as usize] >= min).collect()
            };
            let here = parts_of(a);
            let split = here.len() >= 2;
            // Each side pair once: the neighbours below and to the right.
            let walled = [Pos::new(a.row + 1, a.col), Pos::new(a.row, a.col + 1)]
                .into_iter()
                .filter(|b| (b.row as usize) < ch && (b.col as usize) < cw && free(*b))
                // A cell without pixels (a fine map smaller than the coarse one) tells nothing.
                .filter(|b| {
                    let (pr, pc) = (rows[b.row as usize], cols[b.col as usize]);
                    pr.0 < pr.1 && pc.0 < pc.1
                })
                .any(|b| !parts_of(b).iter().any(|l| here.contains(l)));
            if split || walled {
                opened.push(a);
            }
        }
    }
    opened
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Pos;
    use proptest::prelude::*;

    #[test]
    fn a_cell_of_a_fraction_of_pixels_merges_the_pixels_whose_centres_it_covers() {
        // 0.15 m pixels, 1 m cells: 6.67 pixels per cell. 20 pixels (3 m) make 3 cells holding
        // pixels 0–6, 7–12 and 13–19 (7, 6 and 7 pixel centres).
        let mut probs = vec![0.0; 20 * 20];
        let mut set = |r: usize, c: usize| probs[r * 20 + c] = 0.9;
        // Cell (0, 0): 2 of 49 pixels occupied (4 %): free. Cell (1, 1): 11 of 36 (31 %;
        // pixel column 12 is its last): obstacle. Cell (2, 2): 12 of 49 (24.5 %): free.
        // Cell (1, 2): 11 of 42 (26 %; pixel column 13 is its first): obstacle.
        set(0, 0);
        set(6, 6);
        (0..10).for_each(|k| set(7 + k % 6, 7 + k / 6));
        (0..12).for_each(|k| set(13 + k % 7, 13 + k / 7));
        (0..11).for_each(|k| set(7 + k % 6, 13 + k / 6));
        set(7, 12);
        let g = discretize_area(&probs, 20, 20, 1.0 / 0.15, &DiscretizeParams::default());
        assert_eq!((g.height(), g.width()), (3, 3));
        let at = |r, c| g.get(Pos::new(r, c));
        assert_eq!(at(0, 0), Occupancy::Free);
        assert_eq!(at(1, 1), Occupancy::Obstacle);
        assert_eq!(at(2, 2), Occupancy::Free);
        assert_eq!(at(1, 2), Occupancy::Obstacle);
    }

    proptest! {
        /// Every pixel lands in exactly one cell, every cell holds at least one pixel, and a
        /// whole number of pixels per cell gives the block rule's grid size.
        #[test]
        fn area_cells_partition_the_pixels(h in 1usize..40, w in 1usize..40, cell_px in 1.0f64..9.0) {
            let g = discretize_area(&vec![1.0; h * w], h, w, cell_px, &DiscretizeParams::default());
            // All pixels occupied: every cell that holds a pixel is an obstacle.
            prop_assert!(g.cells().iter().all(|&c| c == Occupancy::Obstacle));
            let cells = |px: usize| ((px as f64 - 0.5) / cell_px).floor() as usize + 1;
            prop_assert_eq!((g.height(), g.width()), (cells(h), cells(w)));
            let whole = cell_px.round().max(1.0) as usize;
            let g = discretize_area(&vec![0.0; h * w], h, w, whole as f64, &DiscretizeParams::default());
            prop_assert_eq!((g.height(), g.width()), (h.div_ceil(whole), w.div_ceil(whole)));
        }
    }

    /// A 4×4 block with the first `k` pixels (row-major) at probability 0.9, the rest 0.
    fn block(k: usize) -> Vec<f64> {
        (0..16).map(|i| if i < k { 0.9 } else { 0.0 }).collect()
    }

    #[test]
    fn thin_walls_erased_by_the_rule_are_measured_and_warned_about() {
        // 20 × 20 pixels of 0.1 m, a one-pixel wall down column 5: 10 % of each 1 m cell.
        let mut probs = vec![0.0; 400];
        for r in 0..20 {
            probs[r * 20 + 5] = 1.0;
        }
        let p = DiscretizeParams::default();
        let mut fine = discretize(&probs, 20, 20, 1, &p);
        fine.resolution = 0.1;
        let mut coarse = discretize(&probs, 20, 20, 10, &p);
        coarse.resolution = 1.0;
        let e = erasure(&fine, &coarse);
        assert_eq!(
            (e.obstacle_pixels, e.erased_pixels, e.obstacle_cells),
            (20, 20, 0)
        );
        let w = e.warning("wall.yaml", &p).expect("a warning");
        assert!(
            w.contains("wall.yaml") && w.contains("discretize.obstacle_fraction"),
            "{w}"
        );
        // At obstacle_fraction 0.05 the wall stays.
        let keep = DiscretizeParams {
            obstacle_fraction: 0.05,
            ..p
        };
        let mut coarse = discretize(&probs, 20, 20, 10, &keep);
        coarse.resolution = 1.0;
        let e = erasure(&fine, &coarse);
        assert_eq!((e.erased_pixels, e.obstacle_cells), (0, 2));
        assert_eq!(e.warning("wall.yaml", &keep), None);
    }

    /// 60 × 60 pixels of 0.1 m (6 × 6 cells of 1 m) holding a solid 2 × 1-cell block in the
    /// bottom-left corner and a one-pixel wall down pixel column `wall` from the top to row
    /// `door` (a door below it), plus `extra` obstacle pixels: the fine map and its
    /// discretization by `p`.
    fn walled(
        wall: usize,
        door: usize,
        extra: &[(usize, usize)],
        p: &DiscretizeParams,
    ) -> (OccGrid, OccGrid) {
        let mut probs = vec![0.0; 3600];
        for r in 40..60 {
            for c in 0..10 {
                probs[r * 60 + c] = 1.0;
            }
        }
        for r in 0..door {
            probs[r * 60 + wall] = 1.0;
        }
        for &(r, c) in extra {
            probs[r * 60 + c] = 1.0;
        }
        let mut fine = discretize(&probs, 60, 60, 1, p);
        fine.resolution = 0.1;
        let mut coarse = discretize(&probs, 60, 60, 10, p);
        coarse.resolution = 1.0;
        (fine, coarse)
    }

    #[test]
    fn a_thin_wall_through_or_between_free_cells_opens_passages_and_is_warned_about() {
        let p = DiscretizeParams::default();
        let cells = |v: &[(i32, i32)]| v.iter().map(|&(r, c)| Pos::new(r, c)).collect::<Vec<_>>();
        // Through the middle of cell column 2, cell rows 0–3 (the door is in rows 4 and 5):
        // cells 0–2 join the two sides; cell 3's sides meet below the wall's end, inside its
        // neighbourhood.
        let (fine, coarse) = walled(25, 40, &[], &p);
        assert_eq!(coarse.count(Occupancy::Obstacle), 2, "the block stays");
        assert_eq!(
            opened_passages(&fine, &coarse),
            cells(&[(0, 2), (1, 2), (2, 2)])
        );
        // Along the border between cell columns 1 and 2 (pixel column 20 is cell 2's first):
        // the pairs (row, 1)–(row, 2) of rows 0–2 are walled; row 3's pair meets below the
        // wall's end, inside the neighbourhood.
        let (fine, coarse) = walled(20, 40, &[], &p);
        assert_eq!(
            opened_passages(&fine, &coarse),
            cells(&[(0, 1), (1, 1), (2, 1)])
        );
        // The warning: 40 of 240 obstacle pixels erased is not "most", but the passages are
        // named, with the setting that keeps them.
        let e = erasure(&fine, &coarse);
        assert_eq!((e.obstacle_pixels, e.erased_pixels), (240, 40));
        let w = e.warning("rooms.yaml", &p).expect("a warning");
        assert!(
            w.contains("rooms.yaml")
                && w.contains("at 3 free cells")
                && w.contains("row 0, column 1")
                && w.contains("discretize.obstacle_fraction"),
            "{w}"
        );
        // At obstacle_fraction 0.05 the wall's cells are obstacles: no passage, no warning.
        let keep = DiscretizeParams {
            obstacle_fraction: 0.05,
            ..p
        };
        let (fine, coarse) = walled(20, 40, &[], &keep);
        assert_eq!(opened_passages(&fine, &coarse), vec![]);
        assert_eq!(erasure(&fine, &coarse).warning("rooms.yaml", &keep), None);
    }

    #[test]
    fn pillars_stubs_and_speckle_open_no_passage() {
        let p = DiscretizeParams::default();
        // A wall stub from the top ending half way down cell (0, 2); a 2 × 2-pixel pillar in
        // the middle of cell (3, 3); speckle: single pixels here and there; a ring of eight
        // pixels in cell (2, 4) enclosing one free pixel (a part of its own, below a tenth of
        // the cell).
        let mut extra: Vec<(usize, usize)> = vec![(34, 34), (34, 35), (35, 34), (35, 35)];
        extra.extend([(12, 12), (27, 48), (51, 33)]);
        extra.extend([
            (24, 44),
            (24, 45),
            (24, 46),
            (25, 44),
            (25, 46),
            (26, 44),
            (26, 45),
            (26, 46),
        ]);
        let (fine, coarse) = walled(25, 5, &extra, &p);
        assert_eq!(coarse.count(Occupancy::Obstacle), 2);
        assert_eq!(opened_passages(&fine, &coarse), vec![]);
        assert_eq!(erasure(&fine, &coarse).warning("open.yaml", &p), None);
    }

    #[test]
    fn exactly_a_quarter_is_free_one_more_is_obstacle() {
        let p = DiscretizeParams::default();
        let g = discretize(&block(4), 4, 4, 4, &p);
        assert_eq!((g.height(), g.width()), (1, 1));
        assert_eq!(g.cells(), &[Occupancy::Free]);
        let g = discretize(&block(5), 4, 4, 4, &p);
        assert_eq!(g.cells(), &[Occupancy::Obstacle]);
    }

    #[test]
    fn probability_threshold_is_strict() {
        let p = DiscretizeParams::default();
        // All pixels exactly at 0.65: none is "> 0.65".
        let g = discretize(&[0.65; 16], 4, 4, 4, &p);
        assert_eq!(g.cells(), &[Occupancy::Free]);
        let g = discretize(&[0.651; 16], 4, 4, 4, &p);
        assert_eq!(g.cells(), &[Occupancy::Obstacle]);
        let g = discretize(&[f64::NAN; 16], 4, 4, 4, &p);
        assert_eq!(g.cells(), &[Occupancy::Free]);
    }

    #[test]
    fn partial_blocks_use_the_pixels_they_have() {
        // 5×5 pixels, factor 4: cells (0,1), (1,0), (1,1) are partial (4, 4 and 1 pixels).
        let mut probs = vec![0.0; 25];
        probs[4] = 1.0; // row 0, col 4 → cell (0,1): 1 of 4 pixels = 25 % → free
        probs[24] = 1.0; // row 4, col 4 → cell (1,1): 1 of 1 pixel → obstacle
        probs[20] = 1.0; // row 4, col 0 → cell (1,0)
        probs[21] = 1.0; // row 4, col 1 → cell (1,0): 2 of 4 → obstacle
        let g = discretize(&probs, 5, 5, 4, &DiscretizeParams::default());
        assert_eq!((g.height(), g.width()), (2, 2));
        assert_eq!(g.get(Pos::new(0, 0)), Occupancy::Free);
        assert_eq!(g.get(Pos::new(0, 1)), Occupancy::Free);
        assert_eq!(g.get(Pos::new(1, 0)), Occupancy::Obstacle);
        assert_eq!(g.get(Pos::new(1, 1)), Occupancy::Obstacle);
    }

    #[test]
    fn empty_image_gives_empty_grid() {
        let g = discretize(&[], 0, 0, 3, &DiscretizeParams::default());
        assert!(g.is_empty());
    }

    proptest! {
        #[test]
        fn factor_one_is_a_plain_threshold(
            (h, w, probs) in (1usize..12, 1usize..12).prop_flat_map(|(h, w)| {
                (Just(h), Just(w), proptest::collection::vec(0.0f64..=1.0, h * w))
            })
        ) {
            let params = DiscretizeParams::default();
            let g = discretize(&probs, h, w, 1, &params);
            prop_assert_eq!((g.height(), g.width()), (h, w));
            for (cell, p) in g.cells().iter().zip(&probs) {
                let want = if *p > 0.65 { Occupancy::Obstacle } else { Occupancy::Free };
                prop_assert_eq!(*cell, want);
            }
        }

        #[test]
        fn output_shape_is_the_ceiling(h in 0usize..20, w in 0usize..20, f in 1usize..6) {
            let g = discretize(&vec![0.0; h * w], h, w, f, &DiscretizeParams::default());
            prop_assert_eq!((g.height(), g.width()), (h.div_ceil(f), w.div_ceil(f)));
        }
    }
}
