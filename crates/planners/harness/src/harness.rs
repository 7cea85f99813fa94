//! The one training harness of madenet's learners (MADE-Net, MADE-Net-DT, the rollout teacher,
//! DME-DRL): what every training run does around its own algorithm.
//!
//! - [`train`]: any [`Learner`] — settle the run directory ([`prepare_run`]: `config.toml`,
//!   resume or not) and run the learner's loop on a pool of the config's threads;
//! - [`Logs`]: `episodes.csv`, the updates log, `validation.csv` and TensorBoard events,
//!   truncated on resume to what the checkpoint has seen, then appended together;
//! - [`Clock`]: wall time carried across resumes, the `max_minutes` budget and the
//!   `checkpoint_minutes` cadence;
//! - [`EpisodeRun`]: an episode-based learner's loop plumbing — its [`Logs`] and [`Clock`],
//!   validation rows, and when it validates, checkpoints and stops ([`Cadence`]);
//! - checkpoints and models: [`replace_dir`] (a directory replaced whole, never half-written),
//!   [`read_json`] / [`read_postcard`] and [`write_json`] / [`write_postcard`] for the state and
//!   replay files inside it, [`new_best`] for `best/`.
//!
//! A learner keeps only what is its own: its networks, data, update and validation.

use crate::error::{io_err, write_atomic, TrainError};
use crate::scenario::Validation;
use madenet_trainlog::{
    truncate_rows, EpisodeRow, LogRow, LogWriter, MaddpgUpdateRow, TfEventWriter, UpdateRow,
    ValidationRow,
};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use madenet_sim::PolicyRegistry;

/// Opens a training run directory (created if needed) and settles its config: a new run writes
/// `cfg` (or the defaults) to `config.toml`; a directory holding a checkpoint resumes with the
/// saved config, which `cfg`, if given, may change only where `same_run(given, saved)` allows
/// (the run's length). Also recovers `checkpoint/` from a crash between the two renames of
/// [`replace_dir`]. Returns the config and whether the run resumes.
pub fn prepare_run<C: Default + Serialize>(
    run_dir: &Path,
    cfg: Option<C>,
    load: impl Fn(&Path) -> Result<C, TrainError>,
    validate: impl Fn(&C) -> Result<(), String>,
    same_run: impl Fn(&C, &C) -> bool,
) -> Result<(C, bool), TrainError> {
    std::fs::create_dir_all(run_dir).map_err(io_err(run_dir))?;
    let cfg_path = run_dir.join("config.toml");
    let ckpt_dir = run_dir.join("checkpoint");
    // A crash between the two renames of `replace_dir` leaves only `checkpoint.old`.
    if !ckpt_dir.exists() && ckpt_dir.with_extension("old").exists() {
        std::fs::rename(ckpt_dir.with_extension("old"), &ckpt_dir).map_err(io_err(&ckpt_dir))?;
    }
    let resuming = ckpt_dir.join("state.json").exists();
    let save = |cfg: &C| -> Result<(), TrainError> {
        let text = toml::to_string(cfg).map_err(|e| TrainError::Other(e.to_string()))?;
        write_atomic(&cfg_path, text.as_bytes())
    };
    let checked = |cfg: C| -> Result<C, TrainError> {
        validate(&cfg).map_err(|m| TrainError::Config {
            path: "train config".into(),
            message: m,
        })?;
        save(&cfg)?;
        Ok(cfg)
    };
    // The config the checkpoint was trained with, kept beside `config.toml`: an edit of
    // `config.toml` after the start is refused by field, before any weights are loaded.
    let started_path = run_dir.join(".config-at-start.toml");
    let cfg = if cfg_path.exists() {
        let saved = load(&cfg_path)?;
        if resuming && started_path.exists() {
            let started = load(&started_path)?;
            if !same_run(&saved, &started) {
                return Err(TrainError::Config {
                    path: cfg_path.display().to_string(),
                    message: format!(
                        "edited after the run started ({}); only the run's length may change on resume: use a new directory, or undo the edit",
                        changed_fields(&started, &saved).join(", ")
                    ),
                });
            }
        }
        match cfg {
            // Only the run's length may change on resume: the rest defines the run.
            Some(given) if !same_run(&given, &saved) => {
                return Err(TrainError::Config {
                    path: cfg_path.display().to_string(),
                    message: "this run was started with a different config (only its length may change on resume: `episodes` and `max_minutes`, or `max_minutes` alone for made-net-rollout); use a new directory".into(),
                });
            }
            Some(given) => checked(given)?,
            None => saved,
        }
    } else {
        checked(cfg.unwrap_or_default())?
    };
    if !resuming {
        let text = toml::to_string(&cfg).map_err(|e| TrainError::Other(e.to_string()))?;
        write_atomic(&started_path, text.as_bytes())?;
    }
    Ok((cfg, resuming))
}

