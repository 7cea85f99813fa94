//! The policy catalogue of madenet: every policy it can run, by name, in one
//! [`PolicyRegistry`].
//!
//! - the simulator's built-ins (`nf`, `spread`, …: [`PolicyRegistry::builtin`]),
//! - the classical baselines UB and PB ([`madenet_baselines::register`]) with given parameters,
//! - the shipped learned models (`made-net`, `made-net-any`, `made-net-paper`, `made-net-dt`,
//!   `dme-drl`: `models/`, embedded in the binary),
//! - and any trained model folder (`madenet train`'s `best/` or `last/`) of any learner,
//!   under a name of the caller's choosing ([`register_model`]; the learners by method:
//!   [`LearnerKind`]).
//!
//! The command line, the study, the Python package and the runtime's tests all take their
//! policies from here, so `madenet policies`, `madenet compare --methods` and
//! `madenet.policies()` list the same names.
//!
//! ```
//! let policies = madenet_catalogue::shipped().unwrap();
//! for name in ["nf", "spread", "ub", "pb", "made-net", "dme-drl"] {
//!     assert!(policies.names().iter().any(|n| n == name));
//! }
//! ```
#![deny(missing_docs)]

use madenet_baselines::BaselineParams;
use madenet_sim::PolicyRegistry;
use std::path::Path;

mod training;
pub use training::TrainRequest;

/// A catalogue that could not be built.
#[derive(Debug, thiserror::Error)]
pub enum CatalogueError {
    /// A trained model folder did not load; the message names the file and field.
    #[error("{0}")]
    Model(String),
    /// A training run cannot start as asked ([`TrainRequest`]); the message names the flag or
    /// the file and field.
    #[error("{0}")]
    Train(String),
    /// Training failed ([`madenet_learn::TrainError`]).
    #[error(transparent)]
    Training(#[from] madenet_learn::TrainError),
}

/// Every policy madenet ships, the baselines with parameters `baselines`. The learned models
/// load when a trial first asks for them, so building the catalogue costs nothing for a
/// process that plays none (`madenet world`, `radio`, `policies`).
pub fn catalogue(baselines: &BaselineParams) -> Result<PolicyRegistry, CatalogueError> {
    let mut r = PolicyRegistry::builtin();
    madenet_baselines::register(&mut r, baselines);
    madenet_learn::shipped::register(&mut r);
    madenet_dme::shipped::register(&mut r);
    Ok(r)
}

/// [`catalogue`] with the model trained in `model_dir`, if given, as `model` (`--model DIR`).
pub fn with_model(
    baselines: &BaselineParams,
    model_dir: Option<&Path>,
) -> Result<PolicyRegistry, CatalogueError> {
    let mut r = catalogue(baselines)?;
    if let Some(dir) = model_dir {
        register_model(&mut r, "model", "the model given with --model", dir)?;
    }
    Ok(r)
}

/// [`catalogue`] with the baselines' default parameters (the paper's).
pub fn shipped() -> Result<PolicyRegistry, CatalogueError> {
    catalogue(&BaselineParams::default())
}

/// The learners, by the methods they train: the one table the command line (`madenet train
/// --method`), model loading ([`register_model`]) and the Python package read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LearnerKind {
    /// MADE-Net and MADE-Net-DT ([`madenet_learn::MadeNetLearner`]).
    MadeNet,
    /// MADE-Net's DEP from the rollout teacher ([`madenet_learn::dagger::RolloutLearner`]).
    Rollout,
    /// The DME-DRL baseline ([`madenet_dme::train::DmeLearner`]).
    DmeDrl,
}

impl LearnerKind {
    /// Every learner.
    pub const ALL: [LearnerKind; 3] = [
        LearnerKind::MadeNet,
        LearnerKind::Rollout,
        LearnerKind::DmeDrl,
    ];

