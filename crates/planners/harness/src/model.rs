//! A trained model's folder, whatever the learner: `model.toml` (the learner's own info type)
//! and its weight files in order, read with their sizes capped ([`read_model_dir`]), and the
//! loaded model registered as a policy ([`register_trained`]). Checking the weight files is
//! [`crate::integrity`]'s job.

use crate::error::{io_err, TrainError};
use madenet_agent::Policy;
use madenet_sim::PolicyRegistry;
use madenet_world::ScenarioConfig;
use std::path::Path;

/// A model folder's `model.toml` in `text` (`label` names it in errors): unknown keys and bad
/// values are [`TrainError::Config`].
pub fn parse_model_toml<I: serde::de::DeserializeOwned>(
    text: &str,
    label: &str,
) -> Result<I, TrainError> {
    madenet_files::parse_toml(text).map_err(|message| TrainError::Config {
        path: label.to_string(),
        message,
    })
}

/// A model folder's weight files in order: each one's path (or name) and bytes.
pub type WeightFiles = Vec<(String, Vec<u8>)>;

/// Reads the model folder `dir`: its `model.toml`, parsed by `parse(text, label)`, and then the
/// weight files that `weights(&info)` lists, in order, each with its path. Returns the info,
/// the files and the label (the `model.toml`'s path) that errors name.
pub fn read_model_dir<I>(
    dir: &Path,
    parse: impl FnOnce(&str, &str) -> Result<I, TrainError>,
    weights: impl FnOnce(&I) -> &[String],
) -> Result<(I, WeightFiles, String), TrainError> {
    let path = dir.join("model.toml");
    let text = madenet_files::read_text_capped(&path, madenet_files::InputKind::Config)
        .map_err(io_err(&path))?;
    let label = path.display().to_string();
    let info = parse(&text, &label)?;
    let mut files = Vec::new();
    for f in weights(&info) {
        let p = dir.join(f);
        files.push((
            p.display().to_string(),
            madenet_files::read_capped(&p, madenet_files::InputKind::Weights)
                .map_err(io_err(&p))?,
        ));
    }
    Ok((info, files, label))
}

/// Registers trained model `model` as policy `name`: it refuses the scenarios that
/// `check(model, height, width, scenario)` refuses, and robot i plays
/// `policy(model, name, i)` (a model's own `check` and `policy`).
pub fn register_trained<M: Clone + Send + Sync + 'static>(
    registry: &mut PolicyRegistry,
    name: &str,
    about: &str,
    model: &M,
    check: fn(&M, usize, usize, &ScenarioConfig) -> Result<(), String>,
    policy: fn(&M, &str, usize) -> Box<dyn Policy>,
) {
    let (model, checker) = (model.clone(), model.clone());
    let owned = name.to_string();
    registry.register_checked(
        name,
        about,
        move |ctx| check(&checker, ctx.height, ctx.width, ctx.config),
        move |ctx| policy(&model, &owned, ctx.robot),
    );
}
