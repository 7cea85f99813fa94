"""Keyword arguments → the TOML / JSON overrides the Rust core parses (and checks)."""

from __future__ import annotations

import json
import os


def _toml_value(key: str, value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a valid TOML basic string
    raise ValueError(f"{key}: unsupported value {value!r} (numbers, booleans and strings only)")


def scenario_overrides(kwargs: dict) -> str:
    """Scenario fields (``comm_success_prob=0.5`` …) as TOML lines."""
    return "".join(f"{k} = {_toml_value(k, v)}\n" for k, v in kwargs.items())


def check_render(render_mode, cell_px, modes) -> None:
    """The rendering arguments every madenet environment takes."""
    if render_mode is not None and render_mode not in modes:
        raise ValueError(f"render_mode: {render_mode!r} is not supported (expected None or one of {modes})")
    if not isinstance(cell_px, int) or not 1 <= cell_px <= 64:
        raise ValueError(f"cell_px: {cell_px!r} is not an int in 1..64")


def path_or_none(config, name: str = "config") -> str | None:
    """A config file argument ``name``: ``None`` or a path."""
    if config is None:
        return None
    if isinstance(config, (str, os.PathLike)):
        return os.fspath(config)
    raise ValueError(f"{name}: expected a TOML file path, got {type(config).__name__}")


def study_overrides(config, fields: dict) -> tuple[str | None, str]:
    """A study config (path, dict or None) plus keyword fields → (path, JSON overrides)."""
    extra = {}
    if isinstance(config, dict):
        extra.update(config)
        config = None
    extra.update(fields)
    try:
        text = json.dumps(extra)
    except TypeError as e:
        raise ValueError(f"study fields: {e}") from None
    return path_or_none(config), text
