//! `CoreContinuousEnv`: the continuous world as a step-wise environment
//! ([`madenet_env::ContinuousEnv`]), for the Python package's `ContinuousExplorationEnv`.

use crate::{registry, scenario, value_error};
use madenet_continuous::ContinuousConfig;
use madenet_env::ContinuousEnv;
use madenet_sim::continuous::ContinuousSpec;
use madenet_sim::{MapSource, StartSpec};
use pyo3::prelude::*;
use std::str::FromStr;

/// One continuous-world environment: `map` is `generate:SEED` (a cluttered world `side`
/// metres square), `paper:N` or a map file at its native resolution; `start` a corner name or
/// `r,c;r,c;…` (cells); `policy` the robots' own policy (acting where an action is `None`);
/// `continuous_config` a TOML file of the world's parameters.
#[pyclass(module = "madenet._core", unsendable)]
pub struct CoreContinuousEnv {
    env: ContinuousEnv,
    map_name: String,
}

env_pymethods! {
    CoreContinuousEnv {
        #[new]
        #[pyo3(signature = (map = "generate:1", side = 20.0, start = "bottom-left", policy = "nf", config = None, overrides = "", continuous_config = None))]
        fn new(
            map: &str,
            side: f64,
            start: &str,
            policy: &str,
            config: Option<&str>,
            overrides: &str,
            continuous_config: Option<&str>,
        ) -> PyResult<Self> {
            let scenario = scenario(config, overrides)?;
            if !(side.is_finite() && (4.0..=1000.0).contains(&side)) {
                return Err(value_error(format!(
                    "side: a generated world is 4 to 1000 m square, got {side}"
                )));
            }
            let continuous: ContinuousConfig = match continuous_config {
                Some(p) => madenet_files::read_toml(std::path::Path::new(p))
                    .map_err(|e| value_error(format!("continuous_config: {e}")))?,
                None => ContinuousConfig::default(),
            };
            continuous
                .validate()
                .map_err(|e| value_error(format!("continuous_config: {e}")))?;
            let source = MapSource::from_str(map).map_err(|e| value_error(format!("map: {e}")))?;
            let scene = source
                .scene(side)
                .map_err(|e| value_error(format!("map: {e}")))?;
            let starts =
                StartSpec::from_str(start).map_err(|e| value_error(format!("start: {e}")))?;
            starts
                .check_team(scenario.num_robots)
                .map_err(|e| value_error(format!("start: {e}")))?;
            let starts = starts.continuous_cells(&scene, &scenario, continuous.robot.radius);
            if starts.is_empty() {
                return Err(value_error(format!(
                    "start: map {} has no {} connected free cells there",
                    source.name(),
                    scenario.num_robots
                )));
            }
            let spec = ContinuousSpec {
                scene: std::sync::Arc::new(scene),
                starts,
                config: scenario,
                continuous,
                policy: policy.to_string(),
                seed: 0,
            };
            let env = ContinuousEnv::new(spec, registry()?).map_err(value_error)?;
            Ok(CoreContinuousEnv {
                env,
                map_name: source.name(),
            })
        }

        /// Simulated seconds since the episode started.
        #[getter]
        fn time(&self) -> f64 {
            self.env.time()
        }

        /// Starts an episode (the seed drives the sensors, the radio and the robots' policies)
        /// and runs it to its first decision point.
        fn reset(&mut self, py: Python<'_>, seed: u64) -> PyResult<()> {
            let env = &mut self.env;
            py.detach(|| env.reset(seed)).map_err(value_error)
        }

        /// Applies one action per robot (a candidate index, or `None`: the robot's own policy);
        /// returns (team reward, simulated seconds, terminated, truncated).
        fn step(
            &mut self,
            py: Python<'_>,
            actions: Vec<Option<i64>>,
        ) -> PyResult<(f64, f64, bool, bool)> {
            let actions = actions
                .into_iter()
                .map(|a| {
                    a.map(|k| {
                        usize::try_from(k).map_err(|_| value_error(format!("action {k}: negative")))
                    })
                    .transpose()
                })
                .collect::<PyResult<Vec<_>>>()?;
            let env = &mut self.env;
            let s = py.detach(|| env.step(&actions)).map_err(value_error)?;
            Ok((s.team_reward, s.seconds, s.terminated, s.truncated))
        }
    }

    /// Rows H of the agents' cells.
    height;
    /// Columns W of the agents' cells.
    width;
    /// Actions per robot: |G| goal candidates.
    action_count;
    /// The episode has ended (explored, time cap, or no reachable frontier left).
    done;
    /// The episode's result as `madenet run --world continuous --json` prints it (a JSON
    /// string); ends the episode.
    finish;
}