    /// The methods it trains (`method` in configs and `model.toml`).
    pub fn methods(self) -> &'static [&'static str] {
        use madenet_learn::Learner;
        match self {
            LearnerKind::MadeNet => madenet_learn::MadeNetLearner::METHODS,
            LearnerKind::Rollout => madenet_learn::dagger::RolloutLearner::METHODS,
            LearnerKind::DmeDrl => madenet_dme::train::DmeLearner::METHODS,
        }
    }

    /// The learner that trains `method`, if any.
    pub fn for_method(method: &str) -> Option<LearnerKind> {
        Self::ALL
            .into_iter()
            .find(|l| l.methods().contains(&method))
    }

    /// Every method of every learner, in table order.
    pub fn all_methods() -> Vec<&'static str> {
        Self::ALL
            .iter()
            .flat_map(|l| l.methods().iter().copied())
            .collect()
    }
}

/// The only field of `model.toml` read here; each learner's loader reads and checks the rest.
#[derive(serde::Deserialize)]
struct Method {
    method: Option<String>,
}

/// Which learner trained the model in `dir`, from its `model.toml`'s `method`; a folder whose
/// `model.toml` is missing or unreadable, or names no known method, counts as MADE-Net's,
/// whose loader then names the problem.
pub fn learner(dir: &Path) -> LearnerKind {
    match madenet_files::read_toml::<Method>(&dir.join("model.toml")) {
        Ok(Method { method: Some(m) }) => {
            LearnerKind::for_method(&m).unwrap_or(LearnerKind::MadeNet)
        }
        _ => LearnerKind::MadeNet,
    }
}

/// Loads the trained model in `dir` with its learner's loader and registers it as `name`.
pub fn register_model(
    registry: &mut PolicyRegistry,
    name: &str,
    about: &str,
    dir: &Path,
) -> Result<LearnerKind, CatalogueError> {
    use madenet_learn::Learner;
    let kind = learner(dir);
    match kind {
        LearnerKind::MadeNet => {
            madenet_learn::MadeNetLearner::register_model(dir, registry, name, about)
        }
        LearnerKind::Rollout => {
            madenet_learn::dagger::RolloutLearner::register_model(dir, registry, name, about)
        }
        LearnerKind::DmeDrl => {
            madenet_dme::train::DmeLearner::register_model(dir, registry, name, about)
        }
    }
    .map_err(|e| CatalogueError::Model(e.to_string()))?;
    Ok(kind)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped model folders are told apart by their `method`; a folder without
    /// `model.toml` is MADE-Net's, and its loader's error names the missing file.
    #[test]
    fn learner_from_model_toml() {
        let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../models");
        assert_eq!(learner(&models.join("dme-drl")), LearnerKind::DmeDrl);
        for m in ["made-net-paper", "made-net-dt"] {
            assert_eq!(learner(&models.join(m)), LearnerKind::MadeNet, "{m}");
        }
        for m in ["made-net", "made-net-any"] {
            assert_eq!(learner(&models.join(m)), LearnerKind::Rollout, "{m}");
        }
        let empty = tempfile::tempdir().unwrap();
        assert_eq!(learner(empty.path()), LearnerKind::MadeNet);
        let mut r = shipped().unwrap();
        let e = register_model(&mut r, "model", "test", empty.path()).unwrap_err();
        assert!(e.to_string().contains("model.toml"), "{e}");
        assert!(!r.names().iter().any(|n| n == "model"));
    }

    /// A trained DME-DRL folder registers under the caller's name with DME's loader.
    #[test]
    fn registers_a_model_folder_under_a_name() {
        let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../models");
        let mut r = shipped().unwrap();
        let kind = register_model(&mut r, "mine", "a copy", &models.join("dme-drl")).unwrap();
        assert_eq!(kind, LearnerKind::DmeDrl);
        assert!(r.names().iter().any(|n| n == "mine"));
        let kind = register_model(&mut r, "mine2", "a copy", &models.join("made-net")).unwrap();
        assert_eq!(kind, LearnerKind::Rollout);
        assert!(r.names().iter().any(|n| n == "mine2"));
    }
}
