"""The comparison and scalability studies, and the rollout learner's episodes, fanned out as Ray
tasks (``pip install 'madenet[ray]'``)."""

from __future__ import annotations

import math

from madenet._config import study_overrides
from madenet.study import table

_remote = None
_remote_collect = None


def _connect(address: str | None) -> None:
    """Ray at ``address`` (``None``: the running instance, or a new local one)."""
    import ray

    if not ray.is_initialized():
        ray.init(address=address)
    elif address is not None:
        raise ValueError("address: Ray is already initialized here; call ray.shutdown() first or pass address=None")


def _run_batch(kind: str, config_toml: str, indices: list) -> list:
    # Runs inside a Ray worker: the study is rebuilt from its TOML text there, so no Rust
    # object is ever pickled; one thread per task, Ray spreads the tasks.
    from madenet import _core
    return getattr(_core, kind).from_toml(config_toml).run(indices, 1)


def _fan_out(kind: str, study, address: str | None, batch_size: int | None) -> list:
    """Runs every trial of ``study`` (a ``_core`` study of class ``kind``) as Ray tasks of
    ``batch_size`` trials; rows in the study's order."""
    import ray

    global _remote
    text = study.toml_text()
    n = len(study)
    if batch_size is not None and (not isinstance(batch_size, int) or batch_size < 1):
        raise ValueError(f"batch_size: {batch_size!r} is not a positive int")
    _connect(address)
    if batch_size is None:
        cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
        batch_size = max(1, math.ceil(n / (4 * cpus)))
    if _remote is None:
        _remote = ray.remote(_run_batch)
    batches = [list(range(i, min(i + batch_size, n))) for i in range(0, n, batch_size)]
    results = ray.get([_remote.remote(kind, text, b) for b in batches])
    return [row for batch in results for row in batch]


def compare(config=None, address: str | None = None, batch_size: int | None = None,
            as_dataframe: bool = False, **fields):
    """``madenet.compare`` with the trials distributed as Ray tasks (one task per batch of
    ``batch_size`` trials; by default about four batches per CPU of the cluster). Connects to
    ``address`` (``None``: the running Ray instance, or a new local one). Returns the same table
    as ``madenet.compare`` — the same values for the same configuration and seeds, in the same
    order (wall-clock columns aside)."""
    from madenet._core import CoreStudy

    path, extra = study_overrides(config, fields)
    rows = _fan_out("CoreStudy", CoreStudy(path, extra), address, batch_size)
    return table(rows, as_dataframe)


def scale(config=None, address: str | None = None, batch_size: int | None = None,
          as_dataframe: bool = False, **fields):
    """``madenet.scale`` (grid or continuous world) with the trials distributed as Ray tasks,
    as ``compare`` here: the same rows as ``madenet.scale`` for the same configuration and
    seeds, in the same order (wall-clock columns aside)."""
    from madenet._core import CoreScale

    path, extra = study_overrides(config, fields)
    study = CoreScale(path, extra)
    rows = _fan_out("CoreScale", study, address, batch_size)
    return table(rows, as_dataframe, study.columns())


def _collect_batch(config_toml: str, iteration: bytes, batch: bytes) -> bytes:
    # Runs inside a Ray worker: one batch of a training iteration's episodes, labelled by the
    # teacher (its continuations are what training spends its time on), on one thread.
    from madenet import _core
    return _core.collect_rollout(config_toml, iteration, batch, 1)


def train(out, config=None, address: str | None = None, batch_size: int = 8):
    """``madenet train --config CONFIG --out OUT`` for a rollout-teacher config (``method =
    "made-net-rollout"``) with each iteration's episodes collected as Ray tasks of
    ``batch_size`` episodes (their teacher's continuations are the cost of training); the
    updates and validation run here. The run — its ``iterations.csv`` (wall time aside), data,
    checkpoints and models — is the one ``madenet train`` makes with the same config: every
    episode follows from its index (on a cluster of one kind of CPU: the decision scorer's
    matrix kernels are picked per CPU, so a score's last bits may differ between kinds).
    ``max_minutes`` is checked between iterations (a local run also stops inside one).
    Resumes a run in ``out`` as ``madenet train`` does; a new run needs ``config``."""
    import ray

    global _remote_collect
    if not isinstance(batch_size, int) or batch_size < 1:
        raise ValueError(f"batch_size: {batch_size!r} is not a positive int")
    _connect(address)
    if _remote_collect is None:
        _remote_collect = ray.remote(_collect_batch)

    def collect(config_toml, iteration, batches):
        # The config and the iteration's students' weights go to the object store once; each
        # task gets references to them and its own episode indices.
        text, models = ray.put(config_toml), ray.put(iteration)
        return ray.get([_remote_collect.remote(text, models, b) for b in batches])

    from madenet import _core
    _core.train_rollout(str(out), None if config is None else str(config), collect, batch_size)
