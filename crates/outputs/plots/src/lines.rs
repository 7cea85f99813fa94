//! Line panels (Figs. 2 and 5): axis ranges, noise-like series, wide paths and markers.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::layout::{PANEL_H, PANEL_W};
use crate::output::{s, Panels, Target};
use crate::style::{axes_look, colour, draw_marker, font, TITLE_PX};
use crate::ticks::{tick_label, y_label_area};
use crate::LinePanel;

/// Number of markers drawn along each line series (at most).
const MARKERS_PER_LINE: usize = 10;

pub(crate) struct Lines<'a> {
    pub(crate) panels: &'a [LinePanel],
    /// Per panel, per series: how it is drawn.
    pub(crate) looks: Vec<Vec<Look>>,
}

/// How one line series is drawn.
#[derive(Clone, Copy)]
pub(crate) struct Look {
    /// Palette index: colour and marker shape.
    pub(crate) colour: usize,
    /// Thin and translucent without markers.
    pub(crate) faint: bool,
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
pub(crate) fn faint_series(panels: &[LinePanel], n: usize) -> Vec<bool> {
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
pub(crate) fn jagged_series(p: &LinePanel) -> Vec<bool> {
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
    // Whole-number x data (team sizes, iterations) gets whole-number ticks only: no more
    // labels than units, so plotters never steps by a fraction.
    let whole_x = p
        .series
        .iter()
        .all(|s| s.points.iter().all(|&(x, _)| x.fract() == 0.0));
    let x_labels = if whole_x {
        ((x1 - x0).floor() as usize + 1).clamp(2, 10)
    } else {
        10
    };
    axes_look(
        chart
            .configure_mesh()
            .x_labels(x_labels)
            .x_desc(p.x_label.as_str())
            .y_desc(p.y_label.as_str())
            .x_label_formatter(&tick_label)
            .y_label_formatter(&tick_label)
            .max_light_lines(1),
    )
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
    // coinciding lines stay distinguishable; a marker that would cover one
    // already drawn is moved aside ([`dodge`]: series of a few points, such as
    // Fig. 7's team sizes, share every position).
    let n_ser = p.series.len();
    let mut placed: Vec<(i32, i32)> = Vec::new();
    for (i, ser) in p.series.iter().enumerate() {
        if looks[i].faint {
            continue;
        }
        let n = ser.points.len();
        let k = MARKERS_PER_LINE.min(n);
        for m in 0..k {
            let frac = (m as f64 + (i as f64 + 1.0) / (n_ser as f64 + 1.0)) / k as f64;
            let idx = ((frac * n as f64) as usize).min(n - 1);
            let c = dodge(plot.map_coordinate(&ser.points[idx]), &placed);
            placed.push(c);
            draw_marker(&screen, looks[i].colour, c)?;
        }
    }
    Ok(())
}

/// Pixels between two markers' centres below which one would hide the other.
const MARKER_SPACING: i32 = 12;

/// Where to draw a marker meant for pixel `c` so that it covers none of `placed`:
/// `c` itself if free, else the nearest free spot sideways (right, left, further
/// right, …), its height kept so the value it marks still reads off the y axis.
fn dodge(c: (i32, i32), placed: &[(i32, i32)]) -> (i32, i32) {
    let free = |q: (i32, i32)| {
        placed
            .iter()
            .all(|p| (p.0 - q.0).abs() >= MARKER_SPACING || (p.1 - q.1).abs() >= MARKER_SPACING)
    };
    (0..16)
        .map(|k| {
            let step = (k + 1) / 2 * MARKER_SPACING;
            (c.0 + if k % 2 == 1 { step } else { -step }, c.1)
        })
        .find(|&q| free(q))
        .unwrap_or(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fig. 7's complaint: one line exactly under another could not be seen. Markers of
    /// coinciding series are moved aside, so each series shows its own.
    #[test]
    fn markers_of_coinciding_series_are_moved_aside() {
        let mut placed = Vec::new();
        for _ in 0..3 {
            let c = dodge((100, 50), &placed);
            placed.push(c);
        }
        assert_eq!(placed, vec![(100, 50), (112, 50), (88, 50)]);
        // Far enough apart already: kept where they are.
        assert_eq!(dodge((100, 80), &placed), (100, 80));
    }
    use crate::{ewma, LineSeries};

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
}
