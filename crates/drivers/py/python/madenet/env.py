"""PettingZoo environment over madenet's simulator."""

from __future__ import annotations

import json

from gymnasium import spaces

from madenet._config import check_render, path_or_none, scenario_overrides
from madenet._core import CoreEnv
from madenet._parallel import CoreParallelEnv


class ExplorationEnv(CoreParallelEnv):
    """The team of robots exploring one map, as a PettingZoo ``ParallelEnv``.

    ``map``: ``"paper:N"`` (the paper's maps 1-10), ``"generate:SEED"`` or a ROS map YAML path;
    ``start``: a corner (``top-left`` …) or ``"r,c;r,c;r,c"``; ``mode``: ``"macro"`` (action k =
    go to goal candidate k; robots whose macro action is still running have
    ``info["needs_action"] = False`` and their action is ignored) or ``"primitive"`` (one of 9
    moves every timestep: stay, N, NE, E, SE, S, SW, W, NW; a move the mask forbids keeps the robot
    in place); ``config``: a scenario TOML file; keyword arguments override its fields
    (``comm_success_prob=0.5``, ``num_robots=3``, …). Bad values raise ``ValueError`` naming the
    field.

    Observations per robot: ``map`` (4 × H × W binary image: explored, obstacles, robots, goal
    candidates), ``vector`` (the macro observation, Sec. III.C.1) and ``action_mask`` (int8).
    In primitive mode the goal candidates are left out (channel 3 zero, candidate slots −1)
    unless ``candidates=True``: extracting them costs more than the step. Rewards are Eq. (7) per
    robot, summed over the timesteps a step advances; Eq. (8), the team reward, is in
    ``info["team_reward"]``.

    Besides indices, ``step`` accepts ``None`` (stay) and ``(row, col)`` (go to that cell, the
    world's navigator plans the path) per robot: what the shipped policies of
    ``madenet.policy(name).act(env)`` return. ``record=True`` keeps the trajectory for
    ``result()``. ``render_mode="rgb_array"``: ``render()`` returns the frame ``madenet run
    --render`` draws (``cell_px`` pixels per cell).
    """

    metadata = {"name": "madenet_exploration_v0", "render_modes": ["rgb_array"], "render_fps": 4, "is_parallelizable": True}

    def __init__(self, map: str = "paper:1", start: str = "top-left", mode: str = "macro",
                 config: str | None = None, render_mode: str | None = None, candidates: bool = False,
                 record: bool = False, cell_px: int = 16, **overrides):
        check_render(render_mode, cell_px, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.cell_px = cell_px
        self._core = CoreEnv(map, start, mode, path_or_none(config), scenario_overrides(overrides), bool(candidates), bool(record))
        self.mode = mode
        self.max_cycles = None
        k = self._start()
        self._obs_spaces = {a: self._obs_space for a in self.possible_agents}
        self._act_spaces = {a: spaces.Discrete(k) for a in self.possible_agents}

    def observation_space(self, agent: str):
        return self._obs_spaces[agent]

    def action_space(self, agent: str):
        return self._act_spaces[agent]

    def _infos(self, team_reward: float, steps: int) -> dict:
        needs = self._core.needs_action()
        return {a: {"needs_action": bool(needs[i]), "team_reward": float(team_reward), "steps": int(steps), "t": int(self._core.t)}
                for i, a in enumerate(self.possible_agents)}

    def reset(self, seed: int | None = None, options: dict | None = None):
        self._reset_core(seed)
        return self._observations(), self._infos(0.0, 0)

    def step(self, actions: dict):
        if not self.agents:
            raise ValueError("step() after the episode ended; call reset()")
        acts = [actions.get(a, 0) for a in self.possible_agents]
        rewards, team, steps, terminated, truncated = self._core.step(acts)
        obs = self._observations()
        infos = self._infos(team, steps)
        rew = {a: float(rewards[i]) for i, a in enumerate(self.possible_agents)}
        return self._end_step(obs, rew, terminated, truncated, infos)

    def result(self) -> dict:
        """The episode as ``madenet run --json`` prints it (metrics, timing, and the trajectory
        with ``record=True``); ends the episode."""
        return json.loads(self._core.finish())

    def metrics(self) -> dict:
        """The episode's metrics (TNS, TTD, NOLI, OFV, explored, completed, …); ends the episode."""
        return self.result()["metrics"]

    def render(self):
        if self.render_mode is None:
            return None
        return self._core.render(self.cell_px)
