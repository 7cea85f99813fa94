//! Grid maps for madenet.
//!
//! This crate is the first stage of the data flow (map → world → belief → goals → policy →
//! navigator → world). It owns the plain-data description of an environment and nothing else:
//!
//! * [`Pos`], [`Occupancy`] and [`OccGrid`]: a row-major grid of cells (row 0 is the top row,
//!   as in the paper's Fig. 3 and in the images of ROS `map_server`).
//! * [`io`]: reading ROS `map_server` YAML + PGM (P5), PNG and plain-text grids, and writing
//!   YAML + P5 PGM back (free 254, occupied 0, unknown 205).
//! * [`discretize`]: the paper's rule (Sec. V.B.1) for turning a fine occupancy image into
//!   robot-sized cells: a cell is an obstacle when more than 25 % of its pixels have occupancy
//!   probability above 0.65.
//! * [`generate`]: a seeded random map generator for training and tests (connected free space,
//!   irregular obstacles made of wall strokes and blobs).
//! * [`floorplan`]: a seeded floor-plan generator (rooms, doors, corridors, some furniture).
//! * [`paper`]: the paper's 10 evaluation maps (embedded, so a fresh clone needs nothing
//!   else) and its four corner starts.
//!
//! Every fallible function returns [`MapError`], whose message names the file and the field.
//!
//! [`Movement`] and [`OccGrid::can_step`] define how robots move between cells; the
//! connectivity helpers in [`generate`] follow the same rule.

#![deny(missing_docs)]

pub mod discretize;
pub mod floorplan;
pub mod generate;
pub mod io;
pub mod paper;

use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::PathBuf;

/// The 8 unit steps (row, column) in ring order, clockwise from north: each is 45° from the
/// next (the generator's shapes and PB's value functions walk it).
pub const RING8: [(i32, i32); 8] = [
    (-1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
    (1, 0),
    (1, -1),
    (0, -1),
    (-1, -1),
];

/// A cell coordinate: `row` counts down from the top row, `col` to the right.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, Default,
)]
pub struct Pos {
    /// Row index, 0 at the top.
    pub row: i32,
    /// Column index, 0 at the left.
    pub col: i32,
}

impl Pos {
    /// The cell at `row`, `col`.
    pub const fn new(row: i32, col: i32) -> Self {
        Pos { row, col }
    }
    /// Chebyshev (king-move) distance, the metric of the paper's sensing and comm range.
    pub fn chebyshev(self, other: Pos) -> i32 {
        (self.row - other.row)
            .abs()
            .max((self.col - other.col).abs())
    }
    /// Euclidean distance in cells.
    pub fn euclid(self, other: Pos) -> f64 {
        let dr = (self.row - other.row) as f64;
        let dc = (self.col - other.col) as f64;
        (dr * dr + dc * dc).sqrt()
    }
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({}, {})", self.row, self.col)
    }
}

/// What is known of a cell. The numeric values are stable (used in flat `u8` maps).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[repr(u8)]
pub enum Occupancy {
    /// Not (yet) observed.
    #[default]
    Unknown = 0,
    /// Traversable.
    Free = 1,
    /// Blocked.
    Obstacle = 2,
}

impl Occupancy {
    /// Whether the cell is free or an obstacle (not unknown).
    pub fn is_known(self) -> bool {
        self != Occupancy::Unknown
    }
}

/// How robots move between cells: always to one of the 8 neighbours (king moves) that is free;
/// the variants differ on diagonal steps past obstacle corners.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Movement {
    /// A diagonal step needs both orthogonal cells it passes to be free. The reachable cells
    /// are then exactly the 4-connected free component, so a thin diagonal wall blocks
    /// passage.
    NoCornerCutting,
    /// Any free 8-neighbour can be entered, squeezing between two diagonal obstacles (the
    /// default). This is the rule of the paper's evaluation code, and its 10 maps need it:
    /// without it 7 of them split into pockets (test_9's largest holds 63 of 255 free cells).
    #[default]
    CornerCutting,
}

/// A row-major occupancy grid with its metric frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OccGrid {
    width: usize,
    height: usize,
    cells: Vec<Occupancy>,
    /// Metres per cell (ROS `resolution`).
    pub resolution: f64,
    /// Pose of the lower-left pixel (ROS `origin`: x, y, yaw).
    pub origin: [f64; 3],
}

