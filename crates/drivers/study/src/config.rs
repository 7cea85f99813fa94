//! [`StudyConfig`]: what the study runs, in one TOML file.

use madenet_baselines::rollout::{Lookahead, OracleKind};
use madenet_baselines::BaselineParams;
use madenet_map::paper::{Corner, PAPER_MAP_COUNT};
use madenet_sim::{MapSource, PolicyRegistry, StartSpec};
use madenet_world::ScenarioConfig;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The study's design. Defaults are the paper's comparison study (Sec. V.A.4) with 5 seeds per
/// trial instead of the paper's 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StudyConfig {
    /// Methods by policy name (`madenet policies`), in the order tables and figures show them.
    pub methods: Vec<String>,
    /// Maps: `paper` (the paper's 10, embedded), `paper:N`, `generate:SEED`, a map file, or a
    /// folder whose `.yaml` maps are all used (sorted by name).
    pub maps: Vec<String>,
    /// Starts: corner names (`top-left`, …) or explicit cells `r,c;r,c;r,c`.
    pub starts: Vec<String>,
    /// Communication success probabilities (paper: 0, 0.5, 0.8, 1).
    pub csp: Vec<f64>,
    /// Seeds per (method, map, start, CSP): `seed_base`, `seed_base + 1`, …
    pub seeds: u64,
    /// The first seed of each (method, map, start, CSP).
    pub seed_base: u64,
    /// The scenario of every trial (its `comm_success_prob` is replaced by each CSP).
    pub scenario: ScenarioConfig,
    /// Rollout oracles run beside the methods on the same trials (`madenet oracle`): the
    /// ceiling a method is judged against (`noiseless`: knows the map, not the noise) and the
    /// part of a replay's gain that is luck (`placebo`). Reported in their own section of
    /// `report.md`, never ranked with the methods. `[]` runs none.
    pub oracles: Vec<OracleKind>,
    /// The base rule the oracles' continuations follow (a policy choosing among goal
    /// candidates); its own trials run too, listed among the methods or not.
    pub oracle_base: String,
    /// Futures per decision of the `placebo`, `averaged` and `redrawn` oracles (1–64).
    pub oracle_futures: usize,
    /// How the scoring oracles (replay, averaged, noiseless, redrawn) cut and value their continuations
    /// (`horizon`: steps, none by default; `value`: `steps-left` by default or
    /// `mean-discovery`; [`madenet_baselines::rollout::Value`]).
    pub oracle_lookahead: Lookahead,
    /// Parameters of the classical baselines.
    pub baselines: BaselineParams,
}

impl Default for StudyConfig {
    fn default() -> Self {
        StudyConfig {
            methods: [
                "nf",
                "ub",
                "pb",
                "spread",
                "made-net",
                "made-net-paper",
                "made-net-dt",
                "dme-drl",
            ]
            .map(String::from)
            .to_vec(),
            maps: vec!["paper".into()],
            starts: Corner::ALL.iter().map(|c| c.name().to_string()).collect(),
            csp: vec![0.0, 0.5, 0.8, 1.0],
            seeds: 5,
            seed_base: 1,
            scenario: ScenarioConfig::default(),
            oracles: vec![
                OracleKind::Placebo,
                OracleKind::Noiseless,
                OracleKind::KnownMap,
            ],
            oracle_base: "spread".into(),
            oracle_futures: 4,
            oracle_lookahead: Lookahead::default(),
            baselines: BaselineParams::default(),
        }
    }
}

/// A study that cannot start; the message names the file and field.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A file or folder cannot be read or written, or holds something unusable (a malformed
    /// config, no maps, another configuration's results).
    #[error("{path}: {message}")]
    File {
        /// The file or folder, as displayed.
        path: String,
        /// What went wrong with it.
        message: String,
    },
    /// A field of the configuration has a value the study cannot run.
    #[error("study field `{field}`: {message}")]
    Field {
        /// The field's name in the TOML file (`a/b` when it is about several fields).
        field: &'static str,
        /// Why the value is refused.
        message: String,
    },
    /// Any other failure: building the policies, loading a map, a trial that cannot start,
    /// drawing a figure, serializing.
    #[error("{0}")]
    Other(String),
}

pub(crate) fn field(field: &'static str, message: impl Into<String>) -> StudyError {
    StudyError::Field {
        field,
        message: message.into(),
    }
}