/// The fields in which two configs differ, as ``field `a.b` (x at the start, y now)``.
fn changed_fields<C: Serialize>(started: &C, now: &C) -> Vec<String> {
    fn walk(prefix: &str, a: &toml::Value, b: &toml::Value, out: &mut Vec<String>) {
        match (a, b) {
            (toml::Value::Table(ta), toml::Value::Table(tb)) => {
                let mut keys: Vec<&String> = ta.keys().chain(tb.keys()).collect();
                keys.sort();
                keys.dedup();
                for k in keys {
                    let name = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    match (ta.get(k), tb.get(k)) {
                        (Some(x), Some(y)) => walk(&name, x, y, out),
                        (x, y) => out.push(format!(
                            "field `{name}` ({} at the start, {} now)",
                            x.map_or("absent".into(), |v| v.to_string()),
                            y.map_or("absent".into(), |v| v.to_string())
                        )),
                    }
                }
            }
            _ if a != b => out.push(format!("field `{prefix}` ({a} at the start, {b} now)")),
            _ => {}
        }
    }
    let (Ok(a), Ok(b)) = (toml::Value::try_from(started), toml::Value::try_from(now)) else {
        return vec!["a field".into()];
    };
    let mut out = Vec::new();
    walk("", &a, &b, &mut out);
    out
}

/// Reads a learner's TOML config and checks it with `validate`: unknown keys, bad values and
/// failed checks are [`TrainError::Config`] naming the file and the field. Every learner's
/// `from_toml_file`.
pub fn read_config<C: DeserializeOwned>(
    path: &Path,
    validate: impl Fn(&C) -> Result<(), String>,
) -> Result<C, TrainError> {
    let text = madenet_files::read_text_capped(path, madenet_files::InputKind::Config)
        .map_err(io_err(path))?;
    parse_config(path, &text, validate)
}

/// [`read_config`] on `text` already read from `path` (a pipe can be read only once).
pub fn parse_config<C: DeserializeOwned>(
    path: &Path,
    text: &str,
    validate: impl Fn(&C) -> Result<(), String>,
) -> Result<C, TrainError> {
    let config_err = |message| TrainError::Config {
        path: path.display().to_string(),
        message,
    };
    let cfg: C = madenet_files::parse_toml(text).map_err(config_err)?;
    validate(&cfg).map_err(config_err)?;
    Ok(cfg)
}

/// A learner config's readers, in its `impl` (`madenet_harness::toml_config_readers!();`):
/// `from_toml_file` ([`read_config`]) and `from_toml_text` ([`parse_config`]), both checked
/// with its `validate`.
#[macro_export]
macro_rules! toml_config_readers {
    () => {
        /// Reads a TOML file (unknown keys and bad values are errors naming the file and field).
        pub fn from_toml_file(path: &std::path::Path) -> Result<Self, $crate::TrainError> {
            $crate::harness::read_config(path, Self::validate)
        }

        /// [`Self::from_toml_file`] on `text`, already read from `path`.
        pub fn from_toml_text(
            path: &std::path::Path,
            text: &str,
        ) -> Result<Self, $crate::TrainError> {
            $crate::harness::parse_config(path, text, Self::validate)
        }
    };
}

/// The largest CEP joint action space |G|^|I| a learner builds (the paper's is 4³ = 64).
pub const MAX_JOINT_ACTIONS: u64 = 1 << 16;

/// Checks size fields against their bounds: `(field, value, min, max)`; the first out of bounds
/// is ``field `name`: must lie in min..=max, got value``. Every training config bounds every
/// size it allocates by, so a typo cannot ask for terabytes or run for years.
pub fn check_sizes(fields: &[(&str, u64, u64, u64)]) -> Result<(), String> {
    for &(field, value, min, max) in fields {
        if !(min..=max).contains(&value) {
            return Err(format!(
                "field `{field}`: must lie in {min}..={max}, got {value}"
            ));
        }
    }
    Ok(())
}

/// This machine's physical memory in bytes (`None` where the system does not say).
pub fn physical_memory() -> Option<u64> {
    // SAFETY: sysconf only reads system constants.
    let (pages, page) = unsafe {
        (
            libc::sysconf(libc::_SC_PHYS_PAGES),
            libc::sysconf(libc::_SC_PAGESIZE),
        )
    };
    (pages > 0 && page > 0).then(|| pages as u64 * page as u64)
}

