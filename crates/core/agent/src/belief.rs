//! A robot's local map m_i with an incrementally maintained frontier set.

use madenet_map::{Movement, OccGrid, Occupancy, Pos};
use madenet_world::squeezed;

/// The robot's own knowledge of the grid: unknown / free / obstacle per cell, plus the
/// frontier flag of every cell (a known free cell with an unknown 8-neighbour, Yamauchi
/// 1997 — under [`Movement::NoCornerCutting`] a diagonal neighbour squeezed between two
/// known obstacles excepted, since it can be neither seen nor entered from there), kept up
/// to date cell by cell as knowledge arrives.
#[derive(Clone, Debug, PartialEq)]
pub struct Belief {
    map: OccGrid,
    known: usize,
    frontier: Vec<bool>,
    frontier_count: usize,
    /// Unknown in-bounds 8-neighbours of each cell (kept for the default movement rule, where
    /// a free cell is a frontier exactly when this is non-zero).
    unknown_neighbours: Vec<u8>,
    movement: Movement,
}

impl Belief {
    /// A belief drawn as text, one row per string: `.` observed free, `#` observed obstacle,
    /// anything else unknown (for tests and examples; rows as long as the first).
    ///
    /// ```
    /// let b = madenet_agent::Belief::from_rows(&["?.#", "..?"], Default::default());
    /// assert_eq!(b.map()[1], madenet_map::Occupancy::Free);
    /// assert_eq!(b.map()[2], madenet_map::Occupancy::Obstacle);
    /// ```
    pub fn from_rows(rows: &[&str], movement: Movement) -> Self {
        let width = rows.first().map_or(0, |r| r.chars().count());
        let mut b = Belief::new(rows.len(), width, movement);
        for (r, line) in rows.iter().enumerate() {
            for (c, ch) in line.chars().enumerate() {
                let occ = match ch {
                    '.' => Occupancy::Free,
                    '#' => Occupancy::Obstacle,
                    _ => continue,
                };
                b.observe(Pos::new(r as i32, c as i32), occ);
            }
        }
        b
    }

    /// A `height` × `width` map (cells) with every cell unknown, whose frontier follows
    /// `movement`.
    pub fn new(height: usize, width: usize, movement: Movement) -> Self {
        let mut b = Belief {
            map: OccGrid::new(height, width, Occupancy::Unknown),
            known: 0,
            frontier: vec![false; width * height],
            frontier_count: 0,
            unknown_neighbours: vec![0; width * height],
            movement,
        };
        b.reset();
        b
    }

    /// Forgets everything: the state [`Belief::new`] starts from, in place.
    pub fn reset(&mut self) {
        let (height, width) = (self.map.height(), self.map.width());
        self.map.cells_mut().fill(Occupancy::Unknown);
        self.known = 0;
        self.frontier.fill(false);
        self.frontier_count = 0;
        // In-bounds 8-neighbours: the 3 × 3 block clipped to the map, less the cell itself.
        for (i, u) in self.unknown_neighbours.iter_mut().enumerate() {
            let (r, c) = (i / width, i % width);
            let rows = (r + 1).min(height - 1) - r.saturating_sub(1) + 1;
            let cols = (c + 1).min(width - 1) - c.saturating_sub(1) + 1;
            *u = (rows * cols - 1) as u8;
        }
    }

    /// Map width in cells.
    pub fn width(&self) -> usize {
        self.map.width()
    }
    /// Map height in cells.
    pub fn height(&self) -> usize {
        self.map.height()
    }
    /// Flat, row-major cells.
    pub fn map(&self) -> &[Occupancy] {
        self.map.cells()
    }
    /// The local map as a grid (e.g. to save or draw it).
    pub fn grid(&self) -> &OccGrid {
        &self.map
    }
    /// |E_i|: cells this robot knows (obstacles included).
    pub fn known_count(&self) -> usize {
        self.known
    }
    /// The movement rule the robot navigates by.
    pub fn movement(&self) -> Movement {
        self.movement
    }
    /// Number of frontier cells.
    pub fn frontier_count(&self) -> usize {
        self.frontier_count
    }

