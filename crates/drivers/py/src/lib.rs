//! `madenet._core`: the compiled core of madenet's Python package. A thin pyo3 layer over
//! [`madenet_env`] (environments, one or N at a time), the shipped policies
//! ([`madenet_catalogue::shipped`]) and the study runner; the Python package
//! (`python/madenet`) builds the PettingZoo and Gymnasium environments, `run_trial`, `compare`
//! and `madenet.ray` (studies, and the rollout learner's episodes) on it. Every error becomes a `ValueError` naming the field; long calls
//! release the GIL.

#![deny(missing_docs)]

/// The `#[pymethods]` of an environment class over its `env` and `map_name` fields, an
/// [`ExplorationEnv`] (`CoreEnv`) or a [`madenet_env::ContinuousEnv`] (`CoreContinuousEnv`):
/// the class's own methods, then the accessors and calls the two share — team size, rows,
/// columns, actions per robot, vector length, map name, whether the episode ended, the robots
/// awaiting actions, one robot's observation, the episode's result. Where what they mean
/// differs between the worlds, the doc comments after the class's methods are theirs.
macro_rules! env_pymethods {
    (
        $class:ident { $($own:tt)* }
        $(#[$height:meta])* height;
        $(#[$width:meta])* width;
        $(#[$action_count:meta])* action_count;
        $(#[$done:meta])* done;
        $(#[$finish:meta])* finish;
    ) => {
        #[::pyo3::pymethods]
        impl $class {
            /// Team size |I|.
            #[getter]
            fn num_robots(&self) -> usize {
                self.env.num_robots()
            }
            $(#[$height])*
            #[getter]
            fn height(&self) -> usize {
                self.env.height()
            }
            $(#[$width])*
            #[getter]
            fn width(&self) -> usize {
                self.env.width()
            }
            $(#[$action_count])*
            #[getter]
            fn action_count(&self) -> usize {
                self.env.action_count()
            }
            /// Length of one robot's observation vector.
            #[getter]
            fn vector_len(&self) -> usize {
                self.env.vector_len()
            }
            /// Name of the map in outputs (e.g. `test_1` for `paper:1`).
            #[getter]
            fn map_name(&self) -> String {
                self.map_name.clone()
            }
            $(#[$done])*
            #[getter]
            fn done(&self) -> bool {
                self.env.is_done()
            }

            /// Which robots' actions the next step uses.
            fn needs_action(&self) -> Vec<bool> {
                self.env.needs_action()
            }

            /// Robot `robot`'s observation: map image `[4, H, W]` float32, vector float32, mask int8.
            fn observe<'py>(
                &mut self,
                py: ::pyo3::Python<'py>,
                robot: usize,
            ) -> ::pyo3::PyResult<$crate::Observation<'py>> {
                let (h, w) = (self.env.height(), self.env.width());
                let mut map = vec![0.0f32; self.env.map_len()];
                let mut vector = vec![0.0f32; self.env.vector_len()];
                let mut mask = vec![0u8; self.env.action_count()];
                self.env
                    .observe_into(robot, &mut map, &mut vector, &mut mask)
                    .map_err($crate::value_error)?;
                $crate::observation(py, (h, w), map, vector, mask)
            }

            $(#[$finish])*
            fn finish(&mut self) -> ::pyo3::PyResult<String> {
                let result = self
                    .env
                    .finish()
                    .ok_or_else(|| $crate::value_error("no episode: call reset() first"))?;
                serde_json::to_string(&result).map_err($crate::value_error)
            }

            $($own)*
        }
    };
}

mod continuous;
mod study;
mod train;
mod vector;

use madenet_agent::Decision;
use madenet_env::{ActionMode, ExplorationEnv, StepResult};
use madenet_map::{OccGrid, Pos};
use madenet_sim::{MapSource, PolicyRegistry, StartSpec, Trial, TrialSpec};
use madenet_world::ScenarioConfig;
use numpy::{PyArray1, PyArray3, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use std::str::FromStr;
use std::sync::OnceLock;

pub(crate) fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The TOML file `config` as a table (`None` without one), errors naming the path.
pub(crate) fn config_table(config: Option<&str>) -> PyResult<Option<toml::Table>> {
    let Some(path) = config else {
        return Ok(None);
    };
    let text = madenet_files::read_text_capped(
        std::path::Path::new(path),
        madenet_files::InputKind::Config,
    )
    .map_err(|e| value_error(format!("{path}: {e}")))?;
    text.parse::<toml::Table>()
        .map(Some)
        .map_err(|e| value_error(format!("{path}: {}", e.message())))
}

/// The scenario: `config` (a TOML file, optional) with `overrides` (TOML text of top-level
/// keys) on top; every field checked.
pub(crate) fn scenario(config: Option<&str>, overrides: &str) -> PyResult<ScenarioConfig> {
    let mut table = config_table(config)?.unwrap_or_default();
    let extra = overrides
        .parse::<toml::Table>()
        .map_err(|e| value_error(format!("keyword arguments: {}", e.message())))?;
    table.extend(extra);
    let text = toml::to_string(&table).map_err(value_error)?;
    ScenarioConfig::from_toml_str(&text)
        .map_err(|e| value_error(format!("{}: {e}", config.unwrap_or("scenario"))))
}

/// Map, start cells and scenario from the Python arguments.
pub(crate) fn setup(
    map: &str,
    start: &str,
    config: Option<&str>,
    overrides: &str,
) -> PyResult<(OccGrid, String, Vec<Pos>, ScenarioConfig)> {
    let scenario = scenario(config, overrides)?;
    let source = MapSource::from_str(map).map_err(|e| value_error(format!("map: {e}")))?;
    let grid = source
        .load(&scenario)
        .map_err(|e| value_error(format!("map: {e}")))?;
    let starts = StartSpec::from_str(start)
        .map_err(|e| value_error(format!("start: {e}")))?
        .cells(&grid, scenario.num_robots, scenario.movement);
    if starts.is_empty() {
        return Err(value_error(format!(
            "start: `random`: map {} has no {} connected free cells around the cell drawn from it",
            source.name(),
            scenario.num_robots
        )));
    }
    Ok((grid, source.name(), starts, scenario))
}

/// The environment the Python arguments describe ([`setup`], [`action_mode`]), and its map's
/// name.
pub(crate) fn exploration_env(
    map: &str,
    start: &str,
    mode: &str,
    config: Option<&str>,
    overrides: &str,
    candidates: bool,
) -> PyResult<(ExplorationEnv, String)> {
    let (grid, name, starts, scenario) = setup(map, start, config, overrides)?;
    let env = ExplorationEnv::new(grid, &name, starts, scenario, action_mode(mode)?)
        .map_err(value_error)?
        .observing_candidates(candidates);
    Ok((env, name))
}

pub(crate) fn action_mode(mode: &str) -> PyResult<ActionMode> {
    match mode {
        "macro" => Ok(ActionMode::Macro),
        "primitive" => Ok(ActionMode::Primitive),
        other => Err(value_error(format!(
            "mode: `{other}` (expected `macro` or `primitive`)"
        ))),
    }
}

/// Every shipped policy (built-ins, the classical baselines, the learned models), built once.
pub(crate) fn registry() -> PyResult<&'static PolicyRegistry> {
    static REGISTRY: OnceLock<Result<PolicyRegistry, String>> = OnceLock::new();
    REGISTRY
        .get_or_init(|| madenet_catalogue::shipped().map_err(|e| e.to_string()))
        .as_ref()
        .map_err(value_error)
}

/// The shipped policies: (name, description) pairs.
#[pyfunction]
fn policies() -> PyResult<Vec<(String, String)>> {
    Ok(registry()?.describe())
}

/// One trial, as `madenet run --json [--trajectory]` prints it (a JSON string).
#[pyfunction]
#[pyo3(signature = (map, start, policy, seed, config = None, overrides = "", trajectory = false))]
#[allow(clippy::too_many_arguments)]
fn run_trial(
    py: Python<'_>,
    map: &str,
    start: &str,
    policy: &str,
    seed: u64,
    config: Option<&str>,
    overrides: &str,
    trajectory: bool,
) -> PyResult<String> {
    let (grid, map_name, starts, scenario) = setup(map, start, config, overrides)?;
    let registry = registry()?;
    let spec = TrialSpec {
        map: grid,
        map_name,
        starts,
        config: scenario,
        policy: policy.to_string(),
        seed,
    };
    let trial = Trial::with_registry(spec, registry)
        .map_err(|e| value_error(format!("policy / map / start: {e}")))?;
    let result = py.detach(|| trial.record_trajectory(trajectory).run());
    serde_json::to_string(&result).map_err(value_error)
}

/// One action from Python: an int (candidate / move index), `None` (idle) or `(row, col)` (go
/// to that cell).
fn decision(obj: &Bound<'_, PyAny>) -> PyResult<Decision> {
    if obj.is_none() {
        return Ok(Decision::Idle);
    }
    if let Ok(t) = obj.cast::<PyTuple>() {
        let (r, c): (i32, i32) = t
            .extract()
            .map_err(|_| value_error("a goal action is a (row, col) pair of ints"))?;
        return Ok(Decision::Goal(Pos::new(r, c)));
    }
    let k: i64 = obj.extract().map_err(|_| {
        value_error(format!(
            "action {obj}: expected an int, None or a (row, col) goal"
        ))
    })?;
    usize::try_from(k)
        .map(Decision::Candidate)
        .map_err(|_| value_error(format!("action {k}: negative")))
}

fn decision_to_py(py: Python<'_>, d: Decision) -> PyResult<Py<PyAny>> {
    Ok(match d {
        Decision::Candidate(k) => k.into_pyobject(py)?.into_any().unbind(),
        Decision::Goal(p) => (p.row, p.col).into_pyobject(py)?.into_any().unbind(),
        Decision::Idle => py.None(),
    })
}

/// Largest picture scale: 20 × 20 maps at 64 px per cell are ≈ 2.6 k pixels wide already.
const MAX_CELL_PX: u32 = 64;

type Observation<'py> = (
    Bound<'py, PyArray3<f32>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<i8>>,
);

/// An observation's buffers as numpy arrays: the map image `[4, H, W]`, the vector, the mask
/// (int8).
fn observation<'py>(
    py: Python<'py>,
    (h, w): (usize, usize),
    map: Vec<f32>,
    vector: Vec<f32>,
    mask: Vec<u8>,
) -> PyResult<Observation<'py>> {
    let map = PyArray1::from_vec(py, map).reshape([4, h, w])?;
    let mask: Vec<i8> = mask.into_iter().map(|m| m as i8).collect();
    Ok((
        map,
        PyArray1::from_vec(py, vector),
        PyArray1::from_vec(py, mask),
    ))
}

/// One environment (see `madenet_env`): `map` is `paper:N`, `generate:SEED` or a map file,
/// `start` a corner name or `r,c;r,c;…`, `mode` `macro` or `primitive`.
#[pyclass(module = "madenet._core", unsendable)]
pub struct CoreEnv {
    env: ExplorationEnv,
    map_name: String,
}

env_pymethods! {
    CoreEnv {
        #[new]
        #[pyo3(signature = (map = "paper:1", start = "top-left", mode = "macro", config = None, overrides = "", candidates = false, record = false))]
        fn new(
            map: &str,
            start: &str,
            mode: &str,
            config: Option<&str>,
            overrides: &str,
            candidates: bool,
            record: bool,
        ) -> PyResult<Self> {
            let (env, map_name) = exploration_env(map, start, mode, config, overrides, candidates)?;
            Ok(CoreEnv {
                env: env.recording(record),
                map_name,
            })
        }

        /// Goal candidates per decision |G| for this map.
        #[getter]
        fn goal_count(&self) -> usize {
            self.env.goal_count()
        }
        /// Length of the joint observation vector (every robot's vector, in robot order).
        #[getter]
        fn joint_vector_len(&self) -> usize {
            self.env.joint_vector_len()
        }
        /// Number of joint macro actions |G|^|I|; a `ValueError` if it overflows.
        #[getter]
        fn joint_action_count(&self) -> PyResult<usize> {
            self.env
                .joint_action_count()
                .ok_or_else(|| value_error("num_robots: |G|^|I| joint actions overflow"))
        }
        /// The current timestep of the episode.
        #[getter]
        fn t(&self) -> usize {
            self.env.t()
        }

        /// Starts an episode (the seed drives the world's noise and dropouts).
        fn reset(&mut self, seed: u64) -> PyResult<()> {
            self.env.reset(seed).map_err(value_error)
        }

        /// The centralized observation: merged map image `[4, H, W]`, every robot's vector, the
        /// joint action mask (int8, |G|^|I|).
        fn observe_joint<'py>(&mut self, py: Python<'py>) -> PyResult<Observation<'py>> {
            let (h, w) = (self.env.height(), self.env.width());
            let count = self.joint_action_count()?;
            let mut map = vec![0.0f32; self.env.map_len()];
            let mut vector = vec![0.0f32; self.env.joint_vector_len()];
            let mut mask = vec![0u8; count];
            self.env
                .observe_joint_into(&mut map, &mut vector, &mut mask)
                .map_err(value_error)?;
            observation(py, (h, w), map, vector, mask)
        }

        /// Applies one action per robot; returns (rewards, team reward, timesteps, terminated,
        /// truncated). Each action is an int (candidate / move index), `None` (idle) or a
        /// `(row, col)` goal cell.
        fn step(
            &mut self,
            py: Python<'_>,
            actions: Vec<Bound<'_, PyAny>>,
        ) -> PyResult<(Vec<f64>, f64, usize, bool, bool)> {
            let count = self.env.action_count();
            let decisions = actions.iter().map(decision).collect::<PyResult<Vec<_>>>()?;
            let env = &mut self.env;
            let r: StepResult = if decisions
                .iter()
                .all(|d| matches!(d, Decision::Candidate(_)))
            {
                let idx: Vec<usize> = decisions
                    .iter()
                    .map(|d| {
                        if let Decision::Candidate(k) = d {
                            *k
                        } else {
                            0
                        }
                    })
                    .collect();
                if let Some(a) = idx.iter().find(|&&a| a >= count) {
                    return Err(value_error(format!("action {a}: expected 0..{count}")));
                }
                py.detach(|| env.step(&idx))
            } else {
                if env.mode() == ActionMode::Primitive
                    && decisions
                        .iter()
                        .any(|d| matches!(d, Decision::Candidate(_)))
                {
                    return Err(value_error(
                        "actions: in primitive mode move indices cannot be mixed with goals or None",
                    ));
                }
                py.detach(|| env.step_decisions(&decisions))
            }
            .map_err(value_error)?;
            Ok((r.rewards, r.team_reward, r.steps, r.terminated, r.truncated))
        }

        /// Applies joint action a = Σ k_i·|G|^i.
        fn step_joint(
            &mut self,
            py: Python<'_>,
            action: i64,
        ) -> PyResult<(f64, usize, bool, bool)> {
            let a = usize::try_from(action)
                .map_err(|_| value_error(format!("action {action}: negative")))?;
            let env = &mut self.env;
            let r = py.detach(|| env.step_joint(a)).map_err(value_error)?;
            Ok((r.team_reward, r.steps, r.terminated, r.truncated))
        }

        /// What shipped policy `name` decides now for each robot (int, `(row, col)` or `None`).
        fn policy_actions(&mut self, py: Python<'_>, name: &str) -> PyResult<Vec<Py<PyAny>>> {
            // An unknown name is the registry's error, naming the known policies.
            let decisions = self
                .env
                .policy_decisions(name, registry()?)
                .map_err(value_error)?;
            decisions
                .into_iter()
                .map(|d| decision_to_py(py, d))
                .collect()
        }

        /// The frame `madenet run --render` draws, as an RGB array `[height, width, 3]` uint8.
        fn render<'py>(&self, py: Python<'py>, cell_px: u32) -> PyResult<Bound<'py, PyArray3<u8>>> {
            if !(1..=MAX_CELL_PX).contains(&cell_px) {
                return Err(value_error(format!(
                    "cell_px: {cell_px} is not in 1..={MAX_CELL_PX}"
                )));
            }
            let frame = self.env.frame().map_err(value_error)?;
            let img = madenet_render::render(
                &frame,
                &madenet_render::RenderOptions {
                    cell_px,
                    ..Default::default()
                },
            );
            let (w, h) = (img.width() as usize, img.height() as usize);
            let rgb: Vec<u8> = img
                .pixels()
                .flat_map(|p| [p.0[0], p.0[1], p.0[2]])
                .collect();
            PyArray1::from_vec(py, rgb).reshape([h, w, 3])
        }
    }

    /// Map height H, cells.
    height;
    /// Map width W, cells.
    width;
    /// Actions per robot: |G| goal candidates (macro mode) or 9 moves (primitive mode).
    action_count;
    /// The episode has ended (map explored or step cap reached).
    done;
    /// The episode's result as `madenet run --json` prints it (a JSON string; the trajectory
    /// if the environment records); ends the episode.
    finish;
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<CoreEnv>()?;
    m.add_class::<continuous::CoreContinuousEnv>()?;
    m.add_class::<vector::CoreVecEnv>()?;
    m.add_class::<study::CoreStudy>()?;
    m.add_class::<study::CoreScale>()?;
    m.add_function(wrap_pyfunction!(policies, m)?)?;
    m.add_function(wrap_pyfunction!(run_trial, m)?)?;
    m.add_function(wrap_pyfunction!(train::train_rollout, m)?)?;
    m.add_function(wrap_pyfunction!(train::collect_rollout, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
