//! [`VecEnv`]: N environments stepped together, writing every robot's observation, reward and
//! episode flags into flat caller-provided buffers (the Python `VectorEnv`'s core: numpy arrays
//! allocated once, filled in place). Finished environments reset themselves with the next
//! seed of their own sequence, so a batch never stops.

use crate::{EnvError, ExplorationEnv};
use rayon::prelude::*;

/// Flat output buffers for `n` environments of `robots` robots each, row-major by
/// (environment, robot).
pub struct VecBuffers<'a> {
    /// `[n][robots][4·H·W]`
    pub maps: &'a mut [f32],
    /// `[n][robots][vector_len]`
    pub vectors: &'a mut [f32],
    /// `[n][robots][action_count]`
    pub masks: &'a mut [u8],
    /// `[n][robots]`: Eq. (7) summed over the step.
    pub rewards: &'a mut [f32],
    /// `[n][robots]`: whether the robot's next action counts.
    pub needs_action: &'a mut [bool],
    /// `[n]`: the episode ended in this step (the environment has been reset since).
    pub terminated: &'a mut [bool],
    /// `[n]`: the episode hit the step cap in this step, unexplored (the environment has been
    /// reset since).
    pub truncated: &'a mut [bool],
}

/// Owned, zeroed output buffers of the lengths a [`VecEnv`] needs ([`VecEnv::outputs`]), lent
/// out as [`VecBuffers`] for each call (and to read them after): what a Rust caller keeps
/// between steps.
pub struct VecOutputs {
    maps: Vec<f32>,
    vectors: Vec<f32>,
    masks: Vec<u8>,
    rewards: Vec<f32>,
    needs_action: Vec<bool>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
}

impl VecOutputs {
    /// The buffers, borrowed for one [`VecEnv::reset`] or [`VecEnv::step`], or to read.
    pub fn buffers(&mut self) -> VecBuffers<'_> {
        VecBuffers {
            maps: &mut self.maps,
            vectors: &mut self.vectors,
            masks: &mut self.masks,
            rewards: &mut self.rewards,
            needs_action: &mut self.needs_action,
            terminated: &mut self.terminated,
            truncated: &mut self.truncated,
        }
    }
}

/// One environment's share of the [`VecBuffers`].
struct EnvOut<'a> {
    maps: &'a mut [f32],
    vectors: &'a mut [f32],
    masks: &'a mut [u8],
    rewards: &'a mut [f32],
    needs_action: &'a mut [bool],
    terminated: &'a mut bool,
    truncated: &'a mut bool,
}

/// One environment of the batch with its seed sequence.
struct Slot {
    env: ExplorationEnv,
    /// Seed of the sequence of episode seeds.
    seed: u64,
    /// Episodes finished so far.
    episode: u64,
}

impl Slot {
    fn episode_seed(&self) -> u64 {
        madenet_world::rng::derive_seed(self.seed, "episode", self.episode)
    }

    /// Writes every robot's observation and whether it acts next.
    fn observe(&mut self, out: &mut EnvOut<'_>) -> Result<(), EnvError> {
        let e = &mut self.env;
        let (ml, vl, al) = (e.map_len(), e.vector_len(), e.action_count());
        for i in 0..e.num_robots() {
            e.observe_into(
                i,
                &mut out.maps[i * ml..(i + 1) * ml],
                &mut out.vectors[i * vl..(i + 1) * vl],
                &mut out.masks[i * al..(i + 1) * al],
            )?;
        }
        e.needs_action_into(out.needs_action);
        Ok(())
    }

    /// One step with `actions`, resetting with the next seed when the episode ends, then the
    /// observations.
    fn step(&mut self, actions: &[usize], out: &mut EnvOut<'_>) -> Result<(), EnvError> {
        let r = self.env.step_in_place(actions)?;
        for (o, &v) in out.rewards.iter_mut().zip(self.env.step_rewards()) {
            *o = v as f32;
        }
        *out.terminated = r.terminated;
        *out.truncated = r.truncated;
        if r.terminated || r.truncated {
            self.episode += 1;
            let s = self.episode_seed();
            self.env.reset(s)?;
        }
        self.observe(out)
    }
}