/// Refuses a config whose largest memory needs (`(what, bytes)`, each naming its fields)
/// add up to more than `available` bytes (this machine's memory: [`physical_memory`]), so
/// that training fails at once with the sizes named instead of aborting hours in, when the
/// replay fills up.
pub fn check_memory(needs: &[(String, u64)], available: Option<u64>) -> Result<(), String> {
    let Some(available) = available else {
        return Ok(());
    };
    let total = needs.iter().fold(0u64, |t, (_, b)| t.saturating_add(*b));
    if total <= available {
        return Ok(());
    }
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    let parts: Vec<String> = needs
        .iter()
        .map(|(what, b)| format!("{what}: {:.1} GiB", gib(*b)))
        .collect();
    Err(format!(
        "needs more memory than this machine has ({:.1} GiB): {}",
        gib(available),
        parts.join("; ")
    ))
}

/// What a training run reports after each unit of its work (an iteration, or an episode per
/// environment), for a progress bar. One type for every learner.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Progress {
    /// Units done so far.
    pub done: u64,
    /// Units the run is to do.
    pub total: u64,
    /// What a unit is (`"episodes"` or `"iterations"`).
    pub unit: &'static str,
    /// Updates so far.
    pub updates: u64,
    /// The latest validation's mean steps (`None` before the first).
    pub validation_steps: Option<f64>,
    /// The base rule's validation mean steps, for learners that improve on one.
    pub base_steps: Option<f64>,
    /// This unit's own figures, in display order: (name, value, decimals).
    pub figures: Vec<(&'static str, f64, usize)>,
}

impl Progress {
    /// The figures as one line: `name value` pairs, the updates, and the validation.
    pub fn summary(&self) -> String {
        let mut parts: Vec<String> = self
            .figures
            .iter()
            .map(|(name, v, decimals)| format!("{name} {v:.decimals$}"))
            .collect();
        parts.push(format!("updates {}", self.updates));
        if let Some(v) = self.validation_steps {
            parts.push(match self.base_steps {
                Some(b) => format!("val steps {v:.2} (base rule {b:.2})"),
                None => format!("val steps {v:.1}"),
            });
        }
        parts.join("  ")
    }
}

/// The fields every training config has, which `madenet train` sets from its flags.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunFields {
    /// The run's length in episodes (per environment).
    pub episodes: u64,
    /// Wall-time budget in minutes (0: none).
    pub max_minutes: f64,
    /// The seed of every random stream.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
}

/// The contract of a learner: its config, the methods it trains, its loop and its models. The
/// harness runs any learner through it ([`train`]); the command line, the catalogue and the
/// Python package need nothing else of a learner.
pub trait Learner {
    /// Every hyperparameter of a run (TOML; unknown fields refused).
    type Config: Default + Clone + PartialEq + Serialize + DeserializeOwned + Send + Sync;
    /// The `method` names it trains (in configs, `model.toml` and `madenet train --method`).
    const METHODS: &'static [&'static str];
    /// What its loop counts ([`Progress::unit`]): `"episodes"` or `"iterations"`.
    const UNIT: &'static str = "episodes";
    /// The config in `text` (read from `path`, named in errors), checked with [`Self::check`]
    /// ([`parse_config`]).
    fn parse_config(path: &Path, text: &str) -> Result<Self::Config, TrainError> {
        self::parse_config(path, text, Self::check)
    }
    /// Why `cfg` cannot be trained, naming the field.
    fn check(cfg: &Self::Config) -> Result<(), String>;
    /// The fields every config has ([`learner_config!`](crate::learner_config) where
    /// they carry [`RunFields`]' names).
    fn run_fields(cfg: &Self::Config) -> RunFields;
    /// Sets the fields every config has.
    fn set_run_fields(cfg: &mut Self::Config, fields: RunFields);
    /// Makes `cfg` train `method` (one of [`Self::METHODS`]).
    fn set_method(_cfg: &mut Self::Config, method: &str) -> Result<(), String> {
        if Self::METHODS.contains(&method) {
            Ok(())
        } else {
            Err(format!("`{method}` is not trained by this learner"))
        }
    }
    /// Whether a resume may give a larger `episodes` (for a learner whose run is fixed by
    /// other fields, such as iterations, it may not).
    const RESUME_EXTENDS_EPISODES: bool = true;
    /// Whether `given` continues the run saved with `saved`: equal but for `max_minutes` and,
    /// where [`Self::RESUME_EXTENDS_EPISODES`], `episodes`.
    fn same_run(given: &Self::Config, saved: &Self::Config) -> bool {
        let (g, s) = (Self::run_fields(given), Self::run_fields(saved));
        let mut given = given.clone();
        let episodes = if Self::RESUME_EXTENDS_EPISODES {
            s.episodes
        } else {
            g.episodes
        };
        Self::set_run_fields(
            &mut given,
            RunFields {
                episodes,
                max_minutes: s.max_minutes,
                ..g
            },
        );
        given == *saved
    }
    /// The learner's own loop, on the harness's thread pool ([`TrainRun`]: from scratch, or
    /// from the checkpoint in the run folder when resuming; progress after each unit of work).
    fn train_loop(run: TrainRun<'_, Self::Config>) -> Result<(), TrainError>;
    /// Loads the trained model folder `dir` and registers it as policy `name`
    /// ([`learner_config!`](crate::learner_config)`(model = …)` for a model type with `load`
    /// and `register`).
    fn register_model(
        dir: &Path,
        registry: &mut madenet_sim::PolicyRegistry,
        name: &str,
        about: &str,
    ) -> Result<(), TrainError>;
}

