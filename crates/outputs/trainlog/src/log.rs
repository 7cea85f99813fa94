//! The training log's CSV files: rows, reading with errors that name file
//! and line, and appending.

use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::TrainLogError;

/// The environment an episode was played in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Env {
    /// The centralized environment (`cen`): every exchange succeeds, the
    /// team acts on one joint map (trains the CEP).
    Cen,
    /// The decentralized environment (`dec`): exchanges fail with
    /// probability 1 − CSP (trains the DEPs).
    Dec,
}

impl Env {
    /// The name used in the CSV: `cen` or `dec`.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Env::Cen => "cen",
            Env::Dec => "dec",
        }
    }
}

impl fmt::Display for Env {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One training episode: a row of `episodes.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRow {
    /// Index of the episode among all training episodes of the run (both
    /// environments), from 0.
    pub episode: u64,
    /// The environment it was played in.
    pub env: Env,
    /// The communication success probability of the episode, in [0, 1].
    pub csp: f64,
    /// Timesteps the episode lasted.
    pub steps: u32,
    /// The team reward summed over the episode.
    pub team_reward: f64,
    /// Whether the team finished exploring before the step cap (`0`/`1` in
    /// the CSV).
    #[serde(with = "zero_one")]
    pub complete: bool,
    /// The ε of ε-greedy exploration during the episode, in [0, 1].
    pub epsilon: f64,
    /// Gradient updates done so far in the run, after this episode.
    pub updates: u64,
    /// Wall-clock seconds since the run started, after this episode.
    pub wall_s: f64,
}

/// One validation round: a row of `validation.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidationRow {
    /// Training episodes completed when the validation ran.
    pub episode: u64,
    /// Gradient updates done when the validation ran.
    pub updates: u64,
    /// Mean number of timesteps over the validation trials.
    pub mean_steps: f64,
    /// Mean team reward over the validation trials.
    pub mean_team_reward: f64,
    /// Trials that finished exploring before the step cap.
    pub completed: u32,
    /// Validation trials run (at least 1).
    pub trials: u32,
}

/// One gradient update: a row of `updates.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UpdateRow {
    /// Index of the update in the run, from 0.
    pub update: u64,
    /// The CEP's loss (Eq. 5); NaN when no CEP is trained (MADE-Net-DT).
    pub cep_loss: f64,
    /// The DEPs' loss (Eq. 6), averaged over the DEP nets.
    pub dep_loss: f64,
}

/// One MADDPG update (DME-DRL): a row of `updates.csv` in a DME-DRL run directory.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaddpgUpdateRow {
    /// Index of the update in the run, from 0.
    pub update: u64,
    /// The critics' TD loss, averaged over robots.
    pub critic_loss: f64,
    /// The actors' objective −Q, averaged over robots.
    pub actor_loss: f64,
}

/// A row type of the training log: its file name, its header and the
/// checks a row must pass besides parsing.
pub trait LogRow: Serialize + DeserializeOwned {
    /// The file's name in a run directory, e.g. `episodes.csv`.
    const FILE_NAME: &'static str;
    /// The exact header line (without line end).
    const HEADER: &'static str;
    /// A valid row (without line end), against which the columns of a row
    /// that does not parse are tried one at a time to name the bad one.
    const EXAMPLE: &'static str;
    /// Checks the values (finite, within range); `Err` says what is wrong.
    ///
    /// # Errors
    ///
    /// A short description of the first bad value.
    fn check(&self) -> Result<(), String>;
}

fn finite(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} is not finite ({v})"))
    }
}

fn unit(name: &str, v: f64) -> Result<(), String> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(format!("{name} is {v}, not in [0, 1]"))
    }
}

impl LogRow for EpisodeRow {
    const FILE_NAME: &'static str = "episodes.csv";
    const HEADER: &'static str =
        "episode,env,csp,steps,team_reward,complete,epsilon,updates,wall_s";
    const EXAMPLE: &'static str = "0,cen,1,1,0,0,0,0,0";

