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

#![deny(missing_docs)]

mod bars;
mod layout;
mod legend;
mod lines;
mod output;
mod style;
mod ticks;
mod validate;

use std::path::{Path, PathBuf};

use crate::bars::Bars;
use crate::layout::Figure;
use crate::legend::LegendKind;
use crate::lines::{faint_series, jagged_series, Lines, Look};
use crate::output::{with_ext, write_figure, write_one, Target};
use crate::validate::{legend_names, validate_bars, validate_lines};

/// The bundled font's TrueType bytes (the subset of DejaVu Sans 2.37 described in
/// `assets/README.md`) that the figures' text is drawn with, for other crates drawing text in
/// the same face (`madenet-render`'s frame pictures).
pub fn font_bytes() -> &'static [u8] {
    style::FONT_BYTES
}

/// Largest magnitude of a value that can be plotted; larger values (and
/// bar tops `mean ± error` beyond it) are rejected as input errors.
pub const MAX_ABS_VALUE: f64 = 1e15;

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
    write_grid(
        stem,
        cols,
        validate_bars(panels, cols),
        panels
            .iter()
            .map(|p| p.series.iter().map(|s| s.name.as_str())),
        LegendKind::Bar,
        |n| vec![false; n],
        |fig| write_figure(stem, fig, &Bars(panels)),
    )
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
    write_grid(
        stem,
        cols,
        validate_lines(panels, cols),
        panels
            .iter()
            .map(|p| p.series.iter().map(|s| s.name.as_str())),
        LegendKind::Line,
        |n| faint_series(panels, n),
        |fig| {
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
            write_figure(stem, fig, &Lines { panels, looks })
        },
    )
}

/// What [`bar_panels`] and [`line_panels`] share: after `checked` (the panels' own input
/// checks) and a check that the panels' `series` names agree (one iterator of names per
/// panel), both as input errors naming `stem.png`, lays out a grid of `cols` columns with one
/// legend entry per series, series `i` in colour `i`, `faint(n)` marking which of the `n`
/// entries are faint, and hands it to `write` if it is not too large.
fn write_grid<'a, P, S>(
    stem: &Path,
    cols: usize,
    checked: Result<(), String>,
    series: P,
    kind: LegendKind,
    faint: impl FnOnce(usize) -> Vec<bool>,
    write: impl FnOnce(&Figure<'_>) -> Result<Vec<PathBuf>, PlotError>,
) -> Result<Vec<PathBuf>, PlotError>
where
    P: ExactSizeIterator<Item = S>,
    S: Iterator<Item = &'a str>,
{
    let png = with_ext(stem, "png");
    let invalid = |reason| PlotError::InvalidInput {
        path: png.clone(),
        reason,
    };
    checked.map_err(invalid)?;
    let n_panels = series.len();
    let names = legend_names(series).map_err(invalid)?;
    let fig = Figure {
        colours: (0..names.len()).collect(),
        faint: faint(names.len()),
        names: &names,
        kind,
        n_panels,
        cols,
    };
    fig.check_size().map_err(invalid)?;
    write(&fig)
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
