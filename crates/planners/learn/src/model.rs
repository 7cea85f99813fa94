//! A trained model as it is shipped and loaded: `model.toml` ([`ModelInfo`]: the learner that
//! trained it, the network's sizes, provenance, how to act) and its weights, loaded into the
//! DEP nets a policy acts with ([`Model`]). Loading never goes through a trainer.

use crate::agnostic::{AgnosticConfig, AgnosticNet, AgnosticPolicy, AgnosticScorer};
use crate::error::TrainError;
use crate::obs::Observation;
use crate::policy::DepPolicy;
use crate::{cpu, NetConfig, QNet};
use burn::module::Module;
use burn::store::ModuleRecord;
use madenet_agent::Policy;
use madenet_sim::PolicyRegistry;
use madenet_world::ScenarioConfig;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

pub use madenet_harness::model::{parse_model_toml, read_model_dir, register_trained, WeightFiles};

/// Which learner.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// CEP + DEPs trained together (Eq. 5 and 6), two environments.
    MadeNet,
    /// The paper's ablation: the DEPs alone on decentralized experience (double DRQN).
    MadeNetDt,
    /// The DEP regressed on a centralized rollout teacher's candidate values, DAgger-style
    /// ([`crate::dagger`]; a departure from the paper).
    MadeNetRollout,
}

impl Method {
    /// The method's name in configs, `model.toml` and `madenet train --method`.
    pub const fn name(self) -> &'static str {
        match self {
            Method::MadeNet => "made-net",
            Method::MadeNetDt => "made-net-dt",
            Method::MadeNetRollout => "made-net-rollout",
        }
    }
}

/// The trained DEPs as shipped: `model.toml` (method, net config, |I|, |G|) and the weights.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelInfo {
    /// The learner that trained the DEPs.
    pub method: Method,
    /// The paper's (grid) DEP's sizes; absent for an agnostic model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dep: Option<NetConfigToml>,
    /// The agnostic DEP's sizes ([`crate::agnostic`]); absent for a grid model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub agnostic: Option<AgnosticConfig>,
    /// DEP weight files, one per robot group (one when shared).
    pub deps: Vec<String>,
    /// Each weight file's digest ([`crate::integrity::digest`]), in the order of `deps`;
    /// written by training and checked at load. Absent in folders written before it existed
    /// (then integrity is unchecked, and a warning says so).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub digests: Vec<String>,
    /// Episodes per environment behind these weights.
    pub episode: u64,
    /// Updates behind these weights.
    pub updates: u64,
    /// Their validation mean steps.
    pub validation_steps: Option<f64>,
    /// The DEP's observation vector (default: the paper's).
    #[serde(default)]
    pub observation: Observation,
    /// Whether the DEP carries its LSTM state from one decision to the next (default: yes, the
    /// paper's); a model trained on single decisions acts from zero state at each.
    #[serde(default = "yes")]
    pub recurrent: bool,
    /// Conservative acting (ours, rollout-teacher models): take the candidate the `spread` rule
    /// takes unless the DEP values another more by at least this margin (in the model's value
    /// units). Unset: the DEP's greedy choice alone (the paper's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spread_margin: Option<f32>,
}

fn yes() -> bool {
    true
}

/// The DEP's [`NetConfig`] fields that vary, for `model.toml`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NetConfigToml {
    /// Map height H in cells ([`NetConfig::map_height`]).
    pub map_height: usize,
    /// Map width W in cells ([`NetConfig::map_width`]).
    pub map_width: usize,
    /// Team size |I| ([`NetConfig::team_size`]).
    pub team_size: usize,
    /// Goal candidates per robot |G| ([`NetConfig::goal_count`]).
    pub goal_count: usize,
    /// CONCAT as a learned layer ([`NetConfig::concat_fc`]).
    pub concat_fc: bool,
}

