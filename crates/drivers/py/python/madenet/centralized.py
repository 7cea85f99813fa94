"""Gymnasium environment of the whole team under one centralized policy."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from madenet._config import check_render, path_or_none, scenario_overrides
from madenet._core import CoreEnv


class CentralizedEnv(gym.Env):
    """The team as one agent: what the CEP of MADE-Net's centralized training sees and does.

    Action: the joint macro action ``Discrete(|G|^|I|)``, a = Σ k_i·|G|^i with k_i robot i's
    goal candidate. At a step only the robots whose macro action terminated take their part;
    the others' part must be 0 (the mask says so). Observation: ``map`` (the team's merged map
    image: explored, obstacles, every robot's position, every robot's goal candidates),
    ``vector`` (every robot's macro observation in robot order) and ``action_mask`` (int8 over
    the joint actions; a robot without candidates may only take slot 0, "stay"). Reward: Eq. (8),
    the team reward, summed over the timesteps a step advances. Arguments as for
    ``madenet.ExplorationEnv``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(self, map: str = "paper:1", start: str = "top-left", config: str | None = None,
                 render_mode: str | None = None, cell_px: int = 16, **overrides):
        check_render(render_mode, cell_px, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.cell_px = cell_px
        self._core = CoreEnv(map, start, "macro", path_or_none(config), scenario_overrides(overrides), True, False)
        joint = self._core.joint_action_count
        if joint > 1 << 24:
            raise ValueError(f"num_robots: {joint} joint actions (|G|^|I|) are too many for a Discrete space")
        h, w = self._core.height, self._core.width
        self.observation_space = spaces.Dict({
            "map": spaces.Box(0.0, 1.0, (4, h, w), np.float32),
            "vector": spaces.Box(-1.0, 1.0, (self._core.joint_vector_len,), np.float32),
            "action_mask": spaces.MultiBinary(joint),
        })
        self.action_space = spaces.Discrete(joint)

    def _obs(self) -> dict:
        m, v, mask = self._core.observe_joint()
        return {"map": m, "vector": v, "action_mask": mask}

    def _info(self, steps: int) -> dict:
        return {"needs_action": np.array(self._core.needs_action(), dtype=bool), "steps": int(steps), "t": int(self._core.t)}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        episode_seed = int(seed) if seed is not None else int(self.np_random.integers(0, 2**63 - 1))
        self._core.reset(episode_seed)
        return self._obs(), self._info(0)

    def step(self, action):
        # A step after the episode's reported end raises ValueError (from the core); an episode
        # over at its start ends at its first step.
        team, steps, terminated, truncated = self._core.step_joint(int(action))
        return self._obs(), float(team), bool(terminated), bool(truncated), self._info(steps)

    def result(self) -> dict:
        """The episode as ``madenet run --json`` prints it; ends the episode."""
        import json
        return json.loads(self._core.finish())

    def render(self):
        if self.render_mode is None:
            return None
        return self._core.render(self.cell_px)
