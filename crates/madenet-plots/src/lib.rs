//! Figures of the MADE-Net study (Tan et al., RA-L 2023) as PNG and SVG.
//!
//! The crate takes plain data and writes files; it knows nothing about the
//! simulator. Three kinds of figure of the paper are covered:
//!
//! * **Fig. 4** — grouped bar charts: one panel per metric (TNS, TTD, NOLI,
//!   OFV), the communication-success probabilities (CSP 0 %, 50 %, 80 %,
//!   100 %) as groups on the x axis, one bar per method (NF, UB, PB,
//!   MADE-Net-DT, MADE-Net) in every group, with error bars (e.g. standard
//!   deviations). Drawn by [`bar_panels`] from [`BarPanel`]s, typically in a
//!   2 × 2 grid.
//! * **Fig. 5** — mean explored area (%) against distance travelled (m), one
//!   line per method, one panel per CSP (100 % and 0 %). Drawn by
//!   [`line_panels`] from [`LinePanel`]s.
//! * **Fig. 2** — training curves (team reward and steps per episode against
//!   episode), usually shown smoothed with an exponentially weighted moving
//!   average: [`ewma`] computes it, [`line_panels`] draws it — or
//!   [`styled_line_panels`], when raw values and their EWMA should share a
//!   colour or panels show different series (the training log's figure in
//!   `madenet-trainlog`).
//!
//! Every figure is written twice, as `stem.png` and `stem.svg` (the
//! extension is appended to the stem, so `fig4.csp` becomes `fig4.csp.png`),
//! except by [`styled_line_panels`], which writes the one file it is given.
//! Panels are laid out in a grid of `cols` columns; one legend above the
//! grid serves all panels, and series `i` of every panel has colour (and,
//! for lines, marker shape) `i` — so series must be given in the same order,
//! with the same names, in every panel ([`styled_line_panels`] instead
//! matches series to explicit [`LineStyle`]s by name). The palette is
//! Okabe–Ito's colour-blind-safe one; line series also differ by marker
//! shape.
//!
//! Text is drawn with a bundled subset of DejaVu Sans (see
//! `assets/README.md`), registered with plotters' `ab_glyph` font table, so
//! no system font or font library is needed. SVG files name the generic
//! family `sans-serif` and leave font choice to the viewer.
//!
//! Each panel is 800 × 500 px in the PNG, under a legend strip of about
//! 60–100 px: a 2 × 2 grid (Fig. 4) is 1600 × 1064 px, a 1 × 2 grid
//! (Fig. 5, Fig. 2) 1600 × 564 px. The SVG has the same size in user units.
//! Titles are 26 px, axis labels 22 px, tick labels 19 px and legend
//! names 22 px (font scale: ascent to descent).
//!
//! Line series that are noise-like next to the other series of their panel
//! (raw per-episode values drawn with their EWMA, say) are drawn thin and
//! translucent without markers, so the smoothed curve stays readable; see
//! [`line_panels`].
//!
//! Files are written atomically (a temporary file in the same directory,
//! then a rename); missing parent directories are created. Bad input
//! (nothing to draw, mismatched lengths, non-finite numbers or numbers
//! beyond [`MAX_ABS_VALUE`], series named differently in different panels,
//! a figure of more than 16 384 px a side) is reported as a [`PlotError`],
//! never a panic.
//!
//! ```no_run
//! use madenet_plots::{bar_panels, BarPanel, BarSeries};
//! let panel = BarPanel {
//!     title: "Total number of steps".into(),
//!     y_label: "TNS".into(),
//!     categories: vec!["CSP 0 %".into(), "CSP 100 %".into()],
//!     series: vec![
//!         BarSeries { name: "NF".into(), means: vec![104.0, 99.0], errors: vec![10.0, 9.0] },
//!         BarSeries { name: "MADE-Net".into(), means: vec![61.0, 47.0], errors: vec![8.0, 6.0] },
//!     ],
//! };
//! let written = bar_panels(std::path::Path::new("out/fig4"), &[panel], 2)?;
//! assert_eq!(written.len(), 2); // out/fig4.png, out/fig4.svg
//! # Ok::<(), madenet_plots::PlotError>(())
//! ```

#![warn(missing_docs)]

use std::fmt::Display;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;

/// The bundled font (a subset of DejaVu Sans 2.37; licence in
/// `assets/DejaVuSans-LICENSE.txt`).
const FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// The family name the bundled font is registered under and drawn with.
const FONT_FAMILY: &str = "sans-serif";

/// Width of one panel in pixels (PNG); a 2 × 2 grid is 1600 px wide.
const PANEL_W: u32 = 800;
/// Height of one panel in pixels (PNG); a 2 × 2 grid is 1000 px high plus
/// the legend strip.
const PANEL_H: u32 = 500;

const TITLE_PX: f64 = 26.0;
const AXIS_DESC_PX: f64 = 22.0;
const TICK_PX: f64 = 19.0;
const LEGEND_PX: f64 = 22.0;
const LEGEND_ROW_H: u32 = 36;
const LEGEND_PAD: u32 = 14;
const LEGEND_SWATCH_W: i32 = 44;
const LEGEND_ENTRY_GAP: i32 = 36;

/// Okabe–Ito colour-blind-safe palette, reordered so the first five colours
/// are the most distinct. Series `i` gets `PALETTE[i % 8]`.
const PALETTE: [RGBColor; 8] = [
    RGBColor(0x00, 0x72, 0xB2), // blue
    RGBColor(0xD5, 0x5E, 0x00), // vermillion
    RGBColor(0x00, 0x9E, 0x73), // bluish green
    RGBColor(0xE6, 0x9F, 0x00), // orange
    RGBColor(0xCC, 0x79, 0xA7), // reddish purple
    RGBColor(0x56, 0xB4, 0xE9), // sky blue
    RGBColor(0xF0, 0xE4, 0x42), // yellow
    RGBColor(0x00, 0x00, 0x00), // black
];

/// Largest magnitude of a value that can be plotted; larger values (and
/// bar tops `mean ± error` beyond it) are rejected as input errors.
pub const MAX_ABS_VALUE: f64 = 1e15;

