//! The curves of a rollout-teacher (DAgger) run from its `iterations.csv`: validation mean
//! steps and training loss per iteration ([`plot_iterations`]); [`plot_run`] draws whichever
//! curves a run directory holds.

use std::path::{Path, PathBuf};

use madenet_plots::{styled_line_panels, LinePanel, LineSeries, LineStyle};

use crate::{plot_training, TrainLogError};

/// The curves of the training run in `run_dir` into `out` (PNG or SVG by its extension): Fig.
/// 2 of the paper from its `episodes.csv` ([`plot_training`]), or a rollout-teacher run's
/// [`plot_iterations`] when it has only an `iterations.csv`. Returns `out`.
pub fn plot_run(run_dir: &Path, out: &Path) -> Result<PathBuf, TrainLogError> {
    let iterations = run_dir.join("iterations.csv");
    if iterations.exists() && !run_dir.join("episodes.csv").exists() {
        return plot_iterations(&iterations, out);
    }
    plot_training(run_dir, out)
}

/// A rollout-teacher run's curves: validation mean steps per iteration (the DEP as it acts, the
/// greedy DEP, the base rule) and the training loss per iteration, one panel each.
pub fn plot_iterations(csv_path: &Path, out: &Path) -> Result<PathBuf, TrainLogError> {
    let path = || csv_path.to_path_buf();
    let row = |line: u64, message: String| TrainLogError::Row {
        path: path(),
        line,
        message,
    };
    let csv_error = |e: csv::Error| {
        let line = e.position().map_or(1, |p| p.line());
        row(line, e.to_string())
    };
    let mut rd = csv::Reader::from_path(csv_path).map_err(|e| match e.into_kind() {
        csv::ErrorKind::Io(source) => TrainLogError::Io {
            action: "read",
            path: path(),
            source,
        },
        kind => row(1, format!("{kind:?}")),
    })?;
    let headers = rd.headers().map_err(csv_error)?.clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| row(1, format!("no column `{name}`")))
    };
    let (it, val, greedy, base, loss) = (
        col("iteration")?,
        col("validation_steps")?,
        col("greedy_steps")?,
        col("base_steps")?,
        col("loss")?,
    );
    let (mut v, mut g, mut b, mut l) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for rec in rd.records() {
        let rec = rec.map_err(csv_error)?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |k: usize| -> Result<f64, TrainLogError> {
            rec[k]
                .parse::<f64>()
                .map_err(|_| row(line, format!("`{}` is not a number", &rec[k])))
        };
        let x = num(it)? + 1.0;
        v.push((x, num(val)?));
        if num(greedy)? > 0.0 {
            g.push((x, num(greedy)?));
        }
        b.push((x, num(base)?));
        l.push((x, num(loss)?));
    }
    if v.is_empty() {
        return Err(row(1, "no iterations yet".into()));
    }
    let mut steps = vec![
        LineSeries {
            name: "DEP as it acts (validation)".into(),
            points: v,
        },
        LineSeries {
            name: "base rule".into(),
            points: b,
        },
    ];
    if !g.is_empty() {
        steps.push(LineSeries {
            name: "greedy DEP".into(),
            points: g,
        });
    }
    // Two panels side by side: the loss in its own axes (in the title it ran off the figure
    // after five iterations).
    let panels = [
        LinePanel {
            title: "Validation mean steps".into(),
            x_label: "DAgger iteration".into(),
            y_label: "mean TNS over the validation trials".into(),
            series: steps,
        },
        LinePanel {
            title: "Training loss".into(),
            x_label: "DAgger iteration".into(),
            y_label: "mean loss of the iteration's fit".into(),
            series: vec![LineSeries {
                name: "loss".into(),
                points: l,
            }],
        },
    ];
    let styles = [
        "DEP as it acts (validation)",
        "base rule",
        "greedy DEP",
        "loss",
    ]
    .iter()
    .enumerate()
    .filter(|(_, name)| {
        panels
            .iter()
            .any(|p| p.series.iter().any(|s| s.name == **name))
    })
    .map(|(colour, name)| LineStyle {
        name: (*name).into(),
        colour,
        faint: false,
    })
    .collect::<Vec<_>>();
    Ok(styled_line_panels(out, &panels, 2, &styles)?)
}
