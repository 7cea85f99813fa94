//! Map file IO: ROS `map_server` YAML + image, bare PGM / PNG images and plain-text grids.
//!
//! # Reading ([`load`])
//!
//! The format is chosen from the file extension (case-insensitive):
//!
//! | extension       | format                                                             |
//! |-----------------|--------------------------------------------------------------------|
//! | `.yaml`, `.yml` | ROS `map_server` metadata; the image it names may be PGM or PNG    |
//! | `.pgm`          | bare 8-bit PGM (P5, or ASCII P2) read with `map_server` defaults   |
//! | `.png`          | bare PNG read with `map_server` defaults                            |
//! | `.txt`, `.map`  | text grid: `#` obstacle, `.` free, `?` unknown, one row per line   |
//!
//! A pixel value `v` (0–255) becomes the occupancy probability `p = (255 - v) / 255`, or
//! `p = v / 255` when `negate: 1`. In `trinary` mode (the default) `p > occupied_thresh` is an
//! obstacle, `p < free_thresh` is free and anything in between is unknown. In `scale` mode the
//! classification is the same (a three-state grid cannot hold `map_server`'s graded in-between
//! values, so they read as unknown), but discretization (below) uses the graded probability and
//! fully or partly transparent pixels are unknown. In `raw` mode a pixel value `0..=100` is the
//! occupancy in percent (`p = v / 100`, classified with the thresholds as above, `negate`
//! ignored as in ROS 2 `nav2_map_server`), and any other value is unknown. In trinary and scale
//! mode, pixels with alpha below 255 are unknown (as in `nav2_map_server`). RGB(A) images are
//! converted to luma. Bare images (`.pgm`, `.png`) are read at 1 m/pixel, with `negate: 0`,
//! `occupied_thresh: 0.65`, `free_thresh: 0.196` (the values ROS's map saver writes), trinary.
//!
//! The image's top row is grid row 0. The grid's `origin` is the YAML `origin` (zero for bare
//! images and text grids).
//!
//! ## Cell size and discretization
//!
//! [`LoadOptions::cell_size`] is the size of a robot cell in metres. A map with
//! `resolution == cell_size` is classified pixel by pixel as above. The pixels of a finer map
//! (`resolution < cell_size`) are merged into cells with the paper's rule: when
//! `cell_size / resolution` is within 1e-6 of an integer `factor`, blocks of `factor × factor`
//! pixels ([`crate::discretize::discretize`]); otherwise (0.15 m/pixel with 1 m cells, say)
//! the pixels whose centres fall in the area each cell covers
//! ([`crate::discretize::discretize_area`]). A pixel's probability is the one defined above
//! except that pixels classified as unknown count as not occupied (probability 0). The result
//! has `resolution = cell_size` and never contains unknown cells. A map coarser than
//! `cell_size` is an error naming the field `resolution`. Text grids are already in robot
//! cells: their resolution is set to `cell_size`.
//!
//! # Writing ([`save`])
//!
//! [`save_yaml`] writes `<stem>.pgm` (binary P5: free 254, obstacle 0, unknown 205, as ROS's
//! map saver does) next to a YAML file with `mode: trinary`, `negate: 0`,
//! `occupied_thresh: 0.65` and `free_thresh: 0.196`, so that reading it back gives the same
//! grid (205 reads as `p = 50/255 ≈ 0.19608`, not below 0.196, hence unknown). [`save_png`]
//! and the bare-PGM writer use the same pixel values. [`save_text`] writes the text grid.
//! Every file is written atomically (to a temporary file in the same folder, then renamed).
//!
//! # Layout
//!
//! This module holds the public entry points ([`load`], [`load_bytes`], [`save`]) and the
//! helpers they share; each format lives in its own file: `yaml` (ROS `map_server` metadata,
//! read and written), `pgm` (the PGM decoder and encoder), `raster` (other images through the
//! `image` crate, and decoded pixels → grid) and `text` (the text grid).

mod pgm;
mod raster;
#[cfg(test)]
mod tests;
mod text;
mod yaml;

pub use pgm::save_pgm;
pub use raster::save_png;
pub use text::{parse_text, save_text, to_text};
pub(crate) use yaml::load_map_server_with;
pub use yaml::save_yaml;

use crate::discretize::DiscretizeParams;
use crate::{MapError, OccGrid, Occupancy};
use std::path::{Path, PathBuf};
use yaml::MapMeta;

