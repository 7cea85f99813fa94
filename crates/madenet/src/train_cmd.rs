//! `madenet train`: trains MADE-Net, MADE-Net-DT or DME-DRL into a run directory, with a progress bar;
//! `--resume DIR` continues a run from its last checkpoint.

use anyhow::{bail, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use madenet_learn::{Method, TrainConfig};
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

/// What `madenet train` sets in either learner's config.
trait LearnerConfig: Default + Sized {
    fn from_text(path: &Path, text: &str) -> Result<Self>;
    fn episodes(&mut self) -> &mut u64;
    fn max_minutes(&mut self) -> &mut f64;
    fn seed(&mut self) -> &mut u64;
    fn threads(&mut self) -> &mut usize;
    fn check(&self) -> Result<(), String>;
}

macro_rules! learner_config {
    ($t:ty) => {
        impl LearnerConfig for $t {
            fn from_text(path: &Path, text: &str) -> Result<Self> {
                Ok(<$t>::from_toml_text(path, text)?)
            }
            fn episodes(&mut self) -> &mut u64 {
                &mut self.episodes
            }
            fn max_minutes(&mut self) -> &mut f64 {
                &mut self.max_minutes
            }
            fn seed(&mut self) -> &mut u64 {
                &mut self.seed
            }
            fn threads(&mut self) -> &mut usize {
                &mut self.threads
            }
            fn check(&self) -> Result<(), String> {
                self.validate()
            }
        }
    };
}
learner_config!(TrainConfig);
learner_config!(madenet_dme::train::DmeTrainConfig);
learner_config!(madenet_learn::rollout_train::RolloutTrainConfig);

/// The run directory and the config to train with (`None`: resume with the run's saved one),
/// from the arguments and the config `source` (`--config`'s, or the run's on `--resume`);
/// `set_method` applies `--method` to a new run's config.
fn run_dir_and_config<C: LearnerConfig>(
    a: &TrainArgs,
    source: &Source,
    set_method: impl FnOnce(&mut C) -> Result<()>,
) -> Result<(PathBuf, Option<C>)> {
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
            let mut cfg = C::from_text(path, text)?;
            *cfg.episodes() = a.episodes.unwrap_or(*cfg.episodes());
            *cfg.max_minutes() = a.max_minutes.unwrap_or(*cfg.max_minutes());
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
                Some((path, text)) => C::from_text(path, text)?,
                None => C::default(),
            };
            set_method(&mut cfg)?;
            *cfg.episodes() = a.episodes.unwrap_or(*cfg.episodes());
            *cfg.max_minutes() = a.max_minutes.unwrap_or(*cfg.max_minutes());
            *cfg.seed() = a.seed.unwrap_or(*cfg.seed());
            *cfg.threads() = a.threads.unwrap_or(*cfg.threads());
            cfg.check()
                .map_err(|m| anyhow::anyhow!("train config: {m}"))?;
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
    if chosen == Some(madenet_dme::train::METHOD) {
        return run_dme(a, &source);
    }
    if chosen == Some(madenet_learn::rollout_train::METHOD) {
        return run_rollout(a, &source);
    }
    let (dir, cfg) = run_dir_and_config::<TrainConfig>(&a, &source, |cfg| {
        if let Some(m) = &a.method {
            cfg.method = match m.as_str() {
                "made-net" => Method::MadeNet,
                "made-net-dt" => Method::MadeNetDt,
                other => bail!("--method `{other}`: expected made-net, made-net-dt, made-net-rollout or dme-drl"),
            };
        }
        Ok(())
    })?;
    let bar = progress_bar(a.quiet);
    let mut progressed = false;
    let mut on_progress = |p: &madenet_learn::Progress| {
        progressed = true;
        bar.set_length(p.episodes);
        bar.set_position(p.episode);
        let val = p
            .validation_steps
            .map_or(String::new(), |v| format!("  val steps {v:.1}"));
        bar.set_message(format!(
            "ε {:.2}  reward {:.0}  steps {:.0}  updates {}{val}",
            p.epsilon, p.team_reward, p.steps, p.updates
        ));
    };
    madenet_learn::train(&dir, cfg, &mut on_progress)?;
    bar.finish();
    finished(&a, &dir, progressed)
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

fn progress_bar(quiet: bool) -> ProgressBar {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(0)
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} episodes  {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar
}

/// `madenet train --method dme-drl` (or a DME-DRL config or run directory).
fn run_dme(a: TrainArgs, source: &Source) -> Result<()> {
    // `--method dme-drl` is what brought us here: nothing more to set.
    let (dir, cfg) =
        run_dir_and_config::<madenet_dme::train::DmeTrainConfig>(&a, source, |_| Ok(()))?;
    let bar = progress_bar(a.quiet);
    let mut progressed = false;
    let mut on_progress = |p: &madenet_dme::train::Progress| {
        progressed = true;
        bar.set_length(p.episodes);
        bar.set_position(p.episode);
        let val = p
            .validation_steps
            .map_or(String::new(), |v| format!("  val steps {v:.1}"));
        bar.set_message(format!(
            "reward {:.2}  steps {}  updates {}{val}",
            p.reward, p.steps, p.updates
        ));
    };
    madenet_dme::train::train(&dir, cfg, &mut on_progress)?;
    bar.finish();
    finished(&a, &dir, progressed)
}

/// `madenet train --method made-net-rollout` (or such a config or run directory): the DEP
/// trained from the centralized rollout teacher (`madenet_learn::rollout_train`).
fn run_rollout(a: TrainArgs, source: &Source) -> Result<()> {
    let (dir, cfg) =
        run_dir_and_config::<madenet_learn::rollout_train::RolloutTrainConfig>(&a, source, |_| {
            Ok(())
        })?;
    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(0)
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} iterations  {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let mut progressed = false;
    let mut on_progress = |p: &madenet_learn::rollout_train::Progress| {
        progressed = true;
        bar.set_length(p.iterations);
        bar.set_position(p.iteration);
        bar.set_message(format!(
            "episodes {}  decisions {}  loss {:.3}  val steps {:.1} (base rule {:.1})",
            p.episodes, p.decisions, p.loss, p.validation_steps, p.base_steps
        ));
        if a.quiet {
            return;
        }
        bar.println(format!(
            "iteration {}: val steps {:.2} (base {:.2}), loss {:.4}",
            p.iteration, p.validation_steps, p.base_steps, p.loss
        ));
    };
    madenet_learn::rollout_train::train(&dir, cfg, &mut on_progress)?;
    bar.finish();
    finished(&a, &dir, progressed)
}
