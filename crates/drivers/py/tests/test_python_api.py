"""CentralizedEnv (Gymnasium's checker), VectorEnv, render, the shipped policies in an env,
run_trial against the command line, and bad arguments."""

import json
import subprocess

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import madenet
from conftest import read_png_rgb


def without_timing(result: dict) -> dict:
    return {k: v for k, v in result.items() if k not in ("timing", "positions")}


# --- CentralizedEnv ---------------------------------------------------------------------------

@pytest.mark.parametrize("map_name", ["paper:3", "generate:7"])
def test_centralized_env_passes_gymnasium_check_env(map_name):
    env = madenet.CentralizedEnv(map=map_name, comm_success_prob=0.5)
    check_env(env, skip_render_check=True)
    check_env(madenet.CentralizedEnv(map=map_name, render_mode="rgb_array"))


def test_centralized_joint_mask_matches_the_robots_own_masks_and_episode_ends():
    env = madenet.CentralizedEnv(map="paper:4", start="bottom-left")
    per_robot = madenet.ExplorationEnv(map="paper:4", start="bottom-left")
    obs, info = env.reset(seed=3)
    pobs, pinfo = per_robot.reset(seed=3)
    g, n = per_robot.action_space("robot_0").n, len(per_robot.possible_agents)
    assert env.action_space.n == g ** n
    # At the first decision every robot decides: joint action a is valid iff each robot's part is.
    masks = [pobs[a]["action_mask"].astype(bool) for a in per_robot.possible_agents]
    assert sum(m.sum() for m in masks) > n, "some robot has a choice, so the digit order matters"
    for a in range(g ** n):
        parts = [(a // g ** i) % g for i in range(n)]
        assert bool(obs["action_mask"][a]) == all(masks[i][parts[i]] for i in range(n)), a
    # The merged vector is the robots' vectors in order.
    v = per_robot.observation_space("robot_0")["vector"].shape[0]
    for i, a in enumerate(per_robot.possible_agents):
        np.testing.assert_array_equal(obs["vector"][i * v:(i + 1) * v], pobs[a]["vector"])
    rng = np.random.default_rng(1)
    steps = 0
    while True:
        valid = np.flatnonzero(obs["action_mask"])
        assert len(valid) > 0
        obs, reward, term, trunc, info = env.step(int(rng.choice(valid)))
        steps += info["steps"]
        if term or trunc:
            break
    result = env.result()
    assert result["metrics"]["tns"] == steps


# --- render ------------------------------------------------------------------------------------

def test_render_is_the_frame_the_command_line_draws(cli, tmp_path):
    env = madenet.ExplorationEnv(map="paper:3", start="top-right", mode="primitive", render_mode="rgb_array", comm_success_prob=0.8)
    nf = madenet.policy("nf")
    env.reset(seed=2)
    first = env.render()
    assert first.dtype == np.uint8 and first.ndim == 3 and first.shape[2] == 3
    while env.agents:
        env.step(nf.act(env))
    frame = env.render()
    png = tmp_path / "final.png"
    subprocess.run([cli, "run", "--map", "paper:3", "--start", "top-right", "--policy", "nf", "--csp", "0.8", "--seed", "2",
                    "--snapshot", str(png)], check=True, capture_output=True)
    np.testing.assert_array_equal(frame, read_png_rgb(png))
    assert not np.array_equal(first, frame)


# --- policies ----------------------------------------------------------------------------------

@pytest.mark.parametrize("name,mode", [("nf", "primitive"), ("pb", "primitive"), ("made-net", "macro"), ("random", "macro")])
def test_a_shipped_policy_acting_in_the_env_reproduces_its_own_trial(name, mode):
    env = madenet.ExplorationEnv(map="paper:5", start="bottom-right", mode=mode, record=True, comm_success_prob=0.5)
    pi = madenet.policy(name)
    env.reset(seed=7)
    while env.agents:
        env.step(pi.act(env))
    got = env.result()
    want = madenet.run_trial(map="paper:5", start="bottom-right", policy=name, seed=7, trajectory=True, comm_success_prob=0.5)
    assert got["metrics"] == want["metrics"]
    assert got["trajectory"] == want["trajectory"]


def test_policies_in_the_wrong_mode_or_unknown_are_value_errors():
    assert {"nf", "ub", "pb", "spread", "made-net", "made-net-paper", "made-net-dt", "dme-drl"} <= set(madenet.policies())
    env = madenet.ExplorationEnv(mode="macro")
    env.reset(seed=1)
    with pytest.raises(ValueError, match="primitive"):
        madenet.policy("nf").act(env)
    with pytest.raises(ValueError, match="unknown"):
        madenet.policy("no-such-policy")


# --- run_trial and the command line ------------------------------------------------------------

def test_run_trial_gives_the_command_lines_trajectory_and_metrics(cli):
    args = ["--map", "generate:11", "--start", "bottom-left", "--policy", "ub", "--csp", "0.5", "--seed", "9"]
    out = subprocess.run([cli, "run", *args, "--json", "--trajectory"], check=True, capture_output=True, text=True).stdout
    from_cli = json.loads(out)
    from_python = madenet.run_trial(map="generate:11", start="bottom-left", policy="ub", seed=9, trajectory=True, comm_success_prob=0.5)
    assert without_timing(from_python) == without_timing(from_cli)
    assert from_python["positions"].shape == (len(from_cli["trajectory"]), 3, 2)


# --- VectorEnv ---------------------------------------------------------------------------------

def test_vector_env_writes_in_place_and_matches_single_environments():
    venv = madenet.VectorEnv(4, map="paper:6", mode="primitive", seed=5, comm_success_prob=0.8, step_cap=25)
    obs, info = venv.reset()
    buffers = [obs["map"], obs["vector"], obs["action_mask"], venv.rewards, venv.terminated]
    seeds = venv._core.episode_seeds()
    singles = []
    for s in seeds:
        e = madenet.ExplorationEnv(map="paper:6", mode="primitive", comm_success_prob=0.8, step_cap=25)
        e.reset(seed=s)
        singles.append(e)
    space = singles[0].observation_space("robot_0")
    rng = np.random.default_rng(3)
    ended = 0
    for _ in range(60):
        actions = rng.integers(0, 9, size=(4, 3))
        obs, rewards, term, trunc, info = venv.step(actions)
        assert all(a is b for a, b in zip([obs["map"], obs["vector"], obs["action_mask"], rewards, term], buffers))
        for k, e in enumerate(singles):
            o, r, te, tr, _ = e.step({a: int(actions[k, i]) for i, a in enumerate(e.possible_agents)})
            assert bool(term[k]) == te["robot_0"] and bool(trunc[k]) == tr["robot_0"]
            np.testing.assert_allclose(rewards[k], [r[a] for a in e.possible_agents], rtol=1e-6)
            if te["robot_0"] or tr["robot_0"]:
                # The vector env started its next episode at once; follow it.
                ended += 1
                o, _ = e.reset(seed=venv._core.episode_seeds()[k])
            for i, a in enumerate(e.possible_agents):
                np.testing.assert_array_equal(obs["map"][k, i], o[a]["map"])
                np.testing.assert_array_equal(obs["vector"][k, i], o[a]["vector"])
                np.testing.assert_array_equal(obs["action_mask"][k, i], o[a]["action_mask"])
                assert space.contains({"map": obs["map"][k, i], "vector": obs["vector"][k, i],
                                       "action_mask": obs["action_mask"][k, i]})
    assert ended >= 4  # every environment was truncated at the cap of 25 and went on


def test_vector_env_is_deterministic_and_checks_its_arguments():
    def run():
        venv = madenet.VectorEnv(3, map="generate:2", seed=9)
        venv.reset()
        rng = np.random.default_rng(0)
        for _ in range(400):
            venv.step(rng.integers(0, 9, size=(3, 3)))
        return venv.obs["map"].copy(), venv.obs["vector"].copy(), venv._core.episode_seeds()
    a, b = run(), run()
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    with pytest.raises(ValueError, match="num_envs"):
        madenet.VectorEnv(0)
    venv = madenet.VectorEnv(2)
    venv.reset()
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.zeros((2, 2), dtype=np.int64))
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.full((2, 3), 9))
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.zeros((3, 2), dtype=np.int64))
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.zeros((2, 3), dtype=np.float32))
    with pytest.raises(ValueError, match="num_envs"):
        madenet.VectorEnv(10**9)
    # reset(seed) starts the seed sequences over: the same first episodes as a fresh vector.
    fresh = madenet.VectorEnv(2, seed=4)
    fresh.reset()
    venv.reset(seed=4)
    np.testing.assert_array_equal(venv._core.episode_seeds(), fresh._core.episode_seeds())
    np.testing.assert_array_equal(venv.obs["map"], fresh.obs["map"])