/// A loaded model: the DEP nets on the plain CPU device.
#[derive(Clone)]
pub struct Model {
    /// What `model.toml` says: method, sizes, provenance, how to act.
    pub info: ModelInfo,
    /// The grid DEPs (empty for an agnostic model).
    pub deps: Vec<Arc<QNet>>,
    /// The agnostic DEP, shared by every robot ([`Model::agnostic`]; private with `scorer`, so
    /// no model has one without the other or one that is not the other's weights).
    agnostic: Option<Arc<AgnosticNet>>,
    /// The agnostic DEP's weights as its robots decide with them, made from `agnostic` by
    /// [`Model::with_agnostic`].
    scorer: Option<Arc<AgnosticScorer>>,
}

impl Model {
    /// A grid model: one DEP per robot group (one when shared; at least one).
    pub fn with_grid(info: ModelInfo, deps: Vec<Arc<QNet>>) -> Result<Self, TrainError> {
        if deps.is_empty() {
            return Err(TrainError::Other(
                "a grid model needs at least one DEP".into(),
            ));
        }
        Ok(Model {
            info,
            deps,
            agnostic: None,
            scorer: None,
        })
    }

    /// The agnostic DEP (none for a grid model).
    pub fn agnostic(&self) -> Option<&Arc<AgnosticNet>> {
        self.agnostic.as_ref()
    }

    /// An agnostic model: `net` and its scorer.
    pub fn with_agnostic(info: ModelInfo, net: AgnosticNet) -> Self {
        let scorer = Arc::new(AgnosticScorer::new(&net));
        Model {
            info,
            deps: Vec::new(),
            agnostic: Some(Arc::new(net)),
            scorer: Some(scorer),
        }
    }

    /// Loads `dir/model.toml` and its weight files.
    pub fn load(dir: &Path) -> Result<Self, TrainError> {
        let (info, files, label) = read_model_dir(dir, Self::parse_info, |i| &i.deps)?;
        Self::from_parts(info, files, &label)
    }

    /// A model from the text of its `model.toml` and its weight files' bytes, in the order of
    /// its `deps` list (`label` names it in errors).
    pub fn from_bytes(
        model_toml: &str,
        weights: &[&[u8]],
        label: &str,
    ) -> Result<Self, TrainError> {
        let info = Self::parse_info(model_toml, label)?;
        let files = info
            .deps
            .iter()
            .cloned()
            .zip(weights.iter().map(|w| w.to_vec()))
            .collect();
        Self::from_parts(info, files, label)
    }

    fn parse_info(text: &str, label: &str) -> Result<ModelInfo, TrainError> {
        let info: ModelInfo = parse_model_toml(text, label)?;
        if let Some(d) = &info.dep {
            // Sizes are checked here, by name, before any network is built from them.
            let max_robots = madenet_world::MAX_ROBOTS;
            let checks = [
                (
                    "dep.map_height",
                    d.map_height,
                    crate::MIN_MAP_SIDE,
                    crate::MAX_TRAIN_MAP_SIDE,
                ),
                (
                    "dep.map_width",
                    d.map_width,
                    crate::MIN_MAP_SIDE,
                    crate::MAX_TRAIN_MAP_SIDE,
                ),
                ("dep.team_size", d.team_size, 1, max_robots),
                ("dep.goal_count", d.goal_count, 1, 4 * max_robots),
            ];
            for (field, v, lo, hi) in checks {
                if !(lo..=hi).contains(&v) {
                    return Err(TrainError::Config {
                        path: label.to_string(),
                        message: format!("field `{field}`: must lie in {lo}..={hi}, got {v}"),
                    });
                }
            }
        }
        Ok(info)
    }