/// Largest width or height of a figure in pixels.
const MAX_SIDE_PX: u32 = 16_384;

/// Number of markers drawn along each line series (at most).
const MARKERS_PER_LINE: usize = 10;

/// What went wrong while drawing a figure. Every message names the output
/// file concerned.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The data cannot be drawn (empty, mismatched lengths, not finite, …).
    #[error("cannot plot {path}: {reason}")]
    InvalidInput {
        /// The output file that was not written.
        path: PathBuf,
        /// What is wrong with the input.
        reason: String,
    },
    /// The bundled font could not be loaded.
    #[error("cannot plot {path}: bundled font could not be registered")]
    Font {
        /// The output file that was not written.
        path: PathBuf,
    },
    /// plotters failed while drawing or encoding.
    #[error("drawing {path} failed: {message}")]
    Draw {
        /// The output file that was not written.
        path: PathBuf,
        /// plotters' description of the failure.
        message: String,
    },
    /// Creating a directory, writing or renaming a file failed.
    #[error("writing {path} failed: {source}")]
    Io {
        /// The file or directory concerned.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
}

/// One series of a grouped bar chart: one bar per category.
#[derive(Debug, Clone, PartialEq)]
pub struct BarSeries {
    /// Legend name, e.g. `"MADE-Net"`.
    pub name: String,
    /// Bar heights, one per category of the panel.
    pub means: Vec<f64>,
    /// Half-lengths of the error bars (e.g. standard deviations), one per
    /// category and non-negative; an empty vector draws no error bars.
    pub errors: Vec<f64>,
}

/// One panel of grouped bars: categories on x (e.g. "CSP 0 %", "CSP 50 %",
/// …), one bar per series in each group, y from 0.
#[derive(Debug, Clone, PartialEq)]
pub struct BarPanel {
    /// Panel title, e.g. `"Total number of steps (TNS)"`.
    pub title: String,
    /// Y-axis label, e.g. `"TNS"`.
    pub y_label: String,
    /// Group labels along the x axis, left to right.
    pub categories: Vec<String>,
    /// The series; series `i` has colour `i` in every panel.
    pub series: Vec<BarSeries>,
}

/// One line of a line chart.
#[derive(Debug, Clone, PartialEq)]
pub struct LineSeries {
    /// Legend name, e.g. `"MADE-Net"`.
    pub name: String,
    /// `(x, y)` points, joined in the order given.
    pub points: Vec<(f64, f64)>,
}

/// One panel of a line chart. The axes span the data (y padded by 5 %).
#[derive(Debug, Clone, PartialEq)]
pub struct LinePanel {
    /// Panel title, e.g. `"CSP 100 %"`.
    pub title: String,
    /// X-axis label, e.g. `"Distance travelled (m)"`.
    pub x_label: String,
    /// Y-axis label, e.g. `"Explored area (%)"`.
    pub y_label: String,
    /// The series; series `i` has colour and marker `i` in every panel.
    pub series: Vec<LineSeries>,
}

/// Draws bar panels in a grid (rows × `cols`, rows as needed) into
/// `stem.png` and `stem.svg`, sharing one legend above the grid (series
/// names and colours consistent across panels: series `i` always gets
/// colour `i`). Returns the paths written, PNG first.
///
/// Each panel's y axis starts at 0 (or below, if a bar or error bar is
/// negative) and reaches 8 % above the highest error bar, rounded up to a
/// round number. Error bars (with caps) are drawn on top of all bars.
///
/// # Errors
///
/// [`PlotError::InvalidInput`] if `panels` is empty, `cols` is 0, a panel
/// has no categories or no series, a series' `means` (or non-empty
/// `errors`) do not match the categories in number, a value is not finite
/// or beyond [`MAX_ABS_VALUE`], an error is negative, or series `i` has
/// different names in different panels; [`PlotError::Io`] or
/// [`PlotError::Draw`] if the files cannot be written.
pub fn bar_panels(
    stem: &Path,
    panels: &[BarPanel],
    cols: usize,
) -> Result<Vec<PathBuf>, PlotError> {
    let png = with_ext(stem, "png");
    let invalid = |reason| PlotError::InvalidInput {
        path: png.clone(),
        reason,
    };
    validate_bars(panels, cols).map_err(invalid)?;
    let names = legend_names(
        panels
            .iter()
            .map(|p| p.series.iter().map(|s| s.name.as_str())),
    )
    .map_err(invalid)?;
    let fig = Figure {
        colours: (0..names.len()).collect(),
        names: &names,
        faint: vec![false; names.len()],
        kind: LegendKind::Bar,
        n_panels: panels.len(),
        cols,
    };
    fig.check_size().map_err(invalid)?;
    write_figure(stem, &fig, &Bars(panels))
}

/// Draws line panels in a grid (rows × `cols`, rows as needed) into
/// `stem.png` and `stem.svg`, sharing one legend above the grid (series
/// names, colours and markers consistent across panels: series `i` always
/// gets colour `i`). Returns the paths written, PNG first.
///
/// Each panel's x axis spans the data; the y axis spans the data padded by
/// 5 % on both sides. Lines are 3 px wide with up to ten markers each
/// (shape `i` for series `i`, staggered between series). A series whose
/// path is far rougher than the smoothest series of its panel (more than
/// three times as long as its bounding box's half-perimeter, and at least
/// four times as rough as the smoothest) is drawn 1 px wide and translucent,
/// without markers — as for raw training values under their EWMA (Fig. 2).
///
/// # Errors
///
/// [`PlotError::InvalidInput`] if `panels` is empty, `cols` is 0, a panel
/// has no series, a series has no points, a coordinate is not finite or
/// beyond [`MAX_ABS_VALUE`], or series `i` has different names in different
/// panels; [`PlotError::Io`] or [`PlotError::Draw`] if the files cannot be
/// written.
pub fn line_panels(
    stem: &Path,
    panels: &[LinePanel],
    cols: usize,
) -> Result<Vec<PathBuf>, PlotError> {
    let png = with_ext(stem, "png");
    let invalid = |reason| PlotError::InvalidInput {
        path: png.clone(),
        reason,
    };
    validate_lines(panels, cols).map_err(invalid)?;
    let names = legend_names(
        panels
            .iter()
            .map(|p| p.series.iter().map(|s| s.name.as_str())),
    )
    .map_err(invalid)?;
    let fig = Figure {
        colours: (0..names.len()).collect(),
        faint: faint_series(panels, names.len()),
        names: &names,
        kind: LegendKind::Line,
        n_panels: panels.len(),
        cols,
    };
    fig.check_size().map_err(invalid)?;
    let looks = panels
        .iter()
        .map(|p| {
            jagged_series(p)
                .into_iter()
                .enumerate()
                .map(|(colour, faint)| Look { colour, faint })
                .collect()
        })
        .collect();
    write_figure(stem, &fig, &Lines { panels, looks })
}

