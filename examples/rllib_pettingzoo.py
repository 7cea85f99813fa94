"""Training one parameter-shared policy for every robot with RLlib (PPO) on madenet's
ExplorationEnv, through RLlib's ParallelPettingZooEnv wrapper.

NOT run in CI: RLlib pulls in PyTorch (several GB). To try it:

    pip install ./crates/drivers/py "ray[rllib]" torch
    python examples/rllib_pettingzoo.py --iterations 20

The env is macro mode on generated maps (never the paper's evaluation maps); robots whose macro
action is still running ignore their action (`info["needs_action"]`), which plain PPO treats as
noise — fine for a demonstration. RLlib's default models take no Dict observations, so the
`FlattenObservations` connector flattens map, vector and mask into one feature vector; invalid
choices are tolerated by the env (the robot stays and decides again), while true action masking
needs an RLModule that reads `obs["action_mask"]` (see RLlib's action-masking example).

Checked with ray 2.60 (new API stack) and torch 2.15 on CPU.
"""

import argparse

import madenet


def make_env(config: dict):
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv
    seed = int(config.get("map_seed", 0)) + getattr(config, "worker_index", 0)
    return ParallelPettingZooEnv(madenet.ExplorationEnv(map=f"generate:{seed}", mode="macro"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--iterations", type=int, default=10)
    args = ap.parse_args()
    import ray
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.connectors.env_to_module import FlattenObservations
    from ray.tune.registry import register_env

    ray.init()
    register_env("madenet", make_env)
    config = (
        PPOConfig()
        .environment("madenet", env_config={"map_seed": 100})
        .multi_agent(
            # One policy shared by every robot (parameter sharing).
            policies={"shared"},
            policy_mapping_fn=lambda agent_id, *a, **k: "shared",
        )
        .env_runners(
            num_env_runners=1,
            env_to_module_connector=lambda env, spaces, device: FlattenObservations(multi_agent=True),
        )
        .training(train_batch_size=2000)
    )
    algo = config.build_algo()
    for i in range(args.iterations):
        result = algo.train()
        ret = result.get("env_runners", {}).get("episode_return_mean")
        print(f"iteration {i + 1}: mean episode return {ret}")
    algo.stop()
    ray.shutdown()


if __name__ == "__main__":
    main()
