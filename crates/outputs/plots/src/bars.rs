//! Grouped bar panels with error bars (Fig. 4).

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::output::{s, Panels, Target};
use crate::style::{axes_look, colour, font, TITLE_PX};
use crate::ticks::{nice, tick_label, y_label_area, CategoryAxis};
use crate::BarPanel;

pub(crate) struct Bars<'a>(pub(crate) &'a [BarPanel]);

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
    axes_look(
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_label_formatter(&x_fmt)
            .y_desc(p.y_label.as_str())
            .y_label_formatter(&tick_label)
            .y_max_light_lines(1),
    )
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
