//! Input checks: panel and series shapes, finite values, consistent series names.

use crate::{BarPanel, LinePanel, MAX_ABS_VALUE};

/// Checks that there are panels and columns, then each panel with `check`, whose complaint
/// is prefixed with the panel's index and `title`.
fn check_panels<P>(
    panels: &[P],
    cols: usize,
    title: impl Fn(&P) -> &str,
    check: impl Fn(&P) -> Result<(), String>,
) -> Result<(), String> {
    if panels.is_empty() {
        return Err("no panels given".into());
    }
    if cols == 0 {
        return Err("cols must be at least 1".into());
    }
    for (pi, p) in panels.iter().enumerate() {
        check(p).map_err(|what| format!("panel {pi} ({:?}): {what}", title(p)))?;
    }
    Ok(())
}

pub(crate) fn validate_bars(panels: &[BarPanel], cols: usize) -> Result<(), String> {
    check_panels(panels, cols, |p| &p.title, check_bar_panel)
}

/// What is wrong with one panel, if anything.
fn check_bar_panel(p: &BarPanel) -> Result<(), String> {
    if p.categories.is_empty() {
        return Err("no categories".into());
    }
    if p.series.is_empty() {
        return Err("no series".into());
    }
    for s in &p.series {
        if s.means.len() != p.categories.len() {
            return Err(format!(
                "series {:?} has {} means for {} categories",
                s.name,
                s.means.len(),
                p.categories.len()
            ));
        }
        if !s.errors.is_empty() && s.errors.len() != s.means.len() {
            return Err(format!(
                "series {:?} has {} errors for {} means",
                s.name,
                s.errors.len(),
                s.means.len()
            ));
        }
        if let Some(v) = s.means.iter().find(|v| !v.is_finite()) {
            return Err(format!("series {:?} has a non-finite mean ({v})", s.name));
        }
        if let Some(v) = s.errors.iter().find(|v| !v.is_finite() || **v < 0.0) {
            return Err(format!(
                "series {:?} has an error that is negative or not finite ({v})",
                s.name
            ));
        }
        let too_big = s
            .means
            .iter()
            .enumerate()
            .find(|&(j, m)| m.abs() + s.errors.get(j).copied().unwrap_or(0.0) > MAX_ABS_VALUE);
        if let Some((_, v)) = too_big {
            return Err(format!(
                "series {:?} has a bar beyond ±{MAX_ABS_VALUE:e} ({v:e} with its error)",
                s.name
            ));
        }
    }
    Ok(())
}

pub(crate) fn validate_lines(panels: &[LinePanel], cols: usize) -> Result<(), String> {
    check_panels(panels, cols, |p| &p.title, check_line_panel)
}

/// What is wrong with one panel, if anything.
fn check_line_panel(p: &LinePanel) -> Result<(), String> {
    if p.series.is_empty() {
        return Err("no series".into());
    }
    for s in &p.series {
        if s.points.is_empty() {
            return Err(format!("series {:?} has no points", s.name));
        }
        if let Some((x, y)) = s
            .points
            .iter()
            .find(|(x, y)| !x.is_finite() || !y.is_finite())
        {
            return Err(format!(
                "series {:?} has a non-finite point ({x}, {y})",
                s.name
            ));
        }
        let too_big = s
            .points
            .iter()
            .find(|(x, y)| x.abs() > MAX_ABS_VALUE || y.abs() > MAX_ABS_VALUE);
        if let Some((x, y)) = too_big {
            return Err(format!(
                "series {:?} has a point beyond ±{MAX_ABS_VALUE:e} ({x:e}, {y:e})",
                s.name
            ));
        }
    }
    Ok(())
}

/// The legend entries: series names by index, checked to agree across
/// panels (a panel may have fewer series than another).
pub(crate) fn legend_names<'a, P, S>(panels: P) -> Result<Vec<String>, String>
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