    fn check(&self) -> Result<(), String> {
        unit("csp", self.csp)?;
        finite("team_reward", self.team_reward)?;
        unit("epsilon", self.epsilon)?;
        finite("wall_s", self.wall_s)?;
        if self.wall_s < 0.0 {
            return Err(format!("wall_s is negative ({})", self.wall_s));
        }
        Ok(())
    }
}

impl LogRow for ValidationRow {
    const FILE_NAME: &'static str = "validation.csv";
    const HEADER: &'static str = "episode,updates,mean_steps,mean_team_reward,completed,trials";
    const EXAMPLE: &'static str = "0,0,0,0,0,1";

    fn check(&self) -> Result<(), String> {
        finite("mean_steps", self.mean_steps)?;
        finite("mean_team_reward", self.mean_team_reward)?;
        if self.trials == 0 {
            return Err("trials is 0".into());
        }
        if self.completed > self.trials {
            return Err(format!(
                "completed ({}) exceeds trials ({})",
                self.completed, self.trials
            ));
        }
        Ok(())
    }
}

impl LogRow for UpdateRow {
    const FILE_NAME: &'static str = "updates.csv";
    const HEADER: &'static str = "update,cep_loss,dep_loss";
    const EXAMPLE: &'static str = "0,0,0";

    fn check(&self) -> Result<(), String> {
        if !self.cep_loss.is_nan() {
            finite("cep_loss", self.cep_loss)?;
        }
        finite("dep_loss", self.dep_loss)
    }
}

impl LogRow for MaddpgUpdateRow {
    const FILE_NAME: &'static str = "updates.csv";
    const HEADER: &'static str = "update,critic_loss,actor_loss";
    const EXAMPLE: &'static str = "0,0,0";

    fn check(&self) -> Result<(), String> {
        finite("critic_loss", self.critic_loss)?;
        finite("actor_loss", self.actor_loss)
    }
}

/// Rewrites the log at `path` (if it exists) with only the rows `keep` accepts — e.g. the rows
/// a resumed run's checkpoint has seen; a row cut short at the end goes too. The new file
/// replaces the old one atomically.
///
/// # Errors
///
/// As [`read_rows`], and [`TrainLogError::Io`] if the new file cannot be written.
pub fn truncate_rows<R: LogRow>(
    path: &Path,
    keep: impl Fn(&R) -> bool,
) -> Result<(), TrainLogError> {
    if !path.exists() {
        return Ok(());
    }
    let rows: Vec<R> = read_rows(path)?;
    let io = |source| TrainLogError::Io {
        action: "write",
        path: path.to_path_buf(),
        source,
    };
    let mut file = madenet_files::AtomicFile::create(path).map_err(io)?;
    file.write_all(format!("{}\n", R::HEADER).as_bytes())
        .map_err(io)?;
    let mut out = csv::WriterBuilder::new()
        .has_headers(false)
        .from_writer(file);
    for r in rows.iter().filter(|r| keep(r)) {
        out.serialize(r)
            .map_err(|e| io(std::io::Error::other(e.to_string())))?;
    }
    let file = out
        .into_inner()
        .map_err(|e| io(std::io::Error::other(e.to_string())))?;
    file.commit().map_err(|source| TrainLogError::Io {
        action: "replace",
        path: path.to_path_buf(),
        source,
    })
}

/// Reads `episodes.csv` (see [`read_rows`]).
///
/// # Errors
///
/// As [`read_rows`].
pub fn read_episodes(path: impl AsRef<Path>) -> Result<Vec<EpisodeRow>, TrainLogError> {
    read_rows(path.as_ref())
}

/// Reads `validation.csv` (see [`read_rows`]).
///
/// # Errors
///
/// As [`read_rows`].
pub fn read_validation(path: impl AsRef<Path>) -> Result<Vec<ValidationRow>, TrainLogError> {
    read_rows(path.as_ref())
}

