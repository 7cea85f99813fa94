//! A robot's published map read into the agent's cells by the paper's rule (Sec. V.B.1: a cell
//! is an obstacle when more than 25 % of its pixels have occupancy probability above 65 %),
//! with [`read_partial_cell`] for a map still being built: the rule the continuous world's
//! robots read their own maps by, so a node's agent sees what a simulated one sees.
//!
//! Cell rows count from the grid's origin (row 0 holds the grid's first row), as
//! `OccupancyGrid` rows do. Reads are write-once but for the upgrade to an obstacle, as the
//! agent's belief is; [`CellReader::read`] reports each cell when it first becomes known and
//! again when it becomes an obstacle.

use madenet_map::discretize::{read_partial_cell, CellTables, DiscretizeParams};
use madenet_map::{Occupancy, Pos};
use madenet_ros2::msgs::OccupancyGrid;

/// The geometry a reader was made for: size, resolution, origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Columns of pixels.
    pub width: usize,
    /// Rows of pixels.
    pub height: usize,
    /// Metres per pixel.
    pub resolution: f64,
    /// The map's origin (the corner of pixel (0, 0)) in its frame.
    pub origin: (f64, f64),
}

impl Geometry {
    /// The geometry of `grid` (whose data must fit its size).
    pub fn of(grid: &OccupancyGrid) -> Self {
        Geometry {
            width: grid.info.width as usize,
            height: grid.info.height as usize,
            resolution: grid.info.resolution as f64,
            origin: (grid.info.origin.position.x, grid.info.origin.position.y),
        }
    }
}

/// Reads one map's pixels into cells of `cell_size` metres.
#[derive(Clone, Debug)]
pub struct CellReader {
    geometry: Geometry,
    cell_size: f64,
    /// Pixels of value above this are occupied (percent).
    occupied_above: i8,
    obstacle_fraction: f64,
    known_fraction: f64,
    rows: usize,
    cols: usize,
    /// Cell of each pixel row / column.
    row_cell: Vec<u32>,
    col_cell: Vec<u32>,
    pixels: Vec<u32>,
    /// Observed pixels per cell at the last read.
    observed: Vec<u32>,
    cells: Vec<Occupancy>,
}

impl CellReader {
    /// A reader of maps of `geometry` into cells of `cell_size` metres (a pixel belongs to the
    /// cell its centre falls in), by `rule`; a cell is known free once `known_fraction` of its
    /// pixels are observed (the continuous world's `mapping.known_fraction`).
    pub fn new(
        geometry: Geometry,
        cell_size: f64,
        rule: &DiscretizeParams,
        known_fraction: f64,
    ) -> Self {
        let CellTables {
            row_cell,
            col_cell,
            rows,
            cols,
            pixels,
        } = CellTables::new(
            geometry.height,
            geometry.width,
            geometry.resolution,
            cell_size,
        );
        CellReader {
            geometry,
            cell_size,
            occupied_above: (rule.occupied_prob * 100.0).floor().clamp(0.0, 100.0) as i8,
            obstacle_fraction: rule.obstacle_fraction,
            known_fraction,
            rows,
            cols,
            row_cell,
            col_cell,
            observed: vec![0; pixels.len()],
            pixels,
            cells: vec![Occupancy::Unknown; rows * cols],
        }
    }

    /// The geometry this reader reads.
    pub fn geometry(&self) -> Geometry {
        self.geometry
    }

