//! `madenet train`: trains any learner (MADE-Net, MADE-Net-DT, the rollout teacher's DEP, DME-DRL:
//! `madenet_catalogue::LearnerKind`) into a run directory, with a progress bar;
//! `--resume DIR` continues a run from its last checkpoint.

use anyhow::Result;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use madenet_catalogue::TrainRequest;
use madenet_learn::Progress;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct TrainArgs {
    /// Training config (TOML; every field optional, see configs/train.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Run directory to create (logs, checkpoints, best weights).
    #[arg(long, conflicts_with = "resume")]
    out: Option<PathBuf>,
    /// Resume the run in this directory from its last checkpoint (with its saved config).
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Train this method instead of the config's (`made-net`, `made-net-dt`, `made-net-rollout` or `dme-drl`).
    #[arg(long)]
    method: Option<String>,
    /// Override the config's episodes per environment.
    #[arg(long)]
    episodes: Option<u64>,
    /// Override the config's wall-time limit in minutes.
    #[arg(long)]
    max_minutes: Option<f64>,
    /// Override the config's seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Override the config's learner thread count.
    #[arg(long, value_parser = crate::threads_arg)]
    threads: Option<usize>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

pub fn run(a: TrainArgs) -> Result<()> {
    let request = TrainRequest {
        config: a.config.clone(),
        out: a.out.clone(),
        resume: a.resume.clone(),
        method: a.method.clone(),
        episodes: a.episodes,
        max_minutes: a.max_minutes,
        seed: a.seed,
        threads: a.threads,
    };
    // A bar of the learner's units (episodes or iterations); a learner that counts iterations
    // also prints a line per iteration.
    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(0)
    };
    let mut styled = false;
    let (dir, progressed) = request.train(&mut |p: &Progress| {
        if !styled {
            styled = true;
            let template = format!(
                "{{elapsed_precise}} [{{bar:30}}] {{pos}}/{{len}} {}  {{msg}}",
                p.unit
            );
            let style = ProgressStyle::with_template(&template).expect("valid template");
            bar.set_style(style.progress_chars("=> "));
            if !a.quiet {
                madenet_study::progress::lines_off_terminal(&bar, p.unit);
            }
        }
        bar.set_length(p.total);
        bar.set_position(p.done);
        bar.set_message(p.summary());
        if p.unit == "iterations" && !a.quiet {
            bar.println(format!("iteration {}: {}", p.done, p.summary()));
        }
    })?;
    // Left where the run stopped (`finish` would fill it: 20000/20000 after 232 episodes
    // stopped by --max-minutes).
    bar.abandon();
    finished(&a, &dir, progressed)
}

/// Prints the run directory; a resumed run that had nothing left to train says so on stderr
/// (it already reached the `--episodes` or `--max-minutes` it was given or saved with), so
/// `--resume DIR --episodes N` on a run past N is not mistaken for training.
fn finished(a: &TrainArgs, dir: &Path, progressed: bool) -> Result<()> {
    if a.resume.is_some() && !progressed {
        say!(
            "{}: nothing left to train: the run already reached its length{}; give a larger --episodes or --max-minutes to continue it",
            dir.display(),
            match (a.episodes, a.max_minutes) {
                (Some(e), _) => format!(" (it is past --episodes {e})"),
                (None, Some(m)) => format!(" (it is past --max-minutes {m})"),
                (None, None) => String::new(),
            }
        );
    }
    // A run stopped before its first validation has no `best/`: say where its model is.
    if !dir.join("best").is_dir() && dir.join("last").is_dir() {
        say!(
            "{}: no best/ yet (no validation has run); the model so far is {} (--model {0}/last)",
            dir.display(),
            dir.join("last").display()
        );
    }
    out!("{}", dir.display())?;
    Ok(())
}
