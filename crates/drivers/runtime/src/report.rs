//! The result a world node writes (`madenet world --out`, read back by `madenet launch`): the
//! in-process trial's `run --json` object, field order kept, then what a run over processes
//! adds (key `runtime`) and, when asked, the positions of every timestep.

use crate::LockstepResult;
use madenet_map::Pos;
use madenet_sim::{TrialResult, TrialSpec};
use serde::{Deserialize, Serialize};

/// What a run over processes adds to `run --json` (key `runtime`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RuntimeReport {
    /// Robots' observation-to-move latency (waits for teammates included).
    pub latency: crate::Latency,
    /// Robot-timesteps a robot was absent (sent no move in time).
    pub absent_robot_steps: usize,
    /// Messages the world sent (observations, contacts, stops).
    pub world_messages: usize,
    /// Bytes the world sent.
    pub world_bytes: usize,
}

/// What the world node writes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorldOutput {
    /// The trial as `run --json` reports it (its trajectory empty: see `positions`).
    #[serde(flatten)]
    pub result: TrialResult,
    /// What the run over processes adds.
    pub runtime: RuntimeReport,
    /// Robot positions before the first move and after every timestep, when asked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positions: Option<Vec<Vec<Pos>>>,
}

impl WorldOutput {
    /// The output of the run `r` of `spec`, its robots driven by policy `policy`; with the
    /// positions of every timestep if `positions`.
    pub fn new(spec: &TrialSpec, policy: &str, r: LockstepResult, positions: bool) -> Self {
        WorldOutput {
            result: TrialResult {
                map: spec.map_name.clone(),
                policy: policy.to_string(),
                seed: spec.seed,
                comm_success_prob: spec.config.comm_success_prob,
                starts: spec.starts.clone(),
                metrics: r.metrics,
                trajectory: Vec::new(),
                timing: r.timing,
            },
            runtime: RuntimeReport {
                latency: r.latency,
                absent_robot_steps: r.absent_robot_steps,
                world_messages: r.world_sent.messages,
                world_bytes: r.world_sent.bytes,
            },
            positions: positions.then_some(r.positions),
        }
    }

    /// The lines `launch` prints: the trial's ([`TrialResult::summary`], `start` named), then
    /// the latency, the absent robot-timesteps (if any) and the `nodes` processes from `port`.
    pub fn summary(&self, start: &str, nodes: usize, port: u16) -> Vec<String> {
        let mut lines = self.result.summary(start);
        let rt = &self.runtime;
        lines.push(format!(
            "latency    {:.2} ms mean, {:.2} ms longest from a robot's observation to its move ({} moves)",
            1e3 * rt.latency.mean_s,
            1e3 * rt.latency.max_s,
            rt.latency.acted
        ));
        if rt.absent_robot_steps > 0 {
            lines.push(format!(
                "absent     {} robot-timesteps",
                rt.absent_robot_steps
            ));
        }
        lines.push(format!(
            "nodes      {nodes} processes over Zenoh (tcp/127.0.0.1:{port}…)"
        ));
        lines
    }
}
