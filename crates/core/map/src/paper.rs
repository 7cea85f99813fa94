//! The paper's 10 evaluation maps and its four corner starts.
//!
//! The maps (`maps/paper/test_{1..10}.yaml` + `.pgm` in the repository, 20×20 cells of 1 m)
//! are embedded in the binary, so [`paper_map`] needs no files at run time. They are decoded
//! with the same `map_server` rules as [`crate::io::load`], using the embedded YAML.
//!
//! In each episode the three robots start in one corner of the map ([`Corner`]): on the corner
//! cell and its two orthogonal neighbours along the map edges
//! ([`Corner::start_cells`]).

use crate::io::{load_map_server_with, LoadOptions};
use crate::{MapError, OccGrid, Pos};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Number of evaluation maps in the paper (`test_1` … `test_10`).
pub const PAPER_MAP_COUNT: usize = 10;

/// The embedded YAML and PGM of each paper map, index `n - 1`.
const PAPER_FILES: [(&str, &[u8]); PAPER_MAP_COUNT] = [
    (
        include_str!("../../../../maps/paper/test_1.yaml"),
        include_bytes!("../../../../maps/paper/test_1.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_2.yaml"),
        include_bytes!("../../../../maps/paper/test_2.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_3.yaml"),
        include_bytes!("../../../../maps/paper/test_3.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_4.yaml"),
        include_bytes!("../../../../maps/paper/test_4.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_5.yaml"),
        include_bytes!("../../../../maps/paper/test_5.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_6.yaml"),
        include_bytes!("../../../../maps/paper/test_6.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_7.yaml"),
        include_bytes!("../../../../maps/paper/test_7.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_8.yaml"),
        include_bytes!("../../../../maps/paper/test_8.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_9.yaml"),
        include_bytes!("../../../../maps/paper/test_9.pgm"),
    ),
    (
        include_str!("../../../../maps/paper/test_10.yaml"),
        include_bytes!("../../../../maps/paper/test_10.pgm"),
    ),
];

/// The name of paper map `n`: `"test_{n}"`.
pub fn paper_map_name(n: usize) -> String {
    format!("test_{n}")
}

/// Paper evaluation map `n` (1 ..= [`PAPER_MAP_COUNT`]) at 1 m cells: 20×20, every cell free
/// or obstacle. Any other `n` is a [`MapError::Invalid`].
pub fn paper_map(n: usize) -> Result<OccGrid, MapError> {
    let (yaml, pgm) = n
        .checked_sub(1)
        .and_then(|i| PAPER_FILES.get(i))
        .ok_or_else(|| {
            MapError::Invalid(format!(
                "paper map number must be 1..={PAPER_MAP_COUNT}, got {n}"
            ))
        })?;
    let yaml_path = PathBuf::from(format!("maps/paper/{}.yaml", paper_map_name(n)));
    let expected_image = format!("{}.pgm", paper_map_name(n));
    load_map_server_with(yaml, &yaml_path, &LoadOptions::default(), |image: &Path| {
        if image
            .file_name()
            .is_some_and(|f| f == expected_image.as_str())
        {
            Ok(pgm.to_vec())
        } else {
            Err(MapError::Format {
                path: yaml_path.clone(),
                message: format!(
                    "embedded paper map names image {}, expected {expected_image}",
                    image.display()
                ),
            })
        }
    })
}

/// A corner of the map where the robots start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Corner {
    /// Row 0, column 0.
    TopLeft,
    /// Row 0, last column.
    TopRight,
    /// Last row, column 0.
    BottomLeft,
    /// Last row, last column.
    BottomRight,
}

impl Corner {
    /// All four corners, in the order top-left, top-right, bottom-left, bottom-right.
    pub const ALL: [Corner; 4] = [
        Corner::TopLeft,
        Corner::TopRight,
        Corner::BottomLeft,
        Corner::BottomRight,
    ];

    /// The kebab-case name: `"top-left"`, `"top-right"`, `"bottom-left"`, `"bottom-right"`.
    pub fn name(self) -> &'static str {
        match self {
            Corner::TopLeft => "top-left",
            Corner::TopRight => "top-right",
            Corner::BottomLeft => "bottom-left",
            Corner::BottomRight => "bottom-right",
        }
    }

    /// The three start cells in a `height × width` grid: the corner cell, its vertical
    /// neighbour (one row towards the middle) and its horizontal neighbour (one column towards
    /// the middle). For 20×20, top-left is `(0,0), (1,0), (0,1)` and bottom-right is
    /// `(19,19), (18,19), (19,18)` as `(row, col)`. Meant for grids of at least 2×2; on smaller
    /// grids the cells coincide rather than leave the grid.
    pub fn start_cells(self, height: usize, width: usize) -> [Pos; 3] {
        let last_r = height.saturating_sub(1) as i32;
        let last_c = width.saturating_sub(1) as i32;
        let (r, dr) = match self {
            Corner::TopLeft | Corner::TopRight => (0, 1),
            Corner::BottomLeft | Corner::BottomRight => (last_r, -1),
        };
        let (c, dc) = match self {
            Corner::TopLeft | Corner::BottomLeft => (0, 1),
            Corner::TopRight | Corner::BottomRight => (last_c, -1),
        };
        let clamp_r = |x: i32| x.clamp(0, last_r);
        let clamp_c = |x: i32| x.clamp(0, last_c);
        [
            Pos::new(r, c),
            Pos::new(clamp_r(r + dr), c),
            Pos::new(r, clamp_c(c + dc)),
        ]
    }

    /// The start cells of every corner, [`Corner::ALL`] order, in a `height × width` grid: the
    /// 12 cells generated maps keep free by default.
    pub fn all_start_cells(height: usize, width: usize) -> Vec<Pos> {
        Corner::ALL
            .iter()
            .flat_map(|c| c.start_cells(height, width))
            .collect()
    }
}