/// A map of the study, loaded.
#[derive(Clone, Debug)]
pub struct StudyMap {
    /// Name in outputs ([`MapSource::name`]: `test_N` for paper map N, a file's stem, …).
    pub name: String,
    /// The map, loaded at the scenario's cell size.
    pub grid: madenet_map::OccGrid,
    /// One of the paper's 10 evaluation maps (the embedded copy), which the calibration
    /// compares with the authors' results.
    pub paper: bool,
}

/// The method name of an oracle's trials in `trials.csv`.
pub fn oracle_method(kind: OracleKind) -> String {
    format!("oracle-{}", kind.name())
}

impl StudyConfig {
    /// Every policy whose own trials run: the methods, then the oracles' base rule if it is
    /// not one of them.
    pub fn policies_run(&self) -> Vec<String> {
        let mut v = self.methods.clone();
        if !self.oracles.is_empty() && !v.contains(&self.oracle_base) {
            v.push(self.oracle_base.clone());
        }
        v
    }

    /// Reads a TOML config (fields left out take their defaults); errors name the file,
    /// field and line.
    pub fn from_toml_file(path: &Path) -> Result<Self, StudyError> {
        read_toml(path)
    }

    /// The policy catalogue ([`madenet_catalogue::catalogue`]) with this config's baseline
    /// parameters.
    pub fn registry(&self) -> Result<PolicyRegistry, StudyError> {
        madenet_catalogue::catalogue(&self.baselines).map_err(|e| StudyError::Other(e.to_string()))
    }

    /// Checks everything that can be checked before a trial runs, and loads the maps.
    pub fn validate(
        &self,
        registry: &PolicyRegistry,
    ) -> Result<(Vec<StudyMap>, Vec<StartSpec>), StudyError> {
        if self.methods.is_empty() {
            return Err(field("methods", "is empty"));
        }
        let known = registry.names();
        for m in &self.methods {
            if !known.contains(m) {
                return Err(field(
                    "methods",
                    format!("unknown method `{m}`; known: {}", known.join(", ")),
                ));
            }
        }
        if let Some(d) = self
            .methods
            .iter()
            .enumerate()
            .find(|(i, m)| self.methods[..*i].contains(m))
        {
            return Err(field("methods", format!("`{}` is listed twice", d.1)));
        }
        if let Some(d) = self
            .oracles
            .iter()
            .enumerate()
            .find(|(i, o)| self.oracles[..*i].contains(o))
        {
            return Err(field(
                "oracles",
                format!("`{}` is listed twice", d.1.name()),
            ));
        }
        if !self.oracles.is_empty() {
            if !known.contains(&self.oracle_base) {
                return Err(field(
                    "oracle_base",
                    format!(
                        "unknown policy `{}`; known: {}",
                        self.oracle_base,
                        known.join(", ")
                    ),
                ));
            }
            if !(1..=64).contains(&self.oracle_futures) {
                return Err(field(
                    "oracle_futures",
                    format!("{} is not in 1..=64", self.oracle_futures),
                ));
            }
            if let Some(h) = self.oracle_lookahead.horizon {
                if !(1..=100_000).contains(&h) {
                    return Err(field(
                        "oracle_lookahead.horizon",
                        format!("{h} is not in 1..=100000"),
                    ));
                }
            }
        }
        if self.csp.is_empty() {
            return Err(field(
                "csp",
                "is empty: list at least one communication success probability",
            ));
        }
        for &c in &self.csp {
            if !(0.0..=1.0).contains(&c) {
                return Err(field("csp", format!("{c} is not a probability")));
            }
        }
        for (i, &c) in self.csp.iter().enumerate() {
            if self.csp[..i].contains(&c) {
                return Err(field("csp", format!("{c} is listed twice")));
            }
        }
        if self.seeds == 0 {
            return Err(field("seeds", "must be at least 1"));
        }
        if self.seed_base.checked_add(self.seeds - 1).is_none() {
            return Err(field(
                "seed_base",
                format!(
                    "{} + {} seeds runs past the largest seed, {}",
                    self.seed_base,
                    self.seeds,
                    u64::MAX
                ),
            ));
        }
        self.scenario
            .validate()
            .map_err(|e| field("scenario", e.to_string()))?;
        self.baselines
            .validate()
            .map_err(|e| field("baselines", e))?;
        let maps = self.load_maps()?;
        if self.starts.is_empty() {
            return Err(field("starts", "is empty"));
        }
        let starts = self
            .starts
            .iter()
            .map(|s| s.parse::<StartSpec>().map_err(|e| field("starts", e)))
            .collect::<Result<Vec<_>, _>>()?;
        for (i, s) in starts.iter().enumerate() {
            if let Some(j) = starts[..i].iter().position(|t| t.name() == s.name()) {
                return Err(field(
                    "starts",
                    format!(
                        "`{}` and `{}` are the same start ({})",
                        self.starts[j],
                        self.starts[i],
                        s.name()
                    ),
                ));
            }
            s.check_team(self.scenario.num_robots)
                .map_err(|e| field("starts", e))?;
        }
        for map in &maps {
            if starts.contains(&StartSpec::Random)
                && StartSpec::Random
                    .cells(&map.grid, self.scenario.num_robots, self.scenario.movement)
                    .is_empty()
            {
                return Err(field("starts", format!("`random`: map {} has no {} connected free cells around any cell drawn from it", map.name, self.scenario.num_robots)));
            }
        }
        madenet_sim::check_trial_set_size(
            (self.policies_run().len() + self.oracles.len()) as u64,
            &maps
                .iter()
                .map(|m| m.grid.cells().len() as u64)
                .collect::<Vec<_>>(),
            starts.len() as u64,
            self.csp.len() as u64,
            self.seeds,
        )
        .map_err(|e| field("seeds", e))?;
        // Learned models run only on the map and team sizes they were trained for.
        for m in &self.policies_run() {
            for map in &maps {
                let ctx = madenet_sim::PolicyContext {
                    seed: 0,
                    robot: 0,
                    config: &self.scenario,
                    height: map.grid.height(),
                    width: map.grid.width(),
                };
                registry
                    .check(m, &ctx)
                    .map_err(|e| field("methods", format!("{e} (map {})", map.name)))?;
            }
        }
        if let (Some(map), Some(start)) = (maps.first(), starts.first()) {
            if !self.oracles.is_empty() {
                let spec = madenet_sim::TrialSpec {
                    map: map.grid.clone(),
                    map_name: map.name.clone(),
                    starts: start.cells(
                        &map.grid,
                        self.scenario.num_robots,
                        self.scenario.movement,
                    ),
                    config: self.scenario.clone(),
                    policy: self.oracle_base.clone(),
                    seed: self.seed_base,
                };
                madenet_baselines::rollout::check_base(&spec, registry)
                    .map_err(|e| field("oracle_base", e))?;
            }
        }
        Ok((maps, starts))
    }

