//! Axis ticks and labels: tick label text, round axis limits, the category axis of bar panels.

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

use crate::style::{text_width, AXIS_DESC_PX, TICK_PX};

/// Width of the y label area: room for the rotated axis description and
/// the widest tick label likely on an axis from `lo` to `hi` (about ten
/// ticks).
pub(crate) fn y_label_area(lo: f64, hi: f64) -> u32 {
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
pub(crate) fn tick_label(v: &f64) -> String {
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
pub(crate) fn nice(v: f64) -> f64 {
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
pub(crate) struct CategoryAxis(pub(crate) usize);

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
    fn category_axis_ticks_sit_on_categories() {
        let axis = CategoryAxis(4);
        assert_eq!(axis.key_points(10usize), vec![0.0, 1.0, 2.0, 3.0]);
        assert_eq!(axis.map(&-0.5, (0, 400)), 0);
        assert_eq!(axis.map(&3.5, (0, 400)), 400);
        assert_eq!(axis.map(&1.0, (0, 400)), 150);
    }
}