def test_goal_and_idle_actions_and_their_errors():
    env = madenet.ExplorationEnv(map="paper:1", mode="primitive", record=True)
    obs, _ = env.reset(seed=1)
    # Robot 0 is sent to a known free cell two steps away, the others stay.
    m = obs["robot_0"]["map"]
    h, w = m.shape[1:]
    v = obs["robot_0"]["vector"]
    here = (round(float(v[0]) * (h - 1)), round(float(v[1]) * (w - 1)))  # own position, normalised
    free = np.argwhere((m[0] == 1) & (m[1] == 0))
    robots = np.argwhere(m[2] == 1)
    # Two steps away, as far from the (idle) teammates as possible, so that none is in the way.
    ring = [tuple(int(x) for x in p) for p in free if max(abs(p[0] - here[0]), abs(p[1] - here[1])) == 2]
    goal = max(ring, key=lambda g: min(max(abs(g[0] - r[0]), abs(g[1] - r[1])) for r in robots))
    for _ in range(6):
        env.step({"robot_0": goal, "robot_1": None, "robot_2": None})
    traj = env.result()["trajectory"]
    assert all(s["goals"][0] == {"row": goal[0], "col": goal[1]} for s in traj)
    assert all(s["goals"][1] is None and s["goals"][2] is None for s in traj)
    assert {"row": goal[0], "col": goal[1]} in [s["positions"][0] for s in traj]
    env = madenet.ExplorationEnv(map="paper:1", mode="macro")
    env.reset(seed=1)
    with pytest.raises(ValueError, match="outside"):
        env.step({"robot_0": (99, 99), "robot_1": None, "robot_2": None})
    with pytest.raises(ValueError, match="action"):
        env.step({"robot_0": "north"})
    with pytest.raises(ValueError, match="render_mode"):
        madenet.ExplorationEnv(render_mode="human")


