//! What every madenet learner does around its own algorithm (MADE-Net and MADE-Net-DT, the
//! rollout teacher's DAgger learner in `madenet-learn`; DME-DRL in `madenet-dme`). A learner
//! keeps only what is its own — its networks, its data, its update and what its model folder
//! holds — and gets the rest from here, one module each:
//!
//! * [`harness`] — the [`Learner`] contract (config, methods, loop, model loader) and
//!   [`harness::train`], which runs any learner: the run folder and its `config.toml`, resume
//!   from `checkpoint/`, the thread pool; [`Progress`] after each unit of work; the logs
//!   ([`harness::Logs`]: `episodes.csv`, the updates log, `validation.csv`, TensorBoard) cut
//!   to the checkpoint on resume; the [`harness::Clock`] (wall time across resumes, time
//!   budget, checkpoint cadence); checkpoint files written whole ([`harness::replace_dir`],
//!   [`harness::write_json`], [`harness::read_postcard`], …) and `best/` ([`harness::new_best`]);
//!   a config's readers and size checks ([`toml_config_readers!`], [`learner_config!`],
//!   [`cadence!`], [`harness::check_sizes`], [`harness::check_memory`]);
//! * [`scenario`] — the generated training and validation scenarios
//!   ([`scenario::ScenarioDraw`]) and the one validator ([`scenario::validate`]);
//! * [`episode`] — the one episode runner: the trial's staged timestep with a
//!   [`episode::Recorder`] per learner;
//! * [`model`] — the model folder: `model.toml` read and parsed, its weight files read in order
//!   ([`model::read_model_dir`]), a trained model registered as a policy
//!   ([`model::register_trained`]); [`integrity`] — the weight files' digests (and, with the
//!   `burn` feature, weights checked for fit and finite values);
//! * [`bits`] — map images at one bit per cell, as replays keep them;
//! * [`error`] — the learners' one error type, [`TrainError`];
//! * the map sides every learner accepts: [`MIN_MAP_SIDE`] ..= [`MAX_TRAIN_MAP_SIDE`].
//!
//! Nothing here knows a network: the crate needs no tensor library. The `burn` feature adds
//! the pieces generic over burn's modules that the learners on burn share
//! (`integrity::checked_weights`, `harness::load_weights`).

#![deny(missing_docs)]

pub mod bits;
pub mod episode;
pub mod error;
pub mod harness;
pub mod integrity;
pub mod model;
pub mod scenario;

pub use error::TrainError;
pub use harness::{Learner, Progress};

/// Smallest map side a learner trains on or a grid model is built for: MADE-Net's map feature
/// extractor at the paper's convolutions (12 → C1 (4, 2) 5 → C2 (3, 2) 2 → C3 (2, 2) 1, while
/// 11 → 4 → 1 leaves C3's 2×2 kernel nothing to cover; `madenet_learn::NetConfig::min_map_side`
/// computes it for any convolutions).
pub const MIN_MAP_SIDE: usize = 12;

/// The side of the paper's training maps (20 × 20), every learner's default map size.
pub const DEFAULT_MAP_SIDE: usize = 20;

/// The largest map side a learner trains or a grid model is built for (the paper's maps are
/// 20; a 200 × 200 grid DEP has ≈ 5 M parameters, a 1 000 × 1 000 one would have ≈ 130 M).
pub const MAX_TRAIN_MAP_SIDE: usize = 200;