impl OccGrid {
    /// A grid of `height` rows and `width` columns, every cell `fill`, 1 m cells.
    pub fn new(height: usize, width: usize, fill: Occupancy) -> Self {
        OccGrid {
            width,
            height,
            cells: vec![fill; width * height],
            resolution: 1.0,
            origin: [0.0; 3],
        }
    }
    /// Builds a grid from row-major cells. Panics if `cells.len() != height * width`.
    pub fn from_cells(height: usize, width: usize, cells: Vec<Occupancy>) -> Self {
        assert_eq!(
            cells.len(),
            width * height,
            "cell count must be height * width"
        );
        OccGrid {
            width,
            height,
            cells,
            resolution: 1.0,
            origin: [0.0; 3],
        }
    }
    /// Number of columns.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Number of rows.
    pub fn height(&self) -> usize {
        self.height
    }
    /// Number of cells, the paper's |X|.
    pub fn len(&self) -> usize {
        self.cells.len()
    }
    /// Whether the grid has no cells.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }
    /// The cells in row-major order.
    pub fn cells(&self) -> &[Occupancy] {
        &self.cells
    }
    /// The cells in row-major order, mutably.
    pub fn cells_mut(&mut self) -> &mut [Occupancy] {
        &mut self.cells
    }
    /// Whether `p` lies inside the grid.
    pub fn in_bounds(&self, p: Pos) -> bool {
        p.row >= 0 && p.col >= 0 && (p.row as usize) < self.height && (p.col as usize) < self.width
    }
    /// Flat index of an in-bounds position.
    #[inline]
    pub fn index(&self, p: Pos) -> usize {
        debug_assert!(self.in_bounds(p));
        p.row as usize * self.width + p.col as usize
    }
    /// Position of a flat index.
    #[inline]
    pub fn pos(&self, i: usize) -> Pos {
        Pos::new((i / self.width) as i32, (i % self.width) as i32)
    }
    /// Occupancy at `p`; out-of-bounds cells read as obstacles.
    #[inline]
    pub fn get(&self, p: Pos) -> Occupancy {
        if self.in_bounds(p) {
            self.cells[self.index(p)]
        } else {
            Occupancy::Obstacle
        }
    }
    /// Sets the occupancy at `p`. Panics if `p` is out of bounds.
    pub fn set(&mut self, p: Pos, v: Occupancy) {
        let i = self.index(p);
        self.cells[i] = v;
    }
    /// Whether `p` is in bounds and free.
    pub fn is_free(&self, p: Pos) -> bool {
        self.get(p) == Occupancy::Free
    }
    /// Whether a robot may move from `from` to `to` in one step under the default rule
    /// ([`Movement::CornerCutting`]): `to` must be one of the 8 neighbours of `from` and free
    /// (under [`Movement::NoCornerCutting`] a diagonal step also needs both orthogonal cells
    /// it passes to be free). `from` itself is not checked.
    pub fn can_step(&self, from: Pos, to: Pos) -> bool {
        self.can_step_with(from, to, Movement::default())
    }
    /// Like [`OccGrid::can_step`], under the given movement rule.
    pub fn can_step_with(&self, from: Pos, to: Pos, movement: Movement) -> bool {
        let (dr, dc) = (to.row - from.row, to.col - from.col);
        if dr.abs() > 1 || dc.abs() > 1 || (dr == 0 && dc == 0) || !self.is_free(to) {
            return false;
        }
        dr == 0
            || dc == 0
            || movement == Movement::CornerCutting
            || (self.is_free(Pos::new(from.row + dr, from.col))
                && self.is_free(Pos::new(from.row, from.col + dc)))
    }
    /// Number of cells with occupancy `v`.
    pub fn count(&self, v: Occupancy) -> usize {
        self.cells.iter().filter(|&&c| c == v).count()
    }
    /// Fraction of cells that are obstacles.
    pub fn obstacle_density(&self) -> f64 {
        self.count(Occupancy::Obstacle) as f64 / self.len().max(1) as f64
    }
}

/// Everything that can go wrong reading, converting or generating a map. Each message names
/// the file (when there is one) and the field or line at fault.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A metadata field is missing, has the wrong type or an invalid value.
    #[error("{path}: field `{field}`: {message}")]
    Field {
        /// The file holding the field.
        path: PathBuf,
        /// The field's name.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A file is malformed (bad image, bad text grid line, unsupported extension, ...).
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the line or header field where there is one.
        message: String,
    },
    /// An invalid argument or configuration that is not tied to a file.
    #[error("{0}")]
    Invalid(String),
}
