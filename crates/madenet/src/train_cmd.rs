//! `madenet train`: trains any learner (MADE-Net, MADE-Net-DT, the rollout teacher's DEP, DME-DRL:
//! `madenet_catalogue::LearnerKind`) into a run directory, with a progress bar;
//! `--resume DIR` continues a run from its last checkpoint.

use anyhow::{bail, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use madenet_catalogue::LearnerKind;
use madenet_dme::train::DmeLearner;
use madenet_learn::dagger::RolloutLearner;
use madenet_learn::harness::RunFields;
use madenet_learn::{Learner, MadeNetLearner, Progress};
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

/// A training config as read (once: a pipe cannot be read again): its path and text.
type Source = Option<(PathBuf, String)>;

/// The `method` key of a training config, if it has one.
fn method_of(path: &Path, text: &str) -> Result<Option<String>> {
    let value: toml::Table =
        toml::from_str(text).map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.message()))?;
    Ok(value
        .get("method")
        .and_then(|m| m.as_str())
        .map(str::to_string))
}

/// The run directory and the config to train with (`None`: resume with the run's saved one),
/// from the arguments and the config `source` (`--config`'s, or the run's on `--resume`);
/// `set_method` applies `--method` to a new run's config.
fn run_dir_and_config<L: Learner>(
    a: &TrainArgs,
    source: &Source,
) -> Result<(PathBuf, Option<L::Config>)> {
    match (&a.out, &a.resume) {
        (_, Some(dir)) => {
            if !dir.join("config.toml").exists() {
                bail!(
                    "{}: not a training run directory (no config.toml)",
                    dir.display()
                );
            }
            if a.config.is_some() || a.method.is_some() || a.seed.is_some() || a.threads.is_some() {
                bail!("--resume continues with the run's saved config; only --episodes and --max-minutes may extend it");
            }
            if a.episodes.is_none() && a.max_minutes.is_none() {
                return Ok((dir.clone(), None));
            }
            let (path, text) = source.as_ref().expect("read in run()");
            let mut cfg = L::parse_config(path, text)?;
            let f = L::run_fields(&cfg);
            let fields = RunFields {
                episodes: a.episodes.unwrap_or(f.episodes),
                max_minutes: a.max_minutes.unwrap_or(f.max_minutes),
                ..f
            };
            L::set_run_fields(&mut cfg, fields);
            Ok((dir.clone(), Some(cfg)))
        }
        (Some(dir), None) => {
            if dir.join("config.toml").exists() {
                bail!(
                    "{}: already holds a training run; use --resume {0} or another --out",
                    dir.display()
                );
            }
            let mut cfg = match source {
                Some((path, text)) => L::parse_config(path, text)?,
                None => L::Config::default(),
            };
            if let Some(m) = &a.method {
                L::set_method(&mut cfg, m).map_err(|e| anyhow::anyhow!("--method: {e}"))?;
            }
            let f = L::run_fields(&cfg);
            let fields = RunFields {
                episodes: a.episodes.unwrap_or(f.episodes),
                max_minutes: a.max_minutes.unwrap_or(f.max_minutes),
                seed: a.seed.unwrap_or(f.seed),
                threads: a.threads.unwrap_or(f.threads),
            };
            L::set_run_fields(&mut cfg, fields);
            L::check(&cfg).map_err(|m| anyhow::anyhow!("train config: {m}"))?;
            Ok((dir.clone(), Some(cfg)))
        }
        (None, None) => bail!("give --out DIR for a new run or --resume DIR to continue one"),
    }
}

pub fn run(a: TrainArgs) -> Result<()> {
    // Which learner: --method, else the config's (the run's own on --resume), else MADE-Net.
    // A run directory without config.toml is reported by `run_dir_and_config`; a --config that
    // cannot be read is an error here.
    let path = match (&a.resume, &a.config) {
        (Some(dir), _) => Some(dir.join("config.toml")).filter(|p| p.exists()),
        (None, config) => config.clone(),
    };
    let source: Source = match path {
        Some(p) => {
            let text = madenet_files::read_text_capped(&p, madenet_files::InputKind::Config)
                .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
            Some((p, text))
        }
        None => None,
    };
    let from_file = match &source {
        Some((p, text)) => method_of(p, text)?,
        None => None,
    };
    let chosen = if a.resume.is_some() {
        from_file.as_deref()
    } else {
        a.method.as_deref().or(from_file.as_deref())
    };
    let kind = match chosen {
        None => LearnerKind::MadeNet,
        Some(m) => LearnerKind::for_method(m).ok_or_else(|| {
            let source = if a.method.as_deref() == Some(m) {
                "--method".to_string()
            } else {
                format!("{}: field `method`", path_of(&source))
            };
            anyhow::anyhow!(
                "{source} `{m}`: expected {}",
                LearnerKind::all_methods().join(", ")
            )
        })?,
    };
    match kind {
        LearnerKind::MadeNet => train_with::<MadeNetLearner>(&a, &source),
        LearnerKind::Rollout => train_with::<RolloutLearner>(&a, &source),
        LearnerKind::DmeDrl => train_with::<DmeLearner>(&a, &source),
    }
}

fn path_of(source: &Source) -> String {
    source
        .as_ref()
        .map_or("train config".into(), |(p, _)| p.display().to_string())
}

/// Trains learner `L` with a progress bar of its units (episodes or iterations); a learner
/// that counts iterations also prints a line per iteration.
fn train_with<L: Learner>(a: &TrainArgs, source: &Source) -> Result<()> {
    let (dir, cfg) = run_dir_and_config::<L>(a, source)?;
    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(0)
    };
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{elapsed_precise}} [{{bar:30}}] {{pos}}/{{len}} {}  {{msg}}",
            L::UNIT
        ))
        .expect("valid template")
        .progress_chars("=> "),
    );
    let mut progressed = false;
    let mut on_progress = |p: &Progress| {
        progressed = true;
        bar.set_length(p.total);
        bar.set_position(p.done);
        bar.set_message(p.summary());
        if L::UNIT == "iterations" && !a.quiet {
            bar.println(format!("iteration {}: {}", p.done, p.summary()));
        }
    };
    madenet_learn::harness::train::<L>(&dir, cfg, &mut on_progress)?;
    bar.finish();
    finished(a, &dir, progressed)
}

/// Prints the run directory; a resumed run that had nothing left to train says so on stderr
/// (it already reached the `--episodes` or `--max-minutes` it was given or saved with), so
/// `--resume DIR --episodes N` on a run past N is not mistaken for training.
fn finished(a: &TrainArgs, dir: &Path, progressed: bool) -> Result<()> {
    if a.resume.is_some() && !progressed {
        eprintln!(
            "{}: nothing left to train: the run already reached its length{}; give a larger --episodes or --max-minutes to continue it",
            dir.display(),
            match (a.episodes, a.max_minutes) {
                (Some(e), _) => format!(" (it is past --episodes {e})"),
                (None, Some(m)) => format!(" (it is past --max-minutes {m})"),
                (None, None) => String::new(),
            }
        );
    }
    out!("{}", dir.display())?;
    Ok(())
}
