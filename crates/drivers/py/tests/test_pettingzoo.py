"""The peers' own test suites on ExplorationEnv, in both modes, on a paper map and a generated one."""

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test
from pettingzoo.utils.conversions import parallel_to_aec

import madenet

CASES = [("paper:3", "macro"), ("paper:3", "primitive"), ("generate:7", "macro"), ("generate:7", "primitive")]


@pytest.mark.parametrize("map_name,mode", CASES)
def test_parallel_api(map_name, mode):
    parallel_api_test(madenet.ExplorationEnv(map=map_name, mode=mode, comm_success_prob=0.5), num_cycles=1000)


@pytest.mark.parametrize("map_name,mode", CASES)
def test_aec_api(map_name, mode):
    api_test(parallel_to_aec(madenet.ExplorationEnv(map=map_name, mode=mode)), num_cycles=200)


@pytest.mark.parametrize("map_name,mode", CASES)
def test_seed(map_name, mode):
    parallel_seed_test(lambda: madenet.ExplorationEnv(map=map_name, mode=mode, comm_success_prob=0.5))


def test_macro_episode_runs_to_completion_with_masked_random_actions():
    env = madenet.ExplorationEnv(map="paper:2", start="top-right")
    obs, infos = env.reset(seed=4)
    rng = np.random.default_rng(0)
    total = 0
    while env.agents:
        actions = {}
        for a in env.agents:
            valid = np.flatnonzero(obs[a]["action_mask"])
            actions[a] = int(rng.choice(valid)) if infos[a]["needs_action"] and len(valid) else 0
        obs, rewards, term, trunc, infos = env.step(actions)
        total += infos["robot_0"]["steps"]
    m = env.metrics()
    assert m["tns"] == total
    assert 0.0 <= m["explored"] <= 1.0


def test_bad_arguments_are_value_errors_naming_the_field():
    with pytest.raises(ValueError, match="comm_success_prob"):
        madenet.ExplorationEnv(comm_success_prob=2.0)
    with pytest.raises(ValueError, match="mode"):
        madenet.ExplorationEnv(mode="continuous")
    with pytest.raises(ValueError, match="map"):
        madenet.ExplorationEnv(map="paper:11")
    with pytest.raises(ValueError, match="no_such_field"):
        madenet.ExplorationEnv(no_such_field=1)
    env = madenet.ExplorationEnv()
    env.reset(seed=1)
    with pytest.raises(ValueError, match="action"):
        env._core.step([99, 0, 0])
