//! `scale.md` and the figure: the tables, the tests across team sizes and between methods,
//! and a continuous study's comparison with its grid twin.

use super::cells::{paired, tns, ttd};
use super::{CellRow, ScaleConfig, ScalePlanned, ScaleWorld};
use crate::analysis::mean_sd;
use crate::config::StudyError;
use crate::runner::TrialOutcome;
use madenet_stats::{friedman, wilcoxon};
use std::fmt::Write as _;
use std::path::Path;

/// The rest of a table's header after its first column: one column per team size, then the
/// separator line (`2 robots | 3 robots |\n|---|---|---|`).
fn team_columns(teams: &[usize]) -> String {
    let names: Vec<String> = teams.iter().map(|t| format!("{t} robots")).collect();
    format!(
        "{} |\n|---|{}",
        names.join(" | "),
        "---|".repeat(teams.len())
    )
}

fn p_text(p: f64) -> String {
    if p < 1e-3 {
        format!("{p:.1e}")
    } else {
        format!("{p:.3}")
    }
}

pub(super) fn report_text(
    cfg: &ScaleConfig,
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
    cells: &[CellRow],
    wall: f64,
) -> String {
    let mut s = String::new();
    let (what, unit, cap, world) = match cfg.world {
        ScaleWorld::Grid => ("TNS", "steps", "step cap", "grid world"),
        ScaleWorld::Continuous => ("ET", "s", "time cap, s", "continuous world"),
    };
    let _ = writeln!(
        s,
        "# Scalability study ({world})\n\n{} trials (({} methods{}) × sides {:?} × {} maps × starts {} × teams {:?} × {} seeds) at CSP {}, {:.1} min of this run's wall time.\nMean {what} ({unit}) / TTD (m) / NOLI, completed trials in brackets when not all; figure `fig7_scalability.png`.\n",
        outcomes.len(),
        cfg.methods.len(),
        if planned.iter().any(|p| p.planned.oracle.is_some()) {
            " + the known-map reference"
        } else {
            ""
        },
        cfg.sides,
        cfg.maps_per_side,
        cfg.starts.iter().map(|s| s.name()).collect::<Vec<_>>().join(", "),
        cfg.teams,
        cfg.seeds,
        cfg.csp,
        wall / 60.0
    );
    if cfg.world == ScaleWorld::Continuous {
        let sum = |f: fn(&crate::runner::ContinuousColumns) -> u64| {
            outcomes
                .iter()
                .filter_map(|o| o.row.continuous.as_ref())
                .map(f)
                .sum::<u64>()
        };
        let _ = writeln!(
            s,
            "Over all trials: {} robot–obstacle and {} robot–robot collisions, {} cells found impassable by a local planner, {} cells written off (a robot next to them could not read them; they count as explored), of which {} explorable ({:.1} % of all trials' explorable cells: explored unread), {} stuck events, {} of {} trials incomplete ({} stopped by the time cap, the others when no robot had a reachable frontier left).\n",
            sum(|c| c.obstacle_collisions),
            sum(|c| c.robot_collisions),
            sum(|c| c.impassable_cells),
            sum(|c| c.written_off_cells),
            sum(|c| c.unread_cells),
            100.0 * sum(|c| c.unread_cells) as f64 / sum(|c| c.explorable_cells).max(1) as f64,
            sum(|c| c.stuck),
            outcomes.iter().filter(|o| !o.row.completed).count(),
            outcomes.len(),
            planned
                .iter()
                .zip(outcomes)
                .filter(|(p, o)| !o.row.completed && tns(o) >= cfg.step_cap(p.side) as f64)
                .count()
        );
    }
    for &side in &cfg.sides {
        let _ = writeln!(
            s,
            "## {side} × {side} ({cap} {})\n\n| method | {}",
            cfg.step_cap(side),
            team_columns(&cfg.teams)
        );
        for method in &cfg.methods {
            let row: Vec<String> = cfg
                .teams
                .iter()
                .map(|&t| {
                    let c = cells
                        .iter()
                        .find(|c| c.side == side && c.team == t && &c.method == method)
                        .expect("every cell computed");
                    let done = if c.completed < c.trials {
                        format!(" ({}/{})", c.completed, c.trials)
                    } else {
                        String::new()
                    };
                    format!("{:.1} / {:.0} / {:.0}{done}", c.tns, c.ttd_m, c.noli)
                })
                .collect();
            let _ = writeln!(s, "| {method} | {} |", row.join(" | "));
        }
        let _ = writeln!(
            s,
            "\nAcross team sizes ({what}; Friedman over teams, blocks = map × start × seed; Wilcoxon between consecutive sizes):\n"
        );
        for method in &cfg.methods {
            let groups: Vec<Vec<f64>> = cfg
                .teams
                .iter()
                .map(|&t| paired(planned, outcomes, method, Some(side), Some(t), tns))
                .collect();
            let refs: Vec<&[f64]> = groups.iter().map(|g| g.as_slice()).collect();
            let fr = if refs.len() < 3 {
                "Friedman needs 3 or more team sizes".to_string()
            } else {
                friedman(&refs)
                    .map(|f| {
                        format!(
                            "Friedman χ² = {:.1}, p = {}",
                            f.statistic,
                            p_text(f.p_value)
                        )
                    })
                    .unwrap_or_else(|e| format!("Friedman not computed ({e})"))
            };
            let mut steps = Vec::new();
            let mut stops = None;
            for w in 0..cfg.teams.len().saturating_sub(1) {
                let (a, b) = (&groups[w], &groups[w + 1]);
                let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
                let (p, falls) = match wilcoxon(a, b) {
                    Ok(r) => (r.p_value, mean(b) < mean(a) && r.p_value < 0.05),
                    Err(_) => (1.0, false),
                };
                if !falls && stops.is_none() {
                    stops = Some(cfg.teams[w]);
                }
                steps.push(format!(
                    "{}→{}: {:+.1} (p {})",
                    cfg.teams[w],
                    cfg.teams[w + 1],
                    mean(b) - mean(a),
                    p_text(p)
                ));
            }
            let stop_text = match stops {
                Some(t) => format!("stops falling significantly after {t} robots"),
                None => "falls significantly at every step".into(),
            };
            let _ = writeln!(s, "- {method}: {fr}; {}; {stop_text}", steps.join(", "));
        }
        let _ = writeln!(s);
    }
    if cfg.methods.len() > 1 {
        let focus = &cfg.methods[0];
        let _ = writeln!(
            s,
            "## {focus} against the others\n\n| method | cells where {focus} has lower mean {what} | … and lower mean TTD | pooled {what} difference ({unit}) | Wilcoxon p ({what}) | pooled TTD difference (m) | Wilcoxon p (TTD) |\n|---|---|---|---|---|---|---|"
        );
        for other in &cfg.methods[1..] {
            let (mut lower_tns, mut lower_both, mut n) = (0, 0, 0);
            for &side in &cfg.sides {
                for &team in &cfg.teams {
                    let get = |m: &String| {
                        cells
                            .iter()
                            .find(|c| c.side == side && c.team == team && &c.method == m)
                            .expect("every cell computed")
                    };
                    let (a, b) = (get(focus), get(other));
                    n += 1;
                    lower_tns += (a.tns < b.tns) as usize;
                    lower_both += (a.tns < b.tns && a.ttd_m < b.ttd_m) as usize;
                }
            }
            let test = |metric: fn(&TrialOutcome) -> f64| {
                let x = paired(planned, outcomes, focus, None, None, metric);
                let y = paired(planned, outcomes, other, None, None, metric);
                let diff = (x.iter().sum::<f64>() - y.iter().sum::<f64>()) / x.len().max(1) as f64;
                let p = wilcoxon(&x, &y)
                    .map(|r| p_text(r.p_value))
                    .unwrap_or("–".into());
                (diff, p)
            };
            let (dt, pt) = test(tns);
            let (dd, pd) = test(ttd);
            let _ = writeln!(
                s,
                "| {other} | {lower_tns}/{n} | {lower_both}/{n} | {dt:+.2} | {pt} | {dd:+.1} | {pd} |"
            );
        }
    }
    s
}

