"""One trial and the comparison study, from Python."""

from __future__ import annotations

import json
import os

import numpy as np

from madenet import _core
from madenet._config import path_or_none, scenario_overrides, study_overrides

#: Columns whose values are wall-clock times (they differ between runs; everything else is
#: determined by the configuration and seeds).
TIMING_COLUMNS = ("trial_s", "per_decision_s")


def run_trial(map: str = "paper:1", start: str = "top-left", policy: str = "nf", seed: int = 1,
              config: str | None = None, trajectory: bool = False, **overrides) -> dict:
    """One trial, as ``madenet run --json [--trajectory]`` prints it: ``metrics``, ``timing``,
    and with ``trajectory=True`` one record per timestep. Also ``positions``: the robots' cells
    per timestep as an int array ``[T, num_robots, 2]`` (with ``trajectory=True``).
    Scenario fields as keyword arguments (``comm_success_prob=0.8`` …)."""
    text = _core.run_trial(map, start, policy, int(seed), path_or_none(config), scenario_overrides(overrides), bool(trajectory))
    result = json.loads(text)
    if trajectory:
        result["positions"] = np.array([[[p["row"], p["col"]] for p in step["positions"]] for step in result["trajectory"]],
                                       dtype=np.int64).reshape(-1, len(result["starts"]), 2)
    return result


def table(rows: list, as_dataframe: bool = False, columns: list | None = None):
    """Rows (dicts with the columns of ``trials.csv``) → a dict of numpy arrays, column by
    column in ``trials.csv``'s order (or ``columns``'), or a pandas DataFrame."""
    columns = _core.CoreStudy.columns() if columns is None else columns
    data = {c: np.array([r[c] for r in rows]) for c in columns}
    if as_dataframe:
        import pandas as pd
        return pd.DataFrame(data)
    return data


def compare(config=None, out: str | os.PathLike | None = None, threads: int | None = None, fresh: bool = False,
            as_dataframe: bool = False, **fields):
    """The comparison study (``madenet compare``): ``config`` is a study TOML file (see
    ``configs/study.toml``) or a dict of its fields, keyword arguments override fields
    (``methods=["nf", "made-net"]``, ``maps=["paper:3"]``, ``csp=[1.0]``, ``seeds=2`` …).
    Returns the per-trial table (``table``: the columns of ``trials.csv``; ``to_N`` is −1 where
    the coverage was never reached). With ``out``, the study runs exactly as ``madenet compare
    --out OUT`` (every report file written there, resumable); otherwise in memory on
    ``threads`` threads (all cores by default)."""
    path, extra = study_overrides(config, fields)
    study = _core.CoreStudy(path, extra)
    if out is not None:
        _report, rows = study.run_to(os.fspath(out), bool(fresh))
    else:
        rows = study.run(None, threads)
    return table(rows, as_dataframe)


def scale(config=None, threads: int | None = None, as_dataframe: bool = False, **fields):
    """The scalability study's trials (``madenet scale``): ``config`` is a scale TOML file (see
    ``configs/scale.toml``) or a dict of its fields, keyword arguments override fields
    (``world="continuous"``, ``methods=["nf", "spread"]``, ``sides=[20]``, ``teams=[2, 4]``,
    ``seeds=1`` …; ``world="continuous"`` without a file starts from the continuous study's
    defaults, as ``madenet scale --world continuous`` does). Runs in memory on ``threads``
    threads (all cores by default) and returns one row per trial: ``side``, ``team``, then the
    columns of the study's ``trials.csv`` (a continuous study's include ``et_s`` and the
    collisions) — the same values as ``madenet scale`` writes for the same configuration and
    seeds, wall-clock columns aside. The report, figure and grid twin are ``madenet scale``'s."""
    path, extra = study_overrides(config, fields)
    study = _core.CoreScale(path, extra)
    return table(study.run(None, threads), as_dataframe, study.columns())
