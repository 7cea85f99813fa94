"""N environments stepped together in Rust."""

from __future__ import annotations

import numpy as np

from madenet._config import path_or_none, scenario_overrides
from madenet._core import CoreVecEnv


class VectorEnv:
    """``num_envs`` copies of one ``ExplorationEnv`` (same map, starts, scenario, mode) stepped
    together in Rust with the GIL released, on all cores (rayon).

    Observations, rewards and flags live in numpy arrays allocated once: ``reset()`` and
    ``step()`` overwrite them in place and return the same arrays every time (copy what you
    keep). Shapes: ``obs["map"]`` ``[num_envs, num_robots, 4, H, W]`` float32,
    ``obs["vector"]`` ``[num_envs, num_robots, V]`` float32, ``obs["action_mask"]``
    ``[num_envs, num_robots, A]`` int8, rewards ``[num_envs, num_robots]`` float32, terminated /
    truncated ``[num_envs]`` bool, ``info["needs_action"]`` ``[num_envs, num_robots]`` bool.
    An environment whose episode ended in a step has already started its next one (same-step
    autoreset): the observation returned is the new episode's first. Environment k's episodes
    use seeds derived from (``seed``, k, episode number), so a run is reproducible.

    ``mode`` defaults to ``"primitive"`` (one of 9 moves per robot per step); ``"macro"`` works
    too. Other arguments as for ``madenet.ExplorationEnv``.
    """

    def __init__(self, num_envs: int, map: str = "paper:1", start: str = "top-left", mode: str = "primitive",
                 config: str | None = None, seed: int = 0, candidates: bool = False, **overrides):
        if not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed: {seed!r} is not a non-negative int")
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs: {num_envs!r} is not a positive int")
        self._core = CoreVecEnv(num_envs, map, start, mode, path_or_none(config), scenario_overrides(overrides), int(seed), bool(candidates))
        self.num_envs = num_envs
        self.num_robots = self._core.num_robots
        self.action_count = self._core.action_count
        self.obs = {"map": self._core.maps, "vector": self._core.vectors, "action_mask": self._core.masks.view(np.int8)}
        self.rewards = self._core.rewards
        self.terminated = self._core.terminated
        self.truncated = self._core.truncated
        self.info = {"needs_action": self._core.needs_action}

    def reset(self, seed: int | None = None):
        """Resets every environment; with ``seed``, the episode seed sequences start over from it."""
        if seed is not None and (not isinstance(seed, (int, np.integer)) or seed < 0):
            raise ValueError(f"seed: {seed!r} is not a non-negative int")
        self._core.reset(None if seed is None else int(seed))
        return self.obs, self.info

    def step(self, actions):
        """``actions``: ints ``[num_envs, num_robots]`` (any integer dtype)."""
        a = np.asarray(actions)
        if not np.issubdtype(a.dtype, np.integer):
            raise ValueError(f"actions: dtype {a.dtype} is not an integer type")
        if a.shape != (self.num_envs, self.num_robots):
            raise ValueError(f"actions: shape {a.shape}, expected ({self.num_envs}, {self.num_robots})")
        self._core.step(np.ascontiguousarray(a, dtype=np.int64))
        return self.obs, self.rewards, self.terminated, self.truncated, self.info