/// Options for [`load`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadOptions {
    /// Size of a robot cell in metres (default 1.0). Finer maps are discretized to it.
    pub cell_size: f64,
    /// The rule used when a finer map is discretized to `cell_size`.
    pub discretize: DiscretizeParams,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            cell_size: 1.0,
            discretize: DiscretizeParams::default(),
        }
    }
}

/// Pixel value written for free cells (ROS map saver convention).
pub const PIXEL_FREE: u8 = 254;
/// Pixel value written for obstacle cells.
pub const PIXEL_OBSTACLE: u8 = 0;
/// Pixel value written for unknown cells.
pub const PIXEL_UNKNOWN: u8 = 205;
/// `occupied_thresh` written by [`save_yaml`] and assumed for bare images.
pub const SAVE_OCCUPIED_THRESH: f64 = 0.65;
/// `free_thresh` written by [`save_yaml`] and assumed for bare images.
pub const SAVE_FREE_THRESH: f64 = 0.196;

const SUPPORTED: &str = ".yaml/.yml (ROS map_server), .pgm, .png, .txt/.map (text grid)";

/// Lower-cased extension of `path`, or `""`.
fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// The file formats [`load`] reads, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MapFormat {
    Yaml,
    Pgm,
    Png,
    Text,
}

/// The format of `path` by its extension, or [`MapError::Format`] naming the supported ones.
fn map_format(path: &Path) -> Result<MapFormat, MapError> {
    match extension(path).as_str() {
        "yaml" | "yml" => Ok(MapFormat::Yaml),
        "pgm" => Ok(MapFormat::Pgm),
        "png" => Ok(MapFormat::Png),
        "txt" | "map" => Ok(MapFormat::Text),
        other => Err(format_err(
            path,
            format!(
                "unsupported map file extension {:?}; supported: {SUPPORTED}",
                if other.is_empty() {
                    "(none)".to_string()
                } else {
                    format!(".{other}")
                }
            ),
        )),
    }
}

/// Reads a map, choosing the format from the extension (see the [module docs](self)).
///
/// Errors name the file and the field or line at fault: [`MapError::Io`] when a file cannot
/// be read, [`MapError::Field`] for a bad or missing YAML field (or a resolution that does not
/// fit `opts.cell_size`), [`MapError::Format`] for a malformed file or an unsupported extension,
/// [`MapError::Invalid`] for bad `opts`.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<OccGrid, MapError> {
    check_options(opts)?;
    // An unsupported extension is reported without touching the file.
    map_format(path)?;
    let bytes = read_input(path)?;
    load_bytes(&bytes, path, opts, read_input)
}

/// A map file's (or its image's) bytes, read with the cap of a map
/// ([`madenet_files::InputKind::Map`]): a device or a FIFO never reads without end.
fn read_input(path: &Path) -> Result<Vec<u8>, MapError> {
    madenet_files::read_capped(path, madenet_files::InputKind::Map).map_err(|e| io_err(path, e))
}

/// The pixel size in metres a map file is drawn at: a map_server YAML's `resolution`; 1 m for
/// bare images and text grids (as [`load`] reads them). Loading with this as
/// [`LoadOptions::cell_size`] gives the map at its native resolution, one cell per pixel: the
/// fine geometry a continuous world is built from.
pub fn native_resolution(path: &Path) -> Result<f64, MapError> {
    if map_format(path)? != MapFormat::Yaml {
        return Ok(1.0);
    }
    let bytes = read_input(path)?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        io_err(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e),
        )
    })?;
    Ok(yaml::parse_map_yaml(text, path)?.resolution)
}

/// Reads a map from `bytes`, the contents of the file `path` (which [`load`] reads and passes
/// here): the format is chosen from `path`'s extension and errors name it as [`load`]'s do. A
/// YAML map's image path (resolved against `path`'s folder) is given to `read_image`, which
/// returns the image's bytes. No file is touched except through `read_image`.
pub fn load_bytes(
    bytes: &[u8],
    path: &Path,
    opts: &LoadOptions,
    read_image: impl FnOnce(&Path) -> Result<Vec<u8>, MapError>,
) -> Result<OccGrid, MapError> {
    check_options(opts)?;
    // Text formats must be UTF-8; the error is an I/O one, as `fs::read_to_string`'s was.
    let text = || {
        std::str::from_utf8(bytes).map_err(|e| {
            io_err(
                path,
                std::io::Error::new(std::io::ErrorKind::InvalidData, e),
            )
        })
    };
    match map_format(path)? {
        MapFormat::Yaml => load_map_server_with(text()?, path, opts, read_image),
        MapFormat::Pgm => {
            let raster = pgm::decode_pgm(bytes, path)?;
            raster::raster_to_grid(&raster, &MapMeta::bare(), path, path, opts)
        }
        MapFormat::Png => {
            let raster = raster::decode_image(bytes, path, Some(image::ImageFormat::Png))?;
            raster::raster_to_grid(&raster, &MapMeta::bare(), path, path, opts)
        }
        MapFormat::Text => {
            let mut grid = parse_text(text()?, path)?;
            grid.resolution = opts.cell_size;
            Ok(grid)
        }
    }
}