/// How [`styled_line_panels`] draws the series of one name, and that
/// name's entry in the legend.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineStyle {
    /// The series drawn in this style: those of this name, in any panel.
    /// Also the legend text.
    pub name: String,
    /// Colour and marker shape: entry `colour % 8` of the palette (0 blue,
    /// 1 vermillion, 2 bluish green, 3 orange, 4 reddish purple, 5 sky
    /// blue, 6 yellow, 7 black). Styles may share a colour — raw values and
    /// their EWMA, say.
    pub colour: usize,
    /// Drawn 1 px wide and translucent, without markers (noise-like values
    /// such as raw per-episode training values), instead of 3 px wide with
    /// markers.
    pub faint: bool,
}

/// Draws line panels in a grid (rows × `cols`, rows as needed) into the
/// one file `path`, a PNG or an SVG by its extension (`.png` or `.svg`,
/// any case), with each series' look and the legend given explicitly.
/// Returns `path`.
///
/// Unlike [`line_panels`], series are matched to `styles` by name, so
/// panels may show different series in any order, and several series may
/// share a colour. The legend above the grid lists `styles` in the order
/// given; series are drawn in each panel's order (later ones on top). Axes
/// and lines are as in [`line_panels`], except that faintness comes from
/// [`LineStyle::faint`] rather than from the data.
///
/// # Errors
///
/// [`PlotError::InvalidInput`] for any input [`line_panels`] rejects
/// (except differing series between panels), if `path` does not end in
/// `.png` or `.svg`, if `styles` is empty or names a series twice, or if a
/// series has no style; [`PlotError::Io`] or [`PlotError::Draw`] if the
/// file cannot be written.
pub fn styled_line_panels(
    path: &Path,
    panels: &[LinePanel],
    cols: usize,
    styles: &[LineStyle],
) -> Result<PathBuf, PlotError> {
    let invalid = |reason| PlotError::InvalidInput {
        path: path.to_path_buf(),
        reason,
    };
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let target = match ext.as_deref() {
        Some("png") => Target::Bitmap,
        Some("svg") => Target::Vector,
        _ => return Err(invalid("the file name must end in .png or .svg".into())),
    };
    validate_lines(panels, cols).map_err(invalid)?;
    if styles.is_empty() {
        return Err(invalid("no line styles given".into()));
    }
    for (k, st) in styles.iter().enumerate() {
        if styles[..k].iter().any(|o| o.name == st.name) {
            return Err(invalid(format!("two line styles are named {:?}", st.name)));
        }
    }
    let mut looks = Vec::with_capacity(panels.len());
    for (pi, p) in panels.iter().enumerate() {
        let mut panel_looks = Vec::with_capacity(p.series.len());
        for ser in &p.series {
            let st = styles
                .iter()
                .find(|st| st.name == ser.name)
                .ok_or_else(|| {
                    invalid(format!(
                        "panel {pi} ({:?}): series {:?} has no line style",
                        p.title, ser.name
                    ))
                })?;
            panel_looks.push(Look {
                colour: st.colour,
                faint: st.faint,
            });
        }
        looks.push(panel_looks);
    }
    let names: Vec<String> = styles.iter().map(|st| st.name.clone()).collect();
    let fig = Figure {
        names: &names,
        colours: styles.iter().map(|st| st.colour).collect(),
        faint: styles.iter().map(|st| st.faint).collect(),
        kind: LegendKind::Line,
        n_panels: panels.len(),
        cols,
    };
    fig.check_size().map_err(invalid)?;
    write_one(path, &fig, &Lines { panels, looks }, target)?;
    Ok(path.to_path_buf())
}

/// Exponentially weighted moving average with smoothing factor `alpha` as
/// the paper's "EWMA of 0.9": `s_t = alpha·s_{t−1} + (1−alpha)·x_t`,
/// `s_0 = x_0` — for Fig. 2. `alpha = 0` returns the input, values of
/// `alpha` near 1 smooth strongly. The output has the input's length (empty
/// for empty input). Non-finite inputs propagate; `alpha` is not checked.
#[must_use]
pub fn ewma(values: &[f64], alpha: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(values.len());
    let mut prev: Option<f64> = None;
    for &x in values {
        let s = match prev {
            None => x,
            Some(p) => alpha * p + (1.0 - alpha) * x,
        };
        out.push(s);
        prev = Some(s);
    }
    out
}

// ---------------------------------------------------------------------------
// Validation

fn check_cols(n_panels: usize, cols: usize) -> Result<(), String> {
    if n_panels == 0 {
        return Err("no panels given".into());
    }
    if cols == 0 {
        return Err("cols must be at least 1".into());
    }
    Ok(())
}