    /// Whether `p` lies inside the map.
    #[inline]
    pub fn in_bounds(&self, p: Pos) -> bool {
        self.map.in_bounds(p)
    }
    /// Row-major index of the in-bounds cell `p`.
    #[inline]
    pub fn index(&self, p: Pos) -> usize {
        self.map.index(p)
    }
    /// The cell at row-major index `i`.
    #[inline]
    pub fn pos(&self, i: usize) -> Pos {
        self.map.pos(i)
    }
    /// Occupancy of `p`; out of bounds reads as obstacle.
    #[inline]
    pub fn get(&self, p: Pos) -> Occupancy {
        self.map.get(p)
    }
    /// Whether `p` is known free (unknown and out-of-bounds cells are not).
    #[inline]
    pub fn is_free(&self, p: Pos) -> bool {
        self.get(p) == Occupancy::Free
    }
    /// Whether `p` is a frontier cell (false out of bounds).
    #[inline]
    pub fn is_frontier(&self, p: Pos) -> bool {
        self.in_bounds(p) && self.frontier[self.index(p)]
    }
    /// Unknown in-bounds 8-neighbours of the cell at row-major index `i` (the authors'
    /// per-cell exploration reward).
    #[inline]
    pub fn unknown_neighbour_count(&self, i: usize) -> u8 {
        self.unknown_neighbours[i]
    }
    /// Frontier flag by row-major index.
    #[inline]
    pub fn is_frontier_index(&self, i: usize) -> bool {
        self.frontier[i]
    }
    /// All frontier cells in row-major order.
    pub fn frontier_cells(&self) -> impl Iterator<Item = Pos> + '_ {
        self.frontier
            .iter()
            .enumerate()
            .filter(|(_, &f)| f)
            .map(|(i, _)| self.pos(i))
    }

    /// Records an observation of `p`. Knowledge is never lost: a known cell keeps its value
    /// (the world is static and sensing exact), but for one upgrade: a free cell observed as an
    /// obstacle becomes one (a continuous world's robot finds a cell it read as free
    /// impassable; on the grid, where sensing is exact, this never happens). Returns true if
    /// the cell was new.
    #[inline]
    pub fn observe(&mut self, p: Pos, occ: Occupancy) -> bool {
        let i = self.index(p);
        if self.map.cells()[i] != Occupancy::Unknown || occ == Occupancy::Unknown {
            if self.map.cells()[i] == Occupancy::Free && occ == Occupancy::Obstacle {
                self.upgrade_to_obstacle(p);
            }
            return false;
        }
        self.map.cells_mut()[i] = occ;
        self.known += 1;
        let strict = self.movement == Movement::NoCornerCutting;
        for (dr, dc) in NEIGHBOURS {
            let q = Pos::new(p.row + dr, p.col + dc);
            if self.in_bounds(q) {
                let j = self.index(q);
                self.unknown_neighbours[j] -= 1;
                if strict {
                    self.refresh_frontier(q);
                } else if self.unknown_neighbours[j] == 0 && self.frontier[j] {
                    self.frontier[j] = false;
                    self.frontier_count -= 1;
                }
            }
        }
        if strict {
            self.refresh_frontier(p);
        } else if occ == Occupancy::Free && self.unknown_neighbours[i] > 0 {
            self.frontier[i] = true;
            self.frontier_count += 1;
        }
        true
    }

    /// Merges a teammate's local map (Sec. III.C.1, *Mapping*): every cell unknown here and
    /// known there is copied, and a cell free here that the teammate found to be an obstacle
    /// becomes one ([`Belief::observe`]'s upgrade). Returns the number of new cells.
    pub fn merge(&mut self, other: &[Occupancy]) -> usize {
        assert_eq!(
            other.len(),
            self.map.len(),
            "merging maps of different sizes"
        );
        // Blocks of 32 cells are scanned branch-free (vectorized) and only blocks with a cell
        // unknown here and known there are merged cell by cell, in the same cell order as a
        // plain loop: once maps agree, the common case, a merge is this scan.
        let news = |a: Occupancy, b: Occupancy| {
            (a == Occupancy::Unknown && b != Occupancy::Unknown)
                || (a == Occupancy::Free && b == Occupancy::Obstacle)
        };
        let mut added = 0;
        for start in (0..other.len()).step_by(MERGE_BLOCK) {
            let end = (start + MERGE_BLOCK).min(other.len());
            if !block_has_news(&self.map.cells()[start..end], &other[start..end]) {
                continue;
            }
            #[allow(clippy::needless_range_loop)] // i indexes our map and `other` alike
            for i in start..end {
                if news(self.map.cells()[i], other[i]) {
                    let p = self.pos(i);
                    if self.observe(p, other[i]) {
                        added += 1;
                    }
                }
            }
        }
        added
    }

    /// A known free cell turns out to be an obstacle: it is no frontier any more, and under
    /// [`Movement::NoCornerCutting`] its neighbours' frontier flags may change.
    fn upgrade_to_obstacle(&mut self, p: Pos) {
        let i = self.index(p);
        self.map.cells_mut()[i] = Occupancy::Obstacle;
        if self.frontier[i] {
            self.frontier[i] = false;
            self.frontier_count -= 1;
        }
        if self.movement == Movement::NoCornerCutting {
            for (dr, dc) in NEIGHBOURS {
                let q = Pos::new(p.row + dr, p.col + dc);
                if self.in_bounds(q) {
                    self.refresh_frontier(q);
                }
            }
        }
    }

    /// An unknown 8-neighbour that can be seen from `p`: under
    /// [`Movement::NoCornerCutting`] a diagonal neighbour squeezed between two known
    /// obstacles is closed to sight and motion alike, so it does not count.
    fn has_unknown_neighbour(&self, p: Pos) -> bool {
        NEIGHBOURS.iter().any(|&(dr, dc)| {
            let q = Pos::new(p.row + dr, p.col + dc);
            self.in_bounds(q)
                && self.map.cells()[self.index(q)] == Occupancy::Unknown
                && !(self.movement == Movement::NoCornerCutting
                    && squeezed(|c| self.get(c) == Occupancy::Obstacle, p, q))
        })
    }

    fn refresh_frontier(&mut self, p: Pos) {
        let i = self.index(p);
        let f = self.map.cells()[i] == Occupancy::Free && self.has_unknown_neighbour(p);
        if f != self.frontier[i] {
            self.frontier[i] = f;
            if f {
                self.frontier_count += 1;
            } else {
                self.frontier_count -= 1;
            }
        }
    }
}

