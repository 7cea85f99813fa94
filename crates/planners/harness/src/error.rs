//! The learners' one error type, and the two I/O helpers that produce it.

use std::path::Path;

/// A learner's own error carried by a [`TrainError`] ([`TrainError::Net`],
/// [`TrainError::Episode`]): its networks' and its episodes' errors are the learner's types.
pub type LearnerError = Box<dyn std::error::Error + Send + Sync>;

/// Why training cannot start or go on. Messages name the file and field.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// A config, `model.toml`, checkpoint or weight file that cannot be parsed, holds a bad
    /// value, or does not fit the run or model.
    #[error("{path}: {message}")]
    Config {
        /// The file, or a label for a model compiled into the binary or a config given in code.
        path: String,
        /// What is wrong, naming the field where there is one.
        message: String,
    },
    /// The network sizes cannot be built (the learner's own error, e.g.
    /// `madenet_learn::ConfigError`).
    #[error("{0}")]
    Net(#[source] LearnerError),
    /// A file or directory could not be read, written or decoded.
    #[error("{path}: {message}")]
    Io {
        /// The file or directory (or the label of a compiled-in model's weights).
        path: String,
        /// The underlying error.
        message: String,
    },
    /// A training episode could not be run or recorded (the learner's own error, e.g.
    /// `madenet_learn::env::EpisodeError`).
    #[error(transparent)]
    Episode(LearnerError),
    /// A training log could not be read or written.
    #[error(transparent)]
    Log(#[from] madenet_trainlog::TrainLogError),
    /// Anything else (thread pool, encoding, generated maps, unknown shipped model, …).
    #[error("{0}")]
    Other(String),
    /// Stopped on request ([`crate::harness::stop_flag`]) inside its first iteration: nothing
    /// trained in this call; the run resumes from its last checkpoint.
    #[error("stopped before the first iteration of this call finished; the run resumes from its last checkpoint")]
    Stopped,
}

/// An I/O error naming `path`.
pub fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> TrainError + '_ {
    move |e| TrainError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes `bytes` to `path` ([`madenet_files::write_atomic`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), TrainError> {
    madenet_files::write_atomic(path, bytes).map_err(io_err(path))
}