impl fmt::Display for Corner {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Corner {
    type Err = MapError;

    /// Parses `top-left`, `top_left`, `topleft` or `tl` (and likewise for the other corners),
    /// case-insensitively.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let norm: String = s
            .trim()
            .to_ascii_lowercase()
            .chars()
            .filter(|c| !matches!(c, '-' | '_' | ' '))
            .collect();
        match norm.as_str() {
            "topleft" | "tl" => Ok(Corner::TopLeft),
            "topright" | "tr" => Ok(Corner::TopRight),
            "bottomleft" | "bl" => Ok(Corner::BottomLeft),
            "bottomright" | "br" => Ok(Corner::BottomRight),
            _ => Err(MapError::Invalid(format!(
                "unknown corner {s:?}; valid corners: top-left, top-right, bottom-left, bottom-right \
                 (also written top_left, tl, ...)"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::is_connected;
    use crate::io::to_text;
    use crate::Occupancy;

    #[test]
    fn all_paper_maps_load_as_20x20_known_grids() {
        for n in 1..=PAPER_MAP_COUNT {
            let g = paper_map(n).unwrap_or_else(|e| panic!("{}: {e}", paper_map_name(n)));
            assert_eq!((g.height(), g.width()), (20, 20), "{}", paper_map_name(n));
            assert_eq!(g.count(Occupancy::Unknown), 0, "{}", paper_map_name(n));
            assert_eq!(g.resolution, 1.0);
        }
    }

    #[test]
    fn embedded_maps_equal_the_files() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../maps/paper");
        for n in 1..=PAPER_MAP_COUNT {
            let file = dir.join(format!("{}.yaml", paper_map_name(n)));
            let from_disk =
                crate::io::load(&file, &LoadOptions::default()).expect("load from disk");
            assert_eq!(
                from_disk,
                paper_map(n).expect("embedded"),
                "{}",
                paper_map_name(n)
            );
        }
    }

    #[test]
    fn paper_map_numbers_out_of_range_are_errors() {
        assert!(matches!(paper_map(0), Err(MapError::Invalid(_))));
        assert!(matches!(paper_map(11), Err(MapError::Invalid(_))));
        assert_eq!(paper_map_name(3), "test_3");
    }

    #[test]
    fn corner_start_cells_are_free_on_every_paper_map() {
        for n in 1..=PAPER_MAP_COUNT {
            let g = paper_map(n).expect("paper map");
            for corner in Corner::ALL {
                for p in corner.start_cells(g.height(), g.width()) {
                    assert!(
                        g.is_free(p),
                        "{} {corner} start {p} is not free",
                        paper_map_name(n)
                    );
                }
            }
        }
    }

    #[test]
    fn paper_map_densities() {
        for n in 1..=PAPER_MAP_COUNT {
            let g = paper_map(n).expect("paper map");
            let d = g.obstacle_density();
            println!(
                "{}: obstacle density {d:.3}, free space connected: {}",
                paper_map_name(n),
                is_connected(&g)
            );
            if n == 1 || n == 5 {
                println!("{}", to_text(&g));
            }
            assert!(
                (0.10..0.50).contains(&d),
                "{}: density {d}",
                paper_map_name(n)
            );
        }
    }

    #[test]
    fn start_cells_for_20x20() {
        let p = |r, c| Pos::new(r, c);
        for (corner, cells) in [
            (Corner::TopLeft, [p(0, 0), p(1, 0), p(0, 1)]),
            (Corner::TopRight, [p(0, 19), p(1, 19), p(0, 18)]),
            (Corner::BottomLeft, [p(19, 0), p(18, 0), p(19, 1)]),
            (Corner::BottomRight, [p(19, 19), p(18, 19), p(19, 18)]),
        ] {
            assert_eq!(corner.start_cells(20, 20), cells, "{corner}");
        }
        // Non-square grids use H-1 and W-1.
        assert_eq!(
            Corner::BottomRight.start_cells(8, 12),
            [p(7, 11), p(6, 11), p(7, 10)]
        );
        // Degenerate grids stay in bounds.
        assert_eq!(Corner::TopRight.start_cells(1, 1), [p(0, 0); 3]);
    }

    #[test]
    fn corner_names_parse() {
        for c in Corner::ALL {
            assert_eq!(c.name().parse::<Corner>().expect("name"), c);
            assert_eq!(
                c.name()
                    .replace('-', "_")
                    .to_uppercase()
                    .parse::<Corner>()
                    .expect("snake"),
                c
            );
            assert_eq!(c.to_string(), c.name());
        }
        assert_eq!("TL".parse::<Corner>().expect("tl"), Corner::TopLeft);
        assert_eq!("br".parse::<Corner>().expect("br"), Corner::BottomRight);
        let e = "middle".parse::<Corner>().unwrap_err().to_string();
        assert!(
            e.contains("top-left") && e.contains("bottom-right") && e.contains("middle"),
            "{e}"
        );
        assert!(Corner::ALL.len() == 4);
    }

    #[test]
    fn corner_serde_is_kebab_case() {
        // Deserialize via YAML (serde-saphyr is a regular dependency).
        let c: Corner = serde_saphyr::from_str("bottom-left").expect("yaml corner");
        assert_eq!(c, Corner::BottomLeft);
    }
}
