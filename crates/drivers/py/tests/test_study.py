"""madenet.compare against `madenet compare`, and madenet.ray.compare against madenet.compare."""

import csv
import subprocess

import numpy as np
import pytest
from conftest import assert_same_rows

import madenet

SMALL = dict(methods=["nf", "random"], maps=["paper:3", "generate:5"], starts=["top-left", "bottom-right"],
             csp=[1.0, 0.5], seeds=2, oracles=[])


def assert_same_table(a: dict, b: dict):
    assert list(a) == list(b)
    for column in a:
        if column in madenet.TIMING_COLUMNS:
            continue
        np.testing.assert_array_equal(a[column], b[column], err_msg=column)


def test_compare_matches_the_command_line(cli, tmp_path):
    config = tmp_path / "study.toml"
    config.write_text('methods = ["nf", "random"]\nmaps = ["paper:3", "generate:5"]\nstarts = ["top-left", "bottom-right"]\n'
                      'csp = [1.0, 0.5]\nseeds = 2\noracles = []\n')
    subprocess.run([cli, "compare", "--config", str(config), "--out", str(tmp_path / "cli")], check=True, capture_output=True)
    with open(tmp_path / "cli" / "trials.csv") as f:
        rows = list(csv.DictReader(f))
    table = madenet.compare(config)
    assert len(rows) == len(table["tns"]) == 2 * 2 * 2 * 2 * 2
    assert_same_rows(table, rows, 1e-6)
    # In memory (keyword fields) and into a folder (the CLI's outputs) give the same table.
    assert_same_table(madenet.compare(**SMALL, threads=1), table)
    into = madenet.compare(config, out=tmp_path / "py")
    assert_same_table(into, table)
    assert (tmp_path / "py" / "report.md").is_file()


def test_compare_never_writes_over_its_own_config(tmp_path):
    # As `madenet compare --config out/study.toml --out out`: refused before any trial.
    out = tmp_path / "out"
    out.mkdir()
    config = out / "study.toml"
    text = 'methods = ["nf"]\nmaps = ["paper:3"]\nstarts = ["top-left"]\ncsp = [1.0]\nseeds = 1\noracles = []\n'
    config.write_text(text)
    with pytest.raises(ValueError, match="is config's file"):
        madenet.compare(config, out=out, seeds=2)
    assert config.read_text() == text
    assert not (out / "trials.csv").exists()


def test_compare_as_a_dataframe():
    import pandas as pd  # in the [test] extra
    frame = madenet.compare(**SMALL, threads=1, as_dataframe=True)
    assert isinstance(frame, pd.DataFrame)
    assert_same_table({c: frame[c].to_numpy() for c in frame.columns}, madenet.compare(**SMALL, threads=1))


def test_compare_rejects_bad_fields():
    with pytest.raises(ValueError, match="no_such_field"):
        madenet.compare(no_such_field=1)
    with pytest.raises(ValueError, match="methods"):
        madenet.compare(methods=["no-such-method"])
    with pytest.raises(ValueError, match="csp"):
        madenet.compare(csp=[2.0], methods=["nf"])


def test_ray_compare_equals_the_local_study():
    ray = pytest.importorskip("ray")
    import madenet.ray
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        distributed = madenet.ray.compare(**SMALL, batch_size=5)
    finally:
        ray.shutdown()
    assert_same_table(distributed, madenet.compare(**SMALL))
