//! The policy catalogue of madenet: every policy it can run, by name, in one
//! [`PolicyRegistry`].
//!
//! - the simulator's built-ins (`nf`, `spread`, …: [`PolicyRegistry::builtin`]),
//! - the classical baselines UB and PB ([`madenet_baselines::register`]) with given parameters,
//! - the shipped learned models (`made-net`, `made-net-any`, `made-net-paper`, `made-net-dt`,
//!   `dme-drl`: `models/`, embedded in the binary),
//! - and any trained model folder (`madenet train`'s `best/` or `last/`) of either learner,
//!   under a name of the caller's choosing ([`register_model`]).
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

/// A catalogue that could not be built.
#[derive(Debug, thiserror::Error)]
pub enum CatalogueError {
    /// A shipped model did not load (a broken build: the models are embedded).
    #[error("shipped model: {0}")]
    Shipped(String),
    /// A trained model folder did not load; the message names the file and field.
    #[error("{0}")]
    Model(String),
}

/// Every policy madenet ships, the baselines with parameters `baselines`.
pub fn catalogue(baselines: &BaselineParams) -> Result<PolicyRegistry, CatalogueError> {
    let mut r = PolicyRegistry::builtin();
    madenet_baselines::register(&mut r, baselines);
    madenet_learn::shipped::register(&mut r).map_err(|e| CatalogueError::Shipped(e.to_string()))?;
    madenet_dme::shipped::register(&mut r).map_err(|e| CatalogueError::Shipped(e.to_string()))?;
    Ok(r)
}

/// [`catalogue`] with the baselines' default parameters (the paper's).
pub fn shipped() -> Result<PolicyRegistry, CatalogueError> {
    catalogue(&BaselineParams::default())
}

/// Which learner trained a model folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Learner {
    /// MADE-Net (any of its trainers: `made-net`, `made-net-dt`, `made-net-rollout`).
    MadeNet,
    /// The DME-DRL baseline (`method = "dme-drl"`).
    DmeDrl,
}

/// The only field of `model.toml` read here; each learner's loader reads and checks the rest.
#[derive(serde::Deserialize)]
struct Method {
    method: Option<String>,
}

/// Which learner trained the model in `dir`, from its `model.toml`'s `method`; a folder whose
/// `model.toml` is missing or unreadable counts as MADE-Net's, whose loader then names the
/// problem.
pub fn learner(dir: &Path) -> Learner {
    match madenet_files::read_toml::<Method>(&dir.join("model.toml")) {
        Ok(Method { method: Some(m) }) if m == madenet_dme::train::METHOD => Learner::DmeDrl,
        _ => Learner::MadeNet,
    }
}

/// Loads the trained model in `dir` with its learner's loader and registers it as `name`.
pub fn register_model(
    registry: &mut PolicyRegistry,
    name: &str,
    about: &str,
    dir: &Path,
) -> Result<Learner, CatalogueError> {
    let learner = learner(dir);
    let model = |e: &dyn std::fmt::Display| CatalogueError::Model(e.to_string());
    match learner {
        Learner::DmeDrl => madenet_dme::train::Model::load(dir)
            .map_err(|e| model(&e))?
            .register(registry, name, about),
        Learner::MadeNet => madenet_learn::Model::load(dir)
            .map_err(|e| model(&e))?
            .register(registry, name, about),
    }
    Ok(learner)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped model folders are told apart by their `method`; a folder without
    /// `model.toml` is MADE-Net's, and its loader's error names the missing file.
    #[test]
    fn learner_from_model_toml() {
        let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        assert_eq!(learner(&models.join("dme-drl")), Learner::DmeDrl);
        for m in ["made-net", "made-net-any", "made-net-paper", "made-net-dt"] {
            assert_eq!(learner(&models.join(m)), Learner::MadeNet, "{m}");
        }
        let empty = tempfile::tempdir().unwrap();
        assert_eq!(learner(empty.path()), Learner::MadeNet);
        let mut r = shipped().unwrap();
        let e = register_model(&mut r, "model", "test", empty.path()).unwrap_err();
        assert!(e.to_string().contains("model.toml"), "{e}");
        assert!(!r.names().iter().any(|n| n == "model"));
    }

    /// A trained DME-DRL folder registers under the caller's name with DME's loader.
    #[test]
    fn registers_a_model_folder_under_a_name() {
        let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        let mut r = shipped().unwrap();
        let kind = register_model(&mut r, "mine", "a copy", &models.join("dme-drl")).unwrap();
        assert_eq!(kind, Learner::DmeDrl);
        assert!(r.names().iter().any(|n| n == "mine"));
        let kind = register_model(&mut r, "mine2", "a copy", &models.join("made-net")).unwrap();
        assert_eq!(kind, Learner::MadeNet);
        assert!(r.names().iter().any(|n| n == "mine2"));
    }
}
