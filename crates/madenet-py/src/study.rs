//! `CoreStudy`: the comparison study (`madenet compare`) planned once, its trials run in any
//! subset — all of them here, or batches in Ray workers — with the same result per trial.

use crate::value_error;
use madenet_metrics::COVERAGE_LEVELS;
use madenet_sim::PolicyRegistry;
use madenet_study::runner::{self, TrialOutcome};
use madenet_study::StudyConfig;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A validated study: its configuration, policies and planned trials.
#[pyclass(module = "madenet._core", unsendable)]
pub struct CoreStudy {
    config: StudyConfig,
    registry: PolicyRegistry,
    planned: Vec<runner::Planned>,
}

/// `config` (a study TOML file, optional) with `overrides` (a JSON object of top-level fields)
/// on top, parsed with the study's own field checks.
fn study_config(config: Option<&str>, overrides_json: &str) -> PyResult<StudyConfig> {
    let mut table = match config {
        Some(path) => {
            let text = madenet_files::read_text_capped(
                std::path::Path::new(path),
                madenet_files::InputKind::Config,
            )
            .map_err(|e| value_error(format!("{path}: {e}")))?;
            text.parse::<toml::Table>()
                .map_err(|e| value_error(format!("{path}: {}", e.message())))?
        }
        None => toml::Table::new(),
    };
    let extra: serde_json::Value = serde_json::from_str(overrides_json)
        .map_err(|e| value_error(format!("keyword arguments: {e}")))?;
    let extra: toml::Table =
        toml::Table::try_from(extra).map_err(|e| value_error(format!("keyword arguments: {e}")))?;
    table.extend(extra);
    let text = toml::to_string(&table).map_err(value_error)?;
    madenet_files::parse_toml(&text)
        .map_err(|message| value_error(format!("{}: {message}", config.unwrap_or("study"))))
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
    Ok(d)
}

#[pymethods]
impl CoreStudy {
    #[new]
    #[pyo3(signature = (config = None, overrides = "{}"))]
    fn new(config: Option<&str>, overrides: &str) -> PyResult<Self> {
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
        Self::build(config)
    }

    /// The study from the TOML text `toml_text()` returned (how Ray workers rebuild it).
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<Self> {
        Self::build(
            madenet_files::parse_toml(text)
                .map_err(|message| value_error(format!("study: {message}")))?,
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

    /// The columns of `trials.csv`, in order.
    #[staticmethod]
    fn columns() -> Vec<String> {
        runner::header()
    }

    /// Runs the planned trials `indices` (all if `None`) on `threads` threads (all cores if
    /// `None`) with the GIL released; returns one dict per trial (the columns of
    /// `trials.csv`), in the order of `indices`.
    #[pyo3(signature = (indices = None, threads = None))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        indices: Option<Vec<usize>>,
        threads: Option<usize>,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let indices = indices.unwrap_or_else(|| (0..self.planned.len()).collect());
        if let Some(&bad) = indices.iter().find(|&&i| i >= self.planned.len()) {
            return Err(value_error(format!(
                "indices: {bad} is not a trial of this study ({} planned)",
                self.planned.len()
            )));
        }
        let mut pool = rayon::ThreadPoolBuilder::new();
        if let Some(t) = threads {
            pool = pool.num_threads(t.max(1));
        }
        let pool = pool.build().map_err(value_error)?;
        let (planned, registry) = (&self.planned, &self.registry);
        let outcomes: Result<Vec<TrialOutcome>, _> = py.detach(|| {
            use rayon::prelude::*;
            pool.install(|| {
                indices
                    .par_iter()
                    .map(|&i| runner::run_one(&planned[i], registry))
                    .collect()
            })
        });
        outcomes
            .map_err(value_error)?
            .iter()
            .map(|o| outcome_dict(py, o))
            .collect()
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
    fn build(config: StudyConfig) -> PyResult<Self> {
        let registry = config.registry().map_err(value_error)?;
        let (maps, starts) = config.validate(&registry).map_err(value_error)?;
        let planned = runner::plan(&config, &maps, &starts);
        Ok(CoreStudy {
            config,
            registry,
            planned,
        })
    }
}
