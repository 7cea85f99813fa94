//! The learners' one error type ([`madenet_harness::error`], re-exported here), and how
//! MADE-Net's own errors become one.

use crate::env::EpisodeError;
use crate::ConfigError;
pub use madenet_harness::error::*;

impl From<ConfigError> for TrainError {
    fn from(e: ConfigError) -> Self {
        TrainError::Net(Box::new(e))
    }
}

impl From<EpisodeError> for TrainError {
    fn from(e: EpisodeError) -> Self {
        TrainError::Episode(Box::new(e))
    }
}
