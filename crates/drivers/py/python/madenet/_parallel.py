"""What madenet's two PettingZoo environments (``ExplorationEnv``, ``ContinuousExplorationEnv``)
share over their compiled core ``self._core``: the agents, the observation space, the
observations, the episode seeds and the end of a step."""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv


class CoreParallelEnv(ParallelEnv):
    """A ``ParallelEnv`` over ``self._core`` (a ``CoreEnv`` or a ``CoreContinuousEnv``), which
    the subclass's ``__init__`` builds before it calls ``_start``."""

    def _start(self) -> int:
        """The agents, the seed generator and the observation space of ``self._core``; returns
        the number of actions per robot."""
        self.possible_agents = [f"robot_{i}" for i in range(self._core.num_robots)]
        self.agents: list[str] = []
        self._np_random, _ = seeding.np_random(None)
        h, w, k = self._core.height, self._core.width, self._core.action_count
        self._obs_space = spaces.Dict({
            "map": spaces.Box(0.0, 1.0, (4, h, w), np.float32),
            "vector": spaces.Box(-1.0, 1.0, (self._core.vector_len,), np.float32),
            "action_mask": spaces.MultiBinary(k),
        })
        return k

    def _observations(self) -> dict:
        obs = {}
        for i, a in enumerate(self.possible_agents):
            m, v, mask = self._core.observe(i)
            obs[a] = {"map": m, "vector": v, "action_mask": mask}
        return obs

    def _reset_core(self, seed: int | None) -> None:
        """Starts the core's episode: with ``seed`` (which also reseeds the generator of later
        episodes' seeds), else with the generator's next seed."""
        if seed is not None:
            self._np_random, _ = seeding.np_random(seed)
            episode_seed = int(seed)
        else:
            episode_seed = int(self._np_random.integers(0, 2**63 - 1))
        self._core.reset(episode_seed)
        self.agents = self.possible_agents[:]

    def _end_step(self, obs: dict, rew: dict, terminated: bool, truncated: bool, infos: dict):
        """A step's return: everyone terminated or truncated with the episode, which leaves no
        agents once it has ended."""
        term = {a: bool(terminated) for a in self.possible_agents}
        trunc = {a: bool(truncated) for a in self.possible_agents}
        if terminated or truncated:
            self.agents = []
        return obs, rew, term, trunc, infos

    def close(self):
        pass
