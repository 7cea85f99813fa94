//! Decoded images: PNG and other formats through the `image` crate ([`decode_image`]), the
//! [`Raster`] every decoder produces, its conversion to a grid ([`raster_to_grid`]: pixel
//! classification and discretization, see the [`io`](super) docs) and the PNG writer.

use super::yaml::{MapMeta, MapMode};
use super::{check_savable, field_err, format_err, pixel_of, write_atomic, LoadOptions};
use crate::discretize::discretize_area;
use crate::{MapError, OccGrid, Occupancy};
use std::path::Path;

/// A decoded 8-bit grayscale image, row-major from the top row.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Raster {
    pub width: usize,
    pub height: usize,
    pub gray: Vec<u8>,
    /// Alpha per pixel, when the image has an alpha channel.
    pub alpha: Option<Vec<u8>>,
}

/// Decodes an image with the `image` crate (format guessed from the content unless given),
/// converting it to 8-bit luma (+ alpha when present).
pub(super) fn decode_image(
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
pub(super) fn classify_pixel(meta: &MapMeta, v: u8, alpha: u8) -> (f64, Occupancy) {
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
pub(super) fn raster_to_grid(
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
