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

use crate::discretize::{discretize_area, DiscretizeParams};
use crate::{MapError, OccGrid, Occupancy};
use serde::de::{self, Deserialize, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use std::collections::BTreeMap;
use std::fmt;
use std::fs;
use std::path::Path;
#[cfg(test)]
use std::path::PathBuf;
#[cfg(test)]
use std::sync::atomic::{AtomicU64, Ordering};

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
    let bytes = fs::read(path).map_err(|e| io_err(path, e))?;
    load_bytes(&bytes, path, opts, |image| {
        fs::read(image).map_err(|e| io_err(image, e))
    })
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
            let raster = decode_pgm(bytes, path)?;
            raster_to_grid(&raster, &MapMeta::bare(), path, path, opts)
        }
        MapFormat::Png => {
            let raster = decode_image(bytes, path, Some(image::ImageFormat::Png))?;
            raster_to_grid(&raster, &MapMeta::bare(), path, path, opts)
        }
        MapFormat::Text => {
            let mut grid = parse_text(text()?, path)?;
            grid.resolution = opts.cell_size;
            Ok(grid)
        }
    }
}

fn io_err(path: &Path, source: std::io::Error) -> MapError {
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
// ROS map_server metadata
// ---------------------------------------------------------------------------------------------

/// How pixel values are interpreted (ROS `map_server` `mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MapMode {
    Trinary,
    Scale,
    Raw,
}

/// The fields of a ROS `map_server` YAML file.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MapMeta {
    pub image: String,
    pub resolution: f64,
    pub origin: [f64; 3],
    pub negate: bool,
    pub occupied_thresh: f64,
    pub free_thresh: f64,
    pub mode: MapMode,
}

impl MapMeta {
    /// The assumptions for a bare image: 1 m/pixel, map saver thresholds, trinary.
    fn bare() -> Self {
        MapMeta {
            image: String::new(),
            resolution: 1.0,
            origin: [0.0; 3],
            negate: false,
            occupied_thresh: SAVE_OCCUPIED_THRESH,
            free_thresh: SAVE_FREE_THRESH,
            mode: MapMode::Trinary,
        }
    }
}

/// Any YAML value, enough to give precise type errors per field.
#[derive(Clone, Debug, PartialEq)]
enum Val {
    Null,
    Bool(bool),
    Int(i128),
    Float(f64),
    Str(String),
    Seq(Vec<Val>),
    Map,
}

impl Val {
    fn kind(&self) -> &'static str {
        match self {
            Val::Null => "null",
            Val::Bool(_) => "a boolean",
            Val::Int(_) => "an integer",
            Val::Float(_) => "a number",
            Val::Str(_) => "a string",
            Val::Seq(_) => "a list",
            Val::Map => "a mapping",
        }
    }
    fn as_f64(&self) -> Option<f64> {
        match *self {
            Val::Int(i) => Some(i as f64),
            Val::Float(f) => Some(f),
            _ => None,
        }
    }
}

impl<'de> Deserialize<'de> for Val {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(ValVisitor)
    }
}

struct ValVisitor;