fn validate_bars(panels: &[BarPanel], cols: usize) -> Result<(), String> {
    check_cols(panels.len(), cols)?;
    for (pi, p) in panels.iter().enumerate() {
        let at = |what: String| format!("panel {pi} ({:?}): {what}", p.title);
        if p.categories.is_empty() {
            return Err(at("no categories".into()));
        }
        if p.series.is_empty() {
            return Err(at("no series".into()));
        }
        for s in &p.series {
            if s.means.len() != p.categories.len() {
                return Err(at(format!(
                    "series {:?} has {} means for {} categories",
                    s.name,
                    s.means.len(),
                    p.categories.len()
                )));
            }
            if !s.errors.is_empty() && s.errors.len() != s.means.len() {
                return Err(at(format!(
                    "series {:?} has {} errors for {} means",
                    s.name,
                    s.errors.len(),
                    s.means.len()
                )));
            }
            if let Some(v) = s.means.iter().find(|v| !v.is_finite()) {
                return Err(at(format!(
                    "series {:?} has a non-finite mean ({v})",
                    s.name
                )));
            }
            if let Some(v) = s.errors.iter().find(|v| !v.is_finite() || **v < 0.0) {
                return Err(at(format!(
                    "series {:?} has an error that is negative or not finite ({v})",
                    s.name
                )));
            }
            let too_big =
                s.means.iter().enumerate().find(|&(j, m)| {
                    m.abs() + s.errors.get(j).copied().unwrap_or(0.0) > MAX_ABS_VALUE
                });
            if let Some((_, v)) = too_big {
                return Err(at(format!(
                    "series {:?} has a bar beyond ±{MAX_ABS_VALUE:e} ({v:e} with its error)",
                    s.name
                )));
            }
        }
    }
    Ok(())
}

fn validate_lines(panels: &[LinePanel], cols: usize) -> Result<(), String> {
    check_cols(panels.len(), cols)?;
    for (pi, p) in panels.iter().enumerate() {
        let at = |what: String| format!("panel {pi} ({:?}): {what}", p.title);
        if p.series.is_empty() {
            return Err(at("no series".into()));
        }
        for s in &p.series {
            if s.points.is_empty() {
                return Err(at(format!("series {:?} has no points", s.name)));
            }
            if let Some((x, y)) = s
                .points
                .iter()
                .find(|(x, y)| !x.is_finite() || !y.is_finite())
            {
                return Err(at(format!(
                    "series {:?} has a non-finite point ({x}, {y})",
                    s.name
                )));
            }
            let too_big = s
                .points
                .iter()
                .find(|(x, y)| x.abs() > MAX_ABS_VALUE || y.abs() > MAX_ABS_VALUE);
            if let Some((x, y)) = too_big {
                return Err(at(format!(
                    "series {:?} has a point beyond ±{MAX_ABS_VALUE:e} ({x:e}, {y:e})",
                    s.name
                )));
            }
        }
    }
    Ok(())
}

/// The legend entries: series names by index, checked to agree across
/// panels (a panel may have fewer series than another).
fn legend_names<'a, P, S>(panels: P) -> Result<Vec<String>, String>
where
    P: Iterator<Item = S>,
    S: Iterator<Item = &'a str>,
{
    let mut names: Vec<String> = Vec::new();
    for (pi, series) in panels.enumerate() {
        for (si, name) in series.enumerate() {
            match names.get(si) {
                Some(n) if n != name => {
                    return Err(format!(
                    "series {si} is named {n:?} in an earlier panel but {name:?} in panel {pi}; \
                         series must come in the same order in every panel"
                ))
                }
                Some(_) => {}
                None => names.push(name.to_string()),
            }
        }
    }
    Ok(names)
}

// ---------------------------------------------------------------------------
// Output

fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// A temporary path next to `target` that keeps its extension (plotters'
/// bitmap backend picks the encoder from the extension).
fn ensure_font(path: &Path) -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font {
            path: path.to_path_buf(),
        })
    }
}

fn draw_err(path: &Path) -> impl Fn(String) -> PlotError + '_ {
    move |message| PlotError::Draw {
        path: path.to_path_buf(),
        message,
    }
}

fn s<E: Display>(e: E) -> String {
    e.to_string()
}

/// What the shared legend shows next to each name.
#[derive(Clone, Copy, PartialEq, Eq)]
enum LegendKind {
    Bar,
    Line,
}

struct Figure<'a> {
    names: &'a [String],
    /// Per legend entry: its palette index (colour and marker shape).
    colours: Vec<usize>,
    /// Per legend entry: drawn thin and translucent without markers (line
    /// series that are noise-like in every panel they appear in).
    faint: Vec<bool>,
    kind: LegendKind,
    n_panels: usize,
    cols: usize,
}

impl Figure<'_> {
    fn grid(&self) -> (usize, usize) {
        let cols = self.cols.min(self.n_panels).max(1);
        (self.n_panels.div_ceil(cols), cols)
    }

    fn width(&self) -> u32 {
        PANEL_W.saturating_mul(u32::try_from(self.grid().1).unwrap_or(u32::MAX))
    }

    /// Lays the legend entries out in rows that fit the figure width:
    /// returns, per row, the entries' indices and widths.
    fn legend_rows(&self) -> Vec<Vec<(usize, i32)>> {
        let max_w = i32::try_from(self.width()).unwrap_or(i32::MAX) - 2 * LEGEND_PAD as i32;
        let mut rows: Vec<Vec<(usize, i32)>> = vec![Vec::new()];
        let mut used: i32 = 0;
        for (i, name) in self.names.iter().enumerate() {
            let w = (LEGEND_SWATCH_W + 10).saturating_add(text_width(name, LEGEND_PX));
            let extra = if used == 0 {
                w
            } else {
                w.saturating_add(LEGEND_ENTRY_GAP)
            };
            if used > 0 && used.saturating_add(extra) > max_w {
                rows.push(Vec::new());
                used = w;
            } else {
                used = used.saturating_add(extra);
            }
            rows.last_mut().expect("rows is never empty").push((i, w));
        }
        rows
    }

    fn legend_height(&self) -> u32 {
        let rows = u32::try_from(self.legend_rows().len()).unwrap_or(u32::MAX);
        (2 * LEGEND_PAD).saturating_add(LEGEND_ROW_H.saturating_mul(rows))
    }

    fn height(&self) -> u32 {
        let rows = u32::try_from(self.grid().0).unwrap_or(u32::MAX);
        self.legend_height()
            .saturating_add(PANEL_H.saturating_mul(rows))
    }

    /// Refuses figures too large to render sensibly.
    fn check_size(&self) -> Result<(), String> {
        let (rows, cols) = self.grid();
        let legend_rows = self.legend_rows().len();
        let max_panels = (MAX_SIDE_PX / PANEL_W) as usize;
        if cols > max_panels || rows > (MAX_SIDE_PX / PANEL_H) as usize || legend_rows > 50 {
            return Err(format!(
                "a grid of {rows} × {cols} panels with {legend_rows} legend rows exceeds \
                 {MAX_SIDE_PX} px per side"
            ));
        }
        if self.width() > MAX_SIDE_PX || self.height() > MAX_SIDE_PX {
            return Err(format!(
                "the figure would be {} × {} px, more than {MAX_SIDE_PX} px per side",
                self.width(),
                self.height()
            ));
        }
        Ok(())
    }
}