/// Each method's time relative to the block's mean over methods (block = map × start × team ×
/// seed), averaged: below 1 is faster than the methods' average on the same trials.
fn relative_time(
    cfg: &ScaleConfig,
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
) -> Vec<f64> {
    let by_method: Vec<Vec<f64>> = cfg
        .methods
        .iter()
        .map(|m| paired(planned, outcomes, m, None, None, tns))
        .collect();
    let blocks = by_method.first().map_or(0, Vec::len);
    let block_mean =
        |b: usize| by_method.iter().map(|v| v[b]).sum::<f64>() / by_method.len() as f64;
    by_method
        .iter()
        .map(|v| (0..blocks).map(|b| v[b] / block_mean(b)).sum::<f64>() / blocks.max(1) as f64)
        .collect()
}

/// The continuous study beside its grid twin: the methods' ranking and each gap of the first
/// method to the others in both worlds, per side and pooled, with paired Wilcoxon tests.
pub(super) fn twin_text(
    cfg: &ScaleConfig,
    continuous: (&[ScalePlanned], &[TrialOutcome]),
    grid: (&[ScalePlanned], &[TrialOutcome]),
) -> String {
    let mut s = String::new();
    let rank = |(p, o): (&[ScalePlanned], &[TrialOutcome])| {
        let rel = relative_time(cfg, p, o);
        let mut order: Vec<usize> = (0..cfg.methods.len()).collect();
        order.sort_by(|&a, &b| rel[a].total_cmp(&rel[b]));
        order
            .iter()
            .map(|&k| format!("{} {:.3}", cfg.methods[k], rel[k]))
            .collect::<Vec<_>>()
            .join(" < ")
    };
    let _ = writeln!(
        s,
        "## Grid and continuous worlds on the same maps

The grid twin (`grid/`) runs every trial of this study in the grid world: the scenes read as cells by the scenario's rule, the same start cells, teams, methods and seeds, TNS in steps. Ranking by mean time relative to the methods' mean on the same trial (below 1: faster):

- grid: {}
- continuous: {}
",
        rank(grid),
        rank(continuous)
    );
    let Some(focus) = cfg.methods.first() else {
        return s;
    };
    let _ = writeln!(
        s,
        "{focus} against each other method: mean time difference in % of the other's mean (negative: {focus} faster), paired Wilcoxon p over the same trials.

| side | method | grid Δ TNS | p | continuous Δ ET | p | same verdict |
|---|---|---|---|---|---|---|"
    );
    let sides: Vec<Option<usize>> = cfg
        .sides
        .iter()
        .map(|&x| Some(x))
        .chain(std::iter::once(None))
        .collect();
    for side in sides {
        for other in &cfg.methods[1..] {
            let gap = |(p, o): (&[ScalePlanned], &[TrialOutcome])| {
                let x = paired(p, o, focus, side, None, tns);
                let y = paired(p, o, other, side, None, tns);
                let (mx, my) = (mean_sd(&x).0, mean_sd(&y).0);
                let pct = 100.0 * (mx - my) / my.max(f64::MIN_POSITIVE);
                let p = wilcoxon(&x, &y).map(|r| r.p_value).ok();
                (pct, p)
            };
            let (gd, gp) = gap(grid);
            let (cd, cp) = gap(continuous);
            // A verdict: faster, slower or no difference at p < 0.05.
            let verdict = |d: f64, p: Option<f64>| match p {
                Some(p) if p < 0.05 => d.signum() as i32,
                _ => 0,
            };
            let same = if verdict(gd, gp) == verdict(cd, cp) {
                "yes"
            } else {
                "no"
            };
            let p_or = |p: Option<f64>| p.map_or("–".to_string(), p_text);
            let side_text = side.map_or("all".to_string(), |x| format!("{x}"));
            let _ = writeln!(
                s,
                "| {side_text} | {other} | {gd:+.1} % | {} | {cd:+.1} % | {} | {same} |",
                p_or(gp),
                p_or(cp)
            );
        }
    }
    s
}

