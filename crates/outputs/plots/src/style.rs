//! The bundled font, text sizes, the colour palette and the marker shapes.

use std::path::Path;
use std::sync::OnceLock;

use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::output::s;
use crate::PlotError;

/// The bundled font (a subset of DejaVu Sans 2.37; licence in
/// `assets/DejaVuSans-LICENSE.txt`).
pub(crate) const FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// The family name the bundled font is registered under and drawn with.
const FONT_FAMILY: &str = "sans-serif";

pub(crate) const TITLE_PX: f64 = 26.0;
pub(crate) const AXIS_DESC_PX: f64 = 22.0;
pub(crate) const TICK_PX: f64 = 19.0;
pub(crate) const LEGEND_PX: f64 = 22.0;

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

/// A temporary path next to `target` that keeps its extension (plotters'
/// bitmap backend picks the encoder from the extension).
pub(crate) fn ensure_font(path: &Path) -> Result<(), PlotError> {
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

/// Width in pixels of `text` at `size` in the bundled font.
pub(crate) fn text_width(text: &str, size: f64) -> i32 {
    FontDesc::new(FontFamily::Name(FONT_FAMILY), size, FontStyle::Normal)
        .box_size(text)
        .map(|(w, _)| w as i32)
        .unwrap_or((text.chars().count() as f64 * size * 0.6) as i32)
}

/// The look every panel's axes share: tick and axis-label fonts, light grey grid lines,
/// black axes.
pub(crate) fn axes_look<'m, 'a, 'b, X: Ranged, Y: Ranged, DB: DrawingBackend>(
    mesh: &'m mut MeshStyle<'a, 'b, X, Y, DB>,
) -> &'m mut MeshStyle<'a, 'b, X, Y, DB> {
    mesh.label_style::<TextStyle<'b>>(font(TICK_PX))
        .axis_desc_style::<TextStyle<'b>>(font(AXIS_DESC_PX))
        .bold_line_style(RGBColor(0xD0, 0xD0, 0xD0).stroke_width(1))
        .light_line_style(RGBColor(0xEE, 0xEE, 0xEE).stroke_width(1))
        .axis_style(BLACK.stroke_width(1))
}

pub(crate) fn font(size: f64) -> TextStyle<'static> {
    (FONT_FAMILY, size).into_font().color(&BLACK)
}

pub(crate) fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Draws marker `i` (shape by index, colour by index) centred on pixel `c`.
pub(crate) fn draw_marker<DB: DrawingBackend>(
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bundled_font_registers_and_measures_text() {
        ensure_font(Path::new("x.png")).unwrap();
        let w = text_width("MADE-Net", LEGEND_PX);
        assert!((60..200).contains(&w), "width {w}");
    }
}
