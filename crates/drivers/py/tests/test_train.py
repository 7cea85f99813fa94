"""The rollout learner with its episodes collected elsewhere: by a Python function, and as Ray
tasks (`madenet.ray.train`) — the same run as `madenet train` with the same config."""

import json
import subprocess

import pytest

from madenet import _core

# A tiny agnostic run with the redrawn teacher and expert iteration (a student becomes the
# teacher's base within four iterations), so the base's weights travel to the workers too.
TINY = """
method = "made-net-rollout"
seed = 1
episodes = 16  # 4 an iteration
iterations = 4
max_minutes = 0.0
map_side_max = 24
team_max = 3
base_policy = "spread"
expert_iteration = true
patience = 0
floorplan_prob = 0.25
futures = "redrawn"
horizon = 60
value = "mean-discovery"
rollouts = 2
network = "agnostic"
observation = "candidate-features"
updates_per_iteration = 20
batch_size = 16
recurrent = false
spread_margins = [0.1]
validation_maps = 4
validation_csp = [1.0, 0.5, 0.0]
threads = 2

[scenario]
num_robots = 2
step_cap = 120
"""


def run_summary(out):
    """What makes the run: iterations.csv without wall time, the dataset, the counters."""
    rows = [line.rsplit(",", 1)[0] for line in (out / "iterations.csv").read_text().splitlines()]
    state = json.loads((out / "checkpoint" / "state.json").read_text())
    state.pop("wall_s")
    return rows, (out / "checkpoint" / "data.bin").read_bytes(), state


@pytest.fixture(scope="module")
def local(cli, tmp_path_factory):
    root = tmp_path_factory.mktemp("train")
    (root / "tiny.toml").write_text(TINY)
    subprocess.run([cli, "train", "--config", str(root / "tiny.toml"), "--out", str(root / "cli")],
                   check=True, capture_output=True)
    return root, run_summary(root / "cli")


def test_episodes_collected_by_a_python_function_give_the_cli_run(local):
    root, want = local
    calls = []

    sizes = []

    def collect(config_toml, iteration, batches):
        calls.append(len(batches))
        sizes.append((len(iteration), max(len(b) for b in batches)))
        return [_core.collect_rollout(config_toml, iteration, b, 1) for b in batches]

    _core.train_rollout(str(root / "py"), str(root / "tiny.toml"), collect, 3)
    assert calls == [2, 2, 2, 2], "4 episodes an iteration in batches of 3"
    # The students' weights travel once an iteration, beside the batches: a batch is its
    # episode indices only; from the second iteration on the iteration carries a student.
    assert all(batch < 32 for _, batch in sizes), sizes
    assert sizes[0][0] < 64 and all(it > 1000 for it, _ in sizes[1:]), sizes
    rows, data, state = run_summary(root / "py")
    assert len(rows) == 5 and state["iteration"] == 4
    assert "student@" in rows[-1], "expert iteration: the teacher's base became a student"
    assert (rows, data, state) == want


def test_a_collector_that_fails_is_an_error(local):
    root, _ = local

    def short(config_toml, iteration, batches):
        return [_core.collect_rollout(config_toml, iteration, b, 1) for b in batches[1:]]

    with pytest.raises(ValueError, match="collector returned 1 batches for 2"):
        _core.train_rollout(str(root / "short"), str(root / "tiny.toml"), short, 3)
    def boom(config_toml, iteration, batches):
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        _core.train_rollout(str(root / "boom"), str(root / "tiny.toml"), boom, 3)

    def swapped(config_toml, iteration, batches):
        return [_core.collect_rollout(config_toml, iteration, b, 1) for b in reversed(batches)]

    with pytest.raises(ValueError, match=r"batch 0: episodes \[2, 3\], asked for \[0, 1\]"):
        _core.train_rollout(str(root / "swapped"), str(root / "tiny.toml"), swapped, 2)
    with pytest.raises(ValueError, match="a collect request"):
        _core.collect_rollout(TINY, b"\xff\xff", b"", 1)
    with pytest.raises(ValueError, match="config: needed for a new run"):
        _core.train_rollout(str(root / "none"), None, None, 3)
    with pytest.raises(ValueError, match="collect: must be callable"):
        _core.train_rollout(str(root / "nc"), str(root / "tiny.toml"), 3, 3)
    with pytest.raises(ValueError, match="batch_size"):
        _core.train_rollout(str(root / "zero"), str(root / "tiny.toml"), short, 0)


def test_ray_train_equals_the_cli_run(local):
    ray = pytest.importorskip("ray")
    import madenet.ray
    root, want = local
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        madenet.ray.train(root / "ray", config=root / "tiny.toml", batch_size=1)
    finally:
        ray.shutdown()
    assert run_summary(root / "ray") == want


def test_ctrl_c_stops_training_and_the_run_resumes(tmp_path):
    """Ctrl-C (SIGINT) while Rust trains: the call stops at its next check and raises
    KeyboardInterrupt; the run stays resumable (no config needed again)."""
    import signal
    import sys
    import time

    long = TINY.replace("updates_per_iteration = 20", "updates_per_iteration = 1000000")
    (tmp_path / "long.toml").write_text(long)
    out = tmp_path / "run"
    script = (
        "import signal, sys\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from madenet import _core\n"
        "try:\n"
        f"    _core.train_rollout({str(out)!r}, {str(tmp_path / 'long.toml')!r})\n"
        "except KeyboardInterrupt as e:\n"
        "    print('KeyboardInterrupt', e, flush=True)\n"
        "    sys.exit(130)\n"
    )
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while not (out / "config.toml").exists():
        assert time.time() < deadline and child.poll() is None, child.communicate()
        time.sleep(0.1)
    time.sleep(2.0)  # into the first iteration: collecting, then a million updates
    child.send_signal(signal.SIGINT)
    t0 = time.time()
    stdout, stderr = child.communicate(timeout=60)
    assert child.returncode == 130, stderr
    assert "KeyboardInterrupt" in stdout
    assert time.time() - t0 < 30, "stopped at its next check"
    # The run is there to resume (`train_rollout(out)` without a config): its config kept,
    # no half-written checkpoint.
    assert (out / "config.toml").is_file()
    assert not any(p.name.endswith((".tmp", ".old")) for p in out.iterdir()), list(out.iterdir())