impl<'de> Visitor<'de> for ValVisitor {
    type Value = Val;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("any YAML value")
    }
    fn visit_bool<E: de::Error>(self, v: bool) -> Result<Val, E> {
        Ok(Val::Bool(v))
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Val, E> {
        Ok(Val::Int(v.into()))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Val, E> {
        Ok(Val::Int(v.into()))
    }
    fn visit_i128<E: de::Error>(self, v: i128) -> Result<Val, E> {
        Ok(Val::Int(v))
    }
    fn visit_u128<E: de::Error>(self, v: u128) -> Result<Val, E> {
        Ok(i128::try_from(v)
            .map(Val::Int)
            .unwrap_or(Val::Float(v as f64)))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Val, E> {
        Ok(Val::Float(v))
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<Val, E> {
        Ok(Val::Str(v.to_string()))
    }
    fn visit_string<E: de::Error>(self, v: String) -> Result<Val, E> {
        Ok(Val::Str(v))
    }
    fn visit_unit<E: de::Error>(self) -> Result<Val, E> {
        Ok(Val::Null)
    }
    fn visit_none<E: de::Error>(self) -> Result<Val, E> {
        Ok(Val::Null)
    }
    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Val, D::Error> {
        Val::deserialize(d)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Val, A::Error> {
        let mut out = Vec::new();
        while let Some(v) = seq.next_element::<Val>()? {
            out.push(v);
        }
        Ok(Val::Seq(out))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Val, A::Error> {
        while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
        Ok(Val::Map)
    }
}

/// Parses and validates ROS `map_server` YAML text. Unknown keys are ignored (as ROS does).
pub(crate) fn parse_map_yaml(text: &str, yaml_path: &Path) -> Result<MapMeta, MapError> {
    let doc: BTreeMap<String, Val> = serde_saphyr::from_str(text).map_err(|e| {
        format_err(
            yaml_path,
            format!("not a valid map_server YAML mapping: {e}"),
        )
    })?;
    let field = |name: &str| doc.get(name).filter(|v| **v != Val::Null);
    let missing = |name: &str| field_err(yaml_path, name, "missing required field");
    let number = |name: &str| -> Result<f64, MapError> {
        let v = field(name).ok_or_else(|| missing(name))?;
        let x = v.as_f64().ok_or_else(|| {
            field_err(
                yaml_path,
                name,
                format!("expected a number, found {}", v.kind()),
            )
        })?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(field_err(
                yaml_path,
                name,
                format!("must be finite, got {x}"),
            ))
        }
    };

    let image = match field("image").ok_or_else(|| missing("image"))? {
        Val::Str(s) if !s.trim().is_empty() => s.trim().to_string(),
        Val::Str(_) => return Err(field_err(yaml_path, "image", "must not be empty")),
        v => {
            return Err(field_err(
                yaml_path,
                "image",
                format!("expected a file name, found {}", v.kind()),
            ))
        }
    };

    let resolution = number("resolution")?;
    if resolution <= 0.0 {
        return Err(field_err(
            yaml_path,
            "resolution",
            format!("must be positive (metres per pixel), got {resolution}"),
        ));
    }

    let origin = match field("origin").ok_or_else(|| missing("origin"))? {
        Val::Seq(items) if items.len() == 3 => {
            let mut o = [0.0; 3];
            for (slot, item) in o.iter_mut().zip(items) {
                *slot = item.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
                    field_err(
                        yaml_path,
                        "origin",
                        format!(
                            "expected three finite numbers [x, y, yaw], found {}",
                            item.kind()
                        ),
                    )
                })?;
            }
            o
        }
        v => {
            let found = match v {
                Val::Seq(items) => format!("a list of {} items", items.len()),
                other => other.kind().to_string(),
            };
            return Err(field_err(
                yaml_path,
                "origin",
                format!("expected [x, y, yaw], found {found}"),
            ));
        }
    };

    let negate = match field("negate") {
        None => false,
        Some(Val::Int(0)) | Some(Val::Bool(false)) => false,
        Some(Val::Int(1)) | Some(Val::Bool(true)) => true,
        Some(v) => {
            let found = match v {
                Val::Int(i) => i.to_string(),
                other => other.kind().to_string(),
            };
            return Err(field_err(
                yaml_path,
                "negate",
                format!("expected 0 or 1, found {found}"),
            ));
        }
    };

    let occupied_thresh = number("occupied_thresh")?;
    let free_thresh = number("free_thresh")?;
    for (name, v) in [
        ("occupied_thresh", occupied_thresh),
        ("free_thresh", free_thresh),
    ] {
        if !(0.0..=1.0).contains(&v) {
            return Err(field_err(
                yaml_path,
                name,
                format!("must lie in [0, 1], got {v}"),
            ));
        }
    }
    if free_thresh >= occupied_thresh {
        return Err(field_err(
            yaml_path,
            "free_thresh",
            format!("must be below occupied_thresh ({occupied_thresh}), got {free_thresh}"),
        ));
    }

    let mode = match field("mode") {
        None => MapMode::Trinary,
        Some(Val::Str(s)) => match s.trim().to_ascii_lowercase().as_str() {
            "trinary" => MapMode::Trinary,
            "scale" => MapMode::Scale,
            "raw" => MapMode::Raw,
            other => {
                return Err(field_err(
                    yaml_path,
                    "mode",
                    format!("expected trinary, scale or raw, found {other:?}"),
                ))
            }
        },
        Some(v) => {
            return Err(field_err(
                yaml_path,
                "mode",
                format!("expected trinary, scale or raw, found {}", v.kind()),
            ))
        }
    };

    Ok(MapMeta {
        image,
        resolution,
        origin,
        negate,
        occupied_thresh,
        free_thresh,
        mode,
    })
}

/// Loads a `map_server` map from YAML text; `read_image` is given the image path (resolved
/// against the YAML's folder) and returns its bytes. Shared by [`load`] and the embedded
/// paper maps.
pub(crate) fn load_map_server_with(
    yaml_text: &str,
    yaml_path: &Path,
    opts: &LoadOptions,
    read_image: impl FnOnce(&Path) -> Result<Vec<u8>, MapError>,
) -> Result<OccGrid, MapError> {
    check_options(opts)?;
    let meta = parse_map_yaml(yaml_text, yaml_path)?;
    let image_path = yaml_path
        .parent()
        .unwrap_or(Path::new(""))
        .join(&meta.image);
    let bytes = read_image(&image_path)?;
    let raster = if extension(&image_path) == "pgm" {
        decode_pgm(&bytes, &image_path)?
    } else {
        decode_image(&bytes, &image_path, None)?
    };
    raster_to_grid(&raster, &meta, yaml_path, &image_path, opts)
}

// ---------------------------------------------------------------------------------------------
// Images
// ---------------------------------------------------------------------------------------------

/// A decoded 8-bit grayscale image, row-major from the top row.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Raster {
    pub width: usize,
    pub height: usize,
    pub gray: Vec<u8>,
    /// Alpha per pixel, when the image has an alpha channel.
    pub alpha: Option<Vec<u8>>,
}

/// Why a PGM number token could not be read.
enum PgmToken {
    End,
    NotDigit(u8),
    TooLarge,
}

/// Reads one whitespace-separated decimal number of a PGM (skipping `#` comments).
fn pgm_number(bytes: &[u8], pos: &mut usize) -> Result<usize, PgmToken> {
    skip_pgm_space(bytes, pos);
    let start = *pos;
    let mut value: usize = 0;
    while let Some(&b) = bytes.get(*pos).filter(|b| b.is_ascii_digit()) {
        value = value
            .checked_mul(10)
            .and_then(|v| v.checked_add((b - b'0') as usize))
            .ok_or(PgmToken::TooLarge)?;
        *pos += 1;
    }
    if start == *pos {
        return Err(bytes
            .get(*pos)
            .map_or(PgmToken::End, |&b| PgmToken::NotDigit(b)));
    }
    Ok(value)
}

/// Reads a PGM number, describing a failure as an error about `what` in `path`.
fn pgm_field(
    bytes: &[u8],
    pos: &mut usize,
    what: impl Fn() -> String,
    path: &Path,
) -> Result<usize, MapError> {
    pgm_number(bytes, pos).map_err(|e| match e {
        PgmToken::End => format_err(
            path,
            format!("truncated PGM: file ends before the {}", what()),
        ),
        PgmToken::NotDigit(b) => format_err(
            path,
            format!(
                "garbled PGM: expected the {} (a number), found byte 0x{b:02x}",
                what()
            ),
        ),
        PgmToken::TooLarge => format_err(path, format!("garbled PGM: the {} is too large", what())),
    })
}

fn skip_pgm_space(bytes: &[u8], pos: &mut usize) {
    while *pos < bytes.len() {
        if bytes[*pos].is_ascii_whitespace() {
            *pos += 1;
        } else if bytes[*pos] == b'#' {
            while *pos < bytes.len() && bytes[*pos] != b'\n' && bytes[*pos] != b'\r' {
                *pos += 1;
            }
        } else {
            break;
        }
    }
}

/// Decodes an 8-bit PGM: binary P5 or ASCII P2, `maxval` 1–255 (values are rescaled to
/// 0–255 when `maxval < 255`). Every error names `path`.
pub(crate) fn decode_pgm(bytes: &[u8], path: &Path) -> Result<Raster, MapError> {
    let binary = match bytes.get(..2) {
        Some(b"P5") => true,
        Some(b"P2") => false,
        _ => {
            return Err(format_err(
                path,
                "not an 8-bit PGM image: the file must start with P5 (binary) or P2 (ASCII)",
            ));
        }
    };
    let mut pos = 2;
    if bytes
        .get(pos)
        .is_some_and(|b| !b.is_ascii_whitespace() && *b != b'#')
    {
        return Err(format_err(
            path,
            "garbled PGM header: expected whitespace after the magic number",
        ));
    }
    let width = pgm_field(bytes, &mut pos, || "header width".into(), path)?;
    let height = pgm_field(bytes, &mut pos, || "header height".into(), path)?;
    let maxval = pgm_field(bytes, &mut pos, || "header maxval".into(), path)?;
    if width == 0 || height == 0 {
        return Err(format_err(
            path,
            format!("PGM image is empty ({width}×{height} pixels)"),
        ));
    }
    if !(1..=255).contains(&maxval) {
        return Err(format_err(
            path,
            format!("PGM maxval {maxval} is not supported (8-bit images only: 1..=255)"),
        ));
    }
    let n = width.checked_mul(height).ok_or_else(|| {
        format_err(
            path,
            format!("garbled PGM header: {width}×{height} pixels is too large"),
        )
    })?;
    let scale = |v: usize| -> Result<u8, MapError> {
        if v > maxval {
            return Err(format_err(
                path,
                format!("PGM pixel value {v} exceeds maxval {maxval}"),
            ));
        }
        // Rescale to 0..=255, rounding to nearest; exact when maxval == 255.
        Ok(((v * 255 + maxval / 2) / maxval) as u8)
    };
    let mut gray = Vec::with_capacity(n.min(bytes.len()));
    if binary {
        // Exactly one whitespace byte separates maxval from the raster.
        match bytes.get(pos) {
            Some(b) if b.is_ascii_whitespace() => pos += 1,
            Some(_) => {
                return Err(format_err(
                    path,
                    "garbled PGM header: expected whitespace after maxval",
                ))
            }
            None => {
                return Err(format_err(
                    path,
                    format!("truncated PGM: no pixel data (expected {n} bytes)"),
                ))
            }
        }
        let data = &bytes[pos..];
        if data.len() < n {
            return Err(format_err(
                path,
                format!(
                    "truncated PGM: expected {n} pixel bytes for {width}×{height}, found {}",
                    data.len()
                ),
            ));
        }
        for &b in &data[..n] {
            gray.push(scale(b as usize)?);
        }
    } else {
        for i in 0..n {
            let v = pgm_field(
                bytes,
                &mut pos,
                || format!("pixel value #{} of {n}", i + 1),
                path,
            )?;
            gray.push(scale(v)?);
        }
    }
    Ok(Raster {
        width,
        height,
        gray,
        alpha: None,
    })
}

/// Decodes an image with the `image` crate (format guessed from the content unless given),
/// converting it to 8-bit luma (+ alpha when present).
fn decode_image(
    bytes: &[u8],
    path: &Path,
    format: Option<image::ImageFormat>,
) -> Result<Raster, MapError> {
    let img = match format {
        Some(f) => image::load_from_memory_with_format(bytes, f),
        None => image::load_from_memory(bytes),
    }
    .map_err(|e| format_err(path, format!("cannot decode image: {e}")))?;
    let (width, height) = (img.width() as usize, img.height() as usize);
    if width == 0 || height == 0 {
        return Err(format_err(
            path,
            format!("image is empty ({width}×{height} pixels)"),
        ));
    }
    let has_alpha = img.color().has_alpha();
    let la = img.to_luma_alpha8();
    let gray = la.pixels().map(|p| p.0[0]).collect();
    let alpha = has_alpha.then(|| la.pixels().map(|p| p.0[1]).collect());
    Ok(Raster {
        width,
        height,
        gray,
        alpha,
    })
}

/// Occupancy probability and three-state class of one pixel under `meta`.
fn classify_pixel(meta: &MapMeta, v: u8, alpha: u8) -> (f64, Occupancy) {
    let by_thresholds = |p: f64| {
        if p > meta.occupied_thresh {
            Occupancy::Obstacle
        } else if p < meta.free_thresh {
            Occupancy::Free
        } else {
            Occupancy::Unknown
        }
    };
    match meta.mode {
        MapMode::Trinary | MapMode::Scale => {
            let p = if meta.negate {
                v as f64 / 255.0
            } else {
                (255 - v) as f64 / 255.0
            };
            if alpha < 255 {
                (p, Occupancy::Unknown)
            } else {
                (p, by_thresholds(p))
            }
        }
        MapMode::Raw => {
            if v <= 100 {
                let p = v as f64 / 100.0;
                (p, by_thresholds(p))
            } else {
                (0.0, Occupancy::Unknown)
            }
        }
    }
}

/// `cell_size / resolution`, the robot cell in pixels (≥ 1; within 1e-6 of a whole number it is
/// that number), or an error naming the field `resolution` of `path` for a map coarser than the
/// cell; `note` is appended to the message.
fn cell_in_pixels(
    resolution: f64,
    cell_size: f64,
    path: &Path,
    note: &str,
) -> Result<f64, MapError> {
    let ratio = cell_size / resolution;
    if ratio < 1.0 - 1e-6 {
        return Err(field_err(
            path,
            "resolution",
            format!("map resolution {resolution} m/pixel is coarser than the robot cell size {cell_size} m{note}"),
        ));
    }
    if !ratio.is_finite() || ratio > u32::MAX as f64 {
        return Err(field_err(
            path,
            "resolution",
            format!(
                "robot cell size {cell_size} m is {ratio} pixels of {resolution} m: too many{note}"
            ),
        ));
    }
    Ok(if (ratio - ratio.round()).abs() <= 1e-6 {
        ratio.round()
    } else {
        ratio
    })
}

/// Turns a decoded image into a grid at `opts.cell_size` (see the module docs).
/// `meta_path` is named in resolution errors, `image_path` in image errors.
fn raster_to_grid(
    raster: &Raster,
    meta: &MapMeta,
    meta_path: &Path,
    image_path: &Path,
    opts: &LoadOptions,
) -> Result<OccGrid, MapError> {
    let n = raster.width * raster.height;
    if raster.gray.len() != n || raster.alpha.as_ref().is_some_and(|a| a.len() != n) {
        return Err(format_err(
            image_path,
            "internal error: decoded image has the wrong pixel count",
        ));
    }
    let note = if meta_path == image_path {
        " (bare images are read at 1 m/pixel; use a map_server YAML for other resolutions)"
    } else {
        ""
    };
    let cell_px = cell_in_pixels(meta.resolution, opts.cell_size, meta_path, note)?;
    let alpha_at = |i: usize| raster.alpha.as_ref().map_or(255, |a| a[i]);
    let mut grid = if cell_px == 1.0 {
        let cells = (0..n)
            .map(|i| classify_pixel(meta, raster.gray[i], alpha_at(i)).1)
            .collect();
        let mut g = OccGrid::from_cells(raster.height, raster.width, cells);
        g.resolution = meta.resolution;
        g
    } else {
        let probs: Vec<f64> = (0..n)
            .map(|i| {
                let (p, class) = classify_pixel(meta, raster.gray[i], alpha_at(i));
                let graded = meta.mode == MapMode::Scale && alpha_at(i) == 255;
                if class == Occupancy::Unknown && !graded {
                    0.0
                } else {
                    p
                }
            })
            .collect();
        let mut g = discretize_area(
            &probs,
            raster.height,
            raster.width,
            cell_px,
            &opts.discretize,
        );
        g.resolution = opts.cell_size;
        g
    };
    // The origin is the lower-left corner. A partial cell at the bottom extends the grid below
    // the image by `pad` metres, so move the origin down (along the map's rotated -y axis).
    grid.origin = meta.origin;
    let pad = grid.height() as f64 * grid.resolution - raster.height as f64 * meta.resolution;
    if pad > 1e-9 {
        let [x, y, yaw] = meta.origin;
        grid.origin = [x + pad * yaw.sin(), y - pad * yaw.cos(), yaw];
    }
    Ok(grid)
}

// ---------------------------------------------------------------------------------------------
// Text grids
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Writing
// ---------------------------------------------------------------------------------------------

/// Writes `bytes` to `path` ([`madenet_files::write_atomic`]: atomic for regular files,
/// through symlinks, streamed into devices).
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), MapError> {
    madenet_files::write_atomic(path, bytes).map_err(|e| io_err(path, e))
}

