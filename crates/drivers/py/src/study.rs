//! `CoreStudy`: the comparison study (`madenet compare`) planned once, its trials run in any
//! subset — all of them here, or batches in Ray workers — with the same result per trial.
//! `CoreScale`: the scalability study (`madenet scale`, grid or continuous world) the same way.

use crate::{config_table, value_error};
use madenet_metrics::COVERAGE_LEVELS;
use madenet_sim::PolicyRegistry;
use madenet_study::runner::{self, TrialOutcome};
use madenet_study::scale::ScalePlanned;
use madenet_study::{ScaleConfig, ScaleWorld, StudyConfig};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A validated study: its configuration, policies and planned trials.
#[pyclass(module = "madenet._core", unsendable)]
pub struct CoreStudy {
    config: StudyConfig,
    registry: PolicyRegistry,
    planned: Vec<runner::Planned>,
    /// The TOML file it was read from, if any: `run_to` never writes over it.
    source: Option<std::path::PathBuf>,
}

/// `config` (a study TOML file, optional) with `overrides` (a JSON object of top-level fields)
/// on top, parsed with the study's own field checks.
fn study_config(config: Option<&str>, overrides_json: &str) -> PyResult<StudyConfig> {
    config_with(config, None, overrides_json, "study")
}

/// `config` (a TOML file; `None`: `defaults`, or every field's default) with `overrides` (a
/// JSON object of top-level fields) on top, parsed into `T` with its own field checks.
fn config_with<T: serde::de::DeserializeOwned>(
    config: Option<&str>,
    defaults: Option<toml::Table>,
    overrides_json: &str,
    what: &str,
) -> PyResult<T> {
    let mut table = config_table(config)?.or(defaults).unwrap_or_default();
    let extra: serde_json::Value = serde_json::from_str(overrides_json)
        .map_err(|e| value_error(format!("keyword arguments: {e}")))?;
    let extra: toml::Table =
        toml::Table::try_from(extra).map_err(|e| value_error(format!("keyword arguments: {e}")))?;
    table.extend(extra);
    let text = toml::to_string(&table).map_err(value_error)?;
    madenet_files::parse_toml(&text)
        .map_err(|message| value_error(format!("{}: {message}", config.unwrap_or(what))))
}

fn outcome_dict<'py>(py: Python<'py>, o: &TrialOutcome) -> PyResult<Bound<'py, PyDict>> {
    let (r, k) = (&o.row, &o.row.key);
    let d = PyDict::new(py);
    d.set_item("method", &k.method)?;
    d.set_item("map", &k.map)?;
    d.set_item("start", &k.start)?;
    d.set_item("csp", k.csp.parse::<f64>().map_err(value_error)?)?;
    d.set_item("seed", k.seed)?;
    d.set_item("completed", r.completed)?;
    d.set_item("tns", r.tns)?;
    d.set_item("ttd_m", r.ttd)?;
    d.set_item("noli", r.noli)?;
    d.set_item("noli_authors", r.noli_authors)?;
    d.set_item("ofv", r.ofv)?;
    d.set_item("explored", r.explored)?;
    d.set_item("trial_s", r.trial_s)?;
    d.set_item("decisions", r.decisions)?;
    d.set_item("per_decision_s", r.per_decision_s)?;
    for (level, s) in COVERAGE_LEVELS.iter().zip(&r.steps_to) {
        // -1: that coverage was never reached (an empty cell in trials.csv).
        d.set_item(format!("to_{level}"), s.map_or(-1, |v| v as i64))?;
    }
    if let Some(c) = &r.continuous {
        d.set_item("et_s", c.et_s)?;
        d.set_item("obstacle_collisions", c.obstacle_collisions)?;
        d.set_item("robot_collisions", c.robot_collisions)?;
        d.set_item("impassable_cells", c.impassable_cells)?;
        d.set_item("stuck", c.stuck)?;
        d.set_item("written_off_cells", c.written_off_cells)?;
        d.set_item("unread_cells", c.unread_cells)?;
        d.set_item("explorable_cells", c.explorable_cells)?;
    }
    Ok(d)
}

