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
    pub truncated: &'a mut [bool],
}

/// N environments over the same scenario.
pub struct VecEnv {
    envs: Vec<ExplorationEnv>,
    seeds: Vec<u64>,
    episodes: Vec<u64>,
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
        let envs = (0..n)
            .map(|_| {
                let mut e = env.clone_config()?;
                e.share_visibility(rays.clone());
                Ok(e)
            })
            .collect::<Result<Vec<_>, EnvError>>()?;
        let mut v = VecEnv { envs, seeds: vec![0; n], episodes: vec![0; n] };
        v.reseed(seed);
        Ok(v)
    }

    pub fn len(&self) -> usize {
        self.envs.len()
    }
    pub fn is_empty(&self) -> bool {
        self.envs.is_empty()
    }
    pub fn first(&self) -> &ExplorationEnv {
        &self.envs[0]
    }

    /// The seed of each environment's current episode.
    pub fn episode_seeds(&self) -> Vec<u64> {
        self.envs.iter().map(ExplorationEnv::seed).collect()
    }

    fn episode_seed(&self, k: usize) -> u64 {
        madenet_world::rng::derive_seed(self.seeds[k], "episode", self.episodes[k])
    }

    /// Resets every environment and writes the first observations.
    pub fn reset(&mut self, out: VecBuffers<'_>) -> Result<(), EnvError> {
        self.check(&out)?;
        for k in 0..self.envs.len() {
            let s = self.episode_seed(k);
            self.envs[k].reset(s)?;
        }
        out.terminated.fill(false);
        out.truncated.fill(false);
        out.rewards.fill(0.0);
        self.write(out)
    }

    /// Steps environment k with `actions[k·robots..]` (all environments in parallel on rayon's
    /// pool); environments whose episode ended are reset and observed anew.
    pub fn step(&mut self, actions: &[usize], out: VecBuffers<'_>) -> Result<(), EnvError> {
        let robots = self.envs[0].num_robots();
        if actions.len() != self.envs.len() * robots {
            return Err(EnvError::Usage(format!("{} actions for {} environments × {robots} robots", actions.len(), self.envs.len())));
        }
        let count = self.envs[0].action_count();
        if let Some(a) = actions.iter().find(|&&a| a >= count) {
            return Err(EnvError::Usage(format!("action {a}: the action space has {count} actions")));
        }
        // Nothing steps unless every input and output fits.
        self.check(&out)?;
        let seeds: Vec<u64> = (0..self.envs.len()).map(|k| madenet_world::rng::derive_seed(self.seeds[k], "episode", self.episodes[k] + 1)).collect();
        let results: Vec<Result<(Vec<f64>, bool, bool), EnvError>> = self
            .envs
            .par_iter_mut()
            .zip(actions.par_chunks(robots))
            .zip(seeds.par_iter())
            .map(|((env, acts), &next_seed)| {
                let r = env.step(acts)?;
                if env.is_done() {
                    env.reset(next_seed)?;
                }
                Ok((r.rewards, r.terminated, r.truncated))
            })
            .collect();
        for (k, r) in results.into_iter().enumerate() {
            let (rewards, term, trunc) = r?;
            for (o, v) in out.rewards[k * robots..(k + 1) * robots].iter_mut().zip(rewards) {
                *o = v as f32;
            }
            out.terminated[k] = term;
            out.truncated[k] = trunc;
            if term || trunc {
                self.episodes[k] += 1;
            }
        }
        self.write(out)
    }

    /// Every buffer has the length `n` environments need.
    fn check(&self, out: &VecBuffers<'_>) -> Result<(), EnvError> {
        let e0 = &self.envs[0];
        let (n, robots) = (self.envs.len(), e0.num_robots());
        let lengths = [
            (out.maps.len(), n * robots * e0.map_len()),
            (out.vectors.len(), n * robots * e0.vector_len()),
            (out.masks.len(), n * robots * e0.action_count()),
            (out.rewards.len(), n * robots),
            (out.needs_action.len(), n * robots),
            (out.terminated.len(), n),
            (out.truncated.len(), n),
        ];
        if lengths.iter().any(|(got, want)| got != want) {
            return Err(EnvError::Usage("output buffers of the wrong length".into()));
        }
        Ok(())
    }

    /// Starts over with the seed sequences of `seed` (as a new `VecEnv` with that seed would).
    pub fn reseed(&mut self, seed: u64) {
        for (k, s) in self.seeds.iter_mut().enumerate() {
            *s = madenet_world::rng::derive_seed(seed, "vec-env", k as u64);
        }
        self.episodes.fill(0);
    }

    fn write(&mut self, out: VecBuffers<'_>) -> Result<(), EnvError> {
        self.check(&out)?;
        let e0 = &self.envs[0];
        let (robots, ml, vl, al) = (e0.num_robots(), e0.map_len(), e0.vector_len(), e0.action_count());
        let per = |len: usize| len * robots;
        let results: Vec<Result<(), EnvError>> = self
            .envs
            .par_iter_mut()
            .zip(out.maps.par_chunks_mut(per(ml)))
            .zip(out.vectors.par_chunks_mut(per(vl)))
            .zip(out.masks.par_chunks_mut(per(al)))
            .zip(out.needs_action.par_chunks_mut(robots))
            .map(|((((env, maps), vectors), masks), needs)| {
                for i in 0..robots {
                    env.observe_into(i, &mut maps[i * ml..(i + 1) * ml], &mut vectors[i * vl..(i + 1) * vl], &mut masks[i * al..(i + 1) * al])?;
                }
                needs.copy_from_slice(&env.needs_action());
                Ok(())
            })
            .collect();
        results.into_iter().collect()
    }
}