    fn load_maps(&self) -> Result<Vec<StudyMap>, StudyError> {
        if self.maps.is_empty() {
            return Err(field("maps", "is empty"));
        }
        let mut out = Vec::new();
        for m in &self.maps {
            let sources: Vec<MapSource> = if m == "paper" {
                (1..=PAPER_MAP_COUNT).map(MapSource::Paper).collect()
            } else if !m.contains(':') && Path::new(m).is_dir() {
                let mut files: Vec<PathBuf> = std::fs::read_dir(m)
                    .map_err(|e| StudyError::File {
                        path: m.clone(),
                        message: e.to_string(),
                    })?
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| p.extension().is_some_and(|x| x == "yaml" || x == "yml"))
                    .collect();
                files.sort();
                if files.is_empty() {
                    return Err(StudyError::File {
                        path: m.clone(),
                        message: "folder holds no .yaml maps (field `maps`)".into(),
                    });
                }
                files.into_iter().map(MapSource::File).collect()
            } else {
                let src = m.parse::<MapSource>().map_err(|e| field("maps", e))?;
                if let MapSource::File(p) = &src {
                    if !p.exists() {
                        return Err(StudyError::File {
                            path: p.display().to_string(),
                            message: "no such map file or folder (field `maps`)".into(),
                        });
                    }
                }
                vec![src]
            };
            for src in sources {
                let grid = src
                    .load(&self.scenario)
                    .map_err(|e| StudyError::Other(format!("{e} (field `maps`)")))?;
                let name = src.name();
                if out.iter().any(|x: &StudyMap| x.name == name) {
                    return Err(field("maps", format!("two maps are named `{name}`")));
                }
                let paper = matches!(src, MapSource::Paper(_));
                out.push(StudyMap { name, grid, paper });
            }
        }
        Ok(out)
    }
}

/// Reads a study's TOML file ([`madenet_files::read_toml`]: the file, field and line).
pub(crate) fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, StudyError> {
    madenet_files::read_toml(path).map_err(|e| StudyError::File {
        path: e.path,
        message: e.message,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The documented example in `configs/study.toml` lists exactly the defaults.
    #[test]
    fn shipped_example_equals_defaults() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../configs/study.toml");
        assert_eq!(
            StudyConfig::from_toml_file(&path).expect("parses"),
            StudyConfig::default()
        );
    }
}