/// Reads a training-log CSV: the exact header [`LogRow::HEADER`], then one
/// row per line, returned in file order. A file holding only the header
/// (or nothing) gives no rows. A last line without a line end that does not
/// parse is ignored: it is a row the trainer is still writing, or was
/// writing when it stopped.
///
/// # Errors
///
/// [`TrainLogError::Io`] if the file cannot be read (missing, say),
/// [`TrainLogError::Header`] if the header differs, and
/// [`TrainLogError::Row`] — naming the line and column — for a row that
/// does not parse, has the wrong number of fields, or fails
/// [`LogRow::check`].
pub fn read_rows<R: LogRow>(path: &Path) -> Result<Vec<R>, TrainLogError> {
    let bytes = std::fs::read(path).map_err(|source| TrainLogError::Io {
        action: "read",
        path: path.to_path_buf(),
        source,
    })?;
    // The 1-based line of an unterminated last line, if any.
    let partial_line = match bytes.last() {
        Some(&b) if b != b'\n' => Some(bytes.iter().filter(|&&c| c == b'\n').count() as u64 + 1),
        _ => None,
    };
    let row_err = |line: u64, message: String| TrainLogError::Row {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(&bytes[..]);
    let mut records = rdr.records();
    let header = match records.next() {
        None => return Ok(Vec::new()),
        Some(Ok(h)) => h,
        Some(Err(e)) => return Err(row_err(1, e.to_string())),
    };
    let found = header.iter().collect::<Vec<_>>().join(",");
    if found != R::HEADER {
        if partial_line == Some(1) && R::HEADER.starts_with(&found) {
            return Ok(Vec::new()); // the header is still being written
        }
        return Err(TrainLogError::Header {
            path: path.to_path_buf(),
            found,
            expected: R::HEADER,
        });
    }
    let columns: Vec<&str> = R::HEADER.split(',').collect();
    let mut rows = Vec::new();
    for rec in records {
        let (line, result) = match rec {
            Ok(rec) => {
                let line = rec.position().map_or(0, csv::Position::line);
                let parsed = if rec.len() == columns.len() {
                    rec.deserialize::<R>(None)
                        .map_err(|e| describe::<R>(&e, &rec, &columns))
                } else {
                    Err(format!(
                        "{} fields, expected {} ({})",
                        rec.len(),
                        columns.len(),
                        R::HEADER
                    ))
                };
                (line, parsed.and_then(|r| r.check().map(|()| r)))
            }
            Err(e) => {
                let line = e.position().map_or(0, csv::Position::line);
                (line, Err(csv_message(&e)))
            }
        };
        match result {
            Ok(r) => rows.push(r),
            Err(_) if Some(line) == partial_line => break,
            Err(message) => return Err(row_err(line, message)),
        }
    }
    Ok(rows)
}

/// A deserialization error as `column `steps` = "x": invalid digit …`.
/// csv knows the column of its own parse errors but not of serde's (an
/// unknown enum variant, say): then each column of the row is tried alone
/// in [`LogRow::EXAMPLE`].
fn describe<R: LogRow>(e: &csv::Error, rec: &csv::StringRecord, columns: &[&str]) -> String {
    let csv::ErrorKind::Deserialize { err, .. } = e.kind() else {
        return csv_message(e);
    };
    let column = err
        .field()
        .and_then(|i| usize::try_from(i).ok())
        .or_else(|| {
            let example: Vec<&str> = R::EXAMPLE.split(',').collect();
            (0..columns.len().min(example.len())).find(|&i| {
                let mut probe = example.clone();
                probe[i] = rec.get(i).unwrap_or("");
                csv::StringRecord::from(probe)
                    .deserialize::<R>(None)
                    .is_err()
            })
        });
    match column {
        Some(i) => {
            let name = columns.get(i).copied().unwrap_or("?");
            let value = rec.get(i).unwrap_or("");
            format!("column `{name}` = {value:?}: {}", err.kind())
        }
        None => err.kind().to_string(),
    }
}

fn csv_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::Utf8 { .. } => "not valid UTF-8".into(),
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("{len} fields, expected {expected_len}")
        }
        _ => e.to_string(),
    }
}

