//! `CoreVecEnv`: N environments stepped together in Rust ([`madenet_env::VecEnv`]) with the
//! GIL released, writing into numpy arrays allocated once at construction.

use crate::{exploration_env, value_error};
use madenet_env::{VecBuffers, VecEnv};
use numpy::ndarray::{Ix1, Ix2, Ix3, Ix5};
use numpy::{PyArray, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Most environments in one vector.
const MAX_ENVS: usize = 1 << 16;
/// Most bytes of observation buffers.
const MAX_BUFFER_BYTES: usize = 8 << 30;

/// N copies of one environment; see `madenet.VectorEnv`.
#[pyclass(module = "madenet._core", unsendable)]
pub struct CoreVecEnv {
    inner: VecEnv,
    actions: Vec<usize>,
    /// `[n, robots, 4, H, W]` float32
    #[pyo3(get)]
    maps: Py<PyArray<f32, Ix5>>,
    /// `[n, robots, vector_len]` float32
    #[pyo3(get)]
    vectors: Py<PyArray<f32, Ix3>>,
    /// `[n, robots, action_count]` uint8 (1 = valid)
    #[pyo3(get)]
    masks: Py<PyArray<u8, Ix3>>,
    /// `[n, robots]` float32
    #[pyo3(get)]
    rewards: Py<PyArray<f32, Ix2>>,
    /// `[n, robots]` bool
    #[pyo3(get)]
    needs_action: Py<PyArray<bool, Ix2>>,
    /// `[n]` bool
    #[pyo3(get)]
    terminated: Py<PyArray<bool, Ix1>>,
    /// `[n]` bool
    #[pyo3(get)]
    truncated: Py<PyArray<bool, Ix1>>,
}

macro_rules! slice_mut {
    ($guard:ident, $arr:expr, $py:expr) => {
        let mut $guard = $arr.bind($py).try_readwrite().map_err(value_error)?;
    };
}

impl CoreVecEnv {
    /// Runs `f` on the buffers with the GIL released.
    fn with_buffers(
        &mut self,
        py: Python<'_>,
        f: impl FnOnce(&mut VecEnv, &[usize], VecBuffers<'_>) -> Result<(), madenet_env::EnvError>
            + Send,
    ) -> PyResult<()> {
        slice_mut!(m, self.maps, py);
        slice_mut!(v, self.vectors, py);
        slice_mut!(k, self.masks, py);
        slice_mut!(r, self.rewards, py);
        slice_mut!(n, self.needs_action, py);
        slice_mut!(te, self.terminated, py);
        slice_mut!(tr, self.truncated, py);
        let out = VecBuffers {
            maps: m.as_slice_mut().map_err(value_error)?,
            vectors: v.as_slice_mut().map_err(value_error)?,
            masks: k.as_slice_mut().map_err(value_error)?,
            rewards: r.as_slice_mut().map_err(value_error)?,
            needs_action: n.as_slice_mut().map_err(value_error)?,
            terminated: te.as_slice_mut().map_err(value_error)?,
            truncated: tr.as_slice_mut().map_err(value_error)?,
        };
        let (inner, actions) = (&mut self.inner, &self.actions[..]);
        py.detach(move || f(inner, actions, out))
            .map_err(value_error)
    }
}

#[pymethods]
impl CoreVecEnv {
    #[new]
    #[pyo3(signature = (num_envs, map = "paper:1", start = "top-left", mode = "primitive", config = None, overrides = "", seed = 0, candidates = false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        num_envs: usize,
        map: &str,
        start: &str,
        mode: &str,
        config: Option<&str>,
        overrides: &str,
        seed: u64,
        candidates: bool,
    ) -> PyResult<Self> {
        let (env, _) = exploration_env(map, start, mode, config, overrides, candidates)?;
        let (r, h, w, vl, al) = (
            env.num_robots(),
            env.height(),
            env.width(),
            env.vector_len(),
            env.action_count(),
        );
        if num_envs > MAX_ENVS {
            return Err(value_error(format!(
                "num_envs: {num_envs} is more than {MAX_ENVS}"
            )));
        }
        let bytes = [4 * h * w * 4, vl * 4, al]
            .iter()
            .map(|&per_robot| {
                per_robot
                    .checked_mul(r)
                    .and_then(|b| b.checked_mul(num_envs))
            })
            .try_fold(0usize, |acc, b| b.and_then(|b| acc.checked_add(b)));
        if bytes.is_none_or(|b| b > MAX_BUFFER_BYTES) {
            return Err(value_error(format!(
                "num_envs: {num_envs} environments' observations would exceed {} GiB",
                MAX_BUFFER_BYTES >> 30
            )));
        }
        let inner =
            VecEnv::new(env, num_envs, seed).map_err(|e| value_error(format!("num_envs: {e}")))?;
        Ok(CoreVecEnv {
            inner,
            actions: vec![0; num_envs * r],
            maps: PyArray::zeros(py, [num_envs, r, 4, h, w], false).unbind(),
            vectors: PyArray::zeros(py, [num_envs, r, vl], false).unbind(),
            masks: PyArray::zeros(py, [num_envs, r, al], false).unbind(),
            rewards: PyArray::zeros(py, [num_envs, r], false).unbind(),
            needs_action: PyArray::zeros(py, [num_envs, r], false).unbind(),
            terminated: PyArray::zeros(py, [num_envs], false).unbind(),
            truncated: PyArray::zeros(py, [num_envs], false).unbind(),
        })
    }

    /// Number of environments N.
    #[getter]
    fn num_envs(&self) -> usize {
        self.inner.len()
    }
    /// Team size |I| of every environment.
    #[getter]
    fn num_robots(&self) -> usize {
        self.inner.first().num_robots()
    }
    /// Actions per robot: |G| goal candidates (macro mode) or 9 moves (primitive mode).
    #[getter]
    fn action_count(&self) -> usize {
        self.inner.first().action_count()
    }

    /// The seed of each environment's current episode.
    fn episode_seeds(&self) -> Vec<u64> {
        self.inner.episode_seeds()
    }

    /// Resets every environment (with `seed`, the seed sequences start over from it); the
    /// arrays hold the first observations.
    #[pyo3(signature = (seed = None))]
    fn reset(&mut self, py: Python<'_>, seed: Option<u64>) -> PyResult<()> {
        if let Some(s) = seed {
            self.inner.reseed(s);
        }
        self.with_buffers(py, |inner, _, out| inner.reset(out))
    }

    /// Steps every environment with `actions` (`[num_envs, num_robots]` ints); the arrays are
    /// overwritten in place. Finished environments start their next episode.
    fn step(&mut self, py: Python<'_>, actions: &Bound<'_, PyArrayDyn<i64>>) -> PyResult<()> {
        let count = self.inner.first().action_count();
        if actions.shape() != [self.inner.len(), self.num_robots()] {
            return Err(value_error(format!(
                "actions: shape {:?}, expected [{}, {}] (environments × robots)",
                actions.shape(),
                self.inner.len(),
                self.num_robots()
            )));
        }
        {
            let ro = actions.try_readonly().map_err(value_error)?;
            let arr = ro.as_array();
            for (o, &a) in self.actions.iter_mut().zip(arr.iter()) {
                *o = usize::try_from(a)
                    .ok()
                    .filter(|&a| a < count)
                    .ok_or_else(|| value_error(format!("actions: {a} is not in 0..{count}")))?;
            }
        }
        self.with_buffers(py, |inner, actions, out| inner.step(actions, out))
    }
}