    fn from_parts(info: ModelInfo, files: WeightFiles, label: &str) -> Result<Self, TrainError> {
        if files.len() != info.deps.len() || files.is_empty() {
            return Err(TrainError::Config {
                path: label.to_string(),
                message: format!(
                    "field `deps`: {} weight files listed, {} given",
                    info.deps.len(),
                    files.len()
                ),
            });
        }
        let config_err = |message: String| TrainError::Config {
            path: label.to_string(),
            message,
        };
        crate::integrity::check_digests(&info.digests, &files, label)?;
        let record = |name: &String, bytes: Vec<u8>| {
            ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(bytes)).map_err(|e| {
                TrainError::Io {
                    path: name.clone(),
                    message: e.to_string(),
                }
            })
        };
        match (&info.dep, &info.agnostic) {
            (Some(d), None) => {
                let cfg = NetConfig {
                    obs_dim: info.observation.dim(d.team_size, d.goal_count),
                    ..NetConfig::dep(d.map_height, d.map_width, d.team_size, d.goal_count)
                        .with_concat_fc(d.concat_fc)
                };
                let sizes = format!(
                    "`dep.map_height` {}, `dep.map_width` {}, `dep.team_size` {}, `dep.goal_count` {}, `dep.concat_fc` {}",
                    d.map_height, d.map_width, d.team_size, d.goal_count, d.concat_fc
                );
                let mut deps = Vec::new();
                for (name, bytes) in files {
                    let rec = record(&name, bytes)?;
                    let net = cfg.init(&cpu())?.try_load_record(rec);
                    deps.push(Arc::new(crate::integrity::checked_weights(
                        net, &name, label, &sizes,
                    )?));
                }
                Model::with_grid(info, deps)
            }
            (None, Some(a)) => {
                a.validate()
                    .map_err(|m| config_err(format!("table `agnostic`: {m}")))?;
                if files.len() != 1 {
                    return Err(config_err(
                        "field `deps`: an agnostic model has one weight file".into(),
                    ));
                }
                let (name, bytes) = files.into_iter().next().expect("one file");
                let rec = record(&name, bytes)?;
                let net = a.init(&cpu()).map_err(config_err)?.try_load_record(rec);
                let net =
                    crate::integrity::checked_weights(net, &name, label, "the table `agnostic`")?;
                Ok(Model::with_agnostic(info, net))
            }
            _ => Err(config_err(
                "exactly one of the tables `dep` (grid network) and `agnostic` is needed".into(),
            )),
        }
    }

    /// Why this model cannot act in a scenario, if it cannot: the networks are built for one
    /// map size, team size and |G| (the paper trains one model per environment and team).
    pub fn check(
        &self,
        height: usize,
        width: usize,
        scenario: &ScenarioConfig,
    ) -> Result<(), String> {
        let Some(d) = &self.info.dep else {
            // The agnostic DEP plays any map size, team and |G|.
            return Ok(());
        };
        let goals = scenario.goal_count_for(height * width);
        if (height, width, scenario.num_robots, goals)
            != (d.map_height, d.map_width, d.team_size, d.goal_count)
        {
            return Err(format!(
                "the model was trained for {}×{} maps, {} robots and |G| = {}; this scenario has {height}×{width}, {} robots and |G| = {goals} (train a model for it with `madenet train`)",
                d.map_height, d.map_width, d.team_size, d.goal_count, scenario.num_robots
            ));
        }
        Ok(())
    }

    /// Registers this model as policy `name` (robot i uses DEP i, or the shared one); it
    /// refuses scenarios it was not built for ([`Model::check`]).
    pub fn register(&self, registry: &mut PolicyRegistry, name: &str, about: &str) {
        register_trained(registry, name, about, self, Self::check, Self::policy);
    }

    /// Robot `robot`'s policy under name `name`: its grid DEP (or the shared one), or the
    /// agnostic DEP.
    pub fn policy(&self, name: &str, robot: usize) -> Box<dyn Policy> {
        let margin = self.info.spread_margin;
        if let (Some(scorer), Some(a)) = (&self.scorer, &self.info.agnostic) {
            return Box::new(
                AgnosticPolicy::new(name, Arc::clone(scorer), a).with_spread_margin(margin),
            );
        }
        let deps = &self.deps;
        let net = Arc::clone(&deps[robot.min(deps.len() - 1)]);
        Box::new(
            DepPolicy::new(name, net)
                .with_observation(self.info.observation)
                .with_recurrence(self.info.recurrent)
                .with_spread_margin(margin),
        )
    }
}
