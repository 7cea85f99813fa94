"""The shipped policies, acting in an ``ExplorationEnv``."""

from __future__ import annotations

from madenet import _core


def policies() -> dict:
    """Every shipped policy: name → description."""
    return dict(_core.policies())


class Policy:
    """A shipped policy (``nf``, ``ub``, ``pb``, ``made-net``, ``made-net-dt``, ``dme-drl``,
    ``random``): ``act(env)`` returns each robot's action, decided from that robot's own view
    (its map, teammate records and goal candidates — what its observation encodes), as the
    policy does in ``madenet run``. Pass the actions to ``env.step`` every step: the policy's
    instances keep their state (recurrent memory, frame history) through the episode and
    start afresh when the environment resets, so the trajectory is the policy's own.

    Actions are candidate indices for policies that choose among goal candidates, ``(row, col)``
    goal cells for those that pick any cell (NF, UB, PB, DME-DRL), and ``None`` for "stay".
    Policies that decide every timestep act in ``mode="primitive"`` environments, those that
    decide when their macro action terminates (MADE-Net, random) in ``mode="macro"``; the wrong
    mode raises ``ValueError`` saying which to use.

    Call ``act`` once per step: each call is a decision of the policy's instances (it advances
    their random streams and recurrent memory).
    """

    def __init__(self, name: str):
        known = policies()
        if name not in known:
            raise ValueError(f"policy: unknown `{name}`; known: {', '.join(known)}")
        self.name = name
        self.description = known[name]

    def act(self, env) -> dict:
        core = getattr(env, "_core", None)
        if core is None or not hasattr(core, "policy_actions"):
            raise ValueError("env: expected a madenet.ExplorationEnv")
        actions = core.policy_actions(self.name)
        return {a: actions[i] for i, a in enumerate(env.possible_agents)}

    def __repr__(self) -> str:
        return f"madenet.Policy({self.name!r})"


def policy(name: str) -> Policy:
    """The shipped policy ``name`` (see ``madenet.policies()``)."""
    return Policy(name)
