//! The text grid format (`.txt`, `.map`): one row per line, `#` obstacle, `.` free,
//! `?` unknown.

use super::{check_savable, format_err, write_atomic};
use crate::{MapError, OccGrid, Occupancy};
use std::path::Path;

/// Parses a text grid: one row per line, `#` obstacle, `.` free, `?` unknown. Trailing
/// whitespace (including `\r`) is trimmed from each line and blank lines at the end are
/// ignored. All rows must have the same length. Errors ([`MapError::Format`]) name
/// `path_for_errors` and the 1-based line (and column, for a bad character). The grid has
/// resolution 1.0 and a zero origin.
pub fn parse_text(text: &str, path_for_errors: &Path) -> Result<OccGrid, MapError> {
    let mut lines: Vec<&str> = text.lines().map(str::trim_end).collect();
    while lines.last().is_some_and(|l| l.is_empty()) {
        lines.pop();
    }
    if lines.is_empty() {
        return Err(format_err(
            path_for_errors,
            "text map is empty (expected rows of `#`, `.`, `?`)",
        ));
    }
    let width = lines[0].chars().count();
    let mut cells = Vec::with_capacity(width * lines.len());
    for (r, line) in lines.iter().enumerate() {
        let mut len = 0;
        for (c, ch) in line.chars().enumerate() {
            cells.push(match ch {
                '#' => Occupancy::Obstacle,
                '.' => Occupancy::Free,
                '?' => Occupancy::Unknown,
                other => {
                    return Err(format_err(
                        path_for_errors,
                        format!("line {}, column {}: unexpected character {other:?} (expected `#`, `.` or `?`)", r + 1, c + 1),
                    ))
                }
            });
            len += 1;
        }
        if len != width {
            return Err(format_err(
                path_for_errors,
                format!("line {}: row has {len} cells but line 1 has {width}; all rows must have equal length", r + 1),
            ));
        }
    }
    Ok(OccGrid::from_cells(lines.len(), width, cells))
}

/// Renders a grid as text (`#` obstacle, `.` free, `?` unknown), one line per row, each line
/// ending with `\n`. [`parse_text`] reads it back.
pub fn to_text(grid: &OccGrid) -> String {
    let mut s = String::with_capacity((grid.width() + 1) * grid.height());
    for row in grid.cells().chunks(grid.width().max(1)) {
        s.extend(row.iter().map(|c| match c {
            Occupancy::Obstacle => '#',
            Occupancy::Free => '.',
            Occupancy::Unknown => '?',
        }));
        s.push('\n');
    }
    s
}

/// Writes `grid` as a text grid ([`to_text`]), atomically.
pub fn save_text(grid: &OccGrid, path: &Path) -> Result<(), MapError> {
    check_savable(grid, path)?;
    write_atomic(path, to_text(grid).as_bytes())
}
