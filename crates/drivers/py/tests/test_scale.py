"""madenet.scale against `madenet scale` (grid and continuous world), and madenet.ray.scale
against madenet.scale."""

import csv
import subprocess

import pytest
from conftest import assert_same_rows

import madenet

GRID = dict(methods=["nf", "spread"], sides=[20, 30], teams=[2, 3], seeds=1)
CONTINUOUS = dict(world="continuous", methods=["spread"], sides=[12], teams=[2], seeds=1)


def cli_rows(cli, tmp_path, name, flags):
    out = tmp_path / name
    subprocess.run([cli, "scale", "--out", str(out), "--threads", "2", *flags], check=True, capture_output=True)
    with open(out / "trials.csv") as f:
        return list(csv.DictReader(f))


def test_scale_matches_the_command_line_grid_and_continuous(cli, tmp_path):
    rows = cli_rows(cli, tmp_path, "grid", ["--methods", "nf,spread", "--sides", "20,30", "--teams", "2,3", "--seeds", "1"])
    table = madenet.scale(**GRID, threads=2)
    # (methods + the known-map reference) × sides × maps per side × teams × starts
    assert len(rows) == (2 + 1) * 2 * 4 * 2 * 3
    assert_same_rows(table, rows, 1e-9, extra=("side", "team"))
    assert sorted(set(table["side"])) == [20, 30] and sorted(set(table["team"])) == [2, 3]
    rows = cli_rows(cli, tmp_path, "continuous",
                    ["--world", "continuous", "--methods", "spread", "--sides", "12", "--teams", "2", "--seeds", "1"])
    table = madenet.scale(**CONTINUOUS, threads=2)
    assert len(rows) == 3 and "et_s" in table
    assert_same_rows(table, rows, 1e-9, extra=("side", "team"))


def test_scale_rejects_bad_fields():
    with pytest.raises(ValueError, match="no_such_field"):
        madenet.scale(no_such_field=1)
    with pytest.raises(ValueError, match="methods"):
        madenet.scale(methods=["no-such-method"])


def test_ray_scale_equals_the_local_study():
    ray = pytest.importorskip("ray")
    import madenet.ray
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        grid = madenet.ray.scale(**GRID, batch_size=5)
        continuous = madenet.ray.scale(**CONTINUOUS, batch_size=2)
    finally:
        ray.shutdown()
    for distributed, local in ((grid, madenet.scale(**GRID)), (continuous, madenet.scale(**CONTINUOUS))):
        assert list(distributed) == list(local)
        for column in local:
            if column in madenet.TIMING_COLUMNS:
                continue
            assert list(distributed[column]) == list(local[column]), column