// Errors: each names the file (and the field, for `field_err`).

pub(crate) fn io_err(path: &Path, source: std::io::Error) -> MapError {
    MapError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn format_err(path: &Path, message: impl Into<String>) -> MapError {
    MapError::Format {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

fn field_err(path: &Path, field: &str, message: impl Into<String>) -> MapError {
    MapError::Field {
        path: path.to_path_buf(),
        field: field.to_string(),
        message: message.into(),
    }
}

/// Rejects `opts` that no map could be loaded with.
fn check_options(opts: &LoadOptions) -> Result<(), MapError> {
    if !(opts.cell_size.is_finite() && opts.cell_size > 0.0) {
        return Err(MapError::Invalid(format!(
            "LoadOptions: field `cell_size` must be a positive number of metres, got {}",
            opts.cell_size
        )));
    }
    let d = &opts.discretize;
    for (name, v) in [
        ("occupied_prob", d.occupied_prob),
        ("obstacle_fraction", d.obstacle_fraction),
    ] {
        if !(0.0..=1.0).contains(&v) {
            return Err(MapError::Invalid(format!(
                "LoadOptions: field `discretize.{name}` must lie in [0, 1], got {v}"
            )));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Writing
// ---------------------------------------------------------------------------------------------

/// Writes `bytes` to `path` ([`madenet_files::write_atomic`]: atomic for regular files,
/// through symlinks, streamed into devices).
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), MapError> {
    madenet_files::write_atomic(path, bytes).map_err(|e| io_err(path, e))
}

/// The pixel value written for a cell ([`PIXEL_FREE`], [`PIXEL_OBSTACLE`], [`PIXEL_UNKNOWN`]).
fn pixel_of(c: Occupancy) -> u8 {
    match c {
        Occupancy::Free => PIXEL_FREE,
        Occupancy::Obstacle => PIXEL_OBSTACLE,
        Occupancy::Unknown => PIXEL_UNKNOWN,
    }
}

/// An empty grid cannot be written as an image or a text grid.
fn check_savable(grid: &OccGrid, path: &Path) -> Result<(), MapError> {
    if grid.is_empty() {
        return Err(format_err(path, "cannot save an empty grid"));
    }
    Ok(())
}

/// The files reading the map at `path` reads: the file and, for a `map_server` YAML, its
/// image (resolved against the YAML's folder; a YAML that does not parse names none).
pub fn files_read(path: &Path) -> Vec<PathBuf> {
    let mut files = vec![path.to_path_buf()];
    if map_format(path).ok() == Some(MapFormat::Yaml) {
        let meta = read_input(path).ok().and_then(|b| {
            let text = String::from_utf8(b).ok()?;
            yaml::parse_map_yaml(&text, path).ok()
        });
        if let Some(meta) = meta {
            files.push(path.parent().unwrap_or(Path::new("")).join(&meta.image));
        }
    }
    files
}

/// The files [`save`] writes for `path`: the file and, for a YAML, its PGM image beside it.
pub fn files_written(path: &Path) -> Vec<PathBuf> {
    let mut files = vec![path.to_path_buf()];
    if matches!(extension(path).as_str(), "yaml" | "yml") {
        files.extend(yaml::image_beside(path));
    }
    files
}

/// Writes `grid` in the format given by the extension: `.yaml`/`.yml` ([`save_yaml`]),
/// `.pgm` ([`save_pgm`]), `.png` ([`save_png`]), `.txt`/`.map` ([`save_text`]).
pub fn save(grid: &OccGrid, path: &Path) -> Result<(), MapError> {
    match extension(path).as_str() {
        "yaml" | "yml" => save_yaml(grid, path),
        "pgm" => save_pgm(grid, path),
        "png" => save_png(grid, path),
        "txt" | "map" => save_text(grid, path),
        _ => Err(format_err(
            path,
            format!("unsupported map file extension; supported: {SUPPORTED}"),
        )),
    }
}
