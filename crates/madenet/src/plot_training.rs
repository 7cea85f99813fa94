//! `madenet plot-training`: the training curves of a run directory (the paper's Fig. 2), or of a
//! rollout-teacher run (`iterations.csv`: validation steps and loss per DAgger iteration).

use anyhow::{Context, Result};
use clap::Args;
use madenet_plots::{styled_line_panels, LinePanel, LineSeries, LineStyle};
use madenet_trainlog::{plot_training, DEFAULT_FIGURE};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct PlotTrainingArgs {
    /// Training run directory, holding episodes.csv (and validation.csv, if any), or a
    /// rollout-teacher run's iterations.csv.
    dir: PathBuf,
    /// Output figure, PNG or SVG by its extension [default: DIR/fig2_training.png].
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(a: PlotTrainingArgs) -> Result<()> {
    let out = a.out.unwrap_or_else(|| a.dir.join(DEFAULT_FIGURE));
    let rollout = a.dir.join("iterations.csv");
    if rollout.exists() && !a.dir.join("episodes.csv").exists() {
        let written = plot_iterations(&rollout, &out)?;
        out!("{}", written.display())?;
        return Ok(());
    }
    let written = plot_training(&a.dir, &out)?;
    out!("{}", written.display())?;
    Ok(())
}

/// A rollout-teacher run's curves: validation mean steps per iteration (the DEP as it acts, the
/// greedy DEP, the base rule) and the training loss per iteration, one panel each.
fn plot_iterations(csv_path: &Path, out: &Path) -> Result<PathBuf> {
    let mut rd =
        csv::Reader::from_path(csv_path).with_context(|| csv_path.display().to_string())?;
    let headers = rd
        .headers()
        .with_context(|| csv_path.display().to_string())?
        .clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .with_context(|| format!("{}: no column `{name}`", csv_path.display()))
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
        let rec = rec.with_context(|| csv_path.display().to_string())?;
        let num = |k: usize| -> Result<f64> {
            rec[k]
                .parse::<f64>()
                .with_context(|| format!("{}: `{}` is not a number", csv_path.display(), &rec[k]))
        };
        let x = num(it)? + 1.0;
        v.push((x, num(val)?));
        if num(greedy)? > 0.0 {
            g.push((x, num(greedy)?));
        }
        b.push((x, num(base)?));
        l.push((x, num(loss)?));
    }
    anyhow::ensure!(!v.is_empty(), "{}: no iterations yet", csv_path.display());
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
