//! The legend strip above the panel grid: its layout in rows and its drawing.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::layout::Figure;
use crate::output::s;
use crate::style::{colour, draw_marker, font, text_width, LEGEND_PX};

const LEGEND_ROW_H: u32 = 36;
const LEGEND_PAD: u32 = 14;
const LEGEND_SWATCH_W: i32 = 44;
const LEGEND_ENTRY_GAP: i32 = 36;

/// What the shared legend shows next to each name.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum LegendKind {
    Bar,
    Line,
}

impl Figure<'_> {
    /// Lays the legend entries out in rows that fit the figure width:
    /// returns, per row, the entries' indices and widths.
    pub(crate) fn legend_rows(&self) -> Vec<Vec<(usize, i32)>> {
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

    pub(crate) fn legend_height(&self) -> u32 {
        let rows = u32::try_from(self.legend_rows().len()).unwrap_or(u32::MAX);
        (2 * LEGEND_PAD).saturating_add(LEGEND_ROW_H.saturating_mul(rows))
    }
}

pub(crate) fn draw_legend<DB: DrawingBackend>(
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