fn pixel_of(c: Occupancy) -> u8 {
    match c {
        Occupancy::Free => PIXEL_FREE,
        Occupancy::Obstacle => PIXEL_OBSTACLE,
        Occupancy::Unknown => PIXEL_UNKNOWN,
    }
}

fn check_savable(grid: &OccGrid, path: &Path) -> Result<(), MapError> {
    if grid.is_empty() {
        return Err(format_err(path, "cannot save an empty grid"));
    }
    Ok(())
}

/// Encodes a grid as a binary P5 PGM (free 254, obstacle 0, unknown 205).
fn encode_pgm(grid: &OccGrid) -> Vec<u8> {
    let mut out = format!(
        "P5\n# madenet occupancy grid: free 254, obstacle 0, unknown 205\n{} {}\n255\n",
        grid.width(),
        grid.height()
    )
    .into_bytes();
    out.extend(grid.cells().iter().map(|&c| pixel_of(c)));
    out
}

/// `s` as a YAML scalar, double-quoted when it contains anything unusual.
fn yaml_string(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "._-/".contains(c))
    {
        s.to_string()
    } else {
        let escaped: String = s
            .chars()
            .flat_map(|c| match c {
                '"' => vec!['\\', '"'],
                '\\' => vec!['\\', '\\'],
                c => vec![c],
            })
            .collect();
        format!("\"{escaped}\"")
    }
}