/// Width in pixels of `text` at `size` in the bundled font.
fn text_width(text: &str, size: f64) -> i32 {
    FontDesc::new(FontFamily::Name(FONT_FAMILY), size, FontStyle::Normal)
        .box_size(text)
        .map(|(w, _)| w as i32)
        .unwrap_or((text.chars().count() as f64 * size * 0.6) as i32)
}

fn font(size: f64) -> TextStyle<'static> {
    (FONT_FAMILY, size).into_font().color(&BLACK)
}

/// Renders the figure with both backends and writes `stem.png` and
/// `stem.svg` atomically.
fn write_figure<P: Panels>(
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
fn write_one<P: Panels>(
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
            // plotters writes the file itself on `present`: it draws into a temporary path
            // that `madenet_files` then puts at `path`.
            let mut drawing = None;
            let written = madenet_files::write_via_path(path, |tmp: &Path| {
                let root = BitMapBackend::new(tmp, size).into_drawing_area();
                if let Err(message) =
                    render(&root, fig, draw_panel, target).and_then(|()| root.present().map_err(s))
                {
                    drawing = Some(message);
                    return Err(std::io::Error::other("drawing failed"));
                }
                Ok(())
            });
            if let Some(message) = drawing {
                return Err(draw_err(path)(message));
            }
            written.map_err(io_err(path))
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
trait Panels {
    /// Draws panel `i` into `area`.
    fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        i: usize,
        target: Target,
    ) -> Result<(), String>;
}

struct Bars<'a>(&'a [BarPanel]);
struct Lines<'a> {
    panels: &'a [LinePanel],
    /// Per panel, per series: how it is drawn.
    looks: Vec<Vec<Look>>,
}

/// How one line series is drawn.
#[derive(Clone, Copy)]
struct Look {
    /// Palette index: colour and marker shape.
    colour: usize,
    /// Thin and translucent without markers.
    faint: bool,
}

impl Panels for Bars<'_> {
    fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        i: usize,
        _target: Target,
    ) -> Result<(), String> {
        draw_bar_panel(area, &self.0[i])
    }
}

impl Panels for Lines<'_> {
    fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        i: usize,
        target: Target,
    ) -> Result<(), String> {
        draw_line_panel(area, &self.panels[i], &self.looks[i], target)
    }
}

/// The kind of backend drawn on: wide lines are drawn differently.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Target {
    /// PNG: plotters fills wide polylines as polygons, which leaves holes
    /// at sharp turns, so they are drawn segment by segment.
    Bitmap,
    /// SVG: the viewer strokes polylines itself.
    Vector,
}

fn render<DB: DrawingBackend, P: Panels>(
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

fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    fig: &Figure<'_>,
) -> Result<(), String> {
    let width = fig.width() as i32;
    let style = font(LEGEND_PX).pos(Pos::new(HPos::Left, VPos::Center));
    for (r, row) in fig.legend_rows().iter().enumerate() {
        let total = row.iter().fold(-LEGEND_ENTRY_GAP, |acc: i32, (_, w)| {
            acc.saturating_add(*w).saturating_add(LEGEND_ENTRY_GAP)
        });
        let mut x = (width.saturating_sub(total) / 2).max(LEGEND_PAD as i32);
        let cy = (LEGEND_PAD + LEGEND_ROW_H * r as u32 + LEGEND_ROW_H / 2) as i32;
        for &(i, w) in row {
            let shape = fig.colours[i];
            let colour = colour(shape);
            match fig.kind {
                LegendKind::Bar => {
                    let (x0, x1) = (x + 6, x + LEGEND_SWATCH_W - 6);
                    area.draw(&Rectangle::new(
                        [(x0, cy - 11), (x1, cy + 11)],
                        colour.filled(),
                    ))
                    .map_err(s)?;
                    area.draw(&Rectangle::new(
                        [(x0, cy - 11), (x1, cy + 11)],
                        BLACK.stroke_width(1),
                    ))
                    .map_err(s)?;
                }
                LegendKind::Line if fig.faint[i] => {
                    area.draw(&PathElement::new(
                        vec![(x, cy), (x + LEGEND_SWATCH_W, cy)],
                        colour.mix(0.6).stroke_width(3),
                    ))
                    .map_err(s)?;
                }
                LegendKind::Line => {
                    area.draw(&PathElement::new(
                        vec![(x, cy), (x + LEGEND_SWATCH_W, cy)],
                        colour.stroke_width(3),
                    ))
                    .map_err(s)?;
                    draw_marker(area, shape, (x + LEGEND_SWATCH_W / 2, cy))?;
                }
            }
            area.draw(&Text::new(
                fig.names[i].clone(),
                (x + LEGEND_SWATCH_W + 10, cy),
                style.clone(),
            ))
            .map_err(s)?;
            x = x.saturating_add(w).saturating_add(LEGEND_ENTRY_GAP);
        }
    }
    Ok(())
}

fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Draws marker `i` (shape by index, colour by index) centred on pixel `c`.
fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    i: usize,
    c: (i32, i32),
) -> Result<(), String> {
    let fill = colour(i).filled();
    let (x, y) = c;
    let r = 7;
    let poly = |pts: Vec<(i32, i32)>| {
        Polygon::new(
            pts.into_iter()
                .map(|(dx, dy)| (x + dx, y + dy))
                .collect::<Vec<_>>(),
            fill,
        )
    };
    let outline = |pts: Vec<(i32, i32)>| {
        let mut v: Vec<(i32, i32)> = pts.into_iter().map(|(dx, dy)| (x + dx, y + dy)).collect();
        v.push(v[0]);
        PathElement::new(v, WHITE.stroke_width(1))
    };
    let shape: Vec<(i32, i32)> = match i % 8 {
        0 => {
            area.draw(&Circle::new(c, r, fill)).map_err(s)?;
            return area
                .draw(&Circle::new(c, r, WHITE.stroke_width(1)))
                .map_err(s);
        }
        1 => vec![
            (-r + 1, -r + 1),
            (r - 1, -r + 1),
            (r - 1, r - 1),
            (-r + 1, r - 1),
        ],
        2 => vec![(0, -r - 1), (r + 1, r - 1), (-r - 1, r - 1)],
        3 => vec![(0, -r - 1), (r + 1, 0), (0, r + 1), (-r - 1, 0)],
        4 => vec![(0, r + 1), (r + 1, -r + 1), (-r - 1, -r + 1)],
        5 => {
            let a = r - 1;
            area.draw(&PathElement::new(
                vec![(x - a, y - a), (x + a, y + a)],
                colour(i).stroke_width(4),
            ))
            .map_err(s)?;
            return area
                .draw(&PathElement::new(
                    vec![(x - a, y + a), (x + a, y - a)],
                    colour(i).stroke_width(4),
                ))
                .map_err(s);
        }
        6 => {
            // pentagon
            (0..5)
                .map(|k| {
                    let t =
                        -std::f64::consts::FRAC_PI_2 + k as f64 * 2.0 * std::f64::consts::PI / 5.0;
                    (
                        (t.cos() * (r + 1) as f64).round() as i32,
                        (t.sin() * (r + 1) as f64).round() as i32,
                    )
                })
                .collect()
        }
        _ => {
            let a = r;
            area.draw(&PathElement::new(
                vec![(x - a, y), (x + a, y)],
                colour(i).stroke_width(4),
            ))
            .map_err(s)?;
            return area
                .draw(&PathElement::new(
                    vec![(x, y - a), (x, y + a)],
                    colour(i).stroke_width(4),
                ))
                .map_err(s);
        }
    };
    area.draw(&poly(shape.clone())).map_err(s)?;
    area.draw(&outline(shape)).map_err(s)
}

// ---------------------------------------------------------------------------
// Panels

/// Width of the y label area: room for the rotated axis description and
/// the widest tick label likely on an axis from `lo` to `hi` (about ten
/// ticks).
fn y_label_area(lo: f64, hi: f64) -> u32 {
    let step = (hi - lo) / 10.0;
    let decimals = if step > 0.0 {
        (-step.log10().floor()).clamp(0.0, 3.0) as usize
    } else {
        0
    };
    let widest = [lo, hi, (lo + hi) / 2.0]
        .iter()
        .map(|v| text_width(&format!("{v:.decimals$}"), TICK_PX))
        .max()
        .unwrap_or(0);
    (widest.max(0) as u32 + AXIS_DESC_PX as u32 + 34).clamp(60, 220)
}

/// A tick label: integers without decimals, other values with at most
/// three decimals and no trailing zeros.
fn tick_label(v: &f64) -> String {
    let v = *v;
    if (v - v.round()).abs() <= 1e-9 * v.abs().max(1.0) {
        let r = v.round();
        return format!("{}", if r == 0.0 { 0.0 } else { r });
    }
    let t = format!("{v:.3}");
    let t = t.trim_end_matches('0').trim_end_matches('.');
    if t == "-0" {
        "0".into()
    } else {
        t.to_string()
    }
}

/// A "nice" upper/lower limit: `v` rounded away from zero to 1, 2, 2.5 or 5
/// times a power of ten.
fn nice(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let a = v.abs();
    let p = 10f64.powf(a.log10().floor());
    let m = a / p;
    let n = [1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0]
        .into_iter()
        .find(|&k| k >= m - 1e-9)
        .unwrap_or(10.0);
    (n * p).copysign(v)
}

/// The x axis of a bar panel: category `j` is centred on `j`, the axis spans
/// `-0.5 .. n - 0.5`, and the ticks sit exactly on the categories.
struct CategoryAxis(usize);

impl Ranged for CategoryAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = (value + 0.5) / self.0 as f64;
        (limit.0 as f64 + t * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, _hint: Hint) -> Vec<f64> {
        (0..self.0).map(|j| j as f64).collect()
    }

    fn range(&self) -> std::ops::Range<f64> {
        -0.5..self.0 as f64 - 0.5
    }
}

