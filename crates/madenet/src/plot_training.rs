//! `madenet plot-training`: the training curves of a run directory (the paper's Fig. 2), or of a
//! rollout-teacher run (`iterations.csv`: validation steps and loss per DAgger iteration).

use anyhow::Result;
use clap::Args;
use madenet_trainlog::{plot_run, DEFAULT_FIGURE};
use std::path::PathBuf;

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
    let written = plot_run(&a.dir, &out)?;
    out!("{}", written.display())?;
    Ok(())
}