/// Cells per block of [`Belief::merge`]'s scan.
const MERGE_BLOCK: usize = 32;

/// Whether a block has a cell unknown in `mine` and known in `theirs`. Full blocks are fixed-size
/// arrays reduced with a byte-wise OR on the codes (unknown = 0), which compiles to a few vector
/// instructions; a slice `fold` of the same did not vectorize (≈ 4 instructions per cell).
#[inline]
fn block_has_news(mine: &[Occupancy], theirs: &[Occupancy]) -> bool {
    match (
        <&[Occupancy; MERGE_BLOCK]>::try_from(mine),
        <&[Occupancy; MERGE_BLOCK]>::try_from(theirs),
    ) {
        (Ok(a), Ok(b)) => {
            let mut acc = 0u8;
            for i in 0..MERGE_BLOCK {
                acc |= ((a[i] as u8 == 0) as u8 & (b[i] as u8 != 0) as u8)
                    | ((a[i] as u8 == 1) as u8 & (b[i] as u8 == 2) as u8);
            }
            acc != 0
        }
        _ => mine.iter().zip(theirs).any(|(&a, &b)| {
            (a == Occupancy::Unknown && b != Occupancy::Unknown)
                || (a == Occupancy::Free && b == Occupancy::Obstacle)
        }),
    }
}

/// The 8-neighbourhood offsets.
pub const NEIGHBOURS: [(i32, i32); 8] = [
    (-1, -1),
    (-1, 0),
    (-1, 1),
    (0, -1),
    (0, 1),
    (1, -1),
    (1, 0),
    (1, 1),
];

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn recompute(b: &Belief) -> Vec<bool> {
        (0..b.map().len())
            .map(|i| {
                let p = b.pos(i);
                b.get(p) == Occupancy::Free
                    && NEIGHBOURS.iter().any(|&(dr, dc)| {
                        let q = Pos::new(p.row + dr, p.col + dc);
                        let squeeze = b.movement() == Movement::NoCornerCutting
                            && dr != 0
                            && dc != 0
                            && b.get(Pos::new(p.row, q.col)) == Occupancy::Obstacle
                            && b.get(Pos::new(q.row, p.col)) == Occupancy::Obstacle;
                        b.in_bounds(q) && b.get(q) == Occupancy::Unknown && !squeeze
                    })
            })
            .collect()
    }

    proptest! {
        /// The incremental frontier equals a from-scratch recomputation (observations that
        /// turn free cells into obstacles included), and merging never loses knowledge
        /// (monotone: known cells stay known with the same value, but for free cells a
        /// teammate knows as obstacles).
        #[test]
        fn incremental_frontier_and_monotone_merge(
            obs in proptest::collection::vec((0i32..8, 0i32..9, 1u8..3), 0..80),
            other in proptest::collection::vec(0u8..3, 72),
            strict in proptest::bool::ANY,
        ) {
            let movement = if strict { Movement::NoCornerCutting } else { Movement::CornerCutting };
            let mut b = Belief::new(8, 9, movement);
            for (r, c, o) in obs {
                let occ = if o == 1 { Occupancy::Free } else { Occupancy::Obstacle };
                b.observe(Pos::new(r, c), occ);
                let expect = recompute(&b);
                prop_assert_eq!(b.frontier.clone(), expect.clone());
                prop_assert_eq!(b.frontier_count, expect.iter().filter(|&&f| f).count());
            }
            let before = b.clone();
            let other: Vec<Occupancy> = other.into_iter().map(|v| match v { 0 => Occupancy::Unknown, 1 => Occupancy::Free, _ => Occupancy::Obstacle }).collect();
            b.merge(&other);
            for ((&now, &was), &heard) in b.map().iter().zip(before.map()).zip(&other) {
                if was == Occupancy::Free && heard == Occupancy::Obstacle {
                    // The one upgrade: a teammate found the cell impassable.
                    prop_assert_eq!(now, Occupancy::Obstacle);
                } else if was != Occupancy::Unknown {
                    prop_assert_eq!(now, was);
                } else {
                    prop_assert_eq!(now, heard);
                }
            }
            prop_assert!(b.known_count() >= before.known_count());
            prop_assert_eq!(b.known_count(), b.map().iter().filter(|o| o.is_known()).count());
            prop_assert_eq!(b.frontier.clone(), recompute(&b));
        }
    }
}