/// What [`Learner::train_loop`] is given: the run, as [`train`] settled it.
pub struct TrainRun<'a, C> {
    /// The run folder (created; it holds `config.toml`).
    pub dir: &'a Path,
    /// The run's config (the saved one when resuming).
    pub cfg: &'a C,
    /// Whether the run resumes from the checkpoint in `dir`.
    pub resuming: bool,
    /// Called after each unit of work.
    pub progress: &'a mut (dyn FnMut(&Progress) + Send),
}

/// [`Learner::check`] (the config's own `validate`), [`Learner::run_fields`] and
/// [`Learner::set_run_fields`] for a config whose fields carry [`RunFields`]' names
/// (`episodes`, `max_minutes`, `seed`, `threads`), as every learner's config does:
/// `madenet_harness::learner_config!();` in its `impl Learner`. With `(model = M)` also
/// [`Learner::register_model`] for a model type `M` with `M::load(dir)` and
/// `m.register(registry, name, about)`.
#[macro_export]
macro_rules! learner_config {
    (model = $model:ty) => {
        $crate::learner_config!();

        fn register_model(
            dir: &std::path::Path,
            registry: &mut $crate::harness::PolicyRegistry,
            name: &str,
            about: &str,
        ) -> Result<(), $crate::TrainError> {
            <$model>::load(dir)?.register(registry, name, about);
            Ok(())
        }
    };
    () => {
        fn check(cfg: &Self::Config) -> Result<(), String> {
            cfg.validate()
        }

        fn run_fields(cfg: &Self::Config) -> $crate::harness::RunFields {
            $crate::harness::RunFields {
                episodes: cfg.episodes,
                max_minutes: cfg.max_minutes,
                seed: cfg.seed,
                threads: cfg.threads,
            }
        }

        fn set_run_fields(cfg: &mut Self::Config, f: $crate::harness::RunFields) {
            (cfg.episodes, cfg.max_minutes, cfg.seed, cfg.threads) =
                (f.episodes, f.max_minutes, f.seed, f.threads);
        }
    };
}

/// Trains learner `L` into `run_dir` (created; if it holds a checkpoint, the run resumes from
/// it with the saved config — `cfg`, if given, may differ from it only where
/// [`Learner::same_run`] allows; `None`: the saved config, or the defaults for a new run).
pub fn train<L: Learner>(
    run_dir: &Path,
    cfg: Option<L::Config>,
    progress: &mut (dyn FnMut(&Progress) + Send),
) -> Result<(), TrainError> {
    train_with::<L>(run_dir, cfg, |dir, cfg, resuming| {
        L::train_loop(TrainRun {
            dir,
            cfg,
            resuming,
            progress,
        })
    })
}

/// [`train`] with the learner's loop given by the caller (`body(run_dir, config, resuming)`,
/// run on the config's thread pool): a learner's loop with arguments beyond the config, e.g.
/// the rollout learner's episode collector (`madenet_learn::dagger::train_with`).
pub fn train_with<L: Learner>(
    run_dir: &Path,
    cfg: Option<L::Config>,
    body: impl FnOnce(&Path, &L::Config, bool) -> Result<(), TrainError> + Send,
) -> Result<(), TrainError> {
    let (cfg, resuming) = prepare_run(
        run_dir,
        cfg,
        |path| read_config(path, L::check),
        L::check,
        L::same_run,
    )?;
    // A pool of the config's threads, so a run's results depend on its config, not on the
    // machine's core count.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(L::run_fields(&cfg).threads)
        .build()
        .map_err(|e| TrainError::Other(format!("thread pool: {e}")))?;
    pool.install(|| body(run_dir, &cfg, resuming))
}