/// Runs `indices` of `planned` on `threads` threads (all cores if `None`) with the GIL
/// released; outcomes in the order of `indices`.
fn run_indices(
    py: Python<'_>,
    planned: &[&runner::Planned],
    registry: &PolicyRegistry,
    indices: Option<Vec<usize>>,
    threads: Option<usize>,
) -> PyResult<(Vec<usize>, Vec<TrialOutcome>)> {
    let indices = indices.unwrap_or_else(|| (0..planned.len()).collect());
    if let Some(&bad) = indices.iter().find(|&&i| i >= planned.len()) {
        return Err(value_error(format!(
            "indices: {bad} is not a trial of this study ({} planned)",
            planned.len()
        )));
    }
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        pool = pool.num_threads(t.max(1));
    }
    let pool = pool.build().map_err(value_error)?;
    let outcomes: Result<Vec<TrialOutcome>, _> = py.detach(|| {
        use rayon::prelude::*;
        pool.install(|| {
            indices
                .par_iter()
                .map(|&i| runner::run_one(planned[i], registry))
                .collect()
        })
    });
    Ok((indices, outcomes.map_err(value_error)?))
}

/// The `#[pymethods]` of a planned study class (fields `config`, `registry`, `planned`; built
/// by `build` from a configuration, its trials listed by `trials`, the map side and team size
/// leading a row, if any, from `side_team`): what the two share — rebuilding it from the TOML
/// text of its configuration (errors naming `$what`), that text, the number of planned
/// trials, running a subset of them (documented at the class) — then the class's own methods.
macro_rules! study_pymethods {
    (
        $class:ident($what:literal) {
            $(#[$run:meta])* run;
        }
        $($own:tt)*
    ) => {
        #[pymethods]
        impl $class {
            /// The study from the TOML text `toml_text()` returned (how Ray workers rebuild it).
            #[staticmethod]
            fn from_toml(text: &str) -> PyResult<Self> {
                Self::build(
                    madenet_files::parse_toml(text)
                        .map_err(|message| value_error(format!("{}: {message}", $what)))?,
                )
            }

            /// The full configuration as TOML (every field, defaults included).
            fn toml_text(&self) -> PyResult<String> {
                toml::to_string(&self.config).map_err(value_error)
            }

            /// Number of planned trials.
            fn __len__(&self) -> usize {
                self.planned.len()
            }

            $(#[$run])*
            #[pyo3(signature = (indices = None, threads = None))]
            fn run<'py>(
                &self,
                py: Python<'py>,
                indices: Option<Vec<usize>>,
                threads: Option<usize>,
            ) -> PyResult<Vec<Bound<'py, PyDict>>> {
                let trials = self.trials();
                let (indices, outcomes) =
                    run_indices(py, &trials, &self.registry, indices, threads)?;
                indices
                    .iter()
                    .zip(&outcomes)
                    .map(|(&i, o)| {
                        let d = outcome_dict(py, o)?;
                        if let Some((side, team)) = self.side_team(i) {
                            d.set_item("side", side)?;
                            d.set_item("team", team)?;
                        }
                        Ok(d)
                    })
                    .collect()
            }

            $($own)*
        }
    };
}

study_pymethods! {
    CoreStudy("study") {
        /// Runs the planned trials `indices` (all if `None`) on `threads` threads (all cores if
        /// `None`) with the GIL released; returns one dict per trial (the columns of
        /// `trials.csv`), in the order of `indices`.
        run;
    }

    #[new]
    #[pyo3(signature = (config = None, overrides = "{}"))]
    fn new(config: Option<&str>, overrides: &str) -> PyResult<Self> {
        let config_path = config;
        let mut config = study_config(config, overrides)?;
        // Map files by absolute path, so that the study means the same in a worker elsewhere.
        for m in config
            .maps
            .iter_mut()
            .filter(|m| *m != "paper" && !m.starts_with("paper:") && !m.starts_with("generate:"))
        {
            if let Ok(abs) = std::fs::canonicalize(&*m) {
                *m = abs.display().to_string();
            }
        }
        let mut study = Self::build(config)?;
        study.source = config_path.map(std::path::PathBuf::from);
        Ok(study)
    }

    /// The columns of `trials.csv`, in order.
    #[staticmethod]
    fn columns() -> Vec<String> {
        runner::header()
    }

    /// Runs the whole study into folder `out` exactly as `madenet compare --out OUT` does
    /// (trials.csv, curves, summary, statistics, figures, report.md; resumable); returns the
    /// path of report.md and one dict per trial.
    #[pyo3(signature = (out, fresh = false))]
    fn run_to<'py>(
        &self,
        py: Python<'py>,
        out: std::path::PathBuf,
        fresh: bool,
    ) -> PyResult<(String, Vec<Bound<'py, PyDict>>)> {
        let cfg = &self.config;
        // As `madenet compare`: the folder's saved configuration never replaces the file the
        // study was read from.
        if let Some(source) = &self.source {
            let saved = out.join("study.toml");
            madenet_files::check_outputs(&[("out", &saved)], &[("config", source)])
                .map_err(value_error)?;
        }
        let (report, outcomes) = py
            .detach(|| madenet_study::run_study(cfg, &out, fresh, &|_, _| {}))
            .map_err(value_error)?;
        Ok((
            report.display().to_string(),
            outcomes
                .iter()
                .map(|o| outcome_dict(py, o))
                .collect::<PyResult<_>>()?,
        ))
    }
}