    /// Cells: (rows, columns).
    pub fn size(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    /// The cells read so far, row-major.
    pub fn cells(&self) -> &[Occupancy] {
        &self.cells
    }

    /// Cell `p` as read so far (`None` off the map).
    pub fn get(&self, p: Pos) -> Option<Occupancy> {
        let inside = p.row >= 0
            && p.col >= 0
            && (p.row as usize) < self.rows
            && (p.col as usize) < self.cols;
        inside.then(|| self.cells[p.row as usize * self.cols + p.col as usize])
    }

    /// The cell a point of the map's frame lies in, if on the map.
    pub fn cell_at(&self, x: f64, y: f64) -> Option<Pos> {
        let g = &self.geometry;
        let (c, r) = (
            (x - g.origin.0) / g.resolution,
            (y - g.origin.1) / g.resolution,
        );
        if !(c >= 0.0 && r >= 0.0 && c < g.width as f64 && r < g.height as f64) {
            return None;
        }
        let (r, c) = (r as usize, c as usize);
        Some(Pos::new(self.row_cell[r] as i32, self.col_cell[c] as i32))
    }

    /// The centre of cell `p` in the map's frame — of its part on the map, for a cell the
    /// map's edge cuts (so no goal lies off the map).
    pub fn centre(&self, p: Pos) -> (f64, f64) {
        let g = &self.geometry;
        let (w, h) = (
            g.width as f64 * g.resolution,
            g.height as f64 * g.resolution,
        );
        let mid = |k: i32, extent: f64| {
            let lo = (k as f64 * self.cell_size).clamp(0.0, extent);
            let hi = ((k + 1) as f64 * self.cell_size).clamp(0.0, extent);
            0.5 * (lo + hi)
        };
        (g.origin.0 + mid(p.col, w), g.origin.1 + mid(p.row, h))
    }

    /// Reads `grid` (of this reader's geometry: checked by the caller) and appends each cell
    /// whose read changed to `changes`.
    pub fn read(&mut self, grid: &OccupancyGrid, changes: &mut Vec<(Pos, Occupancy)>) {
        let mut observed = std::mem::take(&mut self.observed);
        observed.fill(0);
        let mut occupied = vec![0u32; self.cells.len()];
        let w = self.geometry.width;
        for (r, row) in grid.data.chunks_exact(w.max(1)).enumerate() {
            let base = self.row_cell[r] as usize * self.cols;
            for (c, &v) in row.iter().enumerate() {
                if v >= 0 {
                    let k = base + self.col_cell[c] as usize;
                    observed[k] += 1;
                    occupied[k] += u32::from(v > self.occupied_above);
                }
            }
        }
        for k in 0..self.cells.len() {
            let now = self.cells[k];
            if now == Occupancy::Obstacle {
                continue;
            }
            let read = read_partial_cell(
                self.pixels[k],
                observed[k],
                occupied[k],
                self.obstacle_fraction,
                self.known_fraction,
            );
            let next = madenet_map::discretize::write_once(now, read);
            if next != now {
                self.cells[k] = next;
                changes.push((
                    Pos::new((k / self.cols) as i32, (k % self.cols) as i32),
                    next,
                ));
            }
        }
        self.observed = observed;
    }

    /// Pixels of cell `p` observed at the last read (0 off the map).
    pub fn observed(&self, p: Pos) -> u32 {
        if p.row < 0 || p.col < 0 || p.row as usize >= self.rows || p.col as usize >= self.cols {
            return 0;
        }
        self.observed[p.row as usize * self.cols + p.col as usize]
    }

    /// Marks cell `p` an obstacle (written off) and reports it in `changes` if it was not one.
    pub fn write_off(&mut self, p: Pos, changes: &mut Vec<(Pos, Occupancy)>) {
        if p.row < 0 || p.col < 0 || p.row as usize >= self.rows || p.col as usize >= self.cols {
            return;
        }
        let k = p.row as usize * self.cols + p.col as usize;
        if self.cells[k] != Occupancy::Obstacle {
            self.cells[k] = Occupancy::Obstacle;
            changes.push((p, Occupancy::Obstacle));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(w: u32, h: u32, res: f32, data: Vec<i8>) -> OccupancyGrid {
        let mut g = OccupancyGrid {
            data,
            ..Default::default()
        };
        (g.info.width, g.info.height, g.info.resolution) = (w, h, res);
        g.info.origin.position.x = -1.0;
        g.info.origin.position.y = 2.0;
        g
    }

    #[test]
    fn cells_are_read_by_the_papers_rule_and_written_once() {
        // 20 × 10 pixels of 0.1 m: 2 × 1 cells of 1 m.
        let mut data = vec![-1i8; 200];
        // Left cell: all observed free but 30 occupied pixels (> 25 %): an obstacle.
        for (k, v) in data.iter_mut().enumerate() {
            if k % 20 < 10 {
                *v = if k % 20 < 3 { 90 } else { 0 };
            }
        }
        // Right cell: 40 % observed free: unknown (known_fraction 0.5).
        for (k, v) in data.iter_mut().enumerate() {
            if k % 20 >= 10 && k / 20 < 4 {
                *v = 0;
            }
        }
        let g = grid(20, 10, 0.1, data);
        let mut reader = CellReader::new(Geometry::of(&g), 1.0, &DiscretizeParams::default(), 0.5);
        assert_eq!(reader.size(), (1, 2));
        let mut changes = Vec::new();
        reader.read(&g, &mut changes);
        assert_eq!(changes, vec![(Pos::new(0, 0), Occupancy::Obstacle)]);
        // Half the right cell observed free: known free; then it stays so when it is unknown
        // again (write-once).
        let mut g2 = g.clone();
        for k in 0..200 {
            if k % 20 >= 10 && k / 20 < 5 {
                g2.data[k] = 0;
            }
        }
        changes.clear();
        reader.read(&g2, &mut changes);
        assert_eq!(changes, vec![(Pos::new(0, 1), Occupancy::Free)]);
        changes.clear();
        reader.read(&g, &mut changes);
        assert!(changes.is_empty());
        assert_eq!(reader.cell_at(-0.95, 2.05), Some(Pos::new(0, 0)));
        assert_eq!(reader.cell_at(0.5, 2.5), Some(Pos::new(0, 1)));
        assert_eq!(reader.cell_at(1.5, 2.5), None);
        assert_eq!(reader.centre(Pos::new(0, 1)), (0.5, 2.5));
        // A cell the map's edge cuts: the centre of its part on the map.
        let g3 = grid(25, 10, 0.1, vec![-1; 250]);
        let cut = CellReader::new(Geometry::of(&g3), 1.0, &DiscretizeParams::default(), 0.5);
        assert_eq!(cut.size(), (1, 3));
        let (x, y) = cut.centre(Pos::new(0, 2));
        assert!((x - 1.25).abs() < 1e-6 && (y - 2.5).abs() < 1e-6, "{x} {y}");
    }
}