fn draw_bar_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &BarPanel,
) -> Result<(), String> {
    let n_cat = p.categories.len();
    let n_ser = p.series.len();
    let tops = p.series.iter().flat_map(|s| {
        s.means
            .iter()
            .enumerate()
            .map(move |(j, m)| (m, s.errors.get(j).copied().unwrap_or(0.0)))
    });
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for (m, e) in tops {
        lo = lo.min(m - e).min(*m);
        hi = hi.max(m + e).max(*m);
    }
    let span = (hi - lo).max(f64::MIN_POSITIVE);
    let hi = if hi > 0.0 {
        nice(hi + 0.08 * span)
    } else {
        0.0
    };
    let lo = if lo < 0.0 {
        nice(lo - 0.08 * span)
    } else {
        0.0
    };
    let (lo, hi) = if hi - lo > 0.0 { (lo, hi) } else { (0.0, 1.0) };

    let x_range = CategoryAxis(n_cat);
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, font(TITLE_PX))
        .margin(14)
        .margin_top(8)
        .x_label_area_size(44)
        .y_label_area_size(y_label_area(lo, hi))
        .build_cartesian_2d(x_range, lo..hi)
        .map_err(s)?;
    let cats = &p.categories;
    let x_fmt = |x: &f64| {
        let j = x.round();
        if (x - j).abs() < 1e-6 && j >= 0.0 {
            cats.get(j as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_label_formatter(&x_fmt)
        .y_desc(p.y_label.as_str())
        .y_label_formatter(&tick_label)
        .y_max_light_lines(1)
        .label_style(font(TICK_PX))
        .axis_desc_style(font(AXIS_DESC_PX))
        .bold_line_style(RGBColor(0xD0, 0xD0, 0xD0).stroke_width(1))
        .light_line_style(RGBColor(0xEE, 0xEE, 0xEE).stroke_width(1))
        .axis_style(BLACK.stroke_width(1))
        .draw()
        .map_err(s)?;

    let group_w = 0.8;
    let bar_w = group_w / n_ser as f64;
    let gap = bar_w * 0.06;
    for (i, ser) in p.series.iter().enumerate() {
        let c = colour(i);
        for (j, &m) in ser.means.iter().enumerate() {
            let x0 = j as f64 - group_w / 2.0 + i as f64 * bar_w;
            let (l, r) = (x0 + gap, x0 + bar_w - gap);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(l, 0.0), (r, m)],
                    c.filled(),
                )))
                .map_err(s)?;
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(l, 0.0), (r, m)],
                    RGBColor(0x33, 0x33, 0x33).stroke_width(1),
                )))
                .map_err(s)?;
        }
    }
    // Error bars last so neighbouring bars never hide them.
    let ink = RGBColor(0x20, 0x20, 0x20).stroke_width(2);
    for (i, ser) in p.series.iter().enumerate() {
        for (j, (&m, &e)) in ser.means.iter().zip(&ser.errors).enumerate() {
            if e <= 0.0 {
                continue;
            }
            let xc = j as f64 - group_w / 2.0 + (i as f64 + 0.5) * bar_w;
            let cap = bar_w * 0.25;
            let (y0, y1) = ((m - e).max(lo), (m + e).min(hi));
            let lines = [
                vec![(xc, y0), (xc, y1)],
                vec![(xc - cap, y0), (xc + cap, y0)],
                vec![(xc - cap, y1), (xc + cap, y1)],
            ];
            chart
                .draw_series(lines.into_iter().map(|l| PathElement::new(l, ink)))
                .map_err(s)?;
        }
    }
    Ok(())
}

/// Draws a 3 px wide polyline. On bitmaps each segment is drawn on its own
/// with round joins: plotters' wide-polyline fill leaves holes where a
/// dense path turns sharply.
fn draw_wide_path<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    path: &[(i32, i32)],
    colour: RGBColor,
    target: Target,
) -> Result<(), String> {
    const WIDTH: u32 = 3;
    match target {
        Target::Vector => area
            .draw(&PathElement::new(path.to_vec(), colour.stroke_width(WIDTH)))
            .map_err(s),
        Target::Bitmap => {
            let path = thin_path(path, 2.0);
            for w in path.windows(2) {
                area.draw(&PathElement::new(w.to_vec(), colour.stroke_width(WIDTH)))
                    .map_err(s)?;
            }
            for &c in path.iter().skip(1).take(path.len().saturating_sub(2)) {
                area.draw(&Circle::new(c, 1, colour.filled())).map_err(s)?;
            }
            Ok(())
        }
    }
}

/// Drops points closer than `min_step` pixels to the last kept one (the
/// last point is always kept).
fn thin_path(path: &[(i32, i32)], min_step: f64) -> Vec<(i32, i32)> {
    let mut out: Vec<(i32, i32)> = Vec::with_capacity(path.len());
    for (k, &p) in path.iter().enumerate() {
        let far = out
            .last()
            .is_none_or(|&q| (((p.0 - q.0) as f64).hypot((p.1 - q.1) as f64)) >= min_step);
        if far {
            out.push(p);
        } else if k + 1 == path.len() && out.len() > 1 {
            out.pop();
            out.push(p);
        }
    }
    out
}

/// Per series index: noise-like in every panel that has that series.
fn faint_series(panels: &[LinePanel], n: usize) -> Vec<bool> {
    let mut faint = vec![true; n];
    for p in panels {
        for (i, j) in jagged_series(p).into_iter().enumerate() {
            faint[i] &= j;
        }
    }
    faint
}

/// The axis ranges of a line panel: x spans the data, y spans the data
/// padded by 5 % each side; degenerate spans are widened.
fn line_ranges(p: &LinePanel) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in p.series.iter().flat_map(|s| s.points.iter()) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let widen = |a: f64, b: f64| {
        if b > a {
            (a, b)
        } else {
            let d = if a == 0.0 { 1.0 } else { a.abs() * 0.05 };
            (a - d, b + d)
        }
    };
    let (x0, x1) = widen(x0, x1);
    let (y0, y1) = widen(y0, y1);
    let pad = 0.05 * (y1 - y0);
    (x0, x1, y0 - pad, y1 + pad)
}

/// Which series of a line panel are noise-like next to the others (e.g.
/// raw per-episode training values drawn with their EWMA). A series'
/// roughness is the length of its path on the panel's nominal plot area
/// divided by the half-perimeter of its bounding box (about 1 for a smooth
/// monotone curve). A series is noise-like if its roughness exceeds 3 and
/// is at least 4 times the smallest roughness in the panel. Such series are
/// drawn thin and translucent, without markers, so that the smoother series
/// drawn with them stay visible; a panel of only smooth or only noisy
/// series is drawn as usual.
fn jagged_series(p: &LinePanel) -> Vec<bool> {
    let (x0, x1, y0, y1) = line_ranges(p);
    // Roughly the plotting area of a panel, in pixels.
    let (w, h) = (PANEL_W as f64 - 150.0, PANEL_H as f64 - 130.0);
    let rough: Vec<f64> = p
        .series
        .iter()
        .map(|ser| {
            let px: Vec<(f64, f64)> = ser
                .points
                .iter()
                .map(|&(x, y)| {
                    (
                        ((x - x0) / (x1 - x0) * w).round(),
                        ((y - y0) / (y1 - y0) * h).round(),
                    )
                })
                .collect();
            let len: f64 = px
                .windows(2)
                .map(|q| (q[1].0 - q[0].0).hypot(q[1].1 - q[0].1))
                .sum();
            let (mut a0, mut a1, mut b0, mut b1) = (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            );
            for &(x, y) in &px {
                a0 = a0.min(x);
                a1 = a1.max(x);
                b0 = b0.min(y);
                b1 = b1.max(y);
            }
            len / ((a1 - a0) + (b1 - b0)).max(1.0)
        })
        .collect();
    let smoothest = rough.iter().copied().fold(f64::INFINITY, f64::min);
    rough
        .iter()
        .map(|&r| r > 3.0 && r >= 4.0 * smoothest)
        .collect()
}