/// Writes `grid` as a ROS `map_server` map: `<stem>.pgm` next to `yaml_path` (binary P5, free
/// 254, obstacle 0, unknown 205) and the YAML itself (`image` relative, `mode: trinary`,
/// the grid's `resolution` and `origin`, `negate: 0`, `occupied_thresh: 0.65`,
/// `free_thresh: 0.196`). [`load`] with `cell_size == grid.resolution` reads back the same
/// grid. Both files are written atomically, the image first.
pub fn save_yaml(grid: &OccGrid, yaml_path: &Path) -> Result<(), MapError> {
    check_savable(grid, yaml_path)?;
    if !(grid.resolution.is_finite() && grid.resolution > 0.0) {
        return Err(field_err(
            yaml_path,
            "resolution",
            format!("must be positive and finite, got {}", grid.resolution),
        ));
    }
    if grid.origin.iter().any(|x| !x.is_finite()) {
        return Err(field_err(
            yaml_path,
            "origin",
            format!("must be finite, got {:?}", grid.origin),
        ));
    }
    let stem = yaml_path
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|s| !s.is_empty())
        .ok_or_else(|| format_err(yaml_path, "YAML path needs a UTF-8 file name"))?;
    let image_name = format!("{stem}.pgm");
    let image_path = yaml_path.with_file_name(&image_name);
    write_atomic(&image_path, &encode_pgm(grid))?;
    let [x, y, yaw] = grid.origin;
    let yaml = format!(
        "image: {}\nmode: trinary\nresolution: {:?}\norigin: [{x:?}, {y:?}, {yaw:?}]\nnegate: 0\noccupied_thresh: {SAVE_OCCUPIED_THRESH:?}\nfree_thresh: {SAVE_FREE_THRESH:?}\n",
        yaml_string(&image_name),
        grid.resolution,
    );
    write_atomic(yaml_path, yaml.as_bytes())
}

