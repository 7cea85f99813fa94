//! The collector protocol: an iteration's episodes as one plain-data [`CollectRequest`] (the
//! behaviour's and the teacher's base students as model files' bytes), collected here or by a
//! [`Collector`] elsewhere (Ray tasks running [`collect_bytes`]), with the same episodes either
//! way.

use super::{config::*, teacher::*};
use crate::error::TrainError;
use crate::model::Model;
use madenet_agent::Policy;
use madenet_sim::PolicyRegistry;
use madenet_world::rng::stream;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A model as plain data: its `model.toml` text and its one weight file's bytes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelBytes {
    /// The `model.toml` text.
    pub model_toml: String,
    /// The weight file (`dep0.bpk`).
    pub weights: Vec<u8>,
}

impl ModelBytes {
    /// Reads the model folder `dir` (written by [`write_model`]: `model.toml`, `dep0.bpk`).
    pub(super) fn read(dir: &Path) -> Result<Self, TrainError> {
        let read = |f: &str| {
            let p = dir.join(f);
            std::fs::read(&p).map_err(|e| TrainError::Io {
                path: p.display().to_string(),
                message: e.to_string(),
            })
        };
        let model_toml = String::from_utf8(read("model.toml")?)
            .map_err(|e| TrainError::Other(format!("{}: {e}", dir.display())))?;
        Ok(ModelBytes {
            model_toml,
            weights: read("dep0.bpk")?,
        })
    }

    pub(super) fn model(&self, label: &str) -> Result<Model, TrainError> {
        Model::from_bytes(&self.model_toml, &[&self.weights], label)
    }
}

/// Episodes of one iteration to collect, as plain data (postcard): given the run's config, a
/// worker anywhere collects from it exactly the episodes a local run does ([`collect`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CollectRequest {
    /// The madenet version that made the request: a worker of another version refuses it.
    pub version: String,
    /// The episodes' indices (each episode's scenario and seeds follow from its index).
    pub episodes: Vec<u64>,
    /// The curriculum's largest map side this iteration.
    pub side_max: usize,
    /// The behaviour's student (greedy, ε-random); none while the behaviour is the base rule.
    pub student: Option<ModelBytes>,
    /// The teacher's base student (expert or policy iteration); none while it is the base rule.
    pub base: Option<ModelBytes>,
}

/// Collects the episodes of `req`, in its order, in parallel on the current thread pool; `None`
/// when `stop` said so before an episode started.
pub fn collect(
    cfg: &RolloutTrainConfig,
    req: &CollectRequest,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<Option<Vec<Collected>>, TrainError> {
    let student = match &req.student {
        Some(m) => Some(m.model("the behaviour's student")?),
        None => None,
    };
    let behaviour = behaviour_registry(cfg, student);
    let teacher = match &req.base {
        Some(m) => TeacherBase::student(&m.model("the teacher's base")?),
        None => TeacherBase::rule(cfg),
    };
    let collected: Vec<Option<Collected>> = req
        .episodes
        .par_iter()
        .map(|&e| match stop() {
            true => Ok(None),
            false => collect_episode(cfg, e, req.side_max, &behaviour, &teacher).map(Some),
        })
        .collect::<Result<_, _>>()?;
    Ok(collected.into_iter().collect())
}

/// [`collect`] for a worker in another process (the Python package's Ray tasks): the run's
/// config as TOML text, the iteration's postcard [`CollectRequest`] without its episodes (its
/// students' weights: the same for every batch, so sent once an iteration) and the batch's
/// postcard episode indices in; the postcard `Vec<Collected>` out, on `threads` threads.
pub fn collect_bytes(
    config_toml: &str,
    iteration: &[u8],
    batch: &[u8],
    threads: usize,
) -> Result<Vec<u8>, TrainError> {
    let cfg = RolloutTrainConfig::from_toml_text(Path::new("the run's config"), config_toml)?;
    cfg.validate()
        .map_err(|m| TrainError::Other(format!("the run's config: {m}")))?;
    let mut req: CollectRequest = postcard::from_bytes(iteration)
        .map_err(|e| TrainError::Other(format!("a collect request: {e}")))?;
    if req.version != env!("CARGO_PKG_VERSION") {
        return Err(TrainError::Other(format!(
            "a collect request of madenet {}: this worker is madenet {} (run the same version everywhere)",
            req.version,
            env!("CARGO_PKG_VERSION")
        )));
    }
    req.episodes = postcard::from_bytes(batch)
        .map_err(|e| TrainError::Other(format!("a collect request's episodes: {e}")))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|e| TrainError::Other(format!("thread pool: {e}")))?;
    let collected = pool
        .install(|| collect(&cfg, &req, &|| false))?
        .expect("never stopped");
    postcard::to_allocvec(&collected).map_err(|e| TrainError::Other(e.to_string()))
}