/// Replaces directory `dir` with one written by `fill` (into `dir.tmp`), never leaving a
/// half-written `dir`: the old one is moved to `dir.old` first and removed last.
pub fn replace_dir(
    dir: &Path,
    fill: impl FnOnce(&Path) -> Result<(), TrainError>,
) -> Result<(), TrainError> {
    let tmp = dir.with_extension("tmp");
    let old = dir.with_extension("old");
    remove_any(&tmp)?;
    std::fs::create_dir_all(&tmp).map_err(io_err(&tmp))?;
    fill(&tmp)?;
    if dir.symlink_metadata().is_ok() {
        remove_any(&old)?;
        std::fs::rename(dir, &old).map_err(io_err(dir))?;
    }
    std::fs::rename(&tmp, dir).map_err(io_err(dir))?;
    remove_any(&old)
}

/// Removes `path` whatever it is (a folder with its content, a file, a link); nothing there is
/// fine.
fn remove_any(path: &Path) -> Result<(), TrainError> {
    match path.symlink_metadata() {
        Err(_) => Ok(()),
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(path).map_err(io_err(path)),
        Ok(_) => std::fs::remove_file(path).map_err(io_err(path)),
    }
}

fn decode_err(path: &Path) -> impl FnOnce(String) -> TrainError + '_ {
    move |message| TrainError::Config {
        path: path.display().to_string(),
        message,
    }
}

/// Loads checkpointed weights from `path` into `net`: weights that do not fit the net (the
/// run's `config.toml` changed a size after the checkpoint) are an error naming the file, never
/// burn's panic.
#[cfg(feature = "burn")]
pub fn load_weights<M: burn::module::Module>(net: M, path: &Path) -> Result<M, TrainError> {
    let rec = burn::store::ModuleRecord::load(path).map_err(|e| TrainError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    net.try_load_record(rec).map_err(|e| TrainError::Config {
        path: path.display().to_string(),
        message: format!("the weights do not fit the run's config.toml: {e}"),
    })
}

/// The digests ([`crate::integrity::digest`]) of the weight files `files` in `dir`, for a
/// `model.toml`'s `digests`.
pub fn file_digests(dir: &Path, files: &[String]) -> Result<Vec<String>, TrainError> {
    files
        .iter()
        .map(|f| {
            let p = dir.join(f);
            std::fs::read(&p)
                .map(|b| crate::integrity::digest(&b))
                .map_err(io_err(&p))
        })
        .collect()
}

/// Reads a JSON checkpoint file (e.g. `state.json`); errors name the file.
pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T, TrainError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    serde_json::from_str(&text).map_err(|e| decode_err(path)(e.to_string()))
}

/// Reads a postcard checkpoint file (e.g. `replay.bin`); errors name the file.
pub fn read_postcard<T: DeserializeOwned>(path: &Path) -> Result<T, TrainError> {
    let bytes = std::fs::read(path).map_err(io_err(path))?;
    postcard::from_bytes(&bytes).map_err(|e| decode_err(path)(e.to_string()))
}

/// Writes `value` as pretty JSON (e.g. `state.json` into a directory being filled by
/// [`replace_dir`]), synced to disk ([`write_atomic`]), so a checkpoint survives a power loss.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), TrainError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| TrainError::Other(e.to_string()))?;
    write_atomic(path, text.as_bytes())
}

/// Writes `value` with postcard (e.g. `replay.bin`), synced to disk like [`write_json`].
pub fn write_postcard<T: Serialize>(path: &Path, value: &T) -> Result<(), TrainError> {
    let bytes = postcard::to_stdvec(value)
        .map_err(|e| TrainError::Other(format!("{}: encoding: {e}", path.display())))?;
    write_atomic(path, &bytes)
}

/// Writes a model's `model.toml` (into a model directory being filled by [`replace_dir`]),
/// synced like [`write_json`].
pub fn write_toml<T: Serialize>(path: &Path, value: &T) -> Result<(), TrainError> {
    let text = toml::to_string(value).map_err(|e| TrainError::Other(e.to_string()))?;
    write_atomic(path, text.as_bytes())
}

/// Whether validation mean `steps` beats the run's best so far (fewer steps), recording it as
/// the new best if so: the caller then saves `best/`.
pub fn new_best(best: &mut Option<f64>, steps: f64) -> bool {
    let better = best.is_none_or(|b| steps < b);
    if better {
        *best = Some(steps);
    }
    better
}

/// Set to ask a running training to stop at its next check, as when its time budget runs out
/// (its last checkpoint stays; `--resume` continues): for callers that catch Ctrl-C themselves,
/// as the Python package does (`signal_hook::flag::register(SIGINT, stop_flag())`). Process-wide
/// because signals are; clear it before the next run.
pub fn stop_flag() -> std::sync::Arc<std::sync::atomic::AtomicBool> {
    static STOP: std::sync::LazyLock<std::sync::Arc<std::sync::atomic::AtomicBool>> =
        std::sync::LazyLock::new(Default::default);
    std::sync::Arc::clone(&STOP)
}