/// One panel per map side of `value(method, side, team)` against team size, a series per
/// method (teams without a value left out), drawn as `stem.{png,svg}` in rows of two.
fn team_panels(
    cfg: &ScaleConfig,
    stem: &Path,
    title: impl Fn(usize) -> String,
    y_label: &str,
    value: impl Fn(&str, usize, usize) -> Option<f64>,
) -> Result<(), StudyError> {
    use madenet_plots::{line_panels, LinePanel, LineSeries};
    let panels: Vec<LinePanel> = cfg
        .sides
        .iter()
        .map(|&side| LinePanel {
            title: title(side),
            x_label: "Robots".into(),
            y_label: y_label.into(),
            series: cfg
                .methods
                .iter()
                .map(|m| LineSeries {
                    name: m.clone(),
                    points: cfg
                        .teams
                        .iter()
                        .filter_map(|&t| Some((t as f64, value(m, side, t)?)))
                        .collect(),
                })
                .collect(),
        })
        .collect();
    line_panels(stem, &panels, panels.len().min(2))
        .map_err(|e| StudyError::Other(e.to_string()))?;
    Ok(())
}

pub(super) fn figure(cfg: &ScaleConfig, cells: &[CellRow], out: &Path) -> Result<(), StudyError> {
    let title = |side: usize| match cfg.world {
        ScaleWorld::Grid => format!("{side} × {side} cells"),
        ScaleWorld::Continuous => format!("{0} × {0} m", side as f64 * cfg.scenario.cell_size),
    };
    let y_label = match cfg.world {
        ScaleWorld::Grid => "Mean TNS (steps)",
        ScaleWorld::Continuous => "Mean ET (s)",
    };
    team_panels(
        cfg,
        &out.join("fig7_scalability"),
        title,
        y_label,
        |m, side, t| {
            cells
                .iter()
                .find(|c| c.side == side && c.team == t && c.method == m)
                .map(|c| c.tns)
        },
    )
}