/// A function collecting batches: the run's config as TOML, the iteration's request without
/// episodes (postcard [`CollectRequest`]: its students, sent once) and each batch's postcard
/// episode indices in; each batch's [`collect_bytes`] output out, in order.
pub type BatchCollector<'a> =
    dyn FnMut(&str, Vec<u8>, Vec<Vec<u8>>) -> Result<Vec<Vec<u8>>, TrainError> + Send + 'a;

/// Where an iteration's episodes are collected.
pub enum Collector<'a> {
    /// Here, on the run's thread pool ([`collect`]); an episode not started within the time
    /// budget cuts the iteration.
    Local,
    /// By the caller: the iteration's request (its students, once) and its episodes split into
    /// batches of `batch`, handed to `run` with the run's config as TOML; `run` returns each
    /// batch's [`collect_bytes`] output, in order (e.g. Ray tasks: `madenet.ray.train`).
    Batches {
        /// Episodes per batch (≥ 1).
        batch: usize,
        /// Collects the batches.
        run: &'a mut BatchCollector<'a>,
    },
}

impl Collector<'_> {
    /// The episodes of `req` ([`None`]: the time budget ran out first).
    pub(super) fn collect(
        &mut self,
        cfg: &RolloutTrainConfig,
        req: &CollectRequest,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Option<Vec<Collected>>, TrainError> {
        let (batch, run) = match self {
            Collector::Local => return collect(cfg, req, stop),
            Collector::Batches { batch, run } => (*batch, run),
        };
        let text = toml::to_string(cfg).map_err(|e| TrainError::Other(e.to_string()))?;
        let encode = |e: postcard::Error| TrainError::Other(e.to_string());
        let iteration = postcard::to_allocvec(&CollectRequest {
            episodes: Vec::new(),
            ..req.clone()
        })
        .map_err(encode)?;
        let batches = req
            .episodes
            .chunks(batch.max(1))
            .map(|episodes| postcard::to_allocvec(episodes).map_err(encode))
            .collect::<Result<Vec<_>, _>>()?;
        let n = batches.len();
        let results = run(&text, iteration, batches)?;
        if results.len() != n {
            return Err(TrainError::Other(format!(
                "the collector returned {} batches for {n}",
                results.len()
            )));
        }
        let mut all = Vec::with_capacity(req.episodes.len());
        for (k, (r, want)) in results
            .iter()
            .zip(req.episodes.chunks(batch.max(1)))
            .enumerate()
        {
            let bad = |why: String| TrainError::Other(format!("the collector's batch {k}: {why}"));
            let (part, rest): (Vec<Collected>, _) =
                postcard::take_from_bytes(r).map_err(|e| bad(e.to_string()))?;
            if !rest.is_empty() {
                return Err(bad(format!("{} bytes after the episodes", rest.len())));
            }
            let got: Vec<u64> = part.iter().map(|c| c.episode).collect();
            if got != want {
                return Err(bad(format!("episodes {got:?}, asked for {want:?}")));
            }
            all.extend(part);
        }
        Ok(Some(all))
    }
}

/// A registry whose policy "behaviour" is the base rule (no student yet) or the student DEP
/// (greedy), each with ε-random candidates from a stream of the episode's seed and robot.
pub(super) fn behaviour_registry(
    cfg: &RolloutTrainConfig,
    student: Option<Model>,
) -> PolicyRegistry {
    let mut r = PolicyRegistry::default();
    let (base, eps) = (PolicyRegistry::builtin(), cfg.behaviour_epsilon);
    let name = cfg.base_policy.clone();
    r.register("behaviour", "data collection", move |ctx| {
        let inner: Box<dyn Policy> = match &student {
            Some(model) => model.policy("student", ctx.robot),
            None => base
                .make(&name, ctx)
                .expect("the base policy is a built-in (validated)"),
        };
        Box::new(Behaviour {
            inner,
            epsilon: eps,
            rng: stream(ctx.seed, "behaviour", ctx.robot as u64),
        })
    });
    r
}