def test_an_episode_over_at_its_start_ends_at_the_first_step(tmp_path):
    """A 4 × 4 open map seen whole from the start cells (no sensor misses): every environment
    reports the end at its first step instead of raising, and a VectorEnv keeps stepping."""
    grid = tmp_path / "open.txt"
    grid.write_text("....\n....\n....\n....\n")
    kw = dict(map=str(grid), start="0,0;0,1;1,0", sensor_miss_prob=0.0)
    for mode in ("primitive", "macro"):
        env = madenet.ExplorationEnv(mode=mode, **kw)
        env.reset(seed=1)
        assert env.agents, mode
        _, rewards, terms, truncs, infos = env.step({a: 0 for a in env.agents})
        assert all(terms.values()) and not any(truncs.values()) and not env.agents, mode
        assert set(rewards.values()) == {0.0} and infos["robot_0"]["steps"] == 0, mode
        with pytest.raises(ValueError):
            env.step({a: 0 for a in env.possible_agents})
        venv = madenet.VectorEnv(2, mode=mode, seed=3, **kw)
        venv.reset()
        for _ in range(3):
            venv.step(np.zeros((2, 3), dtype=np.int64))
            assert venv.terminated.all(), mode
    cenv = madenet.CentralizedEnv(**kw)
    cenv.reset(seed=1)
    _, team, terminated, truncated, info = cenv.step(0)
    assert terminated and not truncated and team == 0.0 and info["steps"] == 0
    with pytest.raises(ValueError):
        cenv.step(0)
