"""The continuous world as a PettingZoo environment: the peers' API test, the robots' own policies
giving the command line's trial, outside actions obeyed, bad input refused."""

import json
import subprocess

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import madenet

KW = dict(map="generate:3", side=12, start="bottom-left", policy="nf")


def test_parallel_api():
    parallel_api_test(madenet.ContinuousExplorationEnv(**KW), num_cycles=60)


def test_own_policies_give_the_command_lines_trial(cli):
    env = madenet.ContinuousExplorationEnv(**KW)
    obs, infos = env.reset(seed=5)
    steps, reward, seconds = 0, 0.0, 0.0
    while env.agents:
        obs, rewards, term, trunc, infos = env.step({a: None for a in env.agents})
        steps += 1
        reward += rewards["robot_0"]
        seconds += infos["robot_0"]["seconds"]
    got = env.result()
    out = subprocess.run([cli, "run", "--world", "continuous", "--generate", "3", "--side", "12",
                          "--start", "bottom-left", "--policy", "nf", "--seed", "5", "--json"],
                         check=True, capture_output=True, text=True)
    want = json.loads(out.stdout)
    got.pop("wall_s")
    want.pop("wall_s")
    assert got == want
    assert steps > 10
    assert abs(seconds - want["exploration_time_s"]) < 1.0
    assert reward > 0.5 * want["explorable_cells"]


def test_outside_actions_are_taken():
    env = madenet.ContinuousExplorationEnv(**KW)
    obs, infos = env.reset(seed=5)
    rng = np.random.default_rng(1)
    while env.agents:
        actions = {}
        for a in env.agents:
            valid = np.flatnonzero(obs[a]["action_mask"])
            actions[a] = int(rng.choice(valid)) if infos[a]["needs_action"] and len(valid) else None
        obs, rewards, term, trunc, infos = env.step(actions)
    random_team = env.result()
    env.reset(seed=5)
    while env.agents:
        env.step({})
    own = env.result()
    assert random_team["distance"] != own["distance"]
    assert random_team["obstacle_collisions"] + random_team["robot_collisions"] == 0


def test_bad_input_is_refused_naming_the_field(tmp_path):
    with pytest.raises(ValueError, match="side"):
        madenet.ContinuousExplorationEnv(map="generate:3", side=1)
    with pytest.raises(ValueError, match="start"):
        madenet.ContinuousExplorationEnv(map="generate:3", side=12, start="nowhere")
    with pytest.raises(ValueError, match="comm_success_prob"):
        madenet.ContinuousExplorationEnv(map="generate:3", side=12, comm_success_prob=2.0)
    bad = tmp_path / "world.toml"
    bad.write_text("[robot]\nmax_speed = -1.0\n")
    with pytest.raises(ValueError, match="max_speed"):
        madenet.ContinuousExplorationEnv(map="generate:3", side=12, continuous_config=bad)
    with pytest.raises(ValueError, match="continuous_config"):
        madenet.ContinuousExplorationEnv(map="generate:3", side=12, continuous_config=3)
    env = madenet.ContinuousExplorationEnv(**KW)
    env.reset(seed=1)
    with pytest.raises(ValueError, match="actions"):
        env.step({"robot_0": env.action_space("robot_0").n})
