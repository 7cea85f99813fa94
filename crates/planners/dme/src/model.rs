//! A trained DME-DRL model as shipped and loaded: `model.toml` ([`ModelInfo`]) and one actor
//! weight file per robot ([`Model`]).

use crate::nets::DmeConfig;
use crate::policy::{DmePolicy, SharedActor};
use crate::train::METHOD;
use burn::module::Module;
use burn::store::ModuleRecord;
use burn::tensor::Device;
use madenet_agent::Policy;
use madenet_harness::harness;
use madenet_harness::integrity::{check_digests, checked_weights};
use madenet_harness::model::{parse_model_toml, read_model_dir, register_trained};
use madenet_harness::TrainError;
use madenet_sim::PolicyRegistry;
use madenet_world::ScenarioConfig;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::{Arc, RwLock};

/// The trained actors as shipped: `model.toml` and one weight file per robot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelInfo {
    /// Always `dme-drl` (loading rejects any other method).
    pub method: String,
    /// Map height in cells the actors were trained for.
    pub map_height: usize,
    /// Map width in cells the actors were trained for.
    pub map_width: usize,
    /// Robots |I|: one actor each.
    pub team_size: usize,
    /// Map frames stacked in an actor's input ([`DmeConfig::history`]).
    pub history: usize,
    /// Hidden units of the actors' fully connected layer.
    pub hidden: usize,
    /// Weight files of the actors in robot order, relative to the model's directory
    /// (`actor0.bpk`, …).
    pub actors: Vec<String>,
    /// Each actor file's digest ([`madenet_harness::integrity::digest`]), in the order of
    /// `actors`; written by training, checked at load (absent in older folders: unchecked).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub digests: Vec<String>,
    /// Episodes played when the model was saved.
    pub episode: u64,
    /// MADDPG updates when the model was saved.
    pub updates: u64,
    /// Mean validation steps that made this the best model (`best/`); `None` for `last/`.
    pub validation_steps: Option<f64>,
}

/// A loaded DME-DRL model: one actor per robot on the plain CPU device.
#[derive(Clone)]
pub struct Model {
    /// Sizes and provenance, as in `model.toml`.
    pub info: ModelInfo,
    /// One actor per robot, in robot order (robot i runs actor i).
    pub actors: Vec<SharedActor>,
}

impl Model {
    /// Loads `dir/model.toml` and its actors.
    pub fn load(dir: &Path) -> Result<Self, TrainError> {
        let (info, files, label) =
            read_model_dir(dir, parse_model_toml::<ModelInfo>, |i| &i.actors)?;
        Self::from_parts(info, files.into_iter().map(|(_, b)| b).collect(), &label)
    }

    /// A model from the text of its `model.toml` and its actors' bytes in order.
    pub fn from_bytes(
        model_toml: &str,
        weights: &[&[u8]],
        label: &str,
    ) -> Result<Self, TrainError> {
        let info: ModelInfo = parse_model_toml(model_toml, label)?;
        Self::from_parts(info, weights.iter().map(|w| w.to_vec()).collect(), label)
    }

    fn from_parts(info: ModelInfo, files: Vec<Vec<u8>>, label: &str) -> Result<Self, TrainError> {
        if info.method != METHOD {
            return Err(TrainError::Config {
                path: label.into(),
                message: format!("field `method`: `{}` is not a DME-DRL model", info.method),
            });
        }
        if files.len() != info.team_size || files.len() != info.actors.len() {
            return Err(TrainError::Config {
                path: label.into(),
                message: format!(
                    "field `actors`: {} weight files for a team of {}",
                    files.len(),
                    info.team_size
                ),
            });
        }
        let min_side = madenet_harness::MIN_MAP_SIDE as u64;
        let side = madenet_harness::MAX_TRAIN_MAP_SIDE as u64;
        harness::check_sizes(&[
            ("map_height", info.map_height as u64, min_side, side),
            ("map_width", info.map_width as u64, min_side, side),
            (
                "team_size",
                info.team_size as u64,
                1,
                madenet_world::MAX_ROBOTS as u64,
            ),
            ("history", info.history as u64, 1, 64),
            ("hidden", info.hidden as u64, 1, 4096),
        ])
        .map_err(|message| TrainError::Config {
            path: label.into(),
            message,
        })?;
        let cfg = DmeConfig::new()
            .with_map_height(info.map_height)
            .with_map_width(info.map_width)
            .with_team_size(info.team_size)
            .with_history(info.history)
            .with_hidden(info.hidden);
        cfg.check_size().map_err(|message| TrainError::Config {
            path: label.into(),
            message,
        })?;
        let named: Vec<(String, Vec<u8>)> = info.actors.iter().cloned().zip(files).collect();
        check_digests(&info.digests, &named, label)?;
        let sizes = format!(
            "`map_height` {}, `map_width` {}, `team_size` {}, `history` {}, `hidden` {}",
            info.map_height, info.map_width, info.team_size, info.history, info.hidden
        );
        let mut actors = Vec::new();
        for (name, bytes) in named {
            let rec = ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(bytes))
                .map_err(|e| TrainError::Io {
                    path: format!("{label}: {name}"),
                    message: e.to_string(),
                })?;
            let actor = checked_weights(
                cfg.actor(&Device::flex()).try_load_record(rec),
                &name,
                label,
                &sizes,
            )?;
            actors.push(Arc::new(RwLock::new(actor)));
        }
        Ok(Model { info, actors })
    }

    /// Why this model cannot act in a scenario, if it cannot.
    pub fn check(
        &self,
        height: usize,
        width: usize,
        scenario: &ScenarioConfig,
    ) -> Result<(), String> {
        let i = &self.info;
        if (height, width, scenario.num_robots) != (i.map_height, i.map_width, i.team_size) {
            return Err(format!(
                "the model was trained for {}×{} maps and {} robots; this scenario has {height}×{width} and {} robots (train one for it with `madenet train --method dme-drl`)",
                i.map_height, i.map_width, i.team_size, scenario.num_robots
            ));
        }
        Ok(())
    }

    /// Robot `robot`'s policy under name `name`: its greedy actor (robot i runs actor i).
    pub fn policy(&self, name: &str, robot: usize) -> Box<dyn Policy> {
        let actor = Arc::clone(&self.actors[robot.min(self.actors.len() - 1)]);
        Box::new(DmePolicy::new(name, robot, actor, self.info.history))
    }

    /// Registers this model as policy `name` ([`Model::policy`]); it refuses scenarios it was
    /// not built for ([`Model::check`]).
    pub fn register(&self, registry: &mut PolicyRegistry, name: &str, about: &str) {
        register_trained(registry, name, about, self, Self::check, Self::policy);
    }
}