/// `fig_headroom.{png,svg}`: every method's mean TNS as % above the known-map reference's,
/// against team size, one panel per map side — the headroom table of [`headroom_text`] as a
/// picture. Nothing is drawn without the reference's trials.
pub(super) fn headroom_figure(
    cfg: &ScaleConfig,
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
    out: &Path,
) -> Result<(), StudyError> {
    let reference = crate::config::oracle_method(madenet_baselines::rollout::OracleKind::KnownMap);
    let mean_tns = |m: &str, side: usize, team: usize| {
        let v = paired(planned, outcomes, m, Some(side), Some(team), tns);
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    // A panel with a method that has no point would be refused by the plot: draw nothing.
    let complete = cfg.sides.iter().all(|&side| {
        cfg.methods.iter().all(|m| {
            cfg.teams
                .iter()
                .any(|&t| mean_tns(&reference, side, t).is_some() && mean_tns(m, side, t).is_some())
        })
    });
    if !complete {
        return Ok(());
    }
    team_panels(
        cfg,
        &out.join("fig_headroom"),
        |side| format!("{side} × {side} cells"),
        "Mean TNS above the known-map reference (%)",
        |m, side, t| {
            Some(100.0 * (mean_tns(m, side, t)? / mean_tns(&reference, side, t)?.max(1.0) - 1.0))
        },
    )
}

/// The headroom: per map side and team, the mean lower bound, the known-map reference's mean
/// TNS, and every method's mean TNS above both; the first method's share of each other
/// method's gap to the reference that it closes, pooled per side. Empty without the reference.
pub(super) fn headroom_text(
    cfg: &ScaleConfig,
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
    bounds: &crate::report::Bounds,
) -> String {
    let reference = crate::config::oracle_method(madenet_baselines::rollout::OracleKind::KnownMap);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let tns_of = |m: &str, side: usize, team: Option<usize>| {
        mean(&paired(planned, outcomes, m, Some(side), team, tns))
    };
    if paired(planned, outcomes, &reference, None, None, tns).is_empty() {
        return String::new();
    }
    let bound_of = |side: usize, team: Option<usize>| {
        let v: Vec<f64> = planned
            .iter()
            .filter(|p| {
                p.planned.key.method == reference
                    && p.side == side
                    && team.is_none_or(|t| p.team == t)
            })
            .filter_map(|p| {
                let k = &p.planned.key;
                bounds.get(&(k.map.clone(), k.start.clone(), k.seed))
            })
            .map(|&b| b as f64)
            .collect();
        mean(&v)
    };
    let mut s = format!(
        "## Headroom: the known-map reference and the lower bound\n\n{} Each cell: mean TNS \
         (% above the reference; % above the bound).\n\n",
        crate::report::HEADROOM_DEFINITIONS
    );
    for &side in &cfg.sides {
        let _ = writeln!(
            s,
            "### {side} × {side}\n\n| run | {}",
            team_columns(&cfg.teams)
        );
        let bounds_row: Vec<String> = cfg
            .teams
            .iter()
            .map(|&t| format!("{:.1}", bound_of(side, Some(t))))
            .collect();
        let _ = writeln!(s, "| lower bound | {} |", bounds_row.join(" | "));
        for m in std::iter::once(&reference).chain(&cfg.methods) {
            let row: Vec<String> = cfg
                .teams
                .iter()
                .map(|&t| {
                    let (v, r, b) = (
                        tns_of(m, side, Some(t)),
                        tns_of(&reference, side, Some(t)),
                        bound_of(side, Some(t)),
                    );
                    format!(
                        "{v:.1} ({:+.0} %; {:+.0} %)",
                        100.0 * (v / r.max(1.0) - 1.0),
                        100.0 * (v / b.max(1.0) - 1.0)
                    )
                })
                .collect();
            let _ = writeln!(s, "| {m} | {} |", row.join(" | "));
        }
        if let Some(focus) = cfg.methods.first() {
            let closes: Vec<String> = cfg.methods[1..]
                .iter()
                .map(|other| {
                    let (o, f, r) = (
                        tns_of(other, side, None),
                        tns_of(focus, side, None),
                        tns_of(&reference, side, None),
                    );
                    if o - r > 1e-9 {
                        format!("{other} {:.0} %", 100.0 * (o - f) / (o - r))
                    } else {
                        format!("{other} — (not above the reference)")
                    }
                })
                .collect();
            if !closes.is_empty() {
                let _ = writeln!(
                    s,
                    "\nShare of each method's gap to the reference (all teams pooled) that {focus} closes: {}.",
                    closes.join(", ")
                );
            }
        }
        let _ = writeln!(s);
    }
    s
}