/// Appends rows to a training-log CSV, one whole line per
/// [`append`](Self::append), flushed at once so a reader (a plot of a
/// running training) sees only whole rows.
///
/// ```no_run
/// use madenet_trainlog::{Env, EpisodeRow, LogWriter};
/// let mut log = LogWriter::<EpisodeRow>::open("runs/cep/episodes.csv")?;
/// log.append(&EpisodeRow {
///     episode: 0, env: Env::Cen, csp: 1.0, steps: 143, team_reward: -57.5,
///     complete: true, epsilon: 1.0, updates: 0, wall_s: 0.8,
/// })?;
/// # Ok::<(), madenet_trainlog::TrainLogError>(())
/// ```
#[derive(Debug)]
pub struct LogWriter<R: LogRow> {
    out: csv::Writer<File>,
    path: PathBuf,
    _row: PhantomData<fn(&R)>,
}

impl<R: LogRow> LogWriter<R> {
    /// Opens `path` for appending, creating it (and missing parent
    /// directories) with the header if it does not exist or is empty. An
    /// existing file must start with the header; an unterminated last line
    /// (a row cut short when the trainer stopped) is cut off, so a resumed
    /// run appends whole rows.
    ///
    /// Rows are not deduplicated: a run resumed from a checkpoint older
    /// than its log appends episode numbers that are already there. The
    /// readers keep them; [`plot_training`](crate::plot_training) keeps the
    /// last row of each episode.
    ///
    /// # Errors
    ///
    /// [`TrainLogError::Io`] if the file cannot be opened, read or
    /// written; [`TrainLogError::Header`] if it has another header.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, TrainLogError> {
        let path = path.as_ref().to_path_buf();
        let io = |source| TrainLogError::Io {
            action: "append to",
            path: path.clone(),
            source,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| TrainLogError::Io {
                action: "create",
                path: dir.to_path_buf(),
                source,
            })?;
        }
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io)?;
        let mut text = Vec::new();
        file.read_to_end(&mut text).map_err(io)?;
        // Keep the whole lines; check the header.
        let keep = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let first = &text[..text.iter().position(|&b| b == b'\n').unwrap_or(text.len())];
        let first = String::from_utf8_lossy(first.strip_suffix(b"\r").unwrap_or(first));
        let header_ok = if keep == 0 {
            R::HEADER.starts_with(&*first) // nothing, or a header cut short
        } else {
            first == R::HEADER
        };
        if !header_ok {
            return Err(TrainLogError::Header {
                path: path.clone(),
                found: first.into_owned(),
                expected: R::HEADER,
            });
        }
        if keep < text.len() {
            file.set_len(keep as u64).map_err(io)?;
        }
        file.seek(SeekFrom::End(0)).map_err(io)?;
        if keep == 0 {
            file.write_all(format!("{}\n", R::HEADER).as_bytes())
                .map_err(io)?;
        }
        let out = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(file);
        Ok(LogWriter {
            out,
            path,
            _row: PhantomData,
        })
    }

    /// The file being written.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends one row and flushes it to the file.
    ///
    /// # Errors
    ///
    /// [`TrainLogError::BadRow`] if the row fails [`LogRow::check`] (nothing
    /// is written), [`TrainLogError::Io`] if writing fails.
    pub fn append(&mut self, row: &R) -> Result<(), TrainLogError> {
        row.check().map_err(|message| TrainLogError::BadRow {
            path: self.path.clone(),
            message,
        })?;
        let io = |e: csv::Error| TrainLogError::Io {
            action: "write",
            path: self.path.clone(),
            source: match e.into_kind() {
                csv::ErrorKind::Io(e) => e,
                other => std::io::Error::other(format!("{other:?}")),
            },
        };
        self.out.serialize(row).map_err(io)?;
        self.out.flush().map_err(|source| TrainLogError::Io {
            action: "write",
            path: self.path.clone(),
            source,
        })
    }
}

/// `bool` as `0`/`1`.
mod zero_one {
    use serde::{de, Deserialize, Deserializer, Serializer};

    #[allow(clippy::trivially_copy_pass_by_ref)] // serde's `with` signature
    pub fn serialize<S: Serializer>(v: &bool, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(u8::from(*v))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<bool, D::Error> {
        match u8::deserialize(d)? {
            0 => Ok(false),
            1 => Ok(true),
            n => Err(de::Error::invalid_value(
                de::Unexpected::Unsigned(u64::from(n)),
                &"0 or 1",
            )),
        }
    }
}
