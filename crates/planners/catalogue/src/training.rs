//! A training run as `madenet train` asks for it ([`TrainRequest`]): which learner (`--method`,
//! else the config's `method`, else MADE-Net's; on `--resume`, the run's own), the run
//! directory and the config to train with, then the run through the training harness
//! ([`madenet_learn::harness::train`]).

use crate::{CatalogueError, LearnerKind};
use madenet_dme::train::DmeLearner;
use madenet_learn::dagger::RolloutLearner;
use madenet_learn::harness::RunFields;
use madenet_learn::{Learner, MadeNetLearner, Progress};
use std::path::PathBuf;

/// What `madenet train` was asked: its flags.
#[derive(Clone, Debug, Default)]
pub struct TrainRequest {
    /// The training config (TOML) of a new run.
    pub config: Option<PathBuf>,
    /// The run directory to create.
    pub out: Option<PathBuf>,
    /// The run directory to continue from its last checkpoint, with its saved config.
    pub resume: Option<PathBuf>,
    /// The method to train instead of the config's.
    pub method: Option<String>,
    /// Episodes per environment, overriding the config's (a resumed run may be extended).
    pub episodes: Option<u64>,
    /// The wall-time limit in minutes, overriding the config's (a resumed run may be extended).
    pub max_minutes: Option<f64>,
    /// The seed, overriding the config's.
    pub seed: Option<u64>,
    /// Learner threads, overriding the config's.
    pub threads: Option<usize>,
}

/// A training config as read (once: a pipe cannot be read again): its path and text.
type Source = Option<(PathBuf, String)>;

fn refused(message: impl Into<String>) -> CatalogueError {
    CatalogueError::Train(message.into())
}

impl TrainRequest {
    /// Trains the learner asked for, telling `on_progress` of every unit (episode or
    /// iteration, [`Progress::unit`]); returns the run directory and whether any training was
    /// left to do (a resumed run may already have reached its length).
    pub fn train(
        &self,
        on_progress: &mut (dyn FnMut(&Progress) + Send),
    ) -> Result<(PathBuf, bool), CatalogueError> {
        let source = self.source()?;
        match self.learner(&source)? {
            LearnerKind::MadeNet => self.train_with::<MadeNetLearner>(&source, on_progress),
            LearnerKind::Rollout => self.train_with::<RolloutLearner>(&source, on_progress),
            LearnerKind::DmeDrl => self.train_with::<DmeLearner>(&source, on_progress),
        }
    }

    /// The config read: the run's own on `--resume` (none if it has none: reported later),
    /// else `--config`'s.
    fn source(&self) -> Result<Source, CatalogueError> {
        let path = match (&self.resume, &self.config) {
            (Some(dir), _) => Some(dir.join("config.toml")).filter(|p| p.exists()),
            (None, config) => config.clone(),
        };
        let Some(p) = path else { return Ok(None) };
        let text = madenet_files::read_text_capped(&p, madenet_files::InputKind::Config)
            .map_err(|e| refused(format!("{}: {e}", p.display())))?;
        Ok(Some((p, text)))
    }

    /// Which learner: `--method`, else the config's (the run's own on `--resume`), else
    /// MADE-Net's.
    fn learner(&self, source: &Source) -> Result<LearnerKind, CatalogueError> {
        let from_file = match source {
            Some((path, text)) => {
                // The shared reader: a syntax error names its field and line (issue 59).
                let value: toml::Table = madenet_files::parse_toml(text)
                    .map_err(|e| refused(format!("{}: {e}", path.display())))?;
                value
                    .get("method")
                    .and_then(|m| m.as_str())
                    .map(str::to_string)
            }
            None => None,
        };
        let chosen = match &self.resume {
            Some(_) => from_file.as_deref(),
            None => self.method.as_deref().or(from_file.as_deref()),
        };
        let Some(m) = chosen else {
            return Ok(LearnerKind::MadeNet);
        };
        LearnerKind::for_method(m).ok_or_else(|| {
            let named = match (self.method.as_deref() == Some(m), source) {
                (true, _) => "--method".to_string(),
                (false, Some((p, _))) => format!("{}: field `method`", p.display()),
                (false, None) => "train config: field `method`".to_string(),
            };
            let known = LearnerKind::all_methods().join(", ");
            refused(format!("{named} `{m}`: expected {known}"))
        })
    }

    /// Trains learner `L` in the run directory asked for.
    fn train_with<L: Learner>(
        &self,
        source: &Source,
        on_progress: &mut (dyn FnMut(&Progress) + Send),
    ) -> Result<(PathBuf, bool), CatalogueError> {
        let (dir, cfg) = self.run_dir_and_config::<L>(source)?;
        let mut progressed = false;
        madenet_learn::harness::train::<L>(&dir, cfg, &mut |p: &Progress| {
            progressed = true;
            on_progress(p)
        })?;
        Ok((dir, progressed))
    }

    /// The run directory and the config to train with (`None`: resume with the run's saved
    /// one), `--method` and the overrides applied.
    fn run_dir_and_config<L: Learner>(
        &self,
        source: &Source,
    ) -> Result<(PathBuf, Option<L::Config>), CatalogueError> {
        let parse = |(path, text): &(PathBuf, String)| L::parse_config(path, text);
        match (&self.out, &self.resume) {
            (_, Some(dir)) => {
                if !dir.join("config.toml").exists() {
                    let d = dir.display();
                    return Err(refused(format!(
                        "{d}: not a training run directory (no config.toml)"
                    )));
                }
                let overrides = self.config.is_some() || self.method.is_some();
                if overrides || self.seed.is_some() || self.threads.is_some() {
                    return Err(refused("--resume continues with the run's saved config; only --episodes and --max-minutes may extend it"));
                }
                if self.episodes.is_none() && self.max_minutes.is_none() {
                    return Ok((dir.clone(), None));
                }
                let mut cfg = parse(source.as_ref().expect("read: config.toml exists"))?;
                let f = L::run_fields(&cfg);
                let fields = RunFields {
                    episodes: self.episodes.unwrap_or(f.episodes),
                    max_minutes: self.max_minutes.unwrap_or(f.max_minutes),
                    ..f
                };
                L::set_run_fields(&mut cfg, fields);
                Ok((dir.clone(), Some(cfg)))
            }
            (Some(dir), None) => {
                if dir.join("config.toml").exists() {
                    return Err(refused(format!(
                        "{}: already holds a training run; use --resume {0} or another --out",
                        dir.display()
                    )));
                }
                let mut cfg = match source {
                    Some(s) => parse(s)?,
                    None => L::Config::default(),
                };
                if let Some(m) = &self.method {
                    L::set_method(&mut cfg, m).map_err(|e| refused(format!("--method: {e}")))?;
                }
                let f = L::run_fields(&cfg);
                let fields = RunFields {
                    episodes: self.episodes.unwrap_or(f.episodes),
                    max_minutes: self.max_minutes.unwrap_or(f.max_minutes),
                    seed: self.seed.unwrap_or(f.seed),
                    threads: self.threads.unwrap_or(f.threads),
                };
                L::set_run_fields(&mut cfg, fields);
                L::check(&cfg).map_err(|m| refused(format!("train config: {m}")))?;
                Ok((dir.clone(), Some(cfg)))
            }
            (None, None) => Err(refused(
                "give --out DIR for a new run or --resume DIR to continue one",
            )),
        }
    }
}
