"""Setting fields of a scenario's data by dotted path (``zones.0.hazard.kappa``): mapping keys
and list indices from the top of the mapping."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from resilient_tracking.scenario.errors import ScenarioError, short_repr


def set_path(data: Any, path: str, value: Any) -> None:
    """Set ``data[a][b][0]…`` from a dotted path ``a.b.0``, creating missing mappings on the way.

    Raises ``IndexError``, ``KeyError`` or ``TypeError`` when a step cannot be taken (an index
    past a list's end, a key into a list or a number)."""
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    for key in keys[:-1]:
        data = data.setdefault(key, {}) if isinstance(data, dict) else data[key]
    data[keys[-1]] = value


def set_paths(data: dict[str, Any], overrides: Mapping[str, Any], source: str) -> None:
    """Set every dotted path of ``overrides`` in ``data`` (in place); raises
    :class:`ScenarioError` from ``source`` naming each path that cannot be set."""
    problems = []
    for path, value in overrides.items():
        try:
            set_path(data, path, value)
        except (IndexError, KeyError, TypeError):
            problems.append(f"{path}: no such field to set (got {short_repr(value)})")
    if problems:
        raise ScenarioError(source, problems)
