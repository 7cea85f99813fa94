//! The rollout-teacher learner from Python: `train_rollout` runs `madenet train` for a
//! `made-net-rollout` config with the episodes collected by a Python function (the Ray
//! fan-out of `madenet.ray.train`), `collect_rollout` is what each worker runs.

use crate::value_error;
use madenet_learn::dagger::{collect_bytes, train_with, Collector, RolloutTrainConfig};
use madenet_learn::TrainError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// Trains the rollout-teacher learner into `out` as `madenet train --config CONFIG --out OUT`
/// does (resuming a run there). With `collect`, each iteration's episodes are collected by
/// `collect(config_toml, iteration, batches)` — the iteration's request (its students' weights,
/// the same for every batch: put it in Ray's object store once) and a list of batches' episode
/// bytes, each of `batch_size` episodes — which returns `collect_rollout`'s bytes per batch, in
/// order; the run is the same either way
/// (on one machine: the decision scorer's matrix kernels are picked per CPU). An exception of
/// `collect` ends training at the iteration's start (its checkpoint) and is raised as it was.
/// The time budget (`max_minutes`) is checked between iterations only. A new run needs
/// `config`. Ctrl-C (SIGINT) stops it at its next check — between episodes and updates of a
/// local collection, or when a `collect` call returns — dropping the iteration it is in, and
/// raises `KeyboardInterrupt`; the run resumes from its last checkpoint.
#[pyfunction]
#[pyo3(signature = (out, config = None, collect = None, batch_size = 8))]
pub fn train_rollout(
    py: Python<'_>,
    out: std::path::PathBuf,
    config: Option<std::path::PathBuf>,
    collect: Option<Py<PyAny>>,
    batch_size: usize,
) -> PyResult<()> {
    if batch_size == 0 {
        return Err(value_error("batch_size: must be at least 1"));
    }
    if let Some(f) = &collect {
        if !f.bind(py).is_callable() {
            return Err(value_error(
                "collect: must be callable (config_toml, iteration, batches) -> list of bytes",
            ));
        }
    }
    let cfg = match &config {
        Some(p) => Some(RolloutTrainConfig::from_toml_file(p).map_err(value_error)?),
        // As `madenet train`: without a config, only a run already in `out` (resumed).
        None if !out.join("config.toml").is_file() => {
            return Err(value_error(format!(
                "config: needed for a new run ({} holds none to resume)",
                out.display()
            )))
        }
        None => None,
    };
    // The collect function's own exception, raised again as it was once training stopped.
    let raised = std::sync::Mutex::new(None::<PyErr>);
    let mut run = |toml: &str,
                   iteration: Vec<u8>,
                   batches: Vec<Vec<u8>>|
     -> Result<Vec<Vec<u8>>, TrainError> {
        let f = collect.as_ref().expect("only with a collect function");
        Python::attach(|py| {
            let iteration = PyBytes::new(py, &iteration);
            let batches: Vec<Bound<'_, PyBytes>> =
                batches.iter().map(|b| PyBytes::new(py, b)).collect();
            f.call1(py, (toml, iteration, batches))
                .and_then(|r| r.extract::<Vec<Vec<u8>>>(py))
        })
        .map_err(|e| {
            let why = format!("collect: {e}");
            *raised.lock().expect("not poisoned") = Some(e);
            TrainError::Other(why)
        })
    };
    let mut collector = match collect {
        Some(_) => Collector::Batches {
            batch: batch_size,
            run: &mut run,
        },
        None => Collector::Local,
    };
    // Ctrl-C while Rust trains: Python's own handler only runs once this call returns, so a
    // flag the training checks is set too (signal-hook keeps Python's handler and calls it).
    let stop = madenet_learn::harness::stop_flag();
    stop.store(false, std::sync::atomic::Ordering::Relaxed);
    let watch = signal_hook::flag::register(signal_hook::consts::SIGINT, stop.clone())
        .map_err(|e| value_error(format!("watching Ctrl-C: {e}")))?;
    let result = py.detach(|| train_with(&out, cfg, &mut |_| {}, &mut collector));
    signal_hook::low_level::unregister(watch);
    let stopped = stop.swap(false, std::sync::atomic::Ordering::Relaxed);
    if let Some(e) = raised.lock().expect("not poisoned").take() {
        return Err(e);
    }
    if stopped {
        // Python's handler saw it too: its KeyboardInterrupt; if not, one of ours.
        py.check_signals()?;
        return Err(pyo3::exceptions::PyKeyboardInterrupt::new_err(format!(
            "training stopped; {} resumes from its last checkpoint",
            out.display()
        )));
    }
    result.map_err(|e| value_error(format!("{}: {e}", out.display())))
}

/// Collects one batch of a rollout-teacher iteration's episodes (the iteration's request and a
/// batch from `train_rollout`'s `collect`) on `threads` threads; returns the episodes as bytes.
#[pyfunction]
#[pyo3(signature = (config_toml, iteration, batch, threads = 1))]
pub fn collect_rollout<'py>(
    py: Python<'py>,
    config_toml: &str,
    iteration: &[u8],
    batch: &[u8],
    threads: usize,
) -> PyResult<Bound<'py, PyBytes>> {
    let bytes = py
        .detach(|| collect_bytes(config_toml, iteration, batch, threads))
        .map_err(value_error)?;
    Ok(PyBytes::new(py, &bytes))
}