/// Whether [`stop_flag`] is set.
pub fn stop_requested() -> bool {
    stop_flag().load(std::sync::atomic::Ordering::Relaxed)
}

/// A run's clock: wall time carried across resumes, its `max_minutes` budget and its
/// `checkpoint_minutes` cadence (both measured in this process only).
#[derive(Clone, Debug)]
pub struct Clock {
    started: Instant,
    wall0: f64,
    last_checkpoint: Instant,
}

impl Clock {
    /// Starts now; the run had already trained for `wall0` seconds before this process.
    pub fn start(wall0: f64) -> Self {
        let now = Instant::now();
        Clock {
            started: now,
            wall0,
            last_checkpoint: now,
        }
    }

    /// Seconds of training over the whole run, resumes included.
    pub fn wall(&self) -> f64 {
        self.wall0 + self.started.elapsed().as_secs_f64()
    }

    /// Whether this process has used up `max_minutes` (0: no limit), or was asked to stop
    /// ([`stop_flag`]): either way the run ends at its next check as the budget ends it.
    pub fn out_of_time(&self, max_minutes: f64) -> bool {
        stop_requested()
            || (max_minutes > 0.0 && self.started.elapsed().as_secs_f64() > max_minutes * 60.0)
    }

    /// Whether `minutes` have passed since the last checkpoint (0: never by time).
    pub fn checkpoint_due(&self, minutes: f64) -> bool {
        minutes > 0.0 && self.last_checkpoint.elapsed().as_secs_f64() >= minutes * 60.0
    }

    /// Records that a checkpoint was just written.
    pub fn checkpointed(&mut self) {
        self.last_checkpoint = Instant::now();
    }
}

/// Seconds since the Unix epoch: TensorBoard's wall-clock axis.
fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// A row of a learner's updates log, numbered by update.
pub trait UpdateLog: LogRow {
    /// The update's number (0 for the first).
    fn update(&self) -> u64;
}

impl UpdateLog for UpdateRow {
    fn update(&self) -> u64 {
        self.update
    }
}

impl UpdateLog for MaddpgUpdateRow {
    fn update(&self) -> u64 {
        self.update
    }
}

/// What a checkpoint has seen, to which [`Logs::open`] cuts the logs of a resumed run.
#[derive(Clone, Copy, Debug)]
pub struct Seen {
    /// Episode rows numbered below this were seen (validation rows up to and including it).
    pub episodes: u64,
    /// Updates done.
    pub updates: u64,
    /// The TensorBoard step of the first update's `loss/*` scalars (the learners number them
    /// from 1 or from 0).
    pub first_loss_step: u64,
}

/// The logs of an episode-based run, written together: `episodes.csv`, the updates log
/// (`U`), `validation.csv` and TensorBoard events (`episode/*`, `loss/*`, `validation/*`).
pub struct Logs<U: UpdateLog> {
    /// `episodes.csv`.
    pub episodes: LogWriter<EpisodeRow>,
    /// The updates log (`updates.csv`).
    pub updates: LogWriter<U>,
    /// `validation.csv`.
    pub validation: LogWriter<ValidationRow>,
    scalars: Scalars,
}

impl<U: UpdateLog> Logs<U> {
    /// Opens the logs of `run_dir` for appending, first dropping what the checkpoint has not
    /// `seen` (rows and TensorBoard scalars of a run killed after its last checkpoint), so a
    /// resumed run's logs equal an uninterrupted run's.
    pub fn open(run_dir: &Path, seen: Seen) -> Result<Self, TrainError> {
        let path = |name: &str| run_dir.join(name);
        truncate_rows::<EpisodeRow>(&path(EpisodeRow::FILE_NAME), |r| r.episode < seen.episodes)?;
        truncate_rows::<U>(&path(U::FILE_NAME), |r| r.update() < seen.updates)?;
        truncate_rows::<ValidationRow>(&path(ValidationRow::FILE_NAME), |r| {
            r.episode <= seen.episodes
        })?;
        let loss_end = seen.updates + seen.first_loss_step;
        let scalars = Scalars::open(run_dir, |tag, step| match tag.split('/').next() {
            Some("episode") => step < seen.episodes as i64,
            Some("loss") => step < loss_end as i64,
            Some("validation") => step <= seen.episodes as i64,
            _ => true,
        })?;
        Ok(Logs {
            episodes: LogWriter::open(path(EpisodeRow::FILE_NAME))?,
            updates: LogWriter::open(path(U::FILE_NAME))?,
            validation: LogWriter::open(path(ValidationRow::FILE_NAME))?,
            scalars,
        })
    }

