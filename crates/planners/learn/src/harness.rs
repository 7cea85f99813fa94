//! The one training harness of madenet's learners: [`madenet_harness::harness`], re-exported at
//! this path for the users of `madenet_learn::harness`, and what it needs of MADE-Net's model
//! folder ([`write_model_toml`]).

use crate::error::TrainError;
use crate::model::ModelInfo;
use std::path::Path;

pub use madenet_harness::harness::*;

/// Writes a model's `model.toml` into the model folder `dir` being filled by [`replace_dir`],
/// with the digests of the weight files already there ([`crate::integrity::digest`]).
pub fn write_model_toml(dir: &Path, info: &ModelInfo) -> Result<(), TrainError> {
    let mut info = info.clone();
    info.digests = file_digests(dir, &info.deps)?;
    write_toml(&dir.join("model.toml"), &info)
}
