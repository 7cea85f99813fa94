"""PettingZoo environment over madenet's continuous world."""

from __future__ import annotations

import json

import numpy as np
from gymnasium import spaces

from madenet._config import path_or_none, scenario_overrides
from madenet._core import CoreContinuousEnv
from madenet._parallel import CoreParallelEnv


def _action(agent: str, value):
    """An action: ``None`` (the robot's own policy) or an integer candidate index."""
    if value is None:
        return None
    if isinstance(value, (bool, float)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"actions[{agent!r}]: expected a candidate index or None, got {value!r}")
    return int(value)


class ContinuousExplorationEnv(CoreParallelEnv):
    """The team exploring a continuous world — differential-drive robots, lidar, each robot's
    own occupancy grid read into 1 m cells, a local planner, time in seconds — as a PettingZoo
    ``ParallelEnv`` of macro actions.

    ``map``: ``"generate:SEED"`` (a cluttered world ``side`` metres square), ``"paper:N"`` or a
    map file at its native resolution; ``start``: a corner (``bottom-left`` …) or
    ``"r,c;r,c;r,c"`` (cells); ``policy``: the robots' own policy, which decides for a robot
    whose action is ``None`` (or missing); ``config``: a scenario TOML file, keyword arguments
    overriding its fields (``comm_success_prob=0.5``, ``num_robots=4``, …);
    ``continuous_config``: a TOML file of the world's parameters (robots, lidar, mapping,
    planner). Bad values raise ``ValueError`` naming the field.

    Observations and actions are ``ExplorationEnv``'s macro mode: per robot ``map`` (4 × H × W),
    ``vector`` and ``action_mask``; action k = go to goal candidate k. A step applies the
    actions of the robots whose macro action ended (``info["needs_action"]``) and runs the
    world until one ends again. The reward (each robot's, the team's) is the number of
    explorable cells the team newly knows; ``info["seconds"]`` is the simulated time the step
    took, ``info["time"]`` the time since the start. With every action ``None`` an episode is
    the trial ``madenet run --world continuous`` runs for the same seed.
    """

    metadata = {"name": "madenet_continuous_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, map: str = "generate:1", side: float = 20.0, start: str = "bottom-left",
                 policy: str = "nf", config: str | None = None, continuous_config: str | None = None,
                 **overrides):
        self.render_mode = None
        self._core = CoreContinuousEnv(map, float(side), start, policy, path_or_none(config),
                                       scenario_overrides(overrides),
                                       path_or_none(continuous_config, "continuous_config"))
        self._act_space = spaces.Discrete(self._start())

    def observation_space(self, agent: str):
        return self._obs_space

    def action_space(self, agent: str):
        return self._act_space

    def _infos(self, seconds: float) -> dict:
        needs = self._core.needs_action()
        now = float(self._core.time)
        return {a: {"needs_action": bool(needs[i]), "seconds": float(seconds), "time": now}
                for i, a in enumerate(self.possible_agents)}

    def reset(self, seed: int | None = None, options: dict | None = None):
        self._reset_core(seed)
        return self._observations(), self._infos(0.0)

    def step(self, actions: dict):
        if not self.agents:
            raise ValueError("step() after the episode ended; call reset()")
        acts = [_action(a, actions.get(a)) for a in self.possible_agents]
        team, seconds, terminated, truncated = self._core.step(acts)
        obs = self._observations()
        infos = self._infos(seconds)
        rew = {a: float(team) for a in self.possible_agents}
        return self._end_step(obs, rew, terminated, truncated, infos)

    def result(self) -> dict:
        """The episode as ``madenet run --world continuous --json`` prints it (ET, TTD,
        collisions, the explored fraction per second, …); ends the episode."""
        return json.loads(self._core.finish())

    def render(self):
        return None
