//! `madenet._core`: the compiled core of madenet's Python package. A thin pyo3 layer over
//! [`madenet_env::ExplorationEnv`]; the Python package (`python/madenet`) builds the PettingZoo
//! and Gymnasium environments on it. Errors become `ValueError`s naming the field.

use madenet_env::{ActionMode, ExplorationEnv, StepResult};
use madenet_sim::{MapSource, StartSpec};
use madenet_world::ScenarioConfig;
use numpy::{PyArray1, PyArray3, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::str::FromStr;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The scenario: `config` (a TOML file, optional) with `overrides` (TOML text of top-level
/// keys) on top; every field checked.
fn scenario(config: Option<&str>, overrides: &str) -> PyResult<ScenarioConfig> {
    let mut table = match config {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| value_error(format!("{path}: {e}")))?;
            text.parse::<toml::Table>().map_err(|e| value_error(format!("{path}: {}", e.message())))?
        }
        None => toml::Table::new(),
    };
    let extra = overrides.parse::<toml::Table>().map_err(|e| value_error(format!("keyword arguments: {}", e.message())))?;
    table.extend(extra);
    let text = toml::to_string(&table).map_err(value_error)?;
    ScenarioConfig::from_toml_str(&text).map_err(|e| value_error(format!("{}: {e}", config.unwrap_or("scenario"))))
}

/// One environment (see `madenet_env`): `map` is `paper:N`, `generate:SEED` or a map file,
/// `start` a corner name or `r,c;r,c;…`, `mode` `macro` or `primitive`.
#[pyclass(module = "madenet._core", unsendable)]
pub struct CoreEnv {
    env: ExplorationEnv,
    map_name: String,
}

#[pymethods]
impl CoreEnv {
    #[new]
    #[pyo3(signature = (map = "paper:1", start = "top-left", mode = "macro", config = None, overrides = ""))]
    fn new(map: &str, start: &str, mode: &str, config: Option<&str>, overrides: &str) -> PyResult<Self> {
        let scenario = scenario(config, overrides)?;
        let source = MapSource::from_str(map).map_err(|e| value_error(format!("map: {e}")))?;
        let grid = source.load(&scenario).map_err(|e| value_error(format!("map: {e}")))?;
        let starts = StartSpec::from_str(start).map_err(|e| value_error(format!("start: {e}")))?.cells(grid.height(), grid.width());
        let mode = match mode {
            "macro" => ActionMode::Macro,
            "primitive" => ActionMode::Primitive,
            other => return Err(value_error(format!("mode: `{other}` (expected `macro` or `primitive`)"))),
        };
        let name = source.name();
        let env = ExplorationEnv::new(grid, &name, starts, scenario, mode).map_err(value_error)?;
        Ok(CoreEnv { env, map_name: name })
    }

    #[getter]
    fn num_robots(&self) -> usize {
        self.env.num_robots()
    }
    #[getter]
    fn height(&self) -> usize {
        self.env.height()
    }
    #[getter]
    fn width(&self) -> usize {
        self.env.width()
    }
    #[getter]
    fn action_count(&self) -> usize {
        self.env.action_count()
    }
    #[getter]
    fn vector_len(&self) -> usize {
        self.env.vector_len()
    }
    #[getter]
    fn map_name(&self) -> String {
        self.map_name.clone()
    }
    #[getter]
    fn t(&self) -> usize {
        self.env.t()
    }
    #[getter]
    fn done(&self) -> bool {
        self.env.is_done()
    }

    /// Starts an episode (the seed drives the world's noise and dropouts).
    fn reset(&mut self, seed: u64) -> PyResult<()> {
        self.env.reset(seed).map_err(value_error)
    }

    /// Which robots' actions the next step uses.
    fn needs_action(&self) -> Vec<bool> {
        self.env.needs_action()
    }

    /// Robot `robot`'s observation: map image `[4, H, W]` float32, vector float32, mask int8.
    #[allow(clippy::type_complexity)]
    fn observe<'py>(&mut self, py: Python<'py>, robot: usize) -> PyResult<(Bound<'py, PyArray3<f32>>, Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<i8>>)> {
        let (h, w) = (self.env.height(), self.env.width());
        let mut map = vec![0.0f32; self.env.map_len()];
        let mut vector = vec![0.0f32; self.env.vector_len()];
        let mut mask = vec![0u8; self.env.action_count()];
        self.env.observe_into(robot, &mut map, &mut vector, &mut mask).map_err(value_error)?;
        let map = PyArray1::from_vec(py, map).reshape([4, h, w])?;
        let mask: Vec<i8> = mask.into_iter().map(|m| m as i8).collect();
        Ok((map, PyArray1::from_vec(py, vector), PyArray1::from_vec(py, mask)))
    }

    /// Applies one action per robot; returns (rewards, team reward, timesteps, terminated, truncated).
    fn step(&mut self, py: Python<'_>, actions: Vec<i64>) -> PyResult<(Vec<f64>, f64, usize, bool, bool)> {
        let count = self.env.action_count();
        let actions: Vec<usize> = actions
            .into_iter()
            .map(|a| usize::try_from(a).ok().filter(|&a| a < count).ok_or_else(|| value_error(format!("action {a}: expected 0..{count}"))))
            .collect::<PyResult<_>>()?;
        let env = &mut self.env;
        let r: StepResult = py.detach(|| env.step(&actions)).map_err(value_error)?;
        Ok((r.rewards, r.team_reward, r.steps, r.terminated, r.truncated))
    }

    /// The finished (or current) trial's metrics as a dict: TNS, TTD, NOLI, OFV, explored, completed.
    fn metrics<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let result = self.env.finish().ok_or_else(|| value_error("no episode: call reset() first"))?;
        let m = &result.metrics;
        let d = pyo3::types::PyDict::new(py);
        d.set_item("tns", m.tns)?;
        d.set_item("ttd", m.ttd)?;
        d.set_item("noli", m.noli)?;
        d.set_item("ofv", m.ofv)?;
        d.set_item("explored", m.explored)?;
        d.set_item("completed", m.completed)?;
        Ok(d)
    }
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<CoreEnv>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
