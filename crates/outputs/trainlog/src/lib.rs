//! The training log of MADE-Net (Tan et al., RA-L 2023): what a training
//! run writes while it learns, and the figure drawn from it.
//!
//! A training run owns one **run directory**. This crate defines three of
//! the files in it and knows nothing about the learner itself:
//!
//! | file | written by | read by |
//! |---|---|---|
//! | `episodes.csv` | [`LogWriter<EpisodeRow>`], one row per training episode | [`read_episodes`], [`plot_training`] |
//! | `validation.csv` | [`LogWriter<ValidationRow>`], one row per validation round | [`read_validation`], [`plot_training`] |
//! | `events.out.tfevents.<unix_secs>.madenet` | [`TfEventWriter`], any scalars | TensorBoard (`tensorboard --logdir DIR`) |
//! | `fig2_training.png` ([`DEFAULT_FIGURE`]) | [`plot_training`] (`madenet plot-training DIR`) | people |
//!
//! # The CSV logs
//!
//! Plain CSV with a fixed header, one line per row, `,` separated, `.`
//! decimal point, so that a spreadsheet, pandas or `awk` read them as they
//! are. `episodes.csv` ([`EpisodeRow`]) has the header
//!
//! ```text
//! episode,env,csp,steps,team_reward,complete,epsilon,updates,wall_s
//! ```
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `episode` | u64 | index among all training episodes of the run, from 0 |
//! | `env` | `cen` or `dec` | the centralized or the decentralized environment ([`Env`]) |
//! | `csp` | f64 in [0, 1] | communication success probability of the episode |
//! | `steps` | u32 | timesteps the episode lasted |
//! | `team_reward` | f64 | team reward summed over the episode |
//! | `complete` | `0` or `1` | the team finished exploring before the step cap |
//! | `epsilon` | f64 in [0, 1] | ε of ε-greedy exploration during the episode |
//! | `updates` | u64 | gradient updates so far, after the episode |
//! | `wall_s` | f64 ≥ 0 | wall-clock seconds since the run started, after the episode |
//!
//! and `validation.csv` ([`ValidationRow`]) has the header
//!
//! ```text
//! episode,updates,mean_steps,mean_team_reward,completed,trials
//! ```
//!
//! (training episodes and gradient updates done when the validation ran,
//! the mean steps and mean team reward over its trials, how many of them
//! completed, and how many ran).
//!
//! The readers are strict where it helps and lenient where a live training
//! needs it. The header must match exactly, every value must parse and be
//! finite and within range, and an error names the file, the line and the
//! column:
//!
//! ```text
//! runs/a/episodes.csv:57: column `steps` = "-3": invalid digit found in string
//! ```
//!
//! But a last line without a line end that does not
//! parse is skipped, not an error: it is the row the trainer is writing
//! right now, so the figure of a running training can be drawn at any
//! moment. [`LogWriter`] writes each row whole and flushes it; reopening a
//! log appends, after cutting off a row left half-written by a crash.
//! Resuming from a checkpoint older than the log appends episode numbers
//! that are already there: the readers return every row, in file order;
//! [`plot_training`] keeps the last row of each episode.
//!
//! # TensorBoard event files
//!
//! [`TfEventWriter`] writes the event files TensorBoard reads, by hand:
//! there is no protobuf or tensorboard crate here because a dozen lines of
//! varint encoding beat a protobuf toolchain. A file is a sequence of
//! TFRecord records,
//!
//! ```text
//! u64 LE   length of data
//! u32 LE   masked CRC-32C of the 8 length bytes
//! [u8]     data: one serialized tensorflow.Event
//! u32 LE   masked CRC-32C of data
//! ```
//!
//! where the masked CRC of a CRC-32C (Castagnoli) `c` is
//! `((c >> 15) | (c << 17)) + 0xa282ead8` (wrapping; [`masked_crc32c`]).
//! The first event holds `wall_time` (field 1, double) and `file_version`
//! (field 3, string) = `"brain.Event:2"`; every scalar is an event with
//! `wall_time`, `step` (field 2, int64 varint) and `summary` (field 5), a
//! `Summary` holding one `value` (field 1) with `tag` (field 1, string) and
//! `simple_value` (field 2, float). A resumed run opens a new file in the
//! same directory; TensorBoard reads all of them.
//!
//! # Fig. 2
//!
//! [`plot_training`] draws the paper's Fig. 2 from a run directory: the
//! team reward (left) and the number of steps (right) per training episode,
//! raw values faint and their EWMA with factor 0.9 bold, one colour per
//! environment (blue `cen`, vermillion `dec`), against the episode index —
//! and, if `validation.csv` has rows, a third panel with the validation
//! mean steps (green). It uses `madenet-plots` (bundled font, PNG or SVG).
//!
//! ```no_run
//! use std::path::Path;
//! use madenet_trainlog::{plot_training, read_episodes};
//! let run = Path::new("runs/cep");
//! let rows = read_episodes(run.join("episodes.csv"))?;
//! println!("{} episodes", rows.len());
//! let png = plot_training(run, &run.join("fig2_training.png"))?;
//! # Ok::<(), madenet_trainlog::TrainLogError>(())
//! ```
//!
//! Every error is one line naming the file concerned.

#![deny(missing_docs)]

use std::path::PathBuf;

mod iterations;
mod log;
mod plot;
mod tfevents;

pub use iterations::{plot_iterations, plot_run};
pub use log::{
    read_episodes, read_rows, read_validation, truncate_rows, Env, EpisodeRow, LogRow, LogWriter,
    MaddpgUpdateRow, UpdateRow, ValidationRow,
};
pub use plot::{plot_training, DEFAULT_FIGURE, EWMA_ALPHA};
pub use tfevents::{masked_crc32c, read_scalars, truncate_events, TfEventWriter, FILE_VERSION};

/// What went wrong with a training log. Every message is one line naming
/// the file concerned.
#[derive(Debug, thiserror::Error)]
pub enum TrainLogError {
    /// The file (or its directory) could not be read, created or written.
    #[error("cannot {action} {path}: {source}")]
    Io {
        /// What was being done: `read`, `append to`, `write`, `create`.
        action: &'static str,
        /// The file or directory concerned.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file's first line is not the expected header.
    #[error("{path}:1: header is `{found}`, expected `{expected}`")]
    Header {
        /// The file.
        path: PathBuf,
        /// The header found.
        found: String,
        /// The header expected ([`LogRow::HEADER`]).
        expected: &'static str,
    },
    /// A row does not parse or has a bad value.
    #[error("{path}:{line}: {message}")]
    Row {
        /// The file.
        path: PathBuf,
        /// The 1-based line of the row.
        line: u64,
        /// What is wrong, naming the column where it is one column.
        message: String,
    },
    /// [`LogWriter::append`] was given a row with a bad value.
    #[error("{path}: refusing to append a row: {message}")]
    BadRow {
        /// The file appended to.
        path: PathBuf,
        /// What is wrong with the row.
        message: String,
    },
    /// `episodes.csv` exists but holds no episode.
    #[error("{path}: no episodes to plot (the file is empty or holds only its header)")]
    NoEpisodes {
        /// The file.
        path: PathBuf,
    },
    /// The figure could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] madenet_plots::PlotError),
}
