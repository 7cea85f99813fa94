"""madenet: decentralized multi-robot exploration (MADE-Net, Tan et al., RA-L 2023) with a fast
simulator in Rust.

``ExplorationEnv`` is a PettingZoo ``ParallelEnv`` over the real world (``madenet._core``): macro
actions (choose goal candidate k) or primitive moves, the paper's rewards, the same trajectories
as the ``madenet`` command line for the same seed and decisions.
"""

from madenet._core import __version__
from madenet.env import ExplorationEnv

__all__ = ["ExplorationEnv", "__version__"]
