"""PettingZoo environment over madenet's simulator."""

from __future__ import annotations

import functools

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from madenet._core import CoreEnv


def _toml_value(key: str, value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    raise ValueError(f"{key}: unsupported value {value!r} (numbers, booleans and strings only)")


def _overrides(kwargs: dict) -> str:
    return "".join(f"{k} = {_toml_value(k, v)}\n" for k, v in kwargs.items())


class ExplorationEnv(ParallelEnv):
    """The team of robots exploring one map, as a PettingZoo ``ParallelEnv``.

    ``map``: ``"paper:N"`` (the paper's maps 1-10), ``"generate:SEED"`` or a ROS map YAML path;
    ``start``: a corner (``top-left`` …) or ``"r,c;r,c;r,c"``; ``mode``: ``"macro"`` (action k =
    go to goal candidate k; robots whose macro action is still running have
    ``info["needs_action"] = False`` and their action is ignored) or ``"primitive"`` (one of 9
    moves every timestep); ``config``: a scenario TOML file; keyword arguments override its fields
    (``comm_success_prob=0.5``, ``num_robots=3``, …). Bad values raise ``ValueError`` naming the field.

    Observations per robot: ``map`` (4 × H × W binary image: explored, obstacles, robots, goal
    candidates), ``vector`` (the macro observation, Sec. III.C.1) and ``action_mask`` (int8).
    Rewards are Eq. (7) per robot, summed over the timesteps a step advances; Eq. (8), the team
    reward, is in ``info["team_reward"]``.
    """

    metadata = {"name": "madenet_exploration_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, map: str = "paper:1", start: str = "top-left", mode: str = "macro",
                 config: str | None = None, render_mode: str | None = None, **overrides):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: {render_mode!r} is not supported")
        self.render_mode = render_mode
        self._core = CoreEnv(map, start, mode, config, _overrides(overrides))
        self.mode = mode
        self.possible_agents = [f"robot_{i}" for i in range(self._core.num_robots)]
        self.agents: list[str] = []
        self.max_cycles = None
        self._np_random, _ = seeding.np_random(None)
        h, w, k = self._core.height, self._core.width, self._core.action_count
        self._obs_space = spaces.Dict({
            "map": spaces.Box(0.0, 1.0, (4, h, w), np.float32),
            "vector": spaces.Box(-1.0, 1.0, (self._core.vector_len,), np.float32),
            "action_mask": spaces.MultiBinary(k),
        })
        self._obs_spaces = {a: self._obs_space for a in self.possible_agents}
        self._act_spaces = {a: spaces.Discrete(k) for a in self.possible_agents}

    def observation_space(self, agent: str):
        return self._obs_spaces[agent]

    def action_space(self, agent: str):
        return self._act_spaces[agent]

    def _observations(self) -> dict:
        obs = {}
        for i, a in enumerate(self.possible_agents):
            m, v, mask = self._core.observe(i)
            obs[a] = {"map": m, "vector": v, "action_mask": mask}
        return obs

    def _infos(self, team_reward: float, steps: int) -> dict:
        needs = self._core.needs_action()
        return {a: {"needs_action": bool(needs[i]), "team_reward": float(team_reward), "steps": int(steps), "t": int(self._core.t)}
                for i, a in enumerate(self.possible_agents)}

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._np_random, _ = seeding.np_random(seed)
            episode_seed = int(seed)
        else:
            episode_seed = int(self._np_random.integers(0, 2**63 - 1))
        self._core.reset(episode_seed)
        self.agents = self.possible_agents[:]
        return self._observations(), self._infos(0.0, 0)

    def step(self, actions: dict):
        if not self.agents:
            raise ValueError("step() after the episode ended; call reset()")
        acts = [int(actions.get(a, 0)) for a in self.possible_agents]
        rewards, team, steps, terminated, truncated = self._core.step(acts)
        obs = self._observations()
        infos = self._infos(team, steps)
        rew = {a: float(rewards[i]) for i, a in enumerate(self.possible_agents)}
        term = {a: bool(terminated) for a in self.possible_agents}
        trunc = {a: bool(truncated) for a in self.possible_agents}
        if terminated or truncated:
            self.agents = []
        return obs, rew, term, trunc, infos

    def metrics(self) -> dict:
        """The episode's metrics (TNS, TTD, NOLI, OFV, explored, completed); ends the episode."""
        return self._core.metrics()

    def render(self):
        return None

    def close(self):
        pass