/// Writes `grid` as a bare binary P5 PGM (free 254, obstacle 0, unknown 205), atomically.
pub fn save_pgm(grid: &OccGrid, path: &Path) -> Result<(), MapError> {
    check_savable(grid, path)?;
    write_atomic(path, &encode_pgm(grid))
}

/// Writes `grid` as an 8-bit grayscale PNG (free 254, obstacle 0, unknown 205), atomically.
pub fn save_png(grid: &OccGrid, path: &Path) -> Result<(), MapError> {
    use image::ImageEncoder;
    check_savable(grid, path)?;
    let (w, h) = match (u32::try_from(grid.width()), u32::try_from(grid.height())) {
        (Ok(w), Ok(h)) => (w, h),
        _ => return Err(format_err(path, "grid too large for a PNG")),
    };
    let pixels: Vec<u8> = grid.cells().iter().map(|&c| pixel_of(c)).collect();
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(&pixels, w, h, image::ExtendedColorType::L8)
        .map_err(|e| format_err(path, format!("cannot encode PNG: {e}")))?;
    write_atomic(path, &buf)
}

/// Writes `grid` as a text grid ([`to_text`]), atomically.
pub fn save_text(grid: &OccGrid, path: &Path) -> Result<(), MapError> {
    check_savable(grid, path)?;
    write_atomic(path, to_text(grid).as_bytes())
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::Pos;
    use proptest::prelude::*;

    /// A fresh, empty folder under the system temp dir, unique to this process and call.
    pub(crate) fn temp_dir(name: &str) -> PathBuf {
        static N: AtomicU64 = AtomicU64::new(0);
        let dir = std::env::temp_dir().join(format!(
            "madenet-map-test-{}-{name}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("create temp dir");
        dir
    }

    fn grid_strategy(max: usize) -> impl Strategy<Value = OccGrid> {
        (1..=max, 1..=max).prop_flat_map(|(h, w)| {
            proptest::collection::vec(
                prop_oneof![
                    Just(Occupancy::Free),
                    Just(Occupancy::Obstacle),
                    Just(Occupancy::Unknown)
                ],
                h * w,
            )
            .prop_map(move |cells| OccGrid::from_cells(h, w, cells))
        })
    }

    const YAML_OK: &str = "image: m.pgm\nresolution: 1.0\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
        let p = dir.join(name);
        fs::write(&p, bytes).expect("write test file");
        p
    }

    fn assert_names(err: &MapError, needle: &str) {
        let msg = err.to_string();
        assert!(
            msg.contains(needle),
            "error {msg:?} should mention {needle:?}"
        );
    }

    fn small_pgm() -> Vec<u8> {
        b"P5\n3 2\n255\n\x00\xfe\xcd\xfe\xfe\x00".to_vec()
    }

    #[test]
    fn save_thresholds_round_trip_the_three_pixel_values() {
        let meta = MapMeta::bare();
        assert_eq!(classify_pixel(&meta, PIXEL_FREE, 255).1, Occupancy::Free);
        assert_eq!(
            classify_pixel(&meta, PIXEL_OBSTACLE, 255).1,
            Occupancy::Obstacle
        );
        assert_eq!(
            classify_pixel(&meta, PIXEL_UNKNOWN, 255).1,
            Occupancy::Unknown
        );
        // 205 → 50/255 = 0.19608 ≥ 0.196 (not free) but 0.25 would make it free.
        let p_unknown = f64::from(255 - PIXEL_UNKNOWN) / 255.0;
        assert!(p_unknown > SAVE_FREE_THRESH && p_unknown < 0.25);
    }

    #[test]
    fn reads_yaml_with_pgm() {
        let dir = temp_dir("yaml-ok");
        write(&dir, "m.pgm", &small_pgm());
        let yaml = write(
            &dir,
            "m.yaml",
            YAML_OK
                .replace("[0.0, 0.0, 0.0]", "[1.5, -2, 0.0]")
                .as_bytes(),
        );
        let g = load(&yaml, &LoadOptions::default()).expect("load");
        assert_eq!((g.height(), g.width()), (2, 3));
        assert_eq!(to_text(&g), "#.?\n..#\n");
        assert_eq!(g.origin, [1.5, -2.0, 0.0]);
        assert_eq!(g.resolution, 1.0);
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn negate_and_modes() {
        let dir = temp_dir("modes");
        write(&dir, "m.pgm", &small_pgm());
        let negated = write(
            &dir,
            "n.yaml",
            YAML_OK.replace("negate: 0", "negate: 1").as_bytes(),
        );
        let g = load(&negated, &LoadOptions::default()).expect("negated");
        // 0 → p 0 free; 254 → p 0.996 obstacle; 205 → p 0.80 obstacle.
        assert_eq!(to_text(&g), ".##\n##.\n");
        let scale = write(&dir, "s.yaml", format!("{YAML_OK}mode: scale\n").as_bytes());
        assert_eq!(
            to_text(&load(&scale, &LoadOptions::default()).expect("scale")),
            "#.?\n..#\n"
        );
        // Raw: values 0..=100 are percentages; 205 and 254 are unknown.
        write(&dir, "r.pgm", b"P5\n4 1\n255\n\x00\x32\x64\xfe");
        let raw = write(
            &dir,
            "r.yaml",
            format!("{}mode: raw\n", YAML_OK.replace("m.pgm", "r.pgm")).as_bytes(),
        );
        assert_eq!(
            to_text(&load(&raw, &LoadOptions::default()).expect("raw")),
            ".?#?\n"
        );
        let bad = write(&dir, "b.yaml", format!("{YAML_OK}mode: fancy\n").as_bytes());
        let e = load(&bad, &LoadOptions::default()).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "mode"),
            "{e}"
        );
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn ascii_pgm_and_maxval_scaling() {
        let dir = temp_dir("p2");
        // maxval 1: 0 → 0 (obstacle), 1 → 255 (free).
        let p = write(&dir, "a.pgm", b"P2\n# comment\n2 2\n1\n0 1\n1 0\n");
        assert_eq!(
            to_text(&load(&p, &LoadOptions::default()).expect("p2")),
            "#.\n.#\n"
        );
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn bad_inputs_give_the_right_error() {
        let dir = temp_dir("bad");
        let opts = LoadOptions::default();
        write(&dir, "m.pgm", &small_pgm());

        let missing = dir.join("nope.yaml");
        let e = load(&missing, &opts).unwrap_err();
        assert!(matches!(e, MapError::Io { .. }), "{e}");
        assert_names(&e, "nope.yaml");

        let no_res = write(
            &dir,
            "nores.yaml",
            YAML_OK.replace("resolution: 1.0\n", "").as_bytes(),
        );
        let e = load(&no_res, &opts).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "resolution"),
            "{e}"
        );
        assert_names(&e, "nores.yaml");

        let wrong_type = write(
            &dir,
            "type.yaml",
            YAML_OK
                .replace("resolution: 1.0", "resolution: fine")
                .as_bytes(),
        );
        let e = load(&wrong_type, &opts).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "resolution"),
            "{e}"
        );

        let neg_res = write(
            &dir,
            "negres.yaml",
            YAML_OK
                .replace("resolution: 1.0", "resolution: -1")
                .as_bytes(),
        );
        let e = load(&neg_res, &opts).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "resolution"),
            "{e}"
        );

        let bad_thresh = write(
            &dir,
            "thresh.yaml",
            YAML_OK
                .replace("occupied_thresh: 0.65", "occupied_thresh: 1.5")
                .as_bytes(),
        );
        let e = load(&bad_thresh, &opts).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "occupied_thresh"),
            "{e}"
        );
        assert_names(&e, "thresh.yaml");

        let crossed = write(
            &dir,
            "crossed.yaml",
            YAML_OK
                .replace("free_thresh: 0.196", "free_thresh: 0.7")
                .as_bytes(),
        );
        let e = load(&crossed, &opts).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "free_thresh"),
            "{e}"
        );

        let bad_origin = write(
            &dir,
            "origin.yaml",
            YAML_OK.replace("[0.0, 0.0, 0.0]", "[0.0, 0.0]").as_bytes(),
        );
        let e = load(&bad_origin, &opts).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "origin"),
            "{e}"
        );

        let bad_negate = write(
            &dir,
            "negate.yaml",
            YAML_OK.replace("negate: 0", "negate: 2").as_bytes(),
        );
        let e = load(&bad_negate, &opts).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "negate"),
            "{e}"
        );

        let garbage = write(&dir, "garbage.yaml", b"image: [unclosed\n  - : :");
        let e = load(&garbage, &opts).unwrap_err();
        assert!(matches!(e, MapError::Format { .. }), "{e}");
        assert_names(&e, "garbage.yaml");

        let missing_image = write(
            &dir,
            "noimg.yaml",
            YAML_OK.replace("m.pgm", "absent.pgm").as_bytes(),
        );
        let e = load(&missing_image, &opts).unwrap_err();
        assert!(matches!(e, MapError::Io { .. }), "{e}");
        assert_names(&e, "absent.pgm");

        // Truncated and garbled PGMs, directly and through a YAML.
        let full = small_pgm();
        for (i, bytes) in [
            &full[..full.len() - 2],
            &full[..8],
            &full[..3],
            b"P5\n3 x\n255\n",
            b"P6\n1 1\n255\n\x00",
            b"",
            b"P5\n1 1\n65535\n\x00\x00",
        ]
        .iter()
        .enumerate()
        {
            let name = format!("t{i}.pgm");
            let p = write(&dir, &name, bytes);
            let e = load(&p, &opts).unwrap_err();
            assert!(matches!(e, MapError::Format { .. }), "{e}");
            assert_names(&e, &name);
            let y = write(
                &dir,
                &format!("t{i}.yaml"),
                YAML_OK.replace("m.pgm", &name).as_bytes(),
            );
            let e = load(&y, &opts).unwrap_err();
            assert_names(&e, &name);
        }

        let png = write(&dir, "broken.png", b"\x89PNG\r\n\x1a\nnot really");
        let e = load(&png, &opts).unwrap_err();
        assert!(matches!(e, MapError::Format { .. }), "{e}");
        assert_names(&e, "broken.png");

        let ragged = write(&dir, "ragged.txt", b"...\n..\n...\n");
        let e = load(&ragged, &opts).unwrap_err();
        assert!(matches!(e, MapError::Format { .. }), "{e}");
        assert_names(&e, "ragged.txt");
        assert_names(&e, "line 2");

        let bad_char = write(&dir, "char.txt", b"...\n.x.\n");
        let e = load(&bad_char, &opts).unwrap_err();
        assert!(matches!(e, MapError::Format { .. }), "{e}");
        assert_names(&e, "char.txt");
        assert_names(&e, "line 2, column 2");

        let empty = write(&dir, "empty.txt", b"\n\n");
        assert!(matches!(
            load(&empty, &opts).unwrap_err(),
            MapError::Format { .. }
        ));

        let unsupported = write(&dir, "map.bmp", b"BM");
        let e = load(&unsupported, &opts).unwrap_err();
        assert_names(&e, "map.bmp");
        assert_names(&e, ".yaml");

        let e = load(
            &dir.join("m.pgm"),
            &LoadOptions {
                cell_size: 0.0,
                ..opts
            },
        )
        .unwrap_err();
        assert!(matches!(e, MapError::Invalid(_)), "{e}");
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn resolution_must_not_be_coarser_than_the_cell_size() {
        let dir = temp_dir("res");
        write(&dir, "m.pgm", &small_pgm());
        let yaml = write(&dir, "m.yaml", YAML_OK.as_bytes());
        let e = load(
            &yaml,
            &LoadOptions {
                cell_size: 0.5,
                ..LoadOptions::default()
            },
        )
        .unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == "resolution"),
            "{e}"
        );
        let coarse = write(
            &dir,
            "c.yaml",
            YAML_OK
                .replace("resolution: 1.0", "resolution: 0.3")
                .as_bytes(),
        );
        // 1 m cells of 3.33 pixels of 0.3 m: the 3 × 2 image (0.9 × 0.6 m) is one cell
        // holding all six pixel centres, 2 of them occupied (33 % > 25 %); the cell reaches
        // 0.4 m below the image, so the origin moves down by that.
        let g = load(&coarse, &LoadOptions::default()).expect("resampled by area");
        assert_eq!((g.height(), g.width(), g.resolution), (1, 1, 1.0));
        assert_eq!(g.cells(), [Occupancy::Obstacle]);
        assert!((g.origin[1] + 0.4).abs() < 1e-9, "{:?}", g.origin);
        // Bare images are 1 m/pixel; a 2 m cell merges 2×2 blocks.
        let g = load(
            &dir.join("m.pgm"),
            &LoadOptions {
                cell_size: 2.0,
                ..LoadOptions::default()
            },
        )
        .expect("bare");
        assert_eq!((g.height(), g.width(), g.resolution), (1, 2, 2.0));
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn discretizes_a_fine_yaml_map() {
        // 8×8 pixels at 0.25 m → 2×2 cells of 1 m (4×4 pixels each).
        // Cell (0,0): exactly 4 occupied pixels of 16 → free.
        // Cell (0,1): 5 occupied pixels → obstacle.
        // Cell (1,0): 16 unknown pixels (205) → unknown counts as not occupied → free.
        // Cell (1,1): 4 occupied + 12 unknown → free; (a 5th occupied pixel would flip it).
        let mut px = [PIXEL_FREE; 64];
        let mut set = |r: usize, c: usize, v: u8| px[r * 8 + c] = v;
        for c in 0..4 {
            set(0, c, PIXEL_OBSTACLE);
        }
        for (r, c) in [(0, 4), (1, 5), (2, 6), (3, 7), (3, 4)] {
            set(r, c, PIXEL_OBSTACLE);
        }
        for r in 4..8 {
            for c in 0..8 {
                set(r, c, PIXEL_UNKNOWN);
            }
        }
        for c in 4..8 {
            set(7, c, PIXEL_OBSTACLE);
        }
        let dir = temp_dir("fine");
        let mut pgm = b"P5\n8 8\n255\n".to_vec();
        pgm.extend_from_slice(&px);
        write(&dir, "fine.pgm", &pgm);
        let yaml = write(
            &dir,
            "fine.yaml",
            YAML_OK
                .replace("m.pgm", "fine.pgm")
                .replace("resolution: 1.0", "resolution: 0.25")
                .as_bytes(),
        );
        let g = load(&yaml, &LoadOptions::default()).expect("fine map");
        assert_eq!((g.height(), g.width()), (2, 2));
        assert_eq!(g.resolution, 1.0);
        assert_eq!(g.get(Pos::new(0, 0)), Occupancy::Free);
        assert_eq!(g.get(Pos::new(0, 1)), Occupancy::Obstacle);
        assert_eq!(g.get(Pos::new(1, 0)), Occupancy::Free);
        assert_eq!(g.get(Pos::new(1, 1)), Occupancy::Free);
        // cell_size 0.25 keeps the pixels (and the unknown band).
        let g = load(
            &yaml,
            &LoadOptions {
                cell_size: 0.25,
                ..LoadOptions::default()
            },
        )
        .expect("pixels");
        assert_eq!(
            (g.height(), g.width(), g.count(Occupancy::Unknown)),
            (8, 8, 32 - 4)
        );
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn partial_bottom_block_moves_the_origin_down() {
        let dir = temp_dir("origin");
        write(&dir, "m.pgm", &small_pgm()); // 3 wide, 2 high
        let yaml = write(
            &dir,
            "m.yaml",
            YAML_OK
                .replace("resolution: 1.0", "resolution: 0.5")
                .as_bytes(),
        );
        let g = load(&yaml, &LoadOptions::default()).expect("load");
        // 2 pixel rows fit one 2-pixel cell exactly; 3 columns → 2 cells, no vertical padding.
        assert_eq!((g.height(), g.width(), g.origin), (1, 2, [0.0, 0.0, 0.0]));
        let g = load(
            &yaml,
            &LoadOptions {
                cell_size: 1.5,
                ..LoadOptions::default()
            },
        )
        .expect("load");
        // 2 rows → 1 cell of 3 pixel rows: one padding row of 0.5 m below the image.
        assert_eq!((g.height(), g.width()), (1, 1));
        assert!((g.origin[1] + 0.5).abs() < 1e-12 && g.origin[0].abs() < 1e-12);
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn text_parsing_details() {
        let p = Path::new("inline.txt");
        let g = parse_text("#.?  \r\n...\r\n\n\n", p).expect("parse");
        assert_eq!((g.height(), g.width()), (2, 3));
        assert_eq!(g.get(Pos::new(0, 2)), Occupancy::Unknown);
        assert_eq!(to_text(&g), "#.?\n...\n");
        let e = parse_text("..\n\n..\n", p).unwrap_err();
        assert_names(&e, "line 2");
    }

    #[test]
    fn png_round_trip_and_save_dispatch() {
        let dir = temp_dir("png");
        let g = parse_text("#.?\n..#\n", Path::new("x")).expect("parse");
        for name in ["a.png", "a.pgm", "a.txt", "a.map", "a.yml"] {
            let p = dir.join(name);
            save(&g, &p).expect("save");
            assert_eq!(
                load(&p, &LoadOptions::default()).expect("load"),
                g,
                "{name}"
            );
        }
        assert!(save(&g, &dir.join("a.jpg")).is_err());
        // No temporary files are left behind.
        let leftovers: Vec<_> = fs::read_dir(&dir)
            .expect("read dir")
            .filter_map(Result::ok)
            .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
            .collect();
        assert!(leftovers.is_empty());
        // An RGBA PNG: luma for color, transparent pixels unknown.
        let rgba = image::RgbaImage::from_raw(
            3,
            1,
            vec![0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 0],
        )
        .expect("rgba");
        let p = dir.join("rgba.png");
        rgba.save(&p).expect("save rgba");
        assert_eq!(
            to_text(&load(&p, &LoadOptions::default()).expect("rgba")),
            "#.?\n"
        );
        let _ = fs::remove_dir_all(dir);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn yaml_pgm_round_trip(grid in grid_strategy(12), x in -100.0f64..100.0, y in -100.0f64..100.0, yaw in -3.2f64..3.2) {
            let dir = temp_dir("rt");
            let mut grid = grid;
            grid.origin = [x, y, yaw];
            let path = dir.join("map.yaml");
            save_yaml(&grid, &path).expect("save");
            let back = load(&path, &LoadOptions::default()).expect("load");
            let _ = fs::remove_dir_all(&dir);
            prop_assert_eq!(back, grid);
        }

        #[test]
        fn text_round_trip(grid in grid_strategy(30)) {
            let text = to_text(&grid);
            let back = parse_text(&text, Path::new("t.txt")).expect("parse");
            prop_assert_eq!(back, grid);
        }

        #[test]
        fn garbage_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
            let _ = decode_pgm(&bytes, Path::new("g.pgm"));
            let mut p5 = b"P5\n4 4\n255\n".to_vec();
            p5.extend_from_slice(&bytes);
            let _ = decode_pgm(&p5, Path::new("g.pgm"));
            let _ = parse_text(&String::from_utf8_lossy(&bytes), Path::new("g.txt"));
            let _ = parse_map_yaml(&String::from_utf8_lossy(&bytes), Path::new("g.yaml"));
        }
    }
}