fn draw_line_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &LinePanel,
    looks: &[Look],
    target: Target,
) -> Result<(), String> {
    let (x0, x1, y0, y1) = line_ranges(p);

    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, font(TITLE_PX))
        .margin(14)
        .margin_top(8)
        .margin_right(28)
        .x_label_area_size(70)
        .y_label_area_size(y_label_area(y0, y1))
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc(p.x_label.as_str())
        .y_desc(p.y_label.as_str())
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .max_light_lines(1)
        .label_style(font(TICK_PX))
        .axis_desc_style(font(AXIS_DESC_PX))
        .bold_line_style(RGBColor(0xD0, 0xD0, 0xD0).stroke_width(1))
        .light_line_style(RGBColor(0xEE, 0xEE, 0xEE).stroke_width(1))
        .axis_style(BLACK.stroke_width(1))
        .draw()
        .map_err(s)?;

    let plot = chart.plotting_area();
    let screen = plot.use_screen_coord();
    // Lines are drawn in screen pixels with repeated pixels removed:
    // plotters' wide-line rasteriser misbehaves on zero-length segments.
    let paths: Vec<Vec<(i32, i32)>> = p
        .series
        .iter()
        .map(|ser| {
            let mut v: Vec<(i32, i32)> = Vec::with_capacity(ser.points.len());
            for pt in &ser.points {
                let c = plot.map_coordinate(pt);
                if v.last() != Some(&c) {
                    v.push(c);
                }
            }
            v
        })
        .collect();
    for (i, path) in paths.iter().enumerate() {
        if path.len() < 2 {
            continue;
        }
        let look = looks[i];
        if look.faint {
            let style = colour(look.colour).mix(0.45).stroke_width(1);
            screen
                .draw(&PathElement::new(path.clone(), style))
                .map_err(s)?;
        } else {
            draw_wide_path(&screen, path, colour(look.colour), target)?;
        }
    }
    // Markers on top of all lines, at staggered positions per series so
    // coinciding lines stay distinguishable.
    let n_ser = p.series.len();
    for (i, ser) in p.series.iter().enumerate() {
        if looks[i].faint {
            continue;
        }
        let n = ser.points.len();
        let k = MARKERS_PER_LINE.min(n);
        for m in 0..k {
            let frac = (m as f64 + (i as f64 + 1.0) / (n_ser as f64 + 1.0)) / k as f64;
            let idx = ((frac * n as f64) as usize).min(n - 1);
            let c = plot.map_coordinate(&ser.points[idx]);
            draw_marker(&screen, looks[i].colour, c)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(&140.0), "140");
        assert_eq!(tick_label(&0.0), "0");
        assert_eq!(tick_label(&-0.0), "0");
        assert_eq!(tick_label(&-20.0), "-20");
        assert_eq!(tick_label(&(0.1 + 0.2)), "0.3");
        assert_eq!(tick_label(&2.5), "2.5");
        assert_eq!(tick_label(&0.125), "0.125");
    }

    #[test]
    fn nice_rounds_away_from_zero() {
        assert_eq!(nice(132.0), 150.0);
        assert_eq!(nice(100.0), 100.0);
        assert_eq!(nice(0.0), 0.0);
        assert_eq!(nice(-13.0), -15.0);
        assert!((nice(0.042) - 0.05).abs() < 1e-12);
    }

    #[test]
    fn thin_path_keeps_ends_and_drops_close_points() {
        let p = [(0, 0), (1, 0), (2, 0), (5, 0), (6, 0)];
        assert_eq!(thin_path(&p, 3.0), vec![(0, 0), (6, 0)]);
        assert_eq!(thin_path(&[(0, 0), (1, 0)], 3.0), vec![(0, 0)]);
        assert_eq!(thin_path(&[], 3.0), Vec::<(i32, i32)>::new());
    }

    #[test]
    fn only_noise_next_to_smooth_series_is_faint() {
        let noisy: Vec<f64> = (0..1000)
            .map(|i| ((i * 7919) % 101) as f64 - 50.0 + i as f64 / 20.0)
            .collect();
        let series = |name: &str, v: &[f64]| LineSeries {
            name: name.into(),
            points: v.iter().enumerate().map(|(e, &y)| (e as f64, y)).collect(),
        };
        let panel = |series: Vec<LineSeries>| LinePanel {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series,
        };
        let both = panel(vec![
            series("raw", &noisy),
            series("ewma", &ewma(&noisy, 0.9)),
        ]);
        assert_eq!(jagged_series(&both), vec![true, false]);
        let alone = panel(vec![series("raw", &noisy)]);
        assert_eq!(jagged_series(&alone), vec![false]);
        let smooth: Vec<f64> = (0..100).map(|i| (i as f64 / 10.0).sin()).collect();
        let calm = panel(vec![series("a", &smooth), series("b", &smooth[..50])]);
        assert_eq!(jagged_series(&calm), vec![false, false]);
    }

    #[test]
    fn category_axis_ticks_sit_on_categories() {
        let axis = CategoryAxis(4);
        assert_eq!(axis.key_points(10usize), vec![0.0, 1.0, 2.0, 3.0]);
        assert_eq!(axis.map(&-0.5, (0, 400)), 0);
        assert_eq!(axis.map(&3.5, (0, 400)), 400);
        assert_eq!(axis.map(&1.0, (0, 400)), 150);
    }

    #[test]
    fn the_bundled_font_registers_and_measures_text() {
        ensure_font(Path::new("x.png")).unwrap();
        let w = text_width("MADE-Net", LEGEND_PX);
        assert!((60..200).contains(&w), "width {w}");
    }
}