    /// Adds a TensorBoard scalar `tag` = `value` at `step`.
    pub fn scalar(&mut self, tag: &str, value: f32, step: u64) -> Result<(), TrainError> {
        self.scalars.scalar(tag, value, step)
    }

    /// Flushes the TensorBoard events (the CSV logs are written row by row).
    pub fn flush(&mut self) -> Result<(), TrainError> {
        self.scalars.flush()
    }
}

/// When an episode-based run validates, checkpoints and stops: the fields of its config.
#[derive(Clone, Copy, Debug)]
pub struct Cadence {
    /// The run's length in episodes.
    pub episodes: u64,
    /// Wall-time budget in minutes (0: none; [`Clock::out_of_time`]).
    pub max_minutes: f64,
    /// Validate every this many episodes (0: never).
    pub validate_every: u64,
    /// Checkpoint every this many episodes.
    pub checkpoint_every: u64,
    /// Also checkpoint when this many minutes passed since the last checkpoint (0: by episodes
    /// only; [`Clock::checkpoint_due`]).
    pub checkpoint_minutes: f64,
}

/// The [`Cadence`] of a config with fields of its names (`episodes`, `max_minutes`,
/// `validate_every`, `checkpoint_every`, `checkpoint_minutes`):
/// `madenet_harness::cadence!(cfg)`.
#[macro_export]
macro_rules! cadence {
    ($cfg:expr) => {
        $crate::harness::Cadence {
            episodes: $cfg.episodes,
            max_minutes: $cfg.max_minutes,
            validate_every: $cfg.validate_every,
            checkpoint_every: $cfg.checkpoint_every,
            checkpoint_minutes: $cfg.checkpoint_minutes,
        }
    };
}

/// The plumbing of an episode-based learner's loop (MADE-Net's, DME-DRL's) around its
/// algorithm: its [`Logs`] and [`Clock`], its latest validation, and when it validates,
/// checkpoints and stops ([`Cadence`]).
pub struct EpisodeRun<U: UpdateLog> {
    /// The run's logs.
    pub logs: Logs<U>,
    /// The run's clock.
    pub clock: Clock,
    /// The latest validation's mean steps (before the first in this process: the best so far).
    pub last_validation: Option<f64>,
    cadence: Cadence,
}

impl<U: UpdateLog> EpisodeRun<U> {
    /// Opens the logs of `run_dir` cut to what the checkpoint has `seen` ([`Logs::open`]) and
    /// starts the clock at its `wall_s`; `best_validation` is its best validation so far.
    pub fn open(
        run_dir: &Path,
        seen: Seen,
        wall_s: f64,
        best_validation: Option<f64>,
        cadence: Cadence,
    ) -> Result<Self, TrainError> {
        let logs = Logs::open(run_dir, seen)?;
        Ok(EpisodeRun {
            logs,
            clock: Clock::start(wall_s),
            last_validation: best_validation,
            cadence,
        })
    }

    /// Whether the run validates after `episode` episodes.
    pub fn validates(&self, episode: u64) -> bool {
        self.cadence.validate_every > 0 && episode.is_multiple_of(self.cadence.validate_every)
    }

    /// Logs validation `v`, made after `episode` episodes and `updates` updates: its row in
    /// `validation.csv` and its mean steps as `validation/mean_steps` at step `episode`. It is
    /// the latest validation from now on.
    pub fn log_validation(
        &mut self,
        episode: u64,
        updates: u64,
        v: &Validation,
    ) -> Result<(), TrainError> {
        self.logs.validation.append(&ValidationRow {
            episode,
            updates,
            mean_steps: v.mean_steps,
            mean_team_reward: v.mean_team_return,
            completed: v.completed as u32,
            trials: v.trials as u32,
        })?;
        self.logs
            .scalar("validation/mean_steps", v.mean_steps as f32, episode)?;
        self.last_validation = Some(v.mean_steps);
        Ok(())
    }

    /// The end of the run's episode `done` (counted from 1): checkpoints if due — every
    /// `checkpoint_every` episodes, when the run stops, or `checkpoint_minutes` after the last
    /// checkpoint — with `checkpoint(wall_s)` (`wall_s`: the run's wall time, to be saved with
    /// it; the checkpoint and the models that go with it, such as `last/`), then flushes the
    /// logs. Returns whether the run stops: its last episode, or out of time
    /// ([`Clock::out_of_time`]).
    pub fn end_episode(
        &mut self,
        done: u64,
        checkpoint: impl FnOnce(f64) -> Result<(), TrainError>,
    ) -> Result<bool, TrainError> {
        let (c, clock) = (&self.cadence, &mut self.clock);
        let stopping = done == c.episodes || clock.out_of_time(c.max_minutes);
        if done.is_multiple_of(c.checkpoint_every)
            || stopping
            || clock.checkpoint_due(c.checkpoint_minutes)
        {
            checkpoint(clock.wall())?;
            clock.checkpointed();
        }
        self.logs.flush()?;
        Ok(stopping)
    }