impl CoreStudy {
    /// The planned trials, in plan order.
    fn trials(&self) -> Vec<&runner::Planned> {
        self.planned.iter().collect()
    }

    /// A comparison trial's row has no map side and team size.
    fn side_team(&self, _i: usize) -> Option<(usize, usize)> {
        None
    }

    fn build(config: StudyConfig) -> PyResult<Self> {
        let registry = config.registry().map_err(value_error)?;
        let (maps, starts) = config.validate(&registry).map_err(value_error)?;
        let planned = runner::plan(&config, &maps, &starts);
        Ok(CoreStudy {
            config,
            registry,
            planned,
            source: None,
        })
    }
}

/// A validated scalability study (`madenet scale`): its configuration, policies and planned
/// trials (side × team × start × method × seed, on generated maps or cluttered scenes).
#[pyclass(module = "madenet._core", unsendable)]
pub struct CoreScale {
    config: ScaleConfig,
    registry: PolicyRegistry,
    planned: Vec<ScalePlanned>,
}

study_pymethods! {
    CoreScale("scale") {
        /// Runs the planned trials `indices` (all if `None`) on `threads` threads (all cores if
        /// `None`) with the GIL released; one dict per trial in the order of `indices`: its map
        /// side and team size, then the columns of the study's `trials.csv`. Only the trials
        /// themselves: the grid twin of a continuous study and the report are `madenet scale`'s.
        run;
    }

    /// `config` (a scale TOML file, optional) with `overrides` (JSON of top-level fields) on
    /// top. Without a file, `world = "continuous"` starts from the continuous study's
    /// defaults, as `madenet scale --world continuous` does.
    #[new]
    #[pyo3(signature = (config = None, overrides = "{}"))]
    fn new(config: Option<&str>, overrides: &str) -> PyResult<Self> {
        let continuous = serde_json::from_str::<serde_json::Value>(overrides)
            .ok()
            .and_then(|v| v.get("world").cloned())
            == Some(serde_json::Value::from("continuous"));
        let defaults = match (config, continuous) {
            (None, true) => Some(
                toml::Table::try_from(ScaleConfig::continuous_default()).map_err(value_error)?,
            ),
            _ => None,
        };
        Self::build(config_with(config, defaults, overrides, "scale")?)
    }

    /// The columns of its rows, in order: `side`, `team`, then those of `trials.csv`.
    fn columns(&self) -> Vec<String> {
        let mut c = vec!["side".to_string(), "team".to_string()];
        c.extend(match self.config.world {
            ScaleWorld::Grid => runner::header(),
            ScaleWorld::Continuous => runner::continuous_header(),
        });
        c
    }
}

impl CoreScale {
    /// The planned trials, in plan order.
    fn trials(&self) -> Vec<&runner::Planned> {
        self.planned.iter().map(|p| &p.planned).collect()
    }

    /// The map side and team size of planned trial `i`, the first columns of its row.
    fn side_team(&self, i: usize) -> Option<(usize, usize)> {
        Some((self.planned[i].side, self.planned[i].team))
    }

    fn build(config: ScaleConfig) -> PyResult<Self> {
        let registry = madenet_catalogue::catalogue(&config.baselines).map_err(value_error)?;
        config.validate(&registry).map_err(value_error)?;
        let planned = config.plan().map_err(value_error)?;
        Ok(CoreScale {
            config,
            registry,
            planned,
        })
    }
}
