//! Rendering a figure on the PNG and SVG backends and writing the files atomically.

use std::fmt::Display;
use std::path::{Path, PathBuf};

use image::ImageEncoder;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::layout::Figure;
use crate::legend::draw_legend;
use crate::style::ensure_font;
use crate::PlotError;

pub(crate) fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

fn draw_err(path: &Path) -> impl Fn(String) -> PlotError + '_ {
    move |message| PlotError::Draw {
        path: path.to_path_buf(),
        message,
    }
}

pub(crate) fn s<E: Display>(e: E) -> String {
    e.to_string()
}

/// Renders the figure with both backends and writes `stem.png` and
/// `stem.svg` atomically.
pub(crate) fn write_figure<P: Panels>(
    stem: &Path,
    fig: &Figure<'_>,
    draw_panel: &P,
) -> Result<Vec<PathBuf>, PlotError> {
    let png = with_ext(stem, "png");
    let svg = with_ext(stem, "svg");
    write_one(&png, fig, draw_panel, Target::Bitmap)?;
    write_one(&svg, fig, draw_panel, Target::Vector)?;
    Ok(vec![png, svg])
}

/// Renders the figure with one backend (PNG for [`Target::Bitmap`], SVG
/// for [`Target::Vector`]) and writes it to `path` atomically, creating
/// missing parent directories.
pub(crate) fn write_one<P: Panels>(
    path: &Path,
    fig: &Figure<'_>,
    draw_panel: &P,
    target: Target,
) -> Result<(), PlotError> {
    ensure_font(path)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| PlotError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let size = (fig.width(), fig.height());
    match target {
        Target::Bitmap => {
            // Drawn into an RGB buffer and encoded with the workspace's `image` (plotters' own
            // file writer would bring a second, older `image` into the build: issue 25).
            let (w, h) = (size.0 as usize, size.1 as usize);
            let mut rgb = vec![0u8; w * h * 3];
            {
                let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
                render(&root, fig, draw_panel, target)
                    .and_then(|()| root.present().map_err(s))
                    .map_err(draw_err(path))?;
            }
            let mut png = Vec::new();
            image::codecs::png::PngEncoder::new(&mut png)
                .write_image(&rgb, size.0, size.1, image::ExtendedColorType::Rgb8)
                .map_err(|e| draw_err(path)(e.to_string()))?;
            madenet_files::write_atomic(path, &png).map_err(io_err(path))
        }
        Target::Vector => {
            let mut text = String::new();
            {
                let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
                render(&root, fig, draw_panel, target)
                    .and_then(|()| root.present().map_err(s))
                    .map_err(draw_err(path))?;
            }
            madenet_files::write_atomic(path, text.as_bytes()).map_err(io_err(path))
        }
    }
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> PlotError + '_ {
    move |source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Panels of one kind, drawable on any backend.
pub(crate) trait Panels {
    /// Draws panel `i` into `area`.
    fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        i: usize,
        target: Target,
    ) -> Result<(), String>;
}

/// The kind of backend drawn on: wide lines are drawn differently.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Target {
    /// PNG: plotters fills wide polylines as polygons, which leaves holes
    /// at sharp turns, so they are drawn segment by segment.
    Bitmap,
    /// SVG: the viewer strokes polylines itself.
    Vector,
}

pub(crate) fn render<DB: DrawingBackend, P: Panels>(
    root: &DrawingArea<DB, Shift>,
    fig: &Figure<'_>,
    panels: &P,
    target: Target,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(s)?;
    let (legend, body) = root.split_vertically(fig.legend_height());
    draw_legend(&legend, fig)?;
    let (rows, cols) = fig.grid();
    for (i, area) in body
        .split_evenly((rows, cols))
        .iter()
        .enumerate()
        .take(fig.n_panels)
    {
        panels.draw(area, i, target)?;
    }
    Ok(())
}