    /// The progress after `done` episodes and `updates` updates, with the episode's own
    /// `figures` ([`Progress::figures`]).
    pub fn progress(
        &self,
        done: u64,
        updates: u64,
        figures: Vec<(&'static str, f64, usize)>,
    ) -> Progress {
        Progress {
            done,
            total: self.cadence.episodes,
            unit: "episodes",
            updates,
            validation_steps: self.last_validation,
            base_steps: None,
            figures,
        }
    }
}

/// A run's TensorBoard scalars (`events.out.tfevents.*` in the run directory), for every
/// learner: [`Logs`] writes its through one, an iteration-based learner uses one directly.
pub struct Scalars {
    dir: PathBuf,
    /// Created with the first scalar, so a resume that trains nothing adds no event file.
    tb: Option<TfEventWriter>,
}

impl Scalars {
    /// Opens the scalars of `run_dir`, first dropping the recorded ones that `keep(tag, step)`
    /// refuses (those of a run killed after its last checkpoint).
    pub fn open(run_dir: &Path, keep: impl Fn(&str, i64) -> bool) -> Result<Self, TrainError> {
        madenet_trainlog::truncate_events(run_dir, keep).map_err(io_err(run_dir))?;
        Ok(Scalars {
            dir: run_dir.to_path_buf(),
            tb: None,
        })
    }

    /// Adds scalar `tag` = `value` at `step`.
    pub fn scalar(&mut self, tag: &str, value: f32, step: u64) -> Result<(), TrainError> {
        if self.tb.is_none() {
            self.tb = Some(TfEventWriter::create(&self.dir).map_err(io_err(&self.dir))?);
        }
        let tb = self.tb.as_mut().expect("created above");
        tb.add_scalar(tag, value, step as i64, unix_now())
            .map_err(io_err(&self.dir))
    }

    /// Writes the events out.
    pub fn flush(&mut self) -> Result<(), TrainError> {
        match &mut self.tb {
            Some(tb) => tb.flush().map_err(io_err(&self.dir)),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_best_keeps_the_fewest_steps() {
        let mut best = None;
        assert!(new_best(&mut best, 50.0));
        assert!(!new_best(&mut best, 50.0), "a tie is not better");
        assert!(!new_best(&mut best, 60.0));
        assert!(new_best(&mut best, 40.0));
        assert_eq!(best, Some(40.0));
    }

    /// A run's folders (`checkpoint`, `best`, `.behaviour` …) are replaced whole even where a
    /// file, or a folder left by a crash, stands in the way; nothing but the new folder is left.
    #[test]
    fn replace_dir_replaces_files_and_leftovers() {
        let root = std::env::temp_dir().join(format!("madenet-replace-{}", std::process::id()));
        std::fs::create_dir_all(&root).unwrap();
        let dir = root.join(".behaviour");
        for (name, folder) in [
            (".behaviour", false),
            (".behaviour.tmp", false),
            (".behaviour.old", true),
        ] {
            let p = root.join(name);
            if folder {
                std::fs::create_dir_all(p.join("inner")).unwrap();
            } else {
                std::fs::write(&p, b"in the way").unwrap();
            }
        }
        for round in 0..2 {
            replace_dir(&dir, |tmp| {
                std::fs::write(tmp.join("model.toml"), format!("round {round}"))
                    .map_err(io_err(tmp))
            })
            .unwrap();
            assert_eq!(
                std::fs::read_to_string(dir.join("model.toml")).unwrap(),
                format!("round {round}")
            );
            let mut left: Vec<_> = std::fs::read_dir(&root)
                .unwrap()
                .map(|e| e.unwrap().file_name().into_string().unwrap())
                .collect();
            left.sort();
            assert_eq!(left, [".behaviour"]);
        }
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn clock_budget_and_cadence_off_at_zero() {
        let c = Clock::start(12.5);
        assert!(c.wall() >= 12.5);
        assert!(!c.out_of_time(0.0) && !c.checkpoint_due(0.0));
        assert!(!c.out_of_time(1.0), "one minute has not passed");
        std::thread::sleep(std::time::Duration::from_millis(5));
        assert!(c.checkpoint_due(1e-6), "5 ms is more than 60 µs");
    }
}