/// Runs `f` on every (slot, output share) pair: on the calling thread when rayon has one
/// thread (no hand-off to a worker per call), else on rayon's pool. Every environment runs
/// even if one fails; the first error (in environment order) is returned.
fn for_each_env<F>(slots: &mut [Slot], outs: Vec<EnvOut<'_>>, f: F) -> Result<(), EnvError>
where
    F: Fn(usize, &mut Slot, &mut EnvOut<'_>) -> Result<(), EnvError> + Sync,
{
    if rayon::current_num_threads() <= 1 {
        let mut first = Ok(());
        for (k, (slot, mut out)) in slots.iter_mut().zip(outs).enumerate() {
            let r = f(k, slot, &mut out);
            if first.is_ok() {
                first = r;
            }
        }
        first
    } else {
        let results: Vec<Result<(), EnvError>> = slots
            .par_iter_mut()
            .zip(outs)
            .enumerate()
            .map(|(k, (slot, mut out))| f(k, slot, &mut out))
            .collect();
        results.into_iter().collect()
    }
}

/// N environments over the same scenario.
pub struct VecEnv {
    slots: Vec<Slot>,
}

impl VecEnv {
    /// `n` copies of `env`; environment k's episodes use seeds derived from (`seed`, k, episode).
    pub fn new(env: ExplorationEnv, n: usize, seed: u64) -> Result<Self, EnvError> {
        if n == 0 {
            return Err(EnvError::Usage("a vector of 0 environments".into()));
        }
        let mut env = env;
        // One copy of the cast rays for all (≈ 0.5 MB each on a 20 × 20 map: 64 copies
        // overflowed the caches).
        let rays = env.visibility()?;
        let slots = (0..n)
            .map(|_| {
                let mut e = env.clone_config()?;
                e.share_visibility(rays.clone());
                Ok(Slot {
                    env: e,
                    seed: 0,
                    episode: 0,
                })
            })
            .collect::<Result<Vec<_>, EnvError>>()?;
        let mut v = VecEnv { slots };
        v.reseed(seed);
        Ok(v)
    }

    /// Number of environments N.
    pub fn len(&self) -> usize {
        self.slots.len()
    }
    /// Always false: [`VecEnv::new`] refuses 0 environments.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }
    /// Environment 0, e.g. to read the batch's shapes (robots, map size, action count).
    pub fn first(&self) -> &ExplorationEnv {
        &self.slots[0].env
    }

    /// Zeroed output buffers of the lengths this batch needs.
    pub fn outputs(&self) -> VecOutputs {
        let e = self.first();
        let (n, r) = (self.len(), e.num_robots());
        VecOutputs {
            maps: vec![0.0; n * r * e.map_len()],
            vectors: vec![0.0; n * r * e.vector_len()],
            masks: vec![0; n * r * e.action_count()],
            rewards: vec![0.0; n * r],
            needs_action: vec![false; n * r],
            terminated: vec![false; n],
            truncated: vec![false; n],
        }
    }

    /// The seed of each environment's current episode.
    pub fn episode_seeds(&self) -> Vec<u64> {
        self.slots.iter().map(|s| s.env.seed()).collect()
    }

    /// Resets every environment and writes the first observations.
    pub fn reset(&mut self, out: VecBuffers<'_>) -> Result<(), EnvError> {
        let outs = self.split(out)?;
        for_each_env(&mut self.slots, outs, |_, slot, out| {
            let s = slot.episode_seed();
            slot.env.reset(s)?;
            *out.terminated = false;
            *out.truncated = false;
            out.rewards.fill(0.0);
            slot.observe(out)
        })
    }

    /// Steps environment k with `actions[k·robots..]` (all environments in parallel on rayon's
    /// pool, or in turn on the calling thread when the pool has one thread); environments
    /// whose episode ended are reset and observed anew. Wrong action counts or buffer lengths
    /// are refused before anything steps; an environment failing later (e.g. never reset) does
    /// not stop the others, and the first failure in environment order is returned.
    pub fn step(&mut self, actions: &[usize], out: VecBuffers<'_>) -> Result<(), EnvError> {
        let robots = self.slots[0].env.num_robots();
        if actions.len() != self.slots.len() * robots {
            return Err(EnvError::Usage(format!(
                "{} actions for {} environments × {robots} robots",
                actions.len(),
                self.slots.len()
            )));
        }
        let count = self.slots[0].env.action_count();
        if let Some(a) = actions.iter().find(|&&a| a >= count) {
            return Err(EnvError::Usage(format!(
                "action {a}: the action space has {count} actions"
            )));
        }
        // Nothing steps unless every input and output fits.
        let outs = self.split(out)?;
        for_each_env(&mut self.slots, outs, |k, slot, out| {
            slot.step(&actions[k * robots..(k + 1) * robots], out)
        })
    }

    /// Every buffer has the length `n` environments need; cut into one share per environment.
    fn split<'a>(&self, out: VecBuffers<'a>) -> Result<Vec<EnvOut<'a>>, EnvError> {
        let e0 = &self.slots[0].env;
        let (n, robots) = (self.slots.len(), e0.num_robots());
        let (ml, vl, al) = (e0.map_len(), e0.vector_len(), e0.action_count());
        let lengths = [
            (out.maps.len(), n * robots * ml),
            (out.vectors.len(), n * robots * vl),
            (out.masks.len(), n * robots * al),
            (out.rewards.len(), n * robots),
            (out.needs_action.len(), n * robots),
            (out.terminated.len(), n),
            (out.truncated.len(), n),
        ];
        if lengths.iter().any(|(got, want)| got != want) {
            return Err(EnvError::Usage("output buffers of the wrong length".into()));
        }
        Ok(out
            .maps
            .chunks_mut(robots * ml)
            .zip(out.vectors.chunks_mut(robots * vl))
            .zip(out.masks.chunks_mut(robots * al))
            .zip(out.rewards.chunks_mut(robots))
            .zip(out.needs_action.chunks_mut(robots))
            .zip(out.terminated.iter_mut().zip(out.truncated.iter_mut()))
            .map(
                |(((((maps, vectors), masks), rewards), needs_action), (terminated, truncated))| {
                    EnvOut {
                        maps,
                        vectors,
                        masks,
                        rewards,
                        needs_action,
                        terminated,
                        truncated,
                    }
                },
            )
            .collect())
    }

    /// Starts over with the seed sequences of `seed` (as a new `VecEnv` with that seed would).
    pub fn reseed(&mut self, seed: u64) {
        for (k, s) in self.slots.iter_mut().enumerate() {
            s.seed = madenet_world::rng::derive_seed(seed, "vec-env", k as u64);
            s.episode = 0;
        }
    }
}
