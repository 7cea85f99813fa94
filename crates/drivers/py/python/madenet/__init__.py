"""madenet: decentralized multi-robot exploration (MADE-Net, Tan et al., RA-L 2023) with a fast
simulator in Rust.

* ``ExplorationEnv`` — a PettingZoo ``ParallelEnv`` over the real world: macro actions (choose
  goal candidate k) or primitive moves, the paper's rewards, the same trajectories as the
  ``madenet`` command line for the same seed and decisions;
* ``ContinuousExplorationEnv`` — the same agents' macro actions in the continuous world
  (differential-drive robots, lidar maps, a local planner, seconds), as a PettingZoo
  ``ParallelEnv``;
* ``CentralizedEnv`` — a Gymnasium ``Env`` of the whole team (joint macro action, merged
  observation);
* ``VectorEnv`` — N environments stepped together in Rust into preallocated numpy arrays;
* ``policy(name)`` — the shipped policies (NF, UB, PB, MADE-Net, DME-DRL, …) acting in an env;
* ``run_trial``, ``compare`` and ``scale`` — one trial, the comparison study and the
  scalability study (grid or continuous world); ``madenet.ray.compare`` and
  ``madenet.ray.scale`` fan them out over a Ray cluster.
"""

from madenet._core import __version__
from madenet.centralized import CentralizedEnv
from madenet.continuous import ContinuousExplorationEnv
from madenet.env import ExplorationEnv
from madenet.policies import Policy, policies, policy
from madenet.study import TIMING_COLUMNS, compare, run_trial, scale, table
from madenet.vector import VectorEnv

__all__ = ["CentralizedEnv", "ContinuousExplorationEnv", "ExplorationEnv", "Policy", "TIMING_COLUMNS", "VectorEnv", "__version__", "compare",
           "policies", "policy", "run_trial", "scale", "table"]
