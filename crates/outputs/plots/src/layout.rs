//! The figure's size and panel grid: panel dimensions, rows and columns, size limits.

use crate::legend::LegendKind;

/// Width of one panel in pixels (PNG); a 2 × 2 grid is 1600 px wide.
pub(crate) const PANEL_W: u32 = 800;
/// Height of one panel in pixels (PNG); a 2 × 2 grid is 1000 px high plus
/// the legend strip.
pub(crate) const PANEL_H: u32 = 500;

/// Largest width or height of a figure in pixels.
const MAX_SIDE_PX: u32 = 16_384;

pub(crate) struct Figure<'a> {
    pub(crate) names: &'a [String],
    /// Per legend entry: its palette index (colour and marker shape).
    pub(crate) colours: Vec<usize>,
    /// Per legend entry: drawn thin and translucent without markers (line
    /// series that are noise-like in every panel they appear in).
    pub(crate) faint: Vec<bool>,
    pub(crate) kind: LegendKind,
    pub(crate) n_panels: usize,
    pub(crate) cols: usize,
}

impl Figure<'_> {
    pub(crate) fn grid(&self) -> (usize, usize) {
        let cols = self.cols.min(self.n_panels).max(1);
        (self.n_panels.div_ceil(cols), cols)
    }

    pub(crate) fn width(&self) -> u32 {
        PANEL_W.saturating_mul(u32::try_from(self.grid().1).unwrap_or(u32::MAX))
    }

    pub(crate) fn height(&self) -> u32 {
        let rows = u32::try_from(self.grid().0).unwrap_or(u32::MAX);
        self.legend_height()
            .saturating_add(PANEL_H.saturating_mul(rows))
    }

    /// Refuses figures too large to render sensibly.
    pub(crate) fn check_size(&self) -> Result<(), String> {
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
